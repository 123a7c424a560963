"""Per-taxel gains from a uniform load or from presses spread over the skin."""

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.gains import gains_from_force_sums, limits_note
from skin_driver.core.estimation.calibration.session import CalibrationRefused, CalibrationSession
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render, SkinModel

FSR = FsrModel()
# A fixed pattern: every taxel 0.75 to 1.25 times as sensitive as it should be.
PATTERN = np.random.default_rng(7).uniform(0.75, 1.25, (2, 16, 16))


def counts_of(model_force, rng):
    """Return (top, bottom) counts of force maps through the sensitivity pattern."""
    out = []
    for layer, force in enumerate(model_force):
        counts = FSR.force_to_counts(force * PATTERN[layer]) + rng.normal(0.0, 3.0, force.shape)
        out.append(np.clip(np.rint(counts), 0, 4095).astype(np.uint16))
    return out


def test_a_uniform_load_recovers_the_gain_pattern_and_evens_the_skin_out():
    rng = np.random.default_rng(0)
    est = ContactEstimator(EstimatorConfig())
    session = CalibrationSession(est, 'gains', presses=1)
    # A plate with a weight: 3 N on every taxel, 10 % more on one side (a plate is never
    # quite level).
    plate = 3.0 * np.broadcast_to(1.0 + 0.1 * np.linspace(0.0, 1.0, 16), (2, 16, 16))
    top, bottom = counts_of(plate, rng)
    session.add_press(session.record(top, bottom, est.process(top, bottom)))
    outcome = session.finish()
    corrected = np.stack(outcome.calibration.gain_maps()) * PATTERN
    # The pattern's spread (14 %) is cut to less than a third; what is left is the noise of a
    # median over a neighbourhood.
    assert np.std(PATTERN) > 0.12
    assert np.std(corrected / corrected.mean()) < 0.045
    est = est.with_calibration(outcome.calibration)
    even = np.stack(est.maps_of(top, bottom)) / plate
    assert np.std(even / even.mean()) < 0.045


def test_too_little_coverage_is_refused():
    sums = np.zeros((2, 16, 16))
    sums[:, 5:8, 5:8] = 1.0
    with pytest.raises(ValueError, match='only 4 % of its taxels'):
        gains_from_force_sums(sums, 3)
    est = ContactEstimator()
    session = CalibrationSession(est, 'gains', presses=1)
    top = np.zeros((16, 16), np.uint16)
    top[7, 7] = 3000
    session.add_press(session.record(top, top, est.process(top, top)))
    with pytest.raises(CalibrationRefused, match='press evenly over the whole skin'):
        session.finish()


def test_a_plate_smaller_than_the_skin_makes_gains_at_their_limits_and_says_where():
    rng = np.random.default_rng(1)
    est = ContactEstimator(EstimatorConfig())
    session = CalibrationSession(est, 'gains', presses=1)
    # A plate over rows 0-12 only: the load falls off past its edge.
    plate = np.full((2, 16, 16), 3.0)
    plate[:, 12:, :] = np.array([1.0, 0.3, 0.05, 0.02])[None, :, None]
    top, bottom = counts_of(plate, rng)
    session.add_press(session.record(top, bottom, est.process(top, bottom)))
    outcome = session.finish()
    assert outcome.warnings and 'at the high limit 5' in outcome.warnings[0]
    assert 'rows 14-15, cols 0-15' in outcome.warnings[0]
    assert outcome.warnings[0] in outcome.message


def test_an_even_load_warns_of_nothing():
    gains = np.ones((2, 16, 16))
    assert limits_note(gains, gains > 0) == ''


def test_spread_presses_on_a_matrix_with_crosstalk_lose_it_once():
    # Each press's lines are cleaned with its own scan; the crosstalk a force calibration kept is
    # for a plate's frames (which no scan cleans), never a second time for a press.
    skin = SkinModel(crosstalk=0.012, gain_spread=0.1, seed=5)
    rng = np.random.default_rng(0)
    rest = [render(skin, [], rng) for _ in range(10)]
    est = ContactEstimator(EstimatorConfig()).with_tare(np.stack([t for t, _ in rest]),
                                                        np.stack([b for _, b in rest]))
    spots = np.linspace(0.005, 0.07, 7)
    frames = [render(skin, [Press(x, y, 20.0, radius_m=0.004)], rng) for x in spots
              for y in spots]
    found = []
    for share in (0.0, 0.012):
        known = est.with_calibration(est.calibration.updated(crosstalk_share=share))
        session = CalibrationSession(known, 'gains', presses=len(frames))
        for top, bottom in frames:
            record = session.record(top, bottom, known.process(top, bottom))
            assert record.crosstalk_share == pytest.approx(0.012, rel=0.3)
            session.add_press(record)
        found.append(np.stack(session.finish().calibration.gain_maps()))
    np.testing.assert_array_equal(found[0], found[1])
