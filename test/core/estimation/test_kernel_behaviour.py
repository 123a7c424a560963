"""
What the per-scan estimate must do whatever its implementation: symmetries and invariances.

A press mirrored or turned by 90 degrees gives the mirrored or turned contact; a rest offset
that a tare takes off, and a uniform gain, change nothing but what they must.
"""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.physics import Press, render, SkinModel

PITCH = 0.005
N = 16
# Mirrored or turned maps are the same numbers summed in another order: a few ulp apart.
CLOSE = 1e-9

PRESSES = [Press(0.0412, 0.0337, 12.0, math.radians(35), math.radians(20)),
           Press(0.0261, 0.0488, 8.0, math.radians(50), math.radians(-130), 0.003),
           Press(0.0405, 0.0402, 15.0, math.radians(25), math.radians(100))]


def _wrapped(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def _one(est, top, bottom):
    (contact,) = est.process(top, bottom)
    assert contact.direction_valid
    return contact


def _maps(press, seed=0):
    return render(SkinModel(noise_counts=0), [press], np.random.default_rng(seed))


@pytest.mark.parametrize('press', PRESSES)
def test_a_mirrored_press_gives_the_mirrored_contact(press):
    est = ContactEstimator()
    top, bottom = _maps(press)
    plain = _one(est, top, bottom)
    mirrored = _one(est, top[:, ::-1].copy(), bottom[:, ::-1].copy())
    assert mirrored.x_m == pytest.approx((N - 1) * PITCH - plain.x_m, rel=CLOSE)
    assert mirrored.y_m == pytest.approx(plain.y_m, rel=CLOSE)
    assert mirrored.force_n == pytest.approx(plain.force_n, rel=CLOSE)
    assert mirrored.shift_m == pytest.approx((-plain.shift_m[0], plain.shift_m[1]), abs=1e-12)
    assert _wrapped(mirrored.azimuth_rad - (math.pi - plain.azimuth_rad)) == pytest.approx(
        0.0, abs=1e-9)
    assert mirrored.alpha_rad == pytest.approx(plain.alpha_rad, rel=CLOSE)


@pytest.mark.parametrize('press', PRESSES)
def test_a_press_turned_a_quarter_gives_the_turned_contact(press):
    # np.rot90 puts the taxel (row r, column c) at (N - 1 - c, r): x' = y, y' = (N - 1) p - x,
    # and the shift (sx, sy) turns to (sy, -sx), a quarter turn off the azimuth.
    est = ContactEstimator()
    top, bottom = _maps(press)
    plain = _one(est, top, bottom)
    turned = _one(est, np.rot90(top).copy(), np.rot90(bottom).copy())
    assert turned.x_m == pytest.approx(plain.y_m, rel=CLOSE)
    assert turned.y_m == pytest.approx((N - 1) * PITCH - plain.x_m, rel=CLOSE)
    assert turned.force_n == pytest.approx(plain.force_n, rel=CLOSE)
    assert turned.shift_m == pytest.approx((plain.shift_m[1], -plain.shift_m[0]), abs=1e-12)
    assert _wrapped(turned.azimuth_rad - (plain.azimuth_rad - math.pi / 2)) == pytest.approx(
        0.0, abs=1e-9)


def test_a_rest_offset_that_the_tare_takes_off_changes_nothing():
    model = SkinModel()
    rng = np.random.default_rng(4)
    rest = [render(model, [], rng) for _ in range(8)]
    offset = np.random.default_rng(9).integers(0, 300, (2, N, N))
    frames = np.stack([np.stack(r) for r in rest]).astype(np.float64)  # (8, 2, N, N)
    plain = ContactEstimator().with_tare(frames[:, 0], frames[:, 1])
    lifted = ContactEstimator().with_tare(frames[:, 0] + offset[0], frames[:, 1] + offset[1])
    for press in PRESSES:
        top, bottom = render(model, [press], rng)
        want = plain.process(top, bottom)
        got = lifted.process(top + offset[0], bottom + offset[1])
        assert len(got) == len(want) >= 1
        for g, w in zip(got, want):
            assert g.direction_valid == w.direction_valid
            for name in ('x_m', 'y_m', 'force_n', 'azimuth_rad', 'alpha_rad', 'confidence'):
                assert getattr(g, name) == pytest.approx(getattr(w, name), rel=1e-9, abs=1e-12)


def test_a_uniform_gain_scales_the_normal_force_and_nothing_of_the_direction():
    top, bottom = _maps(PRESSES[0])
    gain = np.full((N, N), 1.6)
    plain = _one(ContactEstimator(), top, bottom)
    gained = _one(ContactEstimator(calibration=Calibration(gains=(gain, gain))), top, bottom)
    assert gained.force_n == pytest.approx(1.6 * plain.force_n, rel=CLOSE)
    assert (gained.x_m, gained.y_m) == pytest.approx((plain.x_m, plain.y_m), rel=CLOSE)
    assert gained.shift_m == pytest.approx(plain.shift_m, rel=CLOSE)
    assert gained.azimuth_rad == pytest.approx(plain.azimuth_rad, rel=CLOSE)
    # The tangential force follows the shift alone: only the polar angle sees the new normal.
    assert gained.force_xyz_n[:2] == pytest.approx(plain.force_xyz_n[:2], rel=CLOSE)
