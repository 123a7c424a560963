"""On a robot: the skin's frame per namespace, its mount on a parent link, its URDF patch."""

import importlib.util
import math
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from pipeline import overrides, scene
import pytest
import rclpy
from rclpy.qos import DurabilityPolicy, qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rosutil import ros_context, spin_until
from skin_driver.core.protocol.link import default_port
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.ros import conversions
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.ros.frames import default_frame_id, MountTransform
from skin_driver.tools.harness import spawn, stop
from skin_msgs.msg import SkinFrame, TactileContactArray
import xacro

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.parametrize('namespace, frame', [
    ('/left', 'left_skin_link'), ('/robot/right', 'robot_right_skin_link'),
    ('/skin', 'skin_link'), ('/', 'skin_link'), ('', 'skin_link')])
def test_the_skins_frame_is_named_after_its_namespace(namespace, frame):
    assert default_frame_id(namespace) == frame


@pytest.mark.ros
def test_two_skins_in_two_namespaces_have_two_frames(tmp_path):
    the_scene = scene([])
    sims, frames, skins = [], {}, {}
    with ros_context() as (context, executor):
        drivers, directions = [], []
        for name in ('left', 'right'):
            link = str(tmp_path / f'{name}0')
            sims.append(SimulatedSkin(the_scene, rate_hz=100.0, link_path=link, noise_seed=1))
            drivers.append(SkinDriverNode(context=context, namespace=f'/{name}',
                                          parameter_overrides=overrides({'port': link})))
            directions.append(DirectionNode(context=context, namespace=f'/{name}',
                                            parameter_overrides=overrides({
                                                'diagnostics_period': 0.2,
                                                'calibration_file': str(tmp_path / name)})))
        listener = rclpy.create_node('listener', context=context)
        for name in ('left', 'right'):
            listener.create_subscription(
                TactileContactArray, f'/{name}/contacts',
                lambda msg, name=name: frames.setdefault(name, msg.header.frame_id),
                qos_profile_sensor_data)

        def on_diagnostics(msg):
            for status in msg.status:
                if status.name.endswith('contact estimation') and status.message != \
                        'no frame received yet':
                    skins[status.name.split('/')[1]] = status.hardware_id
        listener.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
        for node in drivers + directions + [listener]:
            executor.add_node(node)
        try:
            for sim in sims:
                sim.start()
            for driver in drivers:
                driver.trigger_configure()
                driver.trigger_activate()
            assert spin_until(executor, lambda: len(frames) == 2 and len(skins) == 2)
        finally:
            for driver in drivers:
                driver.close()
                driver.destroy_node()
            for direction in directions:
                direction.destroy_node()
            for sim in sims:
                sim.stop()
            listener.destroy_node()
    # The contacts carry the frame of their skin, and so does each skin's estimation status.
    assert frames == {'left': 'left_skin_link', 'right': 'right_skin_link'}
    assert skins == frames


def test_the_mount_pose_is_a_rotation_and_a_translation_of_the_parent_link():
    # Pitch of 90 degrees: the skin's z (out of the skin) points along the parent's x.
    t = conversions.mount_transform(Time(sec=1), 'forearm_link', 'left_skin_link',
                                    (0.1, 0.0, 0.05),
                                    (0.0, math.pi / 2, 0.0))
    assert (t.header.frame_id, t.child_frame_id) == ('forearm_link', 'left_skin_link')
    assert (t.transform.translation.x, t.transform.translation.z) == (0.1, 0.05)
    q = t.transform.rotation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5)))


def test_the_skin_patch_macro_gives_a_link_with_its_visual_fixed_to_the_parent(tmp_path):
    robot = tmp_path / 'arm.urdf.xacro'
    robot.write_text(
        '<?xml version="1.0"?>\n<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        f'  <xacro:include filename="{ROOT / "urdf" / "skin_patch.urdf.xacro"}"/>\n'
        '  <link name="forearm_link"/>\n'
        '  <xacro:skin_patch name="left_skin_link" parent="forearm_link" rows="8" cols="16"\n'
        '                    pitch="0.005" xyz="0 0.04 0.1" rpy="0 1.5708 0"/>\n'
        '</robot>\n')
    urdf = ElementTree.fromstring(xacro.process_file(str(robot)).toxml())
    link = urdf.find("link[@name='left_skin_link']")
    size = [float(v) for v in link.find('visual/geometry/box').get('size').split()]
    assert size[:2] == pytest.approx([0.08, 0.04])
    centre = [float(v) for v in link.find('visual/origin').get('xyz').split()]
    assert centre[:2] == pytest.approx([0.0375, 0.0175]) and centre[2] < 0
    joint = urdf.find("joint[@name='left_skin_link_mount']")
    assert joint.get('type') == 'fixed'
    assert joint.find('parent').get('link') == 'forearm_link'
    assert joint.find('child').get('link') == 'left_skin_link'
    assert joint.find('origin').get('rpy') == '0 1.5708 0'


def test_mount_tf_without_tf2_msgs_stops_with_one_line_naming_it():
    """Issue #37: it died with an ImportError's traceback."""
    code = ('import sys; sys.modules["tf2_msgs"] = None\n'
            'from skin_driver.ros.frames import main\nmain()')
    run = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=60)
    out = run.stdout + run.stderr
    assert run.returncode == 1
    assert 'Traceback' not in out
    assert [line for line in out.splitlines() if line.strip()] == [
        line for line in out.splitlines() if 'tf2_msgs is not installed' in line]


@pytest.mark.ros
@pytest.mark.skipif(importlib.util.find_spec('tf2_msgs') is None,
                    reason='tf2_msgs is not installed (no wheel exists); every ROS 2 install '
                           'has it and runs this test')
def test_the_mount_is_latched_on_tf_static_for_a_listener_that_comes_later():
    from tf2_msgs.msg import TFMessage
    received = []
    with ros_context() as (context, executor):
        mount = MountTransform(context=context, namespace='/left', parameter_overrides=overrides(
            {'parent_frame': 'left_forearm_link', 'z': 0.05, 'pitch': 1.5708}))
        listener = rclpy.create_node('listener', context=context)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        listener.create_subscription(TFMessage, '/tf_static', received.append, latched)
        for node in (mount, listener):
            executor.add_node(node)
        assert spin_until(executor, lambda: received)
        mount.destroy_node()
        listener.destroy_node()
    (t,) = received[0].transforms
    assert (t.header.frame_id, t.child_frame_id) == ('left_forearm_link', 'left_skin_link')
    assert t.transform.translation.z == 0.05


@pytest.mark.ros
def test_the_simulator_and_the_driver_meet_by_default_on_a_path_of_the_users_own(
        tmp_path, monkeypatch):
    monkeypatch.setenv('XDG_RUNTIME_DIR', str(tmp_path))
    assert default_port('/left') == str(tmp_path / 'skin_driver' / 'left' / 'skin0')
    frames = []
    with open(tmp_path / 'sim.log', 'w') as log:
        sim = spawn(['-m', 'skin_driver.tools.sim', '--rate', '100'], log)
    try:
        with ros_context() as (context, executor):
            # Neither names a port: both take this user's default, not a shared /tmp path.
            driver = SkinDriverNode(context=context)
            listener = rclpy.create_node('listener', context=context)
            listener.create_subscription(SkinFrame, '/frame', frames.append,
                                         qos_profile_sensor_data)
            for node in (driver, listener):
                executor.add_node(node)
            driver.trigger_configure()
            driver.trigger_activate()
            assert spin_until(executor, lambda: frames, 30.0), (tmp_path / 'sim.log').read_text()
            driver.close()
            driver.destroy_node()
            listener.destroy_node()
    finally:
        stop([sim])
    assert (tmp_path / 'skin_driver' / 'skin').is_dir()
