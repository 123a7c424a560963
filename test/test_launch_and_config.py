"""config/skin.yaml matches the nodes' parameters, and the launch file builds on Jazzy's API."""

import importlib.util
import pathlib

import pytest
import rclpy
from rosutil import ros_context
from skin_driver.direction_node import DirectionNode
from skin_driver.driver_node import SkinDriverNode
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config' / 'skin.yaml'
NODES = {'skin_driver': SkinDriverNode, 'skin_direction': DirectionNode}


def _section(name):
    return yaml.safe_load(CONFIG.read_text())[f'/**/{name}']['ros__parameters']


@pytest.mark.ros
@pytest.mark.parametrize('name', sorted(NODES))
def test_config_holds_every_declared_parameter_and_nothing_else(name):
    with ros_context() as (context, _):
        node = NODES[name](context=context)
        declared = set(node._parameters) - {'use_sim_time', 'start_type_description_service'}
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
        assert node.get_parameter('frame_id').value == 'skin_link'
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


@pytest.mark.skipif(importlib.util.find_spec('launch_ros') is None,
                    reason='launch_ros is not installed (no wheel exists); workstations with '
                           'ROS 2 Jazzy run this test')
def test_launch_file_declares_its_arguments_and_nodes():
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, ExecuteProcess
    spec = importlib.util.spec_from_file_location('skin_launch',
                                                  ROOT / 'launch' / 'skin.launch.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    assert isinstance(description, LaunchDescription)
    names = {a.name for a in description.entities if isinstance(a, DeclareLaunchArgument)}
    assert names == {'port', 'params_file', 'namespace', 'sim', 'scene', 'sim_rate', 'rviz',
                     'fused'}
    executables = [getattr(a, 'node_executable', None) for a in description.entities]
    assert {'driver', 'direction', 'rviz2'} <= set(executables)
    processes = [a for a in description.entities if isinstance(a, ExecuteProcess)
                 and a.name == 'skin_sim']
    assert len(processes) == 1
