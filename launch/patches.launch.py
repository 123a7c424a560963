"""
Several skin patches as one skin: a driver and a direction node per patch, and the patches node.

    ros2 launch skin_driver patches.launch.py sim:=true                # three simulated patches
    ros2 launch skin_driver patches.launch.py sim:=true scene:=my_scene.yaml
    ros2 launch skin_driver patches.launch.py layout:=my_robot.yaml    # real patches

A layout (skin_driver.core.robot.patches.layout_from_dict; config/patches.yaml is an example)
names each patch, which is its nodes' namespace and, with the driver's default, its frame
(<patch>_skin_link), the link it is mounted on with the mount pose, the common frame and the
links' fixed poses in it, and optionally each patch's port. With sim:=true the patch scene
(skin_driver.core.sim.patch_scene; default the bundled crossing scene) gives the layout and one
simulated board per patch plays it, each linked where its driver looks; when the boards exit
(a bad scene), the launch stops with them.

The patches node (skin_patches, in namespace `namespace`) publishes every patch's contacts in
the common frame on <namespace>/contacts and each link's net wrench on
<namespace>/wrench/<link>.
"""

from launch import LaunchDescription
from launch.actions import (DeclareLaunchArgument, ExecuteProcess, OpaqueFunction,
                            RegisterEventHandler, Shutdown)
from launch.conditions import IfCondition
from launch.event_handlers import OnProcessExit
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.substitutions import FindPackagePrefix, FindPackageShare
from skin_driver.core.robot.patches import layout_from_dict, node_parameters
from skin_driver.core.sim.patch_scene import load_patch_scene
import yaml


def _layout(context):
    sim = LaunchConfiguration('sim').perform(context).lower() in ('true', '1', 'yes')
    given = LaunchConfiguration('layout').perform(context)
    if sim and given:
        raise RuntimeError('give either layout:=FILE (real patches) or sim:=true (the scene '
                           'gives the layout), not both')
    if sim:
        return load_patch_scene(LaunchConfiguration('scene').perform(context)).layout
    if not given:
        raise RuntimeError('give layout:=FILE naming your patches and their mounts '
                           '(config/patches.yaml is an example), or sim:=true')
    with open(given) as f:
        return layout_from_dict(yaml.safe_load(f))


def _nodes(context):
    layout = _layout(context)
    params_file = LaunchConfiguration('params_file')
    fused = LaunchConfiguration('fused').perform(context).lower() in ('true', '1', 'yes')
    mount_tf = LaunchConfiguration('mount_tf').perform(context).lower() in ('true', '1', 'yes')
    actions = []
    for patch in layout.patches:
        driver_params = {'fused': fused}
        if patch.port:
            driver_params['port'] = patch.port
        actions.append(LifecycleNode(
            package='skin_driver', executable='driver', name='skin_driver',
            namespace=patch.name, parameters=[params_file, driver_params], output='screen'))
        if not fused:
            actions.append(Node(package='skin_driver', executable='direction',
                                name='skin_direction', namespace=patch.name,
                                parameters=[params_file], output='screen'))
        if mount_tf:
            pose = dict(zip(('x', 'y', 'z'), patch.xyz))
            pose.update(zip(('roll', 'pitch', 'yaw'), patch.rpy))
            actions.append(Node(package='skin_driver', executable='mount_tf',
                                name='skin_mount_tf', namespace=patch.name, output='screen',
                                parameters=[{'parent_frame': patch.parent_frame, **pose}]))
    actions.append(Node(package='skin_driver', executable='patches', name='skin_patches',
                        namespace=LaunchConfiguration('namespace'), output='screen',
                        parameters=[node_parameters(layout)]))
    return actions


def _boards_exited(event, context):
    if context.is_shutdown:  # Ctrl-C stops the boards too: a second shutdown is an error
        return []
    return [Shutdown(reason=f'the simulated patches exited (code {event.returncode}); their '
                            'message is above')]


def generate_launch_description():
    """Return the launch description of N patches and the patches node."""
    share = FindPackageShare('skin_driver')
    arguments = [
        DeclareLaunchArgument('layout', default_value='',
                              description='YAML layout of the patches (names, links, mounts, '
                                          'ports); empty with sim:=true: the scene gives it.'),
        DeclareLaunchArgument('sim', default_value='false',
                              description='Simulate every patch of the scene, one board each.'),
        DeclareLaunchArgument('scene', default_value='crossing',
                              description='Patch scene the simulated boards play (a bundled '
                                          'name or a YAML path).'),
        DeclareLaunchArgument('sim_rate', default_value='100.0',
                              description='Scans per second of each simulated board.'),
        DeclareLaunchArgument('params_file',
                              default_value=PathJoinSubstitution([share, 'config', 'skin.yaml']),
                              description="Parameter file of every patch's driver and direction "
                                          'node.'),
        DeclareLaunchArgument('namespace', default_value='skin',
                              description='Namespace of the patches node and its topics '
                                          '(contacts, wrench/<link>).'),
        DeclareLaunchArgument('fused', default_value='false',
                              description='Estimate in each driver process (see skin.launch.py).'),
        DeclareLaunchArgument('mount_tf', default_value='false',
                              description="Publish each patch's mount on /tf_static (needs "
                                          'tf2_msgs).'),
    ]
    boards = ExecuteProcess(
        cmd=[PathJoinSubstitution([FindPackagePrefix('skin_driver'), 'lib', 'skin_driver',
                                   'patches_sim']),
             '--scene', LaunchConfiguration('scene'), '--rate', LaunchConfiguration('sim_rate'),
             '--loop'],
        name='skin_patches_sim', output='screen',
        condition=IfCondition(LaunchConfiguration('sim')))
    return LaunchDescription(arguments + [
        boards, OpaqueFunction(function=_nodes),
        RegisterEventHandler(OnProcessExit(target_action=boards, on_exit=_boards_exited))])
