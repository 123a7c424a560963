"""Poses, the frame tree, contacts carried between frames and the layout of several patches."""

import math

import numpy as np
import pytest
from skin_driver.core.robot.patches import (carry_contact, check_frame_name, check_patch_name,
                                            FrameTree, layout_from_dict, node_parameters,
                                            parameter_prefix, Pose, sum_wrenches,
                                            UnknownTransform)


def _matrix(pose):
    return np.array(pose.rotation)


def _rx(a):
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def _ry(a):
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def _rz(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


RPYS = [(0.0, 0.0, 0.0), (0.3, -0.7, 2.1), (math.pi / 2, 0.0, 0.0), (-1.2, 1.4, -3.0),
        (0.1, math.pi / 2, 0.2)]


@pytest.mark.parametrize('rpy', RPYS)
def test_rpy_is_fixed_axis_as_urdf_takes_it(rpy):
    pose = Pose.from_xyz_rpy((0.1, -0.2, 0.3), rpy)
    roll, pitch, yaw = rpy
    assert np.allclose(_matrix(pose), _rz(yaw) @ _ry(pitch) @ _rx(roll))
    again = Pose.from_xyz_rpy((0.1, -0.2, 0.3), pose.rpy())
    assert np.allclose(_matrix(again), _matrix(pose))


@pytest.mark.parametrize('rpy', RPYS)
def test_quaternion_round_trip(rpy):
    pose = Pose.from_xyz_rpy((0.0, 0.0, 0.0), rpy)
    q = pose.quaternion()
    assert math.isclose(sum(v * v for v in q), 1.0) and q[3] >= 0
    assert np.allclose(_matrix(Pose.from_quaternion((0, 0, 0), q)), _matrix(pose))
    # A quaternion and its negative are one rotation; an unnormalised one is normalised.
    assert np.allclose(_matrix(Pose.from_quaternion((0, 0, 0), [-2 * v for v in q])),
                       _matrix(pose))


def test_a_zero_or_non_finite_quaternion_is_refused():
    with pytest.raises(ValueError, match='length 0'):
        Pose.from_quaternion((0, 0, 0), (0, 0, 0, 0))
    with pytest.raises(ValueError, match='finite'):
        Pose.from_quaternion((0, 0, 0), (0, 0, math.nan, 1))
    with pytest.raises(ValueError, match='three'):
        Pose.from_xyz_rpy((0, 0), (0, 0, 0))
    with pytest.raises(ValueError, match='finite'):
        Pose.from_xyz_rpy((0, 0, math.inf), (0, 0, 0))


def test_compose_and_inverse():
    a = Pose.from_xyz_rpy((0.1, 0.2, 0.3), (0.3, -0.7, 2.1))
    b = Pose.from_xyz_rpy((-0.4, 0.05, 0.2), (1.0, 0.2, -0.5))
    p = (0.01, -0.02, 0.03)
    assert np.allclose((a @ b).point(p), a.point(b.point(p)))
    assert np.allclose((a @ a.inverse()).point(p), p)
    assert np.allclose(a.inverse().point(a.point(p)), p)


def test_a_carried_wrench_is_the_moment_of_the_same_force_about_the_new_origin():
    pose = Pose.from_xyz_rpy((0.3, -0.1, 0.5), (0.4, 1.1, -2.0))
    location, force = (0.02, 0.035, 0.0), (1.5, -2.0, -8.0)
    torque = tuple(np.cross(location, force))  # as the skin reports it, about its own origin
    shift = (0.001, -0.0005, 0.0)
    loc, sh, f, t = carry_contact(pose, location, shift, force, torque)
    assert np.allclose(loc, pose.point(location))
    assert np.allclose(f, _matrix(pose) @ force)
    assert np.allclose(sh, _matrix(pose) @ shift)
    assert np.allclose(t, np.cross(loc, f))


def test_sum_of_wrenches():
    force, torque = sum_wrenches([((1, 2, 3), (0.1, 0.2, 0.3)), ((-1, 0.5, 2), (0, 0, 1))])
    assert force == pytest.approx((0, 2.5, 5)) and torque == pytest.approx((0.1, 0.2, 1.3))
    assert sum_wrenches([]) == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def _tree():
    tree = FrameTree()
    tree.place('forearm', 'base', Pose.from_xyz_rpy((0.5, 0, 0.2), (0, 0.3, 0)), 'param', True)
    tree.place('upper', 'base', Pose.from_xyz_rpy((0, 0.4, 0.6), (1.0, 0, 0)), 'param', True)
    tree.place('a_skin', 'forearm', Pose.from_xyz_rpy((0, 0, 0.05), (0, 0, 0.2)), 'param', True)
    return tree


def test_tree_poses_follow_the_chain_both_ways():
    tree = _tree()
    p = (0.01, 0.02, 0.0)
    in_base = tree.pose('base', 'a_skin').point(p)
    expected = Pose.from_xyz_rpy((0.5, 0, 0.2), (0, 0.3, 0)).point(
        Pose.from_xyz_rpy((0, 0, 0.05), (0, 0, 0.2)).point(p))
    assert np.allclose(in_base, expected)
    # Across the tree: the skin on the forearm seen from the upper arm.
    in_upper = tree.pose('upper', 'a_skin').point(p)
    assert np.allclose(tree.pose('base', 'upper').point(in_upper), in_base)
    assert tree.pose('base', 'base').point(p) == pytest.approx(p)
    assert tree.parent_of('a_skin') == 'forearm' and tree.parent_of('base') is None


def test_an_unjoined_frame_is_named_with_where_each_chain_ends():
    tree = _tree()
    tree.place('b_skin', 'elbow', Pose())
    with pytest.raises(UnknownTransform, match="'b_skin' to 'elbow'"):
        tree.pose('base', 'b_skin')
    with pytest.raises(UnknownTransform, match="'nowhere'"):
        tree.pose('base', 'nowhere')


def test_fixed_edges_stay_and_loops_are_refused():
    tree = _tree()
    assert not tree.place('a_skin', 'upper', Pose(), 'tf')
    assert tree.parent_of('a_skin') == 'forearm'
    assert tree.place('elbow', 'upper', Pose(), 'tf')
    assert tree.place('elbow', 'upper', Pose.from_xyz_rpy((0.1, 0, 0), (0, 0, 0)), 'tf')
    assert tree.pose('upper', 'elbow').translation == pytest.approx((0.1, 0, 0))
    with pytest.raises(ValueError, match='loop'):
        tree.place('base', 'a_skin', Pose(), 'tf')
    with pytest.raises(ValueError, match='own parent'):
        tree.place('x', 'x', Pose())


def test_names():
    assert check_patch_name('/arm/left') == 'arm/left'
    assert parameter_prefix('arm/left') == 'arm.left'
    for bad in ('', '1a', 'a b', 'a//b', 'a.b', 7):
        with pytest.raises(ValueError):
            check_patch_name(bad)
    assert check_frame_name('forearm_link') == 'forearm_link'
    for bad in ('', '1link', 'a/b', 'a-b'):
        with pytest.raises(ValueError):
            check_frame_name(bad)


LAYOUT = {
    'common_frame': 'base_link',
    'links': {'forearm_link': {'xyz': [0.4, 0, 0.3], 'rpy': [0, 0.5, 0]}},
    'patches': {'a': {'parent_frame': 'forearm_link', 'xyz': [0, 0, 0.05], 'rpy': [0, 0, 0]},
                'b': {'parent_frame': 'forearm_link', 'xyz': [0.08, 0, 0.05]},
                'c': {'parent_frame': 'base_link', 'rpy': [3.14159, 0, 0], 'port': '/dev/x'}},
}


def test_layout_reads_and_becomes_the_nodes_parameters():
    layout = layout_from_dict(LAYOUT)
    assert [p.name for p in layout.patches] == ['a', 'b', 'c']
    assert layout.patch('c').port == '/dev/x'
    assert layout.patch('b').rpy == (0.0, 0.0, 0.0)
    params = node_parameters(layout)
    assert params['patches'] == ['a', 'b', 'c']
    assert params['b.xyz'] == [0.08, 0.0, 0.05]
    assert params['links.forearm_link.rpy'] == [0.0, 0.5, 0.0]
    assert params['c.parent_frame'] == 'base_link'
    tree = layout.tree()
    assert np.allclose(tree.pose('base_link', 'b').point((0, 0, 0)),
                       Pose.from_xyz_rpy((0.4, 0, 0.3), (0, 0.5, 0)).point((0.08, 0, 0.05)))


@pytest.mark.parametrize('change, message', [
    ({'patches': {}}, 'patches is empty'),
    ({'patches': {'a': {'xyz': [0, 0, 0]}}}, 'needs parent_frame'),
    ({'patches': {'a': {'parent_frame': 'l', 'xyz': [0, 0]}}}, 'patches.a.xyz'),
    ({'patches': {'a': {'parent_frame': 'l', 'size': 3}}}, "unknown key 'size'"),
    ({'links': {'l': {'xyz': [0, 0, 'x']}}}, 'links.l.xyz'),
    ({'links': {'base_link': {}}}, 'common frame itself'),
    ({'common_frame': 'a b'}, 'common_frame'),
    ({'robot': 1}, "unknown key 'robot'"),
])
def test_a_bad_layout_is_refused_naming_what(change, message):
    with pytest.raises(ValueError, match=message):
        layout_from_dict({**LAYOUT, **change})
