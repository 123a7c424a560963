"""config/skin.yaml matches the nodes' parameters, and the launch file builds on Jazzy's API."""

import importlib.util
import pathlib

import pytest
import rclpy
from rosutil import ros_context
from skin_driver.ros import rviz_config
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
CONFIG = ROOT / 'config' / 'skin.yaml'
NODES = {'skin_driver': SkinDriverNode, 'skin_direction': DirectionNode}


def _section(name):
    return yaml.safe_load(CONFIG.read_text())[f'/**/{name}']['ros__parameters']


@pytest.mark.ros
@pytest.mark.parametrize('name', sorted(NODES))
def test_config_holds_every_declared_parameter_and_nothing_else(name):
    with ros_context() as (context, _):
        node = NODES[name](context=context)
        # ROS's own: QoS overrides (read-only, per topic) are ROS 2's, not the node's.
        declared = {name for name in node.list_parameters([], 0).names
                    if not name.startswith('qos_overrides.')} - {
            'use_sim_time', 'start_type_description_service'}
        node.destroy_node()
    assert set(_section(name)) == declared


def test_every_parameter_line_of_the_config_has_a_comment():
    lines = [line for line in CONFIG.read_text().splitlines()
             if ':' in line and line.startswith('    ') and not line.strip().startswith('#')]
    assert lines, 'no parameter lines found'
    assert [line for line in lines if '#' not in line] == []


@pytest.mark.ros
def test_nodes_take_their_section_of_the_config_through_the_namespace_wildcard():
    context = rclpy.Context()
    rclpy.init(context=context, args=['--ros-args', '--params-file', str(CONFIG)])
    try:
        node = SkinDriverNode(context=context, namespace='/anywhere', parameter_overrides=[])
        assert node.get_parameter('baud').value == _section('skin_driver')['baud']
        # Empty: the driver names the frame after its namespace (anywhere_skin_link).
        assert node.get_parameter('frame_id').value == ''
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_rviz_config_shows_the_heatmaps_markers_and_wrench():
    rviz = yaml.safe_load((ROOT / 'config' / 'skin.rviz').read_text())
    manager = rviz['Visualization Manager']
    topics = {d['Topic']['Value'] for d in manager['Displays'] if 'Topic' in d}
    assert topics == {'/skin/top/heatmap', '/skin/bottom/heatmap', '/skin/markers',
                      '/skin/wrench'}
    assert manager['Global Options']['Fixed Frame'] == 'skin_link'
    # Each display is named for what its topic carries: the wrench is the net one of all
    # contacts, not the strongest contact's force.
    names = {d.get('Topic', {}).get('Value', d['Class']): d['Name'] for d in manager['Displays']}
    assert names == {
        'rviz_default_plugins/Grid': 'Taxel grid (16 x 16 at 5 mm)',
        '/skin/markers': 'Taxel forces and contacts',
        '/skin/top/heatmap': 'Top layer heatmap (seen from above)',
        '/skin/bottom/heatmap': 'Bottom layer heatmap (seen from above)',
        '/skin/wrench': 'Net wrench of all contacts (at the skin origin)'}


def test_rviz_config_follows_the_launch_namespace(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_HOME', str(tmp_path))
    path = rviz_config.write_namespaced(str(ROOT / 'config' / 'skin.rviz'), 'left')
    manager = yaml.safe_load(pathlib.Path(path).read_text())['Visualization Manager']
    topics = {d['Topic']['Value'] for d in manager['Displays'] if 'Topic' in d}
    assert topics == {'/left/top/heatmap', '/left/bottom/heatmap', '/left/markers',
                      '/left/wrench'}
    assert rviz_config.namespaced('Value: /skin/wrench', '/robot/left_hand/') == \
        'Value: /robot/left_hand/wrench'
    assert rviz_config.namespaced('Value: /skin/wrench', '') == 'Value: /wrench'
    assert manager['Global Options']['Fixed Frame'] == 'left_skin_link'
    assert 'Fixed Frame: tool0' in rviz_config.namespaced('    Fixed Frame: skin_link', 'left',
                                                          'tool0')


def test_missing_rviz2_is_one_line_naming_the_package(monkeypatch):
    def not_found(name):
        raise rviz_config.PackageNotFoundError(name)
    monkeypatch.setattr(rviz_config, 'get_package_prefix', not_found)
    problem = rviz_config.rviz2_problem()
    assert 'rviz2 is not installed' in problem and '\n' not in problem


NO_LAUNCH_ROS = pytest.mark.skipif(
    importlib.util.find_spec('launch_ros') is None,
    reason='launch_ros is not installed (no wheel exists); workstations with ROS 2 Jazzy run '
           'this test')


def _load_launch_file():
    spec = importlib.util.spec_from_file_location('skin_launch',
                                                  ROOT / 'launch' / 'skin.launch.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@NO_LAUNCH_ROS
def test_launch_file_declares_its_arguments_and_nodes():
    from launch import LaunchContext, LaunchDescription
    from launch.actions import DeclareLaunchArgument, ExecuteProcess
    from launch.utilities import perform_substitutions
    description = _load_launch_file().generate_launch_description()
    assert isinstance(description, LaunchDescription)
    names = {a.name for a in description.entities if isinstance(a, DeclareLaunchArgument)}
    assert names == {'port', 'params_file', 'namespace', 'sim', 'scene', 'sim_rate', 'rviz',
                     'fused', 'realtime_priority', 'frame_id', 'parent_frame', 'mount_x',
                     'mount_y', 'mount_z', 'mount_roll', 'mount_pitch', 'mount_yaw'}
    executables = [getattr(a, 'node_executable', None) for a in description.entities]
    assert {'driver', 'direction'} <= set(executables)
    # ExecuteProcess keeps its name as substitutions until launch performs them (nodes have
    # none until launched).
    processes = [a for a in description.entities if isinstance(a, ExecuteProcess) and a.name
                 and perform_substitutions(LaunchContext(), a.name) == 'skin_sim']
    assert len(processes) == 1


@NO_LAUNCH_ROS
def test_rviz_without_rviz2_fails_up_front_and_starts_nothing(tmp_path, monkeypatch):
    from launch import LaunchDescription, LaunchService
    from launch.actions import IncludeLaunchDescription, RegisterEventHandler
    from launch.event_handlers import OnProcessStart
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    def not_found(name):
        raise rviz_config.PackageNotFoundError(name)
    monkeypatch.setattr(rviz_config, 'get_package_prefix', not_found)
    started = []
    service = LaunchService()
    service.include_launch_description(LaunchDescription([
        RegisterEventHandler(OnProcessStart(on_start=lambda event, _: started.append(event))),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(ROOT / 'launch' / 'skin.launch.py')),
            launch_arguments={'rviz': 'true', 'sim': 'true',
                              'port': str(tmp_path / 'skin0')}.items())]))
    assert service.run() != 0
    assert [e.process_name for e in started] == []


@NO_LAUNCH_ROS
@pytest.mark.timeout(60)
def test_a_simulator_that_dies_stops_the_launch_with_its_reason(tmp_path):
    from launch import LaunchDescription, LaunchService
    from launch.actions import IncludeLaunchDescription, RegisterEventHandler
    from launch.event_handlers import OnShutdown
    from launch.launch_description_sources import PythonLaunchDescriptionSource
    reasons = []
    service = LaunchService()
    service.include_launch_description(LaunchDescription([
        RegisterEventHandler(OnShutdown(on_shutdown=lambda event, _: reasons.append(
            event.reason))),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(str(ROOT / 'launch' / 'skin.launch.py')),
            launch_arguments={'sim': 'true', 'scene': 'nosuch',
                              'port': str(tmp_path / 'skin0')}.items())]))
    # Before: the launch kept the driver retrying a port nobody serves, and never returned.
    service.run()
    assert any('simulated skin exited' in str(reason) for reason in reasons)
