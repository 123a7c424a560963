"""
ROS-free core: protocol, conditioning, estimation, calibration and simulation physics.

Nothing under this package may import rclpy or any ROS message package;
test_core_is_ros_free checks it.
"""
