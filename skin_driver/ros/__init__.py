"""The ROS side of the driver: nodes and what they share."""
