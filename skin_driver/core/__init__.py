"""
ROS-free core in three wings, with one import rule.

* :mod:`protocol` -- the wire format between the skin's board and the driver.
* :mod:`estimation` -- conditioning, contacts, layer shift, force, calibration maths and sessions,
  and the dataset format they are scored on.
* :mod:`sim` -- the simulated skin: physics, the family of skins, scenes, the paper's protocol
  (the experiments, oracle and floor that judge the estimator are the lab's, ``skin_lab``).

``sim`` may import ``estimation``; ``estimation`` never imports ``sim`` (it must work on a skin
whose physics nobody modelled) and ``protocol`` imports neither. Nothing here imports rclpy or a
ROS message package. test_core_is_ros_free checks both rules.
"""
