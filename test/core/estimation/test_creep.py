"""Creep calibration: the fit of a held load's rising reading, its session's refusals, its file."""

from types import SimpleNamespace

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.creep import (CreepError, CreepFit, CreepSession,
                                                           fit_creep, fit_recovery)
from skin_lab.evaluate.drift import calibrate_creep

AGES = np.concatenate([[0.01, 0.03, 0.1, 0.3, 0.6], np.arange(1.0, 181.0, 1.0)])


def _contact(force, x=0.04, y=0.04):
    return SimpleNamespace(x_m=x, y_m=y, force_n=force)


def test_the_fit_recovers_rate_and_settling_of_a_noisy_logarithmic_rise():
    truth = CreepFit(0.04, 2.0)
    rng = np.random.default_rng(0)
    forces = 10.0 * truth.factor(AGES) * (1 + 0.002 * rng.standard_normal(AGES.size))
    fit = fit_creep(AGES, forces)
    assert fit.per_decade == pytest.approx(0.04, rel=0.1)
    assert fit.settle_s == pytest.approx(2.0, rel=0.35)
    assert fit.load_n == pytest.approx(10.0, rel=0.01)
    assert fit.over_48_hours() == pytest.approx(truth.over_48_hours(), rel=0.1)
    # a film that does not creep: no rise found
    flat = fit_creep(AGES, np.full(AGES.size, 5.0))
    assert flat.per_decade == pytest.approx(0.0, abs=1e-9)


def test_a_load_that_changes_beyond_creep_is_refused_with_a_message():
    forces = 10.0 * CreepFit(0.03, 1.0).factor(AGES)
    forces[AGES > 90] *= 0.8  # someone leant off it
    with pytest.raises(CreepError, match='moving or changing load'):
        fit_creep(AGES, forces)


def test_a_session_refuses_no_load_a_load_that_comes_off_moves_or_is_two():
    session = CreepSession(hold_s=60.0)
    for t in range(10):
        assert session.add(float(t), []) == 0.0
    with pytest.raises(CreepError, match='no load held'):
        session.finish()
    session = CreepSession(hold_s=60.0)
    session.add(0.0, [_contact(5.0)])
    assert session.add(30.0, [_contact(5.1)]) == pytest.approx(0.5)
    with pytest.raises(CreepError, match='came off after 30.0 s'):
        session.add(31.0, [])
    session = CreepSession(hold_s=60.0, pitch_m=0.005)
    session.add(0.0, [_contact(5.0)])
    with pytest.raises(CreepError, match='moved by 1.0 taxels'):
        session.add(1.0, [_contact(5.0, x=0.045)])
    with pytest.raises(CreepError, match='2 contacts'):
        CreepSession().add(0.0, [_contact(5.0), _contact(3.0, x=0.01)])
    short = CreepSession(hold_s=60.0)
    for t in (0.0, 0.5, 1.0, 2.0, 3.0):
        short.add(t, [_contact(5.0)])
    with pytest.raises(CreepError, match='held 3 s'):
        short.finish()


def test_a_session_of_a_still_load_fits_it_and_is_done_when_held_long_enough():
    session = CreepSession(hold_s=60.0)
    truth = CreepFit(0.02, 1.0)
    ages = AGES[AGES <= 61]
    for age in ages:
        session.add(100.0 + age, [_contact(8.0 * float(truth.factor(age)))])
    assert session.done
    assert session.finish().per_decade == pytest.approx(0.02, rel=0.1)


def test_a_simulated_skin_that_creeps_more_is_fitted_a_larger_rate():
    soft, error = calibrate_creep('soft')
    stiff, _ = calibrate_creep('stiff')
    assert error == '' and soft.per_decade > 5 * stiff.per_decade > 0


def test_the_creep_is_kept_in_the_calibration_file_and_an_older_file_loads_without_it(tmp_path):
    path = tmp_path / 'cal.yaml'
    fit = CreepFit(0.03, 1.5, 60.0, 7.0, 180.0, 0.004, '2026-11-28T12:00:00Z')
    Calibration(creep=fit).save_yaml(path)
    loaded = Calibration.load_yaml(path)
    assert loaded.creep == fit
    assert 'creep 3.00 % per decade' in loaded.describe()
    Calibration().save_yaml(path)
    assert 'creep' not in path.read_text()
    assert Calibration.load_yaml(path).creep is None


def test_a_rest_and_a_second_press_tell_how_fast_the_film_recovers():
    truth = CreepFit(0.04, 2.0, 90.0)
    remembered = 180.0 * np.exp(-60.0 / 90.0)
    ratio = float(truth.factor(remembered + 1.0) / truth.factor(1.0))
    assert fit_recovery(truth, 180.0, 60.0, ratio) == pytest.approx(90.0, rel=1e-6)
    # a film that hardly creeps says nothing of its recovery
    assert fit_recovery(CreepFit(0.001, 1.0), 180.0, 60.0, 1.0) is None
    session = CreepSession(hold_s=170.0, rest_s=60.0)
    for age in AGES:
        session.add(10.0 + age, [_contact(8.0 * float(truth.factor(age)))])
    assert session.phase == 'release' and not session.done
    session.add(191.0, [_contact(8.0)])  # still on: the release is awaited
    session.add(192.0, [])
    assert session.phase == 'rest'
    for age in (0.0, 0.5, 0.8, 1.0, 1.2, 1.4):
        force = 8.0 * float(truth.factor(180.0 * np.exp(-(60.0 + age) / 90.0) + age))
        session.add(252.0 + age, [_contact(force)])
    assert session.done
    fit = session.finish()
    assert fit.per_decade == pytest.approx(0.04, rel=0.1)
    assert 45.0 < fit.recovery_s < 180.0
