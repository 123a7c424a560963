"""The goals a scene's labelled presses answer: what `sim --goals` prints a user to send."""

import math
import shlex

from geometry_msgs.msg import Point
import pytest
from skin_driver.core.sim.scene import load_scene, scene_from_dict
from skin_driver.tools.scene_goals import scene_goals
from skin_driver.tools.sim import main
import skin_msgs.action
import yaml

pytestmark = pytest.mark.ros


def as_goal(command: str):
    """Return the Goal message a printed `ros2 action send_goal` command sends."""
    words = shlex.split(command)
    assert words[:3] == ['ros2', 'action', 'send_goal']
    kind = getattr(skin_msgs.action, words[-2].split('/')[-1])
    fields = yaml.safe_load(words[-1])
    if 'points' in fields:
        fields['points'] = [Point(**p) for p in fields['points']]
    return words[-3], kind.Goal(**fields)  # a field of the wrong name or type raises


def test_the_calibrate_scene_prints_one_goal_per_calibration_with_the_loads_it_plays(capsys):
    scene = load_scene('calibrate')
    assert main(['--scene', 'calibrate', '--goals']) == 0
    printed = [line for line in capsys.readouterr().out.splitlines()
               if not line.startswith('#')]
    assert printed == [command for *_, command in scene_goals(scene)]
    goals = dict(as_goal(line) for line in printed)
    where = '/skin/skin_direction/'
    assert sorted(goals) == sorted(where + a for a in (
        'calibrate', 'calibrate_force', 'calibrate_compliance', 'calibrate_gains',
        'calibrate_direction', 'calibrate_mount', 'calibrate_creep'))
    assert goals[where + 'calibrate'].presses == 8
    assert list(goals[where + 'calibrate_force'].forces) == [
        p.force_n for p in scene.labelled('force')]
    assert list(goals[where + 'calibrate_direction'].azimuths) == pytest.approx(
        [math.radians(p.beta_deg) for p in scene.labelled('direction')], abs=1e-4)
    points = [(p.x, p.y, p.z) for p in goals[where + 'calibrate_mount'].points]
    assert [c for p in points for c in p] == pytest.approx(
        [c for p in scene.mount_points() for c in p], abs=1e-4)
    creep = goals[where + 'calibrate_creep']
    # Held 185 s: a 180 s hold, then the load comes back after 30 s off.
    assert (creep.load, creep.hold, creep.rest) == (10.0, 180.0, 30.0)
    assert creep.timeout >= creep.hold + creep.rest
    # Each goal waits long enough for every press of its label.
    for _, label, command in scene_goals(scene):
        presses = scene.labelled(label)
        timeout = as_goal(command)[1].timeout
        assert timeout >= max(p.end_s for p in presses) - presses[0].time_s + 20.0


def test_a_scene_in_another_namespace_and_one_with_touches_but_no_mount():
    touches = {'presses': [{'time_s': 1.0, 'x_m': 0.01, 'y_m': 0.01, 'force_n': 5.0,
                            'alpha_deg': 0.0, 'beta_deg': 0.0, 'radius_m': 0.004,
                            'duration_s': 1.0, 'label': 'mount'}]}
    with pytest.raises(ValueError, match='has no mount'):
        scene_goals(scene_from_dict(touches))
    mounted = scene_from_dict({**touches, 'mount': {'xyz': [0, 0, 0], 'rpy': [0, 0, 0]}})
    (_, _, command), = scene_goals(mounted, namespace='left/')
    assert as_goal(command)[0] == '/left/skin_direction/calibrate_mount'
    # Presses without a calibration's label answer no goal.
    touches['presses'][0]['label'] = ''
    assert scene_goals(scene_from_dict(touches)) == []
