"""Patch scenes: one script of presses rendered on each patch in its own frame."""

import math

import numpy as np
import pytest
from skin_driver.core.robot.patches import Pose
from skin_driver.core.sim import physics
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.core.sim.patch_scene import (bundled_patch_scene_names, load_patch_scene,
                                              patch_scene_from_dict)
from skin_driver.core.sim.scene import bundled_scene_names

SIDE_BY_SIDE = {
    'common_frame': 'base_link',
    'links': {'arm': {'xyz': [0.3, 0.1, 0.2], 'rpy': [0.2, -0.3, 0.9]}},
    'patches': {'a': {'parent_frame': 'arm', 'xyz': [0.0, 0.0, 0.05]},
                'b': {'parent_frame': 'arm', 'xyz': [0.08, 0.0, 0.05]},
                'c': {'parent_frame': 'base_link', 'xyz': [0.0, 0.5, 0.0],
                      'rpy': [0.0, 0.0, 1.5708]}},
    'model': {'rows': 16, 'cols': 16, 'pitch_m': 0.005},
    'defaults': {'radius_m': 0.004, 'ramp_s': 0.1, 'alpha_deg': 0.0, 'beta_deg': 0.0,
                 'force_n': 8.0},
    'presses': [
        {'patch': 'a', 'time_s': 0.0, 'x_m': 0.0375, 'y_m': 0.0375, 'to_x_m': 0.1175,
         'duration_s': 4.0},
        {'patch': 'c', 'time_s': 0.0, 'x_m': 0.03, 'y_m': 0.04, 'alpha_deg': 30.0,
         'beta_deg': 0.0, 'duration_s': 4.0},
    ],
}


def test_a_press_on_one_patch_is_on_no_other_plane():
    scene = patch_scene_from_dict(SIDE_BY_SIDE)
    assert [i for i, _ in scene.active_on('c', 1.0)] == [1]
    assert [i for i, _ in scene.active_on('a', 1.0)] == [0]
    # b lies in a's plane: the sliding press is rendered there too, in b's frame, off its grid.
    (i, press), = scene.active_on('b', 1.0)
    assert i == 0 and press.x_m == pytest.approx(0.0575 - 0.08)


def test_a_sliding_press_moves_from_one_patch_to_the_next():
    scene = patch_scene_from_dict(SIDE_BY_SIDE)
    model = scene.model

    def load(patch, t):
        return physics.render_force(model, [p for _, p in scene.active_on(patch, t)])[0].sum()

    # Early on patch a alone, at the seam on both, late on patch b alone.
    assert load('a', 0.5) > 1.0 and load('b', 0.5) == 0.0
    assert load('a', 2.0) > 1.0 and load('b', 2.0) > 1.0
    assert load('a', 3.9) == 0.0 and load('b', 3.9) > 1.0
    # Its centre in the common frame moves along a straight line through the mounts.
    start, end = scene.point(0, 0.0), scene.point(0, 4.0)
    arm = Pose.from_xyz_rpy((0.3, 0.1, 0.2), (0.2, -0.3, 0.9))
    assert np.allclose(start, arm.point((0.0375, 0.0375, 0.05)))
    assert np.allclose(end, arm.point((0.1175, 0.0375, 0.05)))
    assert np.allclose(scene.point(0, 2.0), (np.array(start) + end) / 2)
    assert np.allclose(scene.point(0, 2.0, 'b'), (0.0775 - 0.08, 0.0375, 0.0), atol=1e-12)


def test_a_tilted_press_keeps_its_direction_on_a_turned_patch():
    scene = patch_scene_from_dict(SIDE_BY_SIDE)
    (_, press), = scene.active_on('c', 1.0)
    assert press.alpha_rad == pytest.approx(math.radians(30.0))
    assert press.beta_rad == pytest.approx(0.0, abs=1e-9)
    assert press.force_n == pytest.approx(8.0)


def test_each_patch_board_plays_its_view():
    scene = patch_scene_from_dict(SIDE_BY_SIDE)
    view = scene.view('c')
    assert view.model == scene.model and view.duration_s == scene.duration_s
    board = SimulatedSkin(view, rate_hz=50.0)  # not started: no pty needed
    assert board.scene is view
    assert [i for i, _ in view.active_at(1.0)] == [1]
    with pytest.raises(KeyError, match='no patch'):
        scene.view('nosuch')


@pytest.mark.parametrize('change, message', [
    ({'presses': [{'patch': 'z', 'time_s': 0, 'x_m': 0, 'y_m': 0, 'duration_s': 1}]},
     "patch 'z' is not in the layout"),
    ({'presses': [{'time_s': 0, 'x_m': 0, 'y_m': 0, 'to_x_m': 'far', 'duration_s': 1}]},
     "'to_x_m' must be a finite number"),
    ({'presses': [{'time_s': 0, 'x_m': 0, 'duration_s': 1}]}, "missing field 'y_m'"),
    ({'generator': {'kind': 'random'}}, "unknown key 'generator'"),
])
def test_a_bad_patch_scene_is_refused_naming_what(change, message):
    with pytest.raises(ValueError, match=message):
        patch_scene_from_dict({**SIDE_BY_SIDE, **change})


def test_the_bundled_crossing_scene_crosses_a_seam_and_stays_out_of_single_scenes():
    assert 'crossing' in bundled_patch_scene_names()
    assert 'crossing' not in bundled_scene_names()
    scene = load_patch_scene('crossing')
    assert len(scene.patch_names) == 3
    assert len({p.parent_frame for p in scene.layout.patches}) == 2
    crossing, = [i for i, p in enumerate(scene.base.presses) if p.label == 'crossing']
    press = scene.base.presses[crossing]
    on = {patch: [t for t in np.linspace(press.time_s + 0.3, press.end_s - 0.3, 30)
                  if physics.render_force(scene.model, [p for i, p in scene.active_on(patch, t)
                                                        if i == crossing])[0].sum() > 0.5]
          for patch in scene.patch_names}
    assert on['forearm_a'] and on['forearm_b'] and not on['upper_arm']
    assert min(on['forearm_a']) < min(on['forearm_b'])
    assert max(on['forearm_a']) < max(on['forearm_b'])
