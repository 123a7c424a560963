"""The patches node: several patches' contacts in one frame, and the net wrench per link."""

import contextlib
import importlib.util
import math
import os
import time
from types import SimpleNamespace

from geometry_msgs.msg import Point, TransformStamped, Vector3, Wrench, WrenchStamped
import numpy as np
from pipeline import FAST_DIRECTION, FAST_DRIVER, overrides
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosutil import ros_context, ros_session, spin_until
from skin_driver.core.robot.patches import layout_from_dict, node_parameters
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.core.sim.patch_scene import load_patch_scene, patch_scene_from_dict
from skin_driver.ros.conversions import status_values
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.ros.params import ParameterError
from skin_driver.ros.patches_node import PatchesNode
from skin_msgs.msg import TactileContact, TactileContactArray
from std_msgs.msg import Header

pytestmark = pytest.mark.ros

TOLERANCE_M = 0.001


def _key(stamp):
    return stamp.sec * 10 ** 9 + stamp.nanosec


def _vec(v):
    return np.array([v.x, v.y, v.z])


class Heard:
    """What a subscriber to the patches node hears: arrays and per-link wrenches."""

    def __init__(self, node, namespace, links, clock=time.monotonic):
        self.arrays, self.wrenches = [], {link: [] for link in links}
        node.create_subscription(TactileContactArray, f'{namespace}/contacts',
                                 lambda msg: self.arrays.append((clock(), msg)),
                                 qos_profile_sensor_data)
        for link in links:
            node.create_subscription(WrenchStamped, f'{namespace}/wrench/{link}',
                                     lambda msg, link=link: self.wrenches[link].append(msg),
                                     qos_profile_sensor_data)


# ---- three simulated patches on two links -----------------------------------------------------

# The crossing scene's robot; each patch held at a spot well inside it (tilted on two), then a
# press sliding from forearm_a across the seam onto forearm_b.
HOLD = (0.3, 2.3)
SLIDE = (2.7, 5.7)


def _scene():
    layout = load_patch_scene('crossing').layout
    data = {
        'common_frame': layout.common_frame,
        'links': {link: {'xyz': list(xyz), 'rpy': list(rpy)}
                  for link, (xyz, rpy) in layout.links.items()},
        'patches': {p.name: {'parent_frame': p.parent_frame, 'xyz': list(p.xyz),
                             'rpy': list(p.rpy)} for p in layout.patches},
        'model': {'rows': 16, 'cols': 16, 'pitch_m': 0.005},
        'defaults': {'radius_m': 0.004, 'ramp_s': 0.1, 'alpha_deg': 0.0, 'beta_deg': 0.0},
        'presses': [
            {'patch': 'forearm_a', 'time_s': HOLD[0], 'x_m': 0.02, 'y_m': 0.05, 'force_n': 8.0,
             'alpha_deg': 30.0, 'beta_deg': 45.0, 'duration_s': HOLD[1] - HOLD[0]},
            {'patch': 'forearm_b', 'time_s': HOLD[0], 'x_m': 0.055, 'y_m': 0.025,
             'force_n': 6.0, 'duration_s': HOLD[1] - HOLD[0]},
            {'patch': 'upper_arm', 'time_s': HOLD[0], 'x_m': 0.03, 'y_m': 0.045,
             'force_n': 10.0, 'alpha_deg': 30.0, 'beta_deg': 90.0,
             'duration_s': HOLD[1] - HOLD[0]},
            {'patch': 'forearm_a', 'time_s': SLIDE[0], 'x_m': 0.0375, 'y_m': 0.0375,
             'to_x_m': 0.1175, 'to_y_m': 0.0375, 'force_n': 8.0,
             'duration_s': SLIDE[1] - SLIDE[0]}],
    }
    return patch_scene_from_dict(data, 'test')


@contextlib.contextmanager
def _patches_pipeline(tmp_path, scene, rate_hz=50.0):
    """
    Yield (boards, patches node, listener node, executor) on one private context.

    Each patch has a board, a driver and a direction node in its namespace; the patches node
    runs in /skin.
    """
    context = rclpy.Context()
    with ros_session(context) as executor:
        boards, drivers, nodes = [], [], []
        try:
            for i, name in enumerate(scene.patch_names):
                folder = tmp_path / name
                os.makedirs(folder, exist_ok=True)
                link = str(folder / 'skin0')
                boards.append(SimulatedSkin(scene.view(name), rate_hz=rate_hz, link_path=link,
                                            noise_seed=1 + i))
                drivers.append(SkinDriverNode(
                    context=context, namespace=name, parameter_overrides=overrides(
                        {**FAST_DRIVER, 'port': link, 'publish_images': False})))
                nodes += [drivers[-1], DirectionNode(
                    context=context, namespace=name, parameter_overrides=overrides(
                        {**FAST_DIRECTION, 'calibration_file': str(folder / 'cal.yaml')}))]
            patches = PatchesNode(context=context, namespace='skin', parameter_overrides=overrides(
                node_parameters(scene.layout)))
            listener = rclpy.create_node('listener', context=context)
            nodes += [patches, listener]
            for node in nodes:
                executor.add_node(node)
            for board in boards:
                board.start()
            for driver in drivers:
                driver.trigger_configure()
                driver.trigger_activate()
            yield boards, patches, listener, executor
        finally:
            for driver in drivers:
                driver.close()
            for board in boards:
                board.stop()
            for node in nodes:
                node.destroy_node()


@pytest.fixture(scope='module')
def three_patches(tmp_path_factory):
    """Run the scene once; return (scene, arrays by scene time, wrenches per link)."""
    scene = _scene()
    links = sorted({p.parent_frame for p in scene.layout.patches})
    with _patches_pipeline(tmp_path_factory.mktemp('patches'), scene) as (
            boards, patches, listener, executor):
        heard = Heard(listener, '/skin', links)
        epoch = boards[0].epoch_monotonic
        assert spin_until(executor, lambda: time.monotonic() - epoch > SLIDE[1] + 0.2, 30.0)
        statuses = patches.statuses()
    arrays = [(received - epoch, msg) for received, msg in heard.arrays]
    return scene, arrays, heard.wrenches, statuses


def _held(scene, arrays):
    # Well inside the hold: after the ramp, and ahead of its end by more than any delay.
    return [msg for t, msg in arrays if HOLD[0] + 0.4 < t < HOLD[1] - 0.3]


def test_every_contact_of_three_patches_is_within_1_mm_of_its_press_in_the_common_frame(
        three_patches):
    scene, arrays, _, _ = three_patches
    held = _held(scene, arrays)
    assert len(held) > 30
    truth = {scene.paths[i].patch: np.array(scene.point(i, 1.0)) for i in range(3)}
    seen = set()
    for msg in held:
        assert msg.header.frame_id == 'base_link'
        for c in msg.contacts:
            assert c.header.frame_id == 'base_link'
            miss = np.linalg.norm(_vec(c.location) - truth[c.patch])
            assert miss < TOLERANCE_M, f'{c.patch}: {1000 * miss:.2f} mm off'
            seen.add(c.patch)
    assert seen == set(scene.patch_names)
    # Each full array holds one contact per patch, strongest first.
    full = [msg for msg in held if len(msg.contacts) == 3]
    assert len(full) > 20
    assert all(list(m.contacts) == sorted(m.contacts, key=lambda c: -c.magnitude) for m in full)


def test_forces_are_carried_into_the_common_frame(three_patches):
    scene, arrays, _, _ = three_patches
    # forearm_a's press: 8 N at 30 degrees from its normal towards beta 45 degrees.
    to_common = scene.pose('base_link', 'forearm_a')
    alpha, beta = math.radians(30.0), math.radians(45.0)
    push = to_common.rotate((math.sin(alpha) * math.cos(beta), math.sin(alpha) * math.sin(beta),
                             -math.cos(alpha)))
    forces = [_vec(c.wrench.force) for msg in _held(scene, arrays) for c in msg.contacts
              if c.patch == 'forearm_a' and c.direction_valid]
    assert len(forces) > 10
    mean = np.mean(forces, axis=0)
    angle = math.degrees(math.acos(np.dot(mean, push) / np.linalg.norm(mean)))
    assert angle < 10.0
    # Torque about the common origin: the moment of the carried force at the carried location.
    for msg in _held(scene, arrays)[:20]:
        for c in msg.contacts:
            assert np.allclose(_vec(c.wrench.torque),
                               np.cross(_vec(c.location), _vec(c.wrench.force)), atol=1e-9)


def test_each_links_net_wrench_is_the_sum_of_its_contacts_about_its_origin(three_patches):
    scene, arrays, wrenches, _ = three_patches
    by_stamp = {}
    for _, msg in arrays:
        by_stamp.setdefault(_key(msg.header.stamp), []).append(msg)
    parent = {p.name: p.parent_frame for p in scene.layout.patches}
    checked = {}
    for link, heard in wrenches.items():
        from_common = scene.pose(link, 'base_link')
        for w in heard:
            assert w.header.frame_id == link
            same = by_stamp.get(_key(w.header.stamp), [])
            if len(same) != 1:
                continue  # its array was not heard (best effort), or two share a stamp
            force, torque = np.zeros(3), np.zeros(3)
            for c in same[0].contacts:
                if parent[c.patch] == link:
                    f, t = from_common.wrench(_vec(c.wrench.force), _vec(c.wrench.torque))
                    force, torque = force + f, torque + t
            assert np.allclose(_vec(w.wrench.force), force, atol=1e-9)
            assert np.allclose(_vec(w.wrench.torque), torque, atol=1e-9)
            if np.linalg.norm(force) > 1.0:
                checked[link] = checked.get(link, 0) + 1
    assert set(checked) == {'forearm_link', 'upper_arm_link'}
    assert min(checked.values()) > 20


def test_a_press_sliding_across_the_seam_passes_from_one_patch_to_the_next(three_patches):
    scene, arrays, _, _ = three_patches
    start, end = np.array(scene.point(3, SLIDE[0])), np.array(scene.point(3, SLIDE[1]))
    along = (end - start) / np.linalg.norm(end - start)
    order = []
    for t, msg in arrays:
        if not SLIDE[0] + 0.2 < t < SLIDE[1] + 0.1:
            continue
        for c in msg.contacts:
            offset = _vec(c.location) - start
            # Wherever it is seen, and by whichever patch, it lies on the path in the common
            # frame: near the seam each patch reports the part of the press on its taxels.
            across = np.linalg.norm(offset - np.dot(offset, along) * along)
            assert across < TOLERANCE_M
            order.append((c.patch, float(np.dot(offset, along))))
    patches = [p for p, _ in order]
    assert {'forearm_a', 'forearm_b'} <= set(patches) <= {'forearm_a', 'forearm_b'}
    assert patches.index('forearm_a') < patches.index('forearm_b')
    last_a = len(patches) - 1 - patches[::-1].index('forearm_a')
    assert last_a < len(patches) - 1
    # It travels: early contacts near the start, late ones near the end.
    assert order[0][1] < 0.02 and order[-1][1] > np.linalg.norm(end - start) - 0.02


def test_diagnostics_tell_each_patch_arriving_with_its_transform(three_patches):
    _, _, _, statuses = three_patches
    patches = {s.name.split('patch ')[-1]: s for s in statuses if ': patch ' in s.name}
    assert set(patches) == {'forearm_a', 'forearm_b', 'upper_arm'}
    for name, status in patches.items():
        values = status_values(status)
        assert status.level == b'\x00', status.message
        assert status.hardware_id == f'{name}_skin_link'
        assert values['transform to common frame'] == 'known'
        assert float(values['last contacts age [s]']) < 1.0
        assert values['mount from'] == 'parameters'


# ---- one node, contacts published by hand -----------------------------------------------------

LAYOUT = {
    'common_frame': 'base_link',
    'links': {'arm': {'xyz': [0.5, -0.2, 0.3], 'rpy': [0.3, 1.0, -0.4]}},
    'patches': {'a': {'parent_frame': 'arm', 'xyz': [0.01, 0.02, 0.05], 'rpy': [0.0, 0.2, 0.0]},
                'b': {'parent_frame': 'base_link', 'xyz': [0.0, 0.3, 0.1],
                      'rpy': [3.14159, 0.0, 1.0]}},
}


def _contact(x, y, force):
    torque = np.cross((x, y, 0.0), force)
    return TactileContact(location=Point(x=x, y=y), magnitude=float(np.linalg.norm(force)),
                          normal_force=-force[2], wrench=Wrench(
                              force=Vector3(x=force[0], y=force[1], z=force[2]),
                              torque=Vector3(x=torque[0], y=torque[1], z=torque[2])))


@contextlib.contextmanager
def _one_node(extra=None, layout=LAYOUT):
    params = {**node_parameters(layout_from_dict(layout)), 'diagnostics_period': 0.1,
              **(extra or {})}
    with ros_context() as (context, executor):
        node = PatchesNode(context=context, namespace='skin',
                           parameter_overrides=overrides(params))
        hand = rclpy.create_node('hand', context=context)
        pubs = {p: hand.create_publisher(TactileContactArray, f'/{p}/contacts',
                                         qos_profile_sensor_data) for p in ('a', 'b')}
        heard = Heard(hand, '/skin', ['arm', 'base_link'])
        executor.add_node(node)
        executor.add_node(hand)
        try:
            yield node, pubs, heard, executor
        finally:
            node.destroy_node()
            hand.destroy_node()


_STAMPS = iter(range(1, 10 ** 6))


def _send(executor, pubs, heard, patch, contacts, frame=None):
    """Publish one patch's array; return the node's array of that stamp."""
    msg = TactileContactArray(header=Header(frame_id=frame or f'{patch}_skin_link'),
                              contacts=contacts)
    msg.header.stamp.sec = next(_STAMPS)

    def answered():
        return [m for _, m in heard.arrays if m.header.stamp.sec == msg.header.stamp.sec]
    for c in contacts:
        c.header = msg.header
    # Best effort: sent again until it is heard (the first may go before discovery).
    assert spin_until(executor, lambda: pubs[patch].publish(msg) or answered(), 10.0,
                      period_s=0.05)
    return answered()[-1]


def _wrench(executor, heard, link, array):
    """Return the link's wrench published with ``array`` (same stamp)."""
    def same():
        return [w for w in heard.wrenches[link] if w.header.stamp == array.header.stamp]
    assert spin_until(executor, same, 10.0)
    return same()[-1]


def test_contacts_are_carried_exactly_through_mount_and_link_pose():
    layout = layout_from_dict(LAYOUT)
    tree = layout.tree()
    with _one_node() as (_, pubs, heard, executor):
        _send(executor, pubs, heard, 'a', [_contact(0.01, 0.03, (1.0, -2.0, -5.0)),
                                           _contact(0.06, 0.04, (0.0, 0.0, -9.0))])
        got = _send(executor, pubs, heard, 'b', [_contact(0.02, 0.02, (0.5, 0.5, -3.0))])
        assert [c.patch for c in got.contacts] == ['a', 'a', 'b']  # strongest first
        a_strong = got.contacts[0]
        expected = tree.pose('base_link', 'a').point((0.06, 0.04, 0.0))
        assert np.allclose(_vec(a_strong.location), expected, atol=1e-12)
        assert np.allclose(_vec(a_strong.wrench.force),
                           tree.pose('base_link', 'a').rotate((0.0, 0.0, -9.0)), atol=1e-12)
        # The arm's wrench: both of a's contacts about the arm's origin; b is on base_link.
        arm = _wrench(executor, heard, 'arm', got)
        base = _wrench(executor, heard, 'base_link', got)
        to_arm = tree.pose('arm', 'a')
        f1, t1 = to_arm.wrench((1.0, -2.0, -5.0), np.cross((0.01, 0.03, 0), (1.0, -2.0, -5.0)))
        f2, t2 = to_arm.wrench((0.0, 0.0, -9.0), np.cross((0.06, 0.04, 0), (0.0, 0.0, -9.0)))
        assert np.allclose(_vec(arm.wrench.force), np.add(f1, f2), atol=1e-12)
        assert np.allclose(_vec(arm.wrench.torque), np.add(t1, t2), atol=1e-12)
        fb, tb = tree.pose('base_link', 'b').wrench(
            (0.5, 0.5, -3.0), np.cross((0.02, 0.02, 0), (0.5, 0.5, -3.0)))
        assert np.allclose(_vec(base.wrench.force), fb, atol=1e-12)
        assert np.allclose(_vec(base.wrench.torque), tb, atol=1e-12)
        assert arm.header.frame_id == 'arm' and base.header.frame_id == 'base_link'
        # A release reaches the link's wrench: zero when nothing touches it.
        got = _send(executor, pubs, heard, 'a', [])
        assert np.allclose(_vec(_wrench(executor, heard, 'arm', got).wrench.force), 0.0)


def test_a_patch_heard_from_no_longer_is_left_out():
    with _one_node({'max_age': 0.05}) as (_, pubs, heard, executor):
        _send(executor, pubs, heard, 'a', [_contact(0.01, 0.03, (0.0, 0.0, -5.0))])
        spin_until(executor, lambda: False, 0.3)
        got = _send(executor, pubs, heard, 'b', [_contact(0.02, 0.02, (0.0, 0.0, -3.0))])
        assert [c.patch for c in got.contacts] == ['b']
        assert np.allclose(_vec(_wrench(executor, heard, 'arm', got).wrench.force), 0.0)


def test_contacts_in_another_frame_are_refused_logged_and_diagnosed(caplog):
    with _one_node() as (node, pubs, heard, executor):
        got = _send(executor, pubs, heard, 'a', [_contact(0.01, 0.03, (0.0, 0.0, -5.0))],
                    frame='skin_link')
        assert got.contacts == []
        status = next(s for s in node.statuses() if s.name.endswith('patch a'))
        assert status.level == b'\x02'
        assert "'skin_link', not the patch frame 'a_skin_link'" in status.message
        assert int(status_values(status)['arrays refused']) >= 1


def test_a_patch_without_a_mount_is_refused_until_tf_static_places_it():
    layout = {**LAYOUT, 'patches': {'a': {'parent_frame': 'arm'},
                                    'b': {'parent_frame': 'base_link'}}}
    params = {'b.parent_frame': ''}
    with _one_node(params, layout) as (node, pubs, heard, executor):
        got = _send(executor, pubs, heard, 'b', [_contact(0.01, 0.03, (0.0, 0.0, -5.0))])
        assert got.contacts == []
        status = next(s for s in node.statuses() if s.name.endswith('patch b'))
        assert 'b_skin_link has no mount' in status.message
        # The mount as mount_tf publishes it on /tf_static (tf2_msgs has no wheel here: the
        # message's fields, not its type).
        tf = TransformStamped(child_frame_id='b_skin_link')
        tf.header.frame_id = 'elbow'
        tf.transform.translation.z = 0.1
        tf.transform.rotation.w = 1.0
        node.on_tf(SimpleNamespace(transforms=[tf]), '/tf_static')
        got = _send(executor, pubs, heard, 'b', [_contact(0.01, 0.03, (0.0, 0.0, -5.0))])
        assert got.contacts == []  # elbow is not joined to base_link yet
        assert "'elbow'" in next(s for s in node.statuses() if s.name.endswith('patch b')).message
        tf2 = TransformStamped(child_frame_id='elbow')
        tf2.header.frame_id = 'base_link'
        tf2.transform.translation.x = 0.2
        tf2.transform.rotation.w = 1.0
        node.on_tf(SimpleNamespace(transforms=[tf2]), '/tf')
        got = _send(executor, pubs, heard, 'b', [_contact(0.01, 0.03, (0.0, 0.0, -5.0))])
        assert np.allclose(_vec(got.contacts[0].location), (0.21, 0.03, 0.1))
        status = next(s for s in node.statuses() if s.name.endswith('patch b'))
        assert status_values(status)['mount from'] == '/tf_static'
        assert status_values(status)['link'] == 'elbow'
        # A mount the parameters give stays: /tf cannot move patch a off its arm.
        tf3 = TransformStamped(child_frame_id='a_skin_link')
        tf3.header.frame_id = 'elbow'
        tf3.transform.rotation.w = 1.0
        node.on_tf(SimpleNamespace(transforms=[tf3]), '/tf_static')
        status = next(s for s in node.statuses() if s.name.endswith('patch a'))
        assert status_values(status)['link'] == 'arm'


def test_without_tf2_msgs_the_node_says_so_and_uses_the_parameters():
    with _one_node() as (node, _, _, _):
        if importlib.util.find_spec('tf2_msgs') is None:
            assert 'tf2_msgs is not installed' in node.transforms_from
        else:
            assert '/tf_static' in node.transforms_from


def test_a_mount_changed_at_run_time_moves_the_contacts_and_a_bad_one_is_refused():
    with _one_node() as (node, pubs, heard, executor):
        result = node.set_parameters([Parameter('b.xyz', value=[0.0, 0.3, 0.2])])[0]
        assert result.successful
        got = _send(executor, pubs, heard, 'b', [_contact(0.0, 0.0, (0.0, 0.0, -5.0))])
        assert np.allclose(_vec(got.contacts[0].location), (0.0, 0.3, 0.2))
        result = node.set_parameters([Parameter('b.xyz', value=[0.0, 0.3])])[0]
        assert not result.successful and 'three numbers' in result.reason


@pytest.mark.parametrize('params, message', [
    ({'patches': ['a', '1b']}, "patch name '1b'"),
    ({'patches': ['a', 'a']}, 'named twice'),
    ({'a.xyz': [0.0, 0.1]}, "'a.xyz'"),
    ({'a.parent_frame': 'a-b'}, 'a parent frame'),
    ({'common_frame': 'base link'}, 'common_frame'),
    ({'patches': ['skin', 'a']}, 'publishes'),
    ({'patches': 'a'}, "'patches'.*list of namespaces"),
])
def test_parameters_it_cannot_work_with_stop_it_naming_them(params, message):
    with ros_context() as (context, _):
        base = node_parameters(layout_from_dict(LAYOUT))
        with pytest.raises(ParameterError, match=message):
            PatchesNode(context=context, namespace='skin',
                        parameter_overrides=overrides({**base, **params}))


def test_without_patches_it_says_what_to_give():
    with ros_context() as (context, _):
        with pytest.raises(ParameterError, match='namespaces of the patches'):
            PatchesNode(context=context)
