"""`make demo` runs the whole pipeline, ends with Table 1 and leaves no process behind."""

import os
import pathlib
import subprocess
import sys
import uuid

import pytest
from skin_driver.core.sim.board import SIM_UID
from skin_driver.core.sim.scene import scene_from_dict
from skin_lab.demo import demo_scene, offset_step

pytestmark = pytest.mark.ros


def _processes_with(tag):
    found = []
    for pid in filter(str.isdigit, os.listdir('/proc')):
        try:
            environ = pathlib.Path(f'/proc/{pid}/environ').read_bytes()
        except OSError:
            continue
        if tag.encode() in environ:
            found.append(int(pid))
    return found


def test_demo_calibrates_and_prints_table_1_next_to_the_papers():
    tag = f'SKIN_DEMO_TEST={uuid.uuid4().hex}'
    env = dict(os.environ, SKIN_DEMO_TEST=tag.split('=')[1])
    result = subprocess.run(
        [sys.executable, '-m', 'skin_lab.demo', '--plain', '--repeats', '1',
         '--pace', '0.6'],
        capture_output=True, text=True, timeout=180, env=env)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    out = result.stdout
    # Which board runs, and who answered, in the board's own words (issue #47).
    assert 'board: the simulated skin (skin_driver sim) on a pseudo-terminal' in out
    assert f'board answered: sim uid {SIM_UID}, fw ' in out
    # The count it says is the count it asked for and used (it said 6 and counted 5).
    used = int(out.split('calibrated (x_p')[1].split(' from ')[1].split()[0])
    assert used == offset_step(scene_from_dict(demo_scene(repeats=1, pace=0.6), name='demo'),
                               60.0)[0].presses
    table = out[out.index('Table 1'):]
    for beta in ('0.0', '45.0', '90.0', '135.0', '180.0', '225.0', '270.0', '315.0'):
        assert f'\n{beta:>10}' in table
    summary = next(line for line in table.splitlines() if line.strip().startswith('summary'))
    fields = summary.split()
    default_mean, seed_mean, paper_mean = float(fields[1]), float(fields[4]), float(fields[7])
    assert paper_mean == 3.72
    # The driver's estimator beats the paper's method on the very same scans.
    assert default_mean < seed_mean
    assert _processes_with(tag) == []


def test_demo_scene_presses_the_offset_where_the_directions_are_pressed():
    scene = scene_from_dict(demo_scene(repeats=2), name='demo')
    directions = [p for p in scene.presses if p.alpha_deg == 45.0]
    assert len(directions) == 2 * 8
    spots = {(round(p.x_m, 9), round(p.y_m, 9)) for p in scene.labelled('offset') + directions}
    assert len(spots) == 1
    # Known forces: at least six, the largest at least three times the smallest (the service's
    # rule), and each at another place.
    forces = [p.force_n for p in scene.labelled('force')]
    assert len(forces) >= 6 and max(forces) >= 3 * min(forces)
    assert len({(p.x_m, p.y_m) for p in scene.labelled('force')}) == len(forces)
    assert all(p.alpha_deg > 0 for p in scene.labelled('compliance'))


def test_demo_pace_scales_the_scene_after_the_lead_in():
    slow = scene_from_dict(demo_scene(repeats=1, pace=1.0), name='demo')
    fast = scene_from_dict(demo_scene(repeats=1, pace=0.5), name='demo')
    lead_in = slow.presses[0].time_s
    assert fast.presses[0].time_s == lead_in
    for a, b in zip(slow.presses, fast.presses):
        assert b.time_s - lead_in == pytest.approx((a.time_s - lead_in) / 2)
        assert b.duration_s == pytest.approx(a.duration_s / 2)
    assert [p.label for p in slow.presses] == [p.label for p in fast.presses]


def test_the_offset_step_says_the_count_it_asks_for():
    """Issue #47: the demo said "6 normal presses" while the goal counted 5."""
    scene = scene_from_dict(demo_scene(repeats=1), name='demo')
    goal, status = offset_step(scene, 60.0)
    normal = len(scene.labelled('offset'))
    assert goal.presses == normal - 1 and goal.timeout == 60.0
    assert status == (f'calibrating (x_p, y_p) from {goal.presses} normal presses (the scene '
                      f'makes {normal}: one spare)')
