"""Tests of the ROS-free calibration session fed with simulated scans of a non-default skin."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinIdentity
from skin_driver.core.estimation.calibration.session import CalibrationRefused, CalibrationSession
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.fsr import FsrFilm
from skin_driver.core.sim.physics import Press, render, SkinModel

# Another FSR curve and three times the default compliance: the assumed model is wrong here.
SKIN = SkinModel(misalignment_m=(4e-4, -2e-4), compliance_m_per_n=2.1e-3,
                 fsr=FsrFilm(r_series_ohm=2000.0, r_min_ohm=150.0, r_max_ohm=6000.0,
                             force_at_r_min_n=40.0))
FORCES = np.linspace(5.0, 40.0, 8)


def tared(seed=0):
    rng = np.random.default_rng(seed)
    est = ContactEstimator(EstimatorConfig())
    quiet = [render(SKIN, [], rng) for _ in range(10)]
    est = est.with_tare(np.stack([q[0] for q in quiet]), np.stack([q[1] for q in quiet]))
    return est, rng


def feed(session, est, rng, presses):
    """Stream each press as a ramp up, a hold and a ramp down, with quiet scans between."""
    notes = []
    for press in presses:
        for share in [0.0] * 10 + list(np.linspace(0.1, 1.0, 8)) + [1.0] * 4 + [0.5, 0.2]:
            scaled = Press(press.x_m, press.y_m, press.force_n * share, press.alpha_rad,
                           press.beta_rad, press.radius_m)
            top, bottom = render(SKIN, [scaled] if share else [], rng)
            notes.append(session.add_scan(top, bottom, est.process(top, bottom)))
    for _ in range(10):
        top, bottom = render(SKIN, [], rng)
        notes.append(session.add_scan(top, bottom, est.process(top, bottom)))
    return [n for n in notes if n]


def force_of(est, rng, force_n, where=(0.04, 0.035)):
    top, bottom = render(SKIN, [Press(*where, force_n, radius_m=0.004)], rng)
    return est.process(top, bottom)[0].force_n


def test_force_session_makes_newtons_right_on_another_fsr_curve():
    est, rng = tared()
    before = force_of(est, rng, 20.0)
    assert before > 1.5 * 20.0  # the assumed curve is far off on this skin
    session = CalibrationSession(est, 'force', forces_n=FORCES)
    places = rng.uniform(0.02, 0.055, (FORCES.size, 2))
    notes = feed(session, est, rng, [Press(x, y, f, radius_m=0.004)
                                     for (x, y), f in zip(places, FORCES)])
    assert session.done and len(notes) == FORCES.size
    outcome = session.finish()
    assert est.calibration == Calibration()  # finish never changes what is in force
    est = est.with_calibration(outcome.calibration)
    assert outcome.presses_used == FORCES.size
    for f in (8.0, 20.0, 35.0):
        assert force_of(est, rng, f) == pytest.approx(f, rel=0.1)


def test_one_press_of_a_wrong_known_force_is_left_out_and_named():
    """Issue #37: one press that disagrees no longer refuses the whole force calibration."""
    est, rng = tared()
    known = FORCES.copy()
    known[3] *= 1.6  # press 4: the robot's load was not what the goal says
    session = CalibrationSession(est, 'force', forces_n=known)
    places = rng.uniform(0.02, 0.055, (FORCES.size, 2))
    feed(session, est, rng, [Press(x, y, f, radius_m=0.004)
                             for (x, y), f in zip(places, FORCES)])
    outcome = session.finish()
    assert outcome.presses_used == FORCES.size - 1
    assert f'left out press 4 ({known[3]:.2f} N' in outcome.message
    est = est.with_calibration(outcome.calibration)
    for f in (8.0, 20.0, 35.0):
        assert force_of(est, rng, f) == pytest.approx(f, rel=0.1)


def test_offset_session_ignores_tilted_presses_and_finds_the_misalignment():
    est, rng = tared(1)
    session = CalibrationSession(est, 'offset', presses=2)
    tilted = Press(0.04, 0.04, 10.0, math.radians(40.0), 0.0, 0.004)
    notes = feed(session, est, rng, [tilted, Press(0.035, 0.04, 10.0, radius_m=0.004),
                                     Press(0.045, 0.035, 12.0, radius_m=0.004)])
    assert 'did not look normal' in notes[0] and session.ignored == 1
    cal = session.finish().calibration
    assert (cal.x_p_m, cal.y_p_m) == pytest.approx(SKIN.misalignment_m, abs=2e-4)
    # Stamped for the skin pressed, the offset part alone made now.
    assert cal.skin == SkinIdentity(SKIN.rows, SKIN.cols, SKIN.pitch_m)
    assert cal.made('offset') == cal.made_utc != '' and cal.made('force') == ''


def test_compliance_session_from_known_tilted_loads():
    est, rng = tared(2)
    est = est.with_calibration(Calibration(x_p_m=SKIN.misalignment_m[0],
                                           y_p_m=SKIN.misalignment_m[1]))
    forces, alphas = [6.0, 8.0, 5.0, 7.0], np.radians([30.0, 20.0, 40.0, 25.0])
    betas = np.radians([0.0, 90.0, 200.0, 300.0])
    session = CalibrationSession(est, 'compliance', forces_n=forces, alphas_rad=alphas)
    feed(session, est, rng, [Press(0.04, 0.04, f, a, b, 0.004)
                             for f, a, b in zip(forces, alphas, betas)])
    outcome = session.finish()
    assert outcome.calibration.compliance_m_per_n == pytest.approx(
        SKIN.compliance_m_per_n, rel=0.15)
    assert outcome.calibration.x_p_m == SKIN.misalignment_m[0]  # the other parts are kept
    assert len(outcome.residuals) == 4


def test_compliance_from_a_reference_wrench_fed_with_the_scans():
    est, rng = tared(3)
    est = est.with_calibration(Calibration(x_p_m=SKIN.misalignment_m[0],
                                           y_p_m=SKIN.misalignment_m[1]))
    session = CalibrationSession(est, 'compliance', presses=3)
    for f, beta in ((6.0, 0.0), (8.0, 2.0), (5.0, 4.0)):
        alpha = math.radians(30.0)
        for share in [0.0] * 3 + list(np.linspace(0.2, 1.0, 6)) + [1.0] * 3 + [0.0] * 10:
            load = f * share
            wrench = (load * math.sin(alpha) * math.cos(beta),
                      load * math.sin(alpha) * math.sin(beta), -load * math.cos(alpha))
            top, bottom = render(SKIN, [Press(0.04, 0.04, load, alpha, beta, 0.004)]
                                 if share else [], rng)
            session.add_scan(top, bottom, est.process(top, bottom), wrench)
    assert session.done
    assert session.finish().calibration.compliance_m_per_n == pytest.approx(
        SKIN.compliance_m_per_n, rel=0.15)


def test_a_refused_force_session_leaves_the_calibration_in_force():
    est, rng = tared(4)
    previous = Calibration(x_p_m=1e-4, compliance_m_per_n=1e-3, presses=3)
    est = est.with_calibration(previous)
    probe = render(SKIN, [Press(0.04, 0.04, 20.0, radius_m=0.004)], rng)
    maps = est.maps_of(*probe)
    known = [5.0, 10.0, 20.0, 30.0, 45.0, 60.0]
    session = CalibrationSession(est, 'force', forces_n=known)
    # The presses made in the reverse order of the forces given: no curve fits them.
    feed(session, est, rng, [Press(0.04, 0.04, f, radius_m=0.004) for f in known[::-1]])
    with pytest.raises(CalibrationRefused, match='too few presses agree with one curve'):
        session.finish()
    assert est.calibration is previous
    np.testing.assert_array_equal(est.maps_of(*probe), maps)


def test_a_refusal_names_the_presses_that_drove_taxels_to_the_adc_full_scale():
    est, rng = tared(5)
    known = [5.0, 10.0, 20.0, 30.0, 45.0, 60.0]
    session = CalibrationSession(est, 'force', forces_n=known)
    for k, force in enumerate(known[::-1]):  # no curve fits these: the refusal must say more
        top, bottom = render(SKIN, [Press(0.04, 0.04, force, radius_m=0.004)], rng)
        if k >= 4:
            # Crosstalk or an overloaded film pushes the centre of presses 5 and 6 to 4095.
            bottom = bottom.copy()
            bottom[8, 8] = 4095
        session.add_press(session.record(top, bottom, est.process(top, bottom)))
    with pytest.raises(CalibrationRefused, match="presses 5, 6 drove taxels to the ADC's full "
                                                 'scale'):
        session.finish()


@pytest.mark.parametrize('kind, args, message', [
    ('force', {}, 'known force of each press'),
    ('force', {'forces_n': [5.0, -1.0]}, 'positive'),
    ('compliance', {'forces_n': [5.0], 'alphas_rad': []}, 'one alpha per force'),
    ('compliance', {'forces_n': [5.0], 'alphas_rad': [2.0]}, 'pi/2'),
    ('twist', {}, 'not one of'),
])
def test_inconsistent_requests_are_refused_at_once(kind, args, message):
    with pytest.raises(CalibrationRefused, match=message):
        CalibrationSession(ContactEstimator(), kind, presses=3, **args)


@pytest.mark.parametrize('kind, args, message', [
    ('force', {'forces_n': [5.0, 10.0]}, '2 presses of known force; the force curve needs at '
                                         'least 6'),
    ('force', {'forces_n': [10.0, 12.0, 14.0, 16.0, 18.0, 20.0]}, 'span only 10.00 to 20.00 N'),
    ('compliance', {'forces_n': [5.0, 6.0], 'alphas_rad': [0.3, 0.4]}, 'needs at least 3'),
    ('compliance', {'presses': 2}, '2 tilted presses asked for'),
])
def test_requests_no_presses_could_satisfy_are_refused_before_any_press(kind, args, message):
    with pytest.raises(CalibrationRefused, match=message):
        CalibrationSession(ContactEstimator(), kind, **args)


def test_a_force_calibration_for_the_model_fit_learns_the_skin_and_another_clears_it():
    est, rng = tared()
    modelled = est.with_config(EstimatorConfig(method='model_fit'))
    session = CalibrationSession(modelled, 'force', forces_n=FORCES)
    places = rng.uniform(0.02, 0.055, (FORCES.size, 2))
    feed(session, modelled, rng, [Press(x, y, f, radius_m=0.004)
                                  for (x, y), f in zip(places, FORCES)])
    outcome = session.finish()
    model = outcome.calibration.taxel_model
    assert model is not None and model.presses == FORCES.size
    assert f'taxel model from {FORCES.size} presses' in outcome.message
    # SKIN's layer and cover blurs are the simulator's defaults; the presses teach them.
    assert model.layer_spread_m == pytest.approx(SKIN.spread_m, rel=0.05)
    assert model.cover_spread_m == pytest.approx(SKIN.cover_spread_m, rel=0.15)
    # A force calibration for a method without a model leaves no stale one behind.
    plain = est.with_calibration(outcome.calibration)
    session = CalibrationSession(plain, 'force', forces_n=FORCES)
    feed(session, plain, rng, [Press(x, y, f, radius_m=0.004)
                               for (x, y), f in zip(places, FORCES)])
    assert session.finish().calibration.taxel_model is None
