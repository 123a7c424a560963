"""
Bring up the skin: serial driver and direction node, optionally the simulated skin and rviz2.

    ros2 launch skin_driver skin.launch.py port:=/dev/ttyACM0   # a real skin
    ros2 launch skin_driver skin.launch.py sim:=true rviz:=true  # simulated skin + heatmap
    ros2 launch skin_driver skin.launch.py fused:=true          # estimate in the driver process
    ros2 launch skin_driver skin.launch.py fused:=true realtime_priority:=80  # reader SCHED_FIFO
    ros2 launch skin_driver skin.launch.py namespace:=left parent_frame:=left_forearm_link \
        mount_z:=0.05 mount_pitch:=1.5708                      # mounted on a robot link

When the simulated skin exits (a bad scene, a port it cannot link), the launch stops with it.
The mount (parent_frame, mount_*) goes to skin_direction, which puts the mount in force on
/tf_static: a mount from ~/calibrate_mount in the calibration file wins over these arguments,
with a warning naming both (docs/robot.md, "What lasts where").
"""

import os

from launch import LaunchDescription
from launch.actions import (DeclareLaunchArgument, ExecuteProcess, OpaqueFunction,
                            RegisterEventHandler, Shutdown)
from launch.conditions import IfCondition, UnlessCondition
from launch.event_handlers import OnProcessExit
from launch.substitution import Substitution
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackagePrefix, FindPackageShare
from skin_driver.core.protocol.link import default_port
from skin_driver.ros import rviz_config

MOUNT_POSE = (('x', 'm'), ('y', 'm'), ('z', 'm'), ('roll', 'rad'), ('pitch', 'rad'),
              ('yaw', 'rad'))


def _require_rviz2(context):
    # Before anything starts: a missing rviz2 found later would leave the nodes running.
    problem = rviz_config.rviz2_problem()
    if problem:
        raise RuntimeError(problem)
    return []


def _rviz(context):
    template = PathJoinSubstitution([FindPackageShare('skin_driver'), 'config', 'skin.rviz'])
    config = rviz_config.write_namespaced(template.perform(context),
                                          LaunchConfiguration('namespace').perform(context),
                                          LaunchConfiguration('frame_id').perform(context))
    return [Node(package='rviz2', executable='rviz2', name='skin_rviz', arguments=['-d', config],
                 output='screen')]


def _given_mount() -> dict:
    # Without a parent link the skin's frame stands alone (rviz shows it as its fixed frame).
    # skin_direction publishes it, so that it and a calibrated mount never both go on /tf_static.
    return {'parent_frame': ParameterValue(LaunchConfiguration('parent_frame'), value_type=str),
            **{f'mount_{name}': ParameterValue(LaunchConfiguration(f'mount_{name}'),
                                               value_type=float) for name, _ in MOUNT_POSE}}


class _Port(Substitution):
    """The port launch argument, or the namespace's default port when it is empty."""

    def perform(self, context) -> str:
        given = LaunchConfiguration('port').perform(context)
        if given:
            return given
        port = default_port(LaunchConfiguration('namespace').perform(context))
        # The default place is this package's own: its folder is made for the simulator's link.
        os.makedirs(os.path.dirname(port), exist_ok=True)
        return port


def _simulator_exited(event, context):
    # The driver would retry a port nobody serves: stop everything, saying why. Not when the
    # launch is already stopping (Ctrl-C stops the simulator too): a second shutdown is an error.
    if context.is_shutdown:
        return []
    return [Shutdown(reason=f'the simulated skin exited (code {event.returncode}); its message '
                            'is above')]


def generate_launch_description():
    """Return the launch description of the whole skin pipeline."""
    share = FindPackageShare('skin_driver')
    port = _Port()
    namespace = LaunchConfiguration('namespace')
    params_file = LaunchConfiguration('params_file')
    with_rviz = IfCondition(LaunchConfiguration('rviz'))
    fused = LaunchConfiguration('fused')
    arguments = [
        DeclareLaunchArgument('port', default_value='',
                              description='Serial device or pyserial URL of the skin board; '
                                          'empty: $XDG_RUNTIME_DIR/skin_driver/<namespace>/skin0 '
                                          '(where the simulated skin links).'),
        DeclareLaunchArgument('params_file',
                              default_value=PathJoinSubstitution([share, 'config', 'skin.yaml']),
                              description='Parameter file for the driver and direction nodes.'),
        DeclareLaunchArgument('namespace', default_value='skin',
                              description='Namespace of the nodes and their topics.'),
        DeclareLaunchArgument('sim', default_value='false',
                              description='Start the simulated skin on a pty linked at port.'),
        DeclareLaunchArgument('scene', default_value='seed',
                              description='Scene the simulated skin plays (name or YAML path).'),
        DeclareLaunchArgument('sim_rate', default_value='100.0',
                              description='Scans per second of the simulated skin.'),
        DeclareLaunchArgument('rviz', default_value='false',
                              description='Start rviz2 with the heatmap configuration.'),
        DeclareLaunchArgument('fused', default_value='false',
                              description='Estimate contacts inside the driver process, on its '
                                          'serial reader thread (1-2 kHz), instead of in a '
                                          'separate direction node.'),
        DeclareLaunchArgument('realtime_priority', default_value='0',
                              description="SCHED_FIFO priority (1..99) of the driver's serial "
                                          'reader thread; 0: normal priority. Without '
                                          'CAP_SYS_NICE or an rtprio limit the driver warns '
                                          'and reads at normal priority (README, "Real-time '
                                          'priority").'),
        DeclareLaunchArgument('frame_id', default_value='',
                              description="The skin's frame in every header; empty: "
                                          '<namespace>_skin_link (skin_link in the namespace '
                                          'skin or none).'),
        DeclareLaunchArgument('parent_frame', default_value='',
                              description='Link the skin is mounted on: publishes the mount pose '
                                          '(mount_x, _y, _z, _roll, _pitch, _yaw) on '
                                          '/tf_static; empty: no transform. A mount from '
                                          '~/calibrate_mount in the calibration file wins.'),
    ] + [DeclareLaunchArgument(f'mount_{name}', default_value='0.0',
                               description=f'Mount pose on parent_frame: {name} ({unit}).')
         for name, unit in MOUNT_POSE]
    # The simulator is a device, not a ROS node: it takes no --ros-args.
    simulator = ExecuteProcess(
        cmd=[PathJoinSubstitution([FindPackagePrefix('skin_driver'), 'lib', 'skin_driver', 'sim']),
             '--link', port, '--scene', LaunchConfiguration('scene'),
             '--rate', LaunchConfiguration('sim_rate'), '--loop'],
        name='skin_sim', output='screen', condition=IfCondition(LaunchConfiguration('sim')))
    driver = LifecycleNode(
        package='skin_driver', executable='driver', name='skin_driver', namespace=namespace,
        parameters=[params_file, {'port': port, 'fused': fused,
                                  'realtime_priority': ParameterValue(
                                      LaunchConfiguration('realtime_priority'), value_type=int),
                                  # as a string even when empty (empty YAML would be null)
                                  'frame_id': ParameterValue(LaunchConfiguration('frame_id'),
                                                             value_type=str),
                                  **_given_mount()}],
        output='screen')
    # Fused, the driver process runs the skin_direction node itself (same name, parameters from
    # the same section of params_file, same services and topics).
    direction = Node(
        package='skin_driver', executable='direction', name='skin_direction',
        namespace=namespace, parameters=[params_file, _given_mount()], output='screen',
        condition=UnlessCondition(fused))
    return LaunchDescription(arguments + [
        OpaqueFunction(function=_require_rviz2, condition=with_rviz),
        simulator, driver, direction,
        RegisterEventHandler(OnProcessExit(target_action=simulator, on_exit=_simulator_exited)),
        OpaqueFunction(function=_rviz, condition=with_rviz)])
