"""The kernel's time (drift.c): baselines that follow drift, presses that stay, creep undone."""

from dataclasses import replace
import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.creep import CreepFit
from skin_driver.core.estimation.scan.drift import drift_status
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.drift import Drift
from skin_driver.core.sim.hold import hold_scene, idle_scene
from skin_driver.core.sim.physics import Press, render, render_held
from skin_driver.core.sim.skins import family_skin


def _estimator(scene, config=None, calibration=None):
    return ContactEstimator(config or EstimatorConfig(), calibration).with_tare(
        scene.tare_top, scene.tare_bottom)


def _phantoms(estimator, scene, timed):
    return sum(len(estimator.process(f.top, f.bottom, f.time_s if timed else None))
               for f in scene.frames)


def test_an_unloaded_skin_drifting_past_its_threshold_reports_nothing_with_its_scans_timed():
    scene = idle_scene(family_skin('harsh'), duration_s=4 * 3600.0, step_s=20.0)
    # the tare alone, believed for hours: the drift reads as contacts
    assert _phantoms(_estimator(scene), scene, timed=False) > 100
    estimator = _estimator(scene)
    assert _phantoms(estimator, scene, timed=True) == 0
    mean, largest = estimator.drift()
    assert max(largest) > 40  # it did drift past the threshold, and was followed


def test_a_press_held_an_hour_while_the_skin_drifts_is_still_a_press_of_the_same_force():
    member = family_skin('noisy')
    scene = hold_scene(member, seed=1)
    estimator = _estimator(scene, EstimatorConfig(creep_per_decade=0.0))
    seen = {}
    for f in scene.frames:
        contacts = estimator.process(f.top, f.bottom, f.time_s)
        if f.label:
            seen[f.label] = contacts
        elif scene.frames[0].time_s < f.time_s and f.time_s < 600.0:
            assert contacts == []
    assert all(len(seen[label]) == 1 for label in ('1s', '60min', 'repress'))
    # what is left is the film's creep (no correction asked for), never a press eaten away
    creep = (1 + 0.025 * math.log10(3601.0)) / (1 + 0.025 * math.log10(2.0))
    ratio = seen['60min'][0].force_n / seen['1s'][0].force_n
    assert 1.0 < ratio < creep + 0.03
    assert seen['60min'][0].held_s == pytest.approx(3600.0, abs=1.0)


def test_the_creep_correction_with_the_skins_creep_holds_the_force_of_an_hour_within_3_percent():
    member = family_skin('soft')
    d = member.model.drift
    scene = hold_scene(member, seed=3)
    calibration = Calibration(creep=CreepFit(d.creep_per_decade, d.settle_s, d.recovery_s))
    forces = {}
    for calibrated in (False, True):
        estimator = _estimator(scene, EstimatorConfig(creep_per_decade=0.0),
                               calibration if calibrated else None)
        for f in scene.frames:
            contacts = estimator.process(f.top, f.bottom, f.time_s)
            if f.label:
                forces[calibrated, f.label] = contacts[0].force_n
    assert forces[False, '60min'] / forces[False, '1s'] > 1.10
    assert forces[True, '60min'] / forces[True, '1s'] == pytest.approx(1.0, abs=0.03)
    assert forces[True, 'repress'] / forces[True, '1s'] == pytest.approx(1.0, abs=0.03)


def test_scans_without_a_time_or_with_a_time_going_back_track_nothing():
    model = replace(family_skin('default').model,
                    drift=Drift(offset_counts_per_hour=200.0))
    rng = np.random.default_rng(0)
    tare = [render_held(model, [], [], 0.0, rng) for _ in range(20)]
    untimed, timed = (ContactEstimator().with_tare(np.stack([t for t, _ in tare]),
                                                   np.stack([b for _, b in tare]))
                      for _ in range(2))
    for t in range(30, 3601, 30):
        frame = render_held(model, [], [], float(t), rng)
        assert timed.process(*frame, time_s=float(t)) == []
    assert untimed.process(*frame)  # 200 counts past its tare: a phantom
    assert timed.process(*frame, time_s=3600.0) == []
    _, largest = timed.drift()
    assert min(largest) > 150
    # a time going back follows nothing: the skin jumped 300 counts, and reads so
    jumped = render_held(model, [], [], 5 * 3600.0, rng)
    assert timed.process(*jumped, time_s=10.0)
    assert timed.drift()[1] == largest


def test_a_change_of_settings_carries_the_time_over_and_a_tare_starts_afresh():
    member = family_skin('default')
    scene = hold_scene(member, seed=4, lead_s=60.0, hold_s=600.0)
    estimator = _estimator(scene)
    frames = [f for f in scene.frames if f.time_s < 60.0 + 300.0]
    for f in frames:
        estimator.process(f.top, f.bottom, f.time_s)
    t = frames[-1].time_s + 1.0
    loaded = render_held(member.model, [scene.press], [t - 60.0], t, np.random.default_rng(9))
    changed = estimator.with_config(replace(estimator.config, min_confidence=0.2))
    changed.carry_from(estimator)
    held = changed.process(*loaded, time_s=t)[0].held_s
    assert held == pytest.approx(t - 60.0, abs=1.0)
    retared = estimator.with_tare(scene.tare_top, scene.tare_bottom)
    retared.carry_from(estimator)
    # its tare is new: it has seen no time yet
    assert retared.process(*loaded, time_s=t)[0].held_s == 0.0


def test_direction_and_location_do_not_move_over_an_hours_hold():
    member = family_skin('default')
    scene = hold_scene(member, seed=5)
    estimator = _estimator(scene)
    seen = {}
    for f in scene.frames:
        contacts = estimator.process(f.top, f.bottom, f.time_s)
        if f.label:
            seen[f.label] = contacts[0]
    first, last = seen['1s'], seen['60min']
    assert abs(math.remainder(last.azimuth_rad - first.azimuth_rad, 2 * math.pi)) < math.radians(2)
    assert math.hypot(last.x_m - first.x_m, last.y_m - first.y_m) < 2e-4
    assert Press  # the press of the scene is the sim's own


def test_the_diagnostics_show_the_tare_and_the_drift_and_warn_when_a_taxel_drifts_apart():
    values, warning = drift_status(ContactEstimator())
    assert values['tare'] == 'no tare yet (the assumed baseline)' and warning == ''
    assert values['creep correction'] == 'default: 2.50 % per decade, settles in 1 s'
    calibrated = ContactEstimator(calibration=Calibration(creep=CreepFit(0.04, 2.0)))
    assert drift_status(calibrated)[0]['creep correction'].startswith(
        'calibrated: creep 4.00 % per decade')
    scene = idle_scene(family_skin('harsh'), duration_s=8 * 3600.0, step_s=60.0)
    estimator = _estimator(scene)
    values, warning = drift_status(estimator)
    assert warning == '' and 'min 0, max 64' in values['tare offset, top [counts]']
    assert values['drift since the tare, top [counts]'] == '+0.0 mean, 0.0 largest'
    for f in scene.frames:
        estimator.process(f.top, f.bottom, f.time_s)
    values, warning = drift_status(estimator)
    # the harsh skin's taxels drift by their own factors: some far from their layer's mean
    assert 'more than the touch threshold (40)' in warning and 'tare the unloaded skin' in warning
    assert 'largest' in values['drift since the tare, bottom [counts]']


def test_without_a_tare_the_drift_is_named_since_the_start_never_since_the_tare():
    """Issue #47: with no tare done, /diagnostics said "drift since the tare +18.6 counts"."""
    scene = idle_scene(family_skin('harsh'), duration_s=600.0, step_s=20.0)
    estimator = ContactEstimator()
    for f in scene.frames:
        estimator.process(f.top, f.bottom, f.time_s)
    values, _ = drift_status(estimator)
    assert values['tare'] == 'no tare yet (the assumed baseline)'
    assert 'drift since the start (no tare yet), top [counts]' in values
    assert not any('since the tare' in key or key.startswith('tare offset') for key in values)


def test_a_still_press_reads_less_by_the_creep_factor_the_estimator_reports():
    # The creep calibration undoes the scans' correction with creep_factor: it must be what a
    # scan divides by. One map scanned at 10, 15 and 110 s ages its taxels 0, 5 and 100 s (no
    # baseline tracking: only the creep changes the force).
    member = family_skin('noisy')
    scene = idle_scene(member, duration_s=1.0, step_s=1.0)
    config = EstimatorConfig(creep_per_decade=0.05, creep_settle_s=0.5, track_s=0.0)
    estimator = _estimator(scene, config)
    pressed = render(member.model, [Press(0.04, 0.04, 8.0)], np.random.default_rng(0))
    force = [estimator.process(*pressed, time_s=t)[0].force_n for t in (10.0, 15.0, 110.0)]
    assert force[2] < force[1] < force[0]
    assert force[1] / force[2] == pytest.approx(
        estimator.creep_factor(100.0) / estimator.creep_factor(5.0), rel=1e-12)
