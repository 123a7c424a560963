"""
What the launch file needs for rviz2: a config for the chosen namespace, and whether rviz2 exists.

config/skin.rviz names its topics under /skin (the launch file's default namespace) and shows
them in skin_link; a launch in another namespace gets a copy with those topics moved there and
the skin's frame of that namespace (or the one the launch names) as rviz's fixed frame.
Checking for rviz2 before anything starts lets `rviz:=true` without rviz2 fail with one line
instead of leaving nodes behind.
"""

import os
import re

from ament_index_python.packages import get_package_prefix, PackageNotFoundError
from skin_driver.core.common.atomic import write_atomically
from skin_driver.ros.frames import default_frame_id
from skin_driver.ros.paths import ros_home

TEMPLATE_NAMESPACE = '/skin/'


def namespaced(template: str, namespace: str, frame_id: str = '') -> str:
    """Return the rviz config text with the template's /skin/ topics under namespace."""
    parts = [part for part in namespace.split('/') if part]
    prefix = '/' + ''.join(f'{part}/' for part in parts)
    text = re.sub(r'(^\s*Value: )' + re.escape(TEMPLATE_NAMESPACE),
                  lambda match: match.group(1) + prefix, template, flags=re.MULTILINE)
    frame = frame_id or default_frame_id(namespace)
    return re.sub(r'(^\s*Fixed Frame: ).*$', lambda match: match.group(1) + frame, text,
                  flags=re.MULTILINE)


def write_namespaced(template_path: str, namespace: str, frame_id: str = '') -> str:
    """Write the config for namespace under $ROS_HOME/skin_driver/rviz and return its path."""
    with open(template_path, encoding='utf-8') as f:
        text = namespaced(f.read(), namespace, frame_id)
    name = '_'.join(part for part in namespace.split('/') if part) or 'root'
    path = os.path.join(ros_home(), 'skin_driver', 'rviz', f'{name}.rviz')
    write_atomically(path, lambda out: out.write(text), make_parents=True)
    return path


def rviz2_problem() -> str:
    """Return why rviz2 cannot start here (one line), or '' when it is installed."""
    try:
        get_package_prefix('rviz2')
    except PackageNotFoundError:
        return ('rviz:=true but rviz2 is not installed (apt-get install ros-jazzy-rviz2); '
                'nothing was started')
    return ''
