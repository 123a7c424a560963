"""Where a ROS 2 tool keeps its files: under $ROS_HOME (default ~/.ros), as ROS 2 itself does."""

import os


def ros_home() -> str:
    """Return $ROS_HOME, or ~/.ros when it is unset or empty."""
    return os.environ.get('ROS_HOME') or os.path.join(os.path.expanduser('~'), '.ros')
