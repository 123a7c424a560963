"""The patches launch file and its layouts: what it starts, and the parameters it hands over."""

import importlib.util
import pathlib

from pipeline import overrides
import pytest
import rclpy
from rosutil import ros_context
from skin_driver.core.robot.patches import layout_from_dict, node_parameters
from skin_driver.core.sim.patch_scene import load_patch_scene
from skin_driver.ros.patches_node import PatchesNode
import yaml

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / 'config' / 'patches.yaml'

NO_LAUNCH_ROS = pytest.mark.skipif(
    importlib.util.find_spec('launch_ros') is None,
    reason='launch_ros is not installed (no wheel exists); workstations with ROS 2 Jazzy run '
           'this test')


@pytest.mark.ros
@pytest.mark.parametrize('layout', ['example', 'crossing'])
def test_the_layouts_the_launch_file_reads_make_a_node(layout):
    if layout == 'example':
        layout = layout_from_dict(yaml.safe_load(EXAMPLE.read_text()))
    else:
        layout = load_patch_scene('crossing').layout
    with ros_context() as (context, _):
        node = PatchesNode(context=context, namespace='skin',
                           parameter_overrides=overrides(node_parameters(layout)))
        try:
            mounts = {p.name: p.parent_frame for p in layout.patches}
            for status in node.statuses()[1:]:
                name = status.name.split('patch ')[-1]
                values = {kv.key: kv.value for kv in status.values}
                assert values['link'] == mounts[name]
                assert values['transform to common frame'] == 'known'
        finally:
            node.destroy_node()


@pytest.mark.ros
def test_a_parameter_file_takes_whole_numbers_for_a_pose(tmp_path):
    path = tmp_path / 'patches.yaml'
    path.write_text(yaml.safe_dump({'/**/skin_patches': {'ros__parameters': {
        'patches': ['a'], 'a.parent_frame': 'arm', 'a.xyz': [0, 0, 1],
        'links.arm.xyz': [1, 2, 3], 'links.arm.rpy': [0.0, 0.0, 0.0]}}}))
    context = rclpy.Context()
    rclpy.init(context=context, args=['--ros-args', '--params-file', str(path)])
    try:
        node = PatchesNode(context=context, namespace='/robot')
        values = {kv.key: kv.value for kv in node.statuses()[1].values}
        assert values['link'] == 'arm' and values['transform to common frame'] == 'known'
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def _load_launch_file():
    spec = importlib.util.spec_from_file_location('patches_launch',
                                                  ROOT / 'launch' / 'patches.launch.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@NO_LAUNCH_ROS
def test_the_launch_file_starts_a_driver_and_direction_node_per_patch_and_the_patches_node():
    from launch import LaunchContext
    from launch.actions import DeclareLaunchArgument
    module = _load_launch_file()
    description = module.generate_launch_description()
    names = {a.name for a in description.entities if isinstance(a, DeclareLaunchArgument)}
    assert names == {'layout', 'sim', 'scene', 'sim_rate', 'params_file', 'namespace', 'fused',
                     'mount_tf'}
    context = LaunchContext()
    context.launch_configurations.update({
        'sim': 'true', 'scene': 'crossing', 'layout': '', 'params_file': 'skin.yaml',
        'fused': 'false', 'mount_tf': 'false', 'namespace': 'skin'})
    executables = sorted(getattr(a, 'node_executable', '') for a in module._nodes(context))
    assert executables == ['direction'] * 3 + ['driver'] * 3 + ['patches']
    context.launch_configurations.update({'sim': 'false', 'layout': str(EXAMPLE)})
    executables = sorted(getattr(a, 'node_executable', '') for a in module._nodes(context))
    assert executables == ['direction'] * 2 + ['driver'] * 2 + ['patches']
    context.launch_configurations['sim'] = 'true'
    with pytest.raises(RuntimeError, match='not both'):
        module._nodes(context)
