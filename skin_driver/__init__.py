"""ROS 2 driver for a two-layer tactile skin: where a touch is, how hard, which way it pushes."""
