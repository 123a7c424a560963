"""The skin on a robot: patches, their mounts and the frames that join them (no ROS)."""
