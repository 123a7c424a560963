"""Tests of time in the simulated skin: creep under load, recovery, offset drift, held scenes."""

import math

import numpy as np
import pytest

from skin_driver.core.sim.drift import creep_factor, Drift, held_age, offset_counts
from skin_driver.core.sim.hold import HOLD_LABELS, hold_scene, idle_scene
from skin_driver.core.sim.physics import Press, render, render_held
from skin_driver.core.sim.skins import family_skin, skin_names

PRESS = Press(0.04, 0.04, 10.0, 0.5, 1.0, 0.004)


def test_creep_rises_with_the_log_of_the_time_under_load_and_settles_after_a_step():
    d = Drift(creep_per_decade=0.02, settle_s=1.0)
    rise = [float(creep_factor(d, 0.02, t)) - 1.0 for t in (9.0, 99.0, 999.0)]
    # one decade more of load adds the rate again
    assert rise[1] - rise[0] == pytest.approx(0.02, rel=1e-9)
    assert rise[2] - rise[1] == pytest.approx(0.02, rel=1e-9)
    # the first second is the settling: less than a decade's rise
    assert 0 < float(creep_factor(d, 0.02, 1.0)) - 1.0 < 0.01


def test_a_film_recovers_after_unloading_and_a_new_press_starts_where_it_has_got_to():
    d = Drift(creep_per_decade=0.02, recovery_s=60.0)
    loads = [(0.0, 3600.0), (3720.0, math.inf)]
    assert held_age(d, loads, 1800.0) == pytest.approx(1800.0)
    assert held_age(d, loads, 3660.0) == pytest.approx(3600.0 * math.exp(-1.0))
    # 1 s into the second press: what the film remembers of the first, plus the second
    assert held_age(d, loads, 3721.0) == pytest.approx(3600.0 * math.exp(-2.0) + 1.0)
    assert held_age(d, [], 100.0) == 0.0


def test_a_skin_without_drift_and_a_frame_at_time_zero_render_as_they_always_did():
    for name in ('default', 'harsh', 'film'):
        model = family_skin(name).model
        old = render(model, [PRESS], np.random.default_rng(3))
        new = render_held(model, [PRESS], [0.0], 0.0, np.random.default_rng(3))
        for a, b in zip(old, new):
            np.testing.assert_array_equal(a, b)


def test_offsets_drift_with_time_and_a_held_press_reads_more_as_it_creeps():
    model = family_skin('harsh').model
    assert offset_counts(model.drift, 0.0) == 0.0
    idle0 = render_held(model, [], [], 0.0, np.random.default_rng(1))[0].astype(float)
    idle8 = render_held(model, [], [], 8 * 3600.0, np.random.default_rng(1))[0].astype(float)
    assert abs(np.mean(idle8 - idle0)) > 40  # more than a touch threshold
    fresh = render_held(model, [PRESS], [1.0], 0.0, np.random.default_rng(1))[1].astype(float)
    held = render_held(model, [PRESS], [3600.0], 0.0, np.random.default_rng(1))[1].astype(float)
    assert held.sum() > fresh.sum()


def test_the_family_differs_in_creep_within_the_makers_range_and_held_out_draws_creep_too():
    creep = {n: family_skin(n).model.drift.over_48_hours() for n in skin_names()}
    assert min(creep.values()) >= 0.02 and max(creep.values()) <= 0.30
    assert max(creep.values()) > 3 * min(creep.values())
    for seed in range(6):
        drift = family_skin(f'held_out:{seed}').model.drift
        assert 0.025 - 1e-9 <= drift.over_48_hours() <= 0.30 + 1e-9
        assert drift.drifts


def test_a_held_scene_is_scored_at_its_labels_in_time_order_and_the_same_for_a_seed():
    member = family_skin('default')
    scene = hold_scene(member, seed=2)
    times = [f.time_s for f in scene.frames]
    assert times == sorted(times)
    labels = {f.label: f.time_s for f in scene.frames if f.label}
    assert set(labels) == set(HOLD_LABELS) | {'repress'}
    assert labels['60min'] - labels['1s'] == pytest.approx(3599.0)
    again = hold_scene(member, seed=2)
    np.testing.assert_array_equal(scene.frames[-1].top, again.frames[-1].top)
    idle = idle_scene(member, duration_s=600.0, step_s=60.0)
    assert len(idle.frames) == 10 and idle.press is None
