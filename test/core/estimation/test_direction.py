"""The direction learned from presses of known direction: the gate, the kernel, the file."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.direction import (DirectionCorrection, features,
                                                               KnownPress, learn_direction)
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.calibration.session import CalibrationRefused, PressRecord
from skin_driver.core.estimation.calibration.session import CalibrationSession
from skin_driver.core.estimation.scan.kernel import DIRECTION_FEATURES
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_lab.experiments import calibrated_scene


def _presses(bias, n=120, seed=0, noise=0.02):
    """Presses of known azimuth whose shift is measured with each imprint's bias(col, row)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        col, row = rng.uniform(3.0, 12.0, 2)
        azimuth = rng.uniform(-math.pi, math.pi)
        length = rng.uniform(0.5, 2.0)
        sx, sy = length * math.cos(azimuth), length * math.sin(azimuth)
        # The bottom imprint's bias less the top one's: what taxel_fit's placing does.
        (tx, ty), (bx, by) = bias(col, row), bias(col + sx, row + sy)
        shift = (sx + bx - tx + rng.normal(0.0, noise), sy + by - ty + rng.normal(0.0, noise))
        out.append(KnownPress(col, row, shift, rng.uniform(5.0, 15.0), azimuth))
    return out


def test_a_bias_that_follows_the_sub_taxel_phase_is_learned_and_kept():
    presses = _presses(lambda c, r: (0.15 * math.sin(2 * math.pi * c),
                                     0.15 * math.cos(2 * math.pi * r)))
    learned = learn_direction(presses)
    assert learned.kept
    # Not all of it: the features see the bottom imprint where the biased shift puts it.
    assert learned.after_deg < 0.7 * learned.before_deg
    assert learned.presses + learned.left_out == 120 and learned.folds == 5


def test_noise_alone_is_not_kept_the_gate_cannot_make_a_skin_worse():
    learned = learn_direction(_presses(lambda c, r: (0.0, 0.0), noise=0.05))
    assert not learned.kept
    assert learned.after_deg >= learned.before_deg * 0.97


def _phase_bias(c, r):
    return 0.15 * math.sin(2 * math.pi * c), 0.15 * math.cos(2 * math.pi * r)


def test_renders_of_the_same_physics_teach_more_than_the_few_presses_and_are_judged_on_them():
    # 30 presses sample the phase bias thinly; 1500 rendered ones of the same physics pin it.
    presses = _presses(_phase_bias, n=30, seed=1)
    alone = learn_direction(presses)
    both = learn_direction(presses, rendered=_presses(_phase_bias, n=1500, seed=2))
    # (renders measured more than 30 deg off their azimuth are left out, as presses are)
    assert both.kept and both.rendered > 1400 and both.presses == 30
    assert both.after_deg < alone.after_deg
    assert 'rendered' in both.describe() and 'judged on 30 presses' in both.describe()
    assert DirectionCorrection.from_dict(both.to_dict()) == both


def test_renders_of_other_physics_are_not_kept_the_presses_judge_them():
    # The model the renders come from is wrong (its bias turns the other way): on the presses
    # the map learned from them does worse than none, so it is not the one kept.
    presses = _presses(_phase_bias, n=120)
    wrong = _presses(lambda c, r: tuple(-v for v in _phase_bias(c, r)), n=1500, seed=2)
    learned = learn_direction(presses, rendered=wrong)
    assert learned.rendered == 0 and learned.kept
    noise_only = learn_direction(_presses(lambda c, r: (0.0, 0.0), noise=0.05), rendered=wrong)
    assert not noise_only.kept


def test_the_renders_map_is_chosen_on_the_renders_not_by_the_presses_that_judge_it():
    # Renders of a bias a third too strong, few enough for the ridge to matter: presses of the
    # true bias and presses of the renders' own would each pick the ridge that suits them, a
    # choice made by peeking at the presses that judge it. The ridge is chosen on the renders,
    # so the same renders give the same map whatever presses judge it.
    renders = _presses(lambda c, r: tuple(1.3 * v for v in _phase_bias(c, r)), n=80, seed=2,
                       noise=0.1)
    judged = [learn_direction(_presses(lambda c, r, k=k: tuple(k * v for v in _phase_bias(c, r)),
                                       n=30, seed=1), rendered=renders) for k in (1.0, 1.3)]
    assert all(j.kept and j.rendered > 70 for j in judged)
    assert judged[0].ridge == judged[1].ridge
    assert judged[0].weight_x == judged[1].weight_x


def test_too_few_presses_are_refused_before_and_after():
    with pytest.raises(ValueError, match='at least 10'):
        learn_direction(_presses(lambda c, r: (0.0, 0.0), n=9))
    est = ContactEstimator(EstimatorConfig())
    with pytest.raises(CalibrationRefused, match='at least 10'):
        CalibrationSession(est, 'direction', azimuths_rad=[0.0] * 4)
    with pytest.raises(CalibrationRefused, match='azimuths, not forces'):
        CalibrationSession(est, 'direction', forces_n=[1.0] * 12)


def _scan_shift(calibration):
    model = SkinModel(noise_counts=0.0)
    top, bottom = render(model, [Press(0.0372, 0.0411, 10.0, math.radians(30), 0.7, 0.003)],
                         np.random.default_rng(0))
    est = ContactEstimator(EstimatorConfig(), calibration)
    return est.process(top, bottom)[0]


def _correction(kept, x0=0.0, y0=0.0):
    wx, wy = [0.0] * DIRECTION_FEATURES, [0.0] * DIRECTION_FEATURES
    wx[0], wy[2] = x0, y0  # the first harmonic of the x phase to x, of the y phase to y
    return DirectionCorrection(kept, 10.0, wx, wy, 50, 5, 2.0, 1.0 if kept else 2.5)


def test_the_kernel_applies_a_kept_correction_and_only_a_kept_one():
    pitch = EstimatorConfig().pitch_m
    plain = _scan_shift(Calibration())
    moved = _scan_shift(Calibration(direction=_correction(True, 0.25, -0.5)))
    ignored = _scan_shift(Calibration(direction=_correction(False, 0.25, -0.5)))
    x = features(plain.x_m / pitch, plain.y_m / pitch, plain.shift_m[0] / pitch,
                 plain.shift_m[1] / pitch, plain.force_n, 10.0)[0]
    assert abs(x[0]) > 0.1 and abs(x[2]) > 0.1  # the press moves both phases
    assert moved.shift_m[0] - plain.shift_m[0] == pytest.approx(0.25 * x[0] * pitch, abs=1e-12)
    assert moved.shift_m[1] - plain.shift_m[1] == pytest.approx(-0.5 * x[2] * pitch, abs=1e-12)
    assert moved.azimuth_rad == pytest.approx(math.atan2(*moved.shift_m[::-1]))
    assert ignored.shift_m == plain.shift_m


def test_the_kernel_and_the_fit_agree_on_the_features():
    # A correction on one feature at a time moves the shift by that feature's value.
    pitch = EstimatorConfig().pitch_m
    plain = _scan_shift(Calibration())
    sx, sy = plain.shift_m[0] / pitch, plain.shift_m[1] / pitch
    x = features(plain.x_m / pitch, plain.y_m / pitch, sx, sy, plain.force_n, 10.0)[0]
    for j in (0, 3, 6, 8, 11):
        wx = [0.0] * DIRECTION_FEATURES
        wx[j] = 0.1
        cal = Calibration(direction=DirectionCorrection(True, 10.0, wx, [0.0] * DIRECTION_FEATURES,
                                                        50, 5, 2, 1))
        assert _scan_shift(cal).shift_m[0] / pitch - sx == pytest.approx(0.1 * x[j], abs=1e-9)


def test_the_features_of_a_quarter_taxel_shift_are_the_kernel_s_order():
    # A quarter taxel into its column, moved a quarter taxel along x, at twice the reference
    # force; the second contact (numbers broadcast) at the reference force has no load part.
    x = features([0.25, 0.25], 0.0, 0.25, 0.0, [20.0, 10.0], 10.0)
    expected = [-1, -1, 0, 0, 0, 2, 0, 0, 1, 0, 0, 1, 0, -1, 0, 1, -1, -1, 0, 0]
    assert x.shape == (2, DIRECTION_FEATURES)
    assert x[0] == pytest.approx(expected, abs=1e-12)
    assert x[1] == pytest.approx(expected[:16] + [0, 0, 0, 0], abs=1e-12)


def test_the_correction_is_stored_and_an_old_file_still_loads(tmp_path):
    cal = Calibration(direction=_correction(True, 0.1))
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    back = Calibration.load_yaml(path)
    assert back.direction == cal.direction
    assert 'held-out azimuth error 2.00 -> 1.00 deg' in back.describe()
    Calibration().save_yaml(path)
    assert 'direction' not in path.read_text()
    assert Calibration.load_yaml(path).direction is None


def test_presses_of_known_direction_lower_the_error_on_the_default_skin():
    # split 4 frames (a robot's presses of known direction) through the evaluator's calibration.
    data = calibrated_scene('random', 'default', np.random.default_rng(1), size=100,
                            direction_presses=120)
    assert int((data.split == 4).sum()) == 120
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert est.calibration.direction is not None and est.calibration.direction.kept
    # Learned from renders of the skin's taxel model, judged on the robot's presses.
    assert any('rendered' in n and 'judged on 120 presses applied' in n for n in notes)
    d = est.calibration.direction
    assert d.after_deg < d.before_deg


def test_a_press_far_off_its_azimuth_is_left_out_not_spoiling_the_rest():
    presses = _presses(lambda c, r: (0.15 * math.sin(2 * math.pi * c), 0.0))
    good = learn_direction(presses)
    bad = presses[:7] + [KnownPress(5.0, 5.0, (1.0, 0.0), 10.0, math.pi)] + presses[7:]
    learned = learn_direction(bad)
    assert learned.left_out == 1 and learned.presses == good.presses
    assert learned.weight_x == pytest.approx(good.weight_x)
    assert '1 press left out' in learned.describe()


def test_with_known_azimuths_a_press_left_out_keeps_its_azimuth():
    est = ContactEstimator(EstimatorConfig())
    azimuths = [0.1 * k for k in range(10)]
    session = CalibrationSession(est, 'direction', azimuths_rad=azimuths)
    counts = np.zeros((2, 16, 16))
    for k in range(10):
        shift = (float('nan'), 0.0) if k == 3 else (1e-3, 0.0)
        note = session.add_press(PressRecord(10.0, shift, counts, place_m=(0.04, 0.04)))
        if k == 3:
            assert 'no layer shift' in note
        else:
            assert f'known azimuth {azimuths[k]:.3f} rad' in note
    assert session.done and len(session.accepted) == 9


def test_without_azimuths_each_press_takes_its_wrenchs_and_one_without_is_ignored():
    est = ContactEstimator(EstimatorConfig())
    session = CalibrationSession(est, 'direction', presses=10)
    counts = np.zeros((2, 16, 16))
    assert 'no tangential reference wrench' in session.add_press(
        PressRecord(10.0, (1e-3, 0.0), counts, wrench_n=(0.0, 0.0, -10.0), place_m=(0.04, 0.04)))
    rng = np.random.default_rng(3)
    for _ in range(10):
        azimuth = rng.uniform(-math.pi, math.pi)
        shift = (1e-3 * math.cos(azimuth + 0.05), 1e-3 * math.sin(azimuth + 0.05))
        place = tuple(rng.uniform(0.02, 0.06, 2))
        session.add_press(PressRecord(10.0, shift, counts, place_m=place,
                                      wrench_n=(3.0 * math.cos(azimuth), 3.0 * math.sin(azimuth),
                                                -10.0)))
    assert session.done and session.ignored == 1
    outcome = session.finish()
    # Every press measured 0.05 rad off the azimuth its wrench gives.
    assert outcome.calibration.direction.before_deg == pytest.approx(math.degrees(0.05))
    assert outcome.presses_used == 10


def test_a_chance_gain_of_a_few_presses_is_not_kept():
    # Pure noise: over many seeds, some folds gain by chance; none may be kept.
    kept = [learn_direction(_presses(lambda c, r: (0.0, 0.0), n=30, seed=s, noise=0.08),
                            seed=s).kept for s in range(10)]
    assert not any(kept)
