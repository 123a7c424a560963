"""
The compiled kernel through the estimator, and its forward model's fit of one contact.

Edge cases, censoring (a saturated imprint's force filled in from its rim, the rim load), gains,
dead taxels, crosstalk, map types, bad input, references; the model fit's known presses,
censored taxels and taxel sensitivities.

What the kernel finds on the family's scenes is held by the golden outputs (test_golden.py);
its symmetries and invariances by test_kernel_behaviour.py.
"""

from dataclasses import replace
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.model.forcecurve import ForceCurve
from skin_driver.core.estimation.model.taxelmodel import (
    DX as model_dx, DY as model_dy, LOG_FORCE as model_force, LOG_RADIUS as model_radius,
    render_counts, start_of, X as model_x, Y as model_y)
from skin_driver.core.estimation.scan.kernel import fit_contact
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import Method, REFERENCES
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.core.sim.skins import family_skin
from skin_lab.experiments import calibrated_scene, make_scene
from taxel_presses import FILM, noisy, press as model_press


def figures(contact) -> np.ndarray:
    return np.array([contact.x_m, contact.y_m, contact.force_n, contact.area_m2,
                     *contact.shift_m, contact.azimuth_rad, contact.azimuth_sigma_rad,
                     contact.alpha_rad, *contact.force_xyz_n, contact.confidence,
                     contact.direction_valid], dtype=np.float64)


def scan(est, top, bottom) -> list:
    """Return the contacts of one scan, each checked finite; the shifts are measured too."""
    contacts = est.process(top, bottom)
    for contact in contacts:
        assert np.isfinite(figures(contact)).all()
    assert len(est.measure_shifts(top, bottom)) >= len(contacts)
    return contacts


@pytest.mark.parametrize('x_m, radius_m', [(0.0, 0.004), (0.005, 0.002)])
def test_the_normal_force_at_the_edge_is_chosen(x_m, radius_m):
    # Centred on the edge column, the bottom imprint is cut (the larger layer sum is taken); a
    # taxel inside, a 2 mm tip's bottom imprint reaches the edge with its rim only (the bottom
    # sum, 10 % below the top one on the default skin).
    # Tared: before a tare every loaded taxel also reads its rest counts (4 % more force here).
    model = family_skin('default').model
    rng = np.random.default_rng(0)
    top, bottom = render(model, [Press(x_m, 0.04, 20.0, radius_m=radius_m)], rng)
    rest = [render(model, [], rng) for _ in range(8)]
    est = ContactEstimator(EstimatorConfig(pitch_m=model.pitch_m)).with_tare(
        np.stack([t for t, _ in rest]), np.stack([b for _, b in rest]))
    (contact,) = scan(est, top, bottom)
    if x_m > 0:
        # The bottom sum reads the press within 2 %; the top one would read it 9 % high.
        assert contact.force_n == pytest.approx(20.0, rel=0.02)


@pytest.mark.parametrize('skin', ['film', 'held_out:6', 'loaded'])
def test_rim_loads_of_a_force_calibration_are_added(skin):
    # Force-calibrated from 16 normal presses of known force: these skins' curves learn a rim
    # load (forcecurve) that the kernel adds itself to every unsaturated imprint.
    member = family_skin(skin)
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 4)
    est = prepared_estimator(data, 'taxel_fit')[0]
    assert any(curve.rim_load_n > 0 for curve in est.calibration.force_curves)
    scored = np.flatnonzero(data.split == 0)
    for top, bottom in zip(data.top[scored], data.bottom[scored]):
        scan(est, top, bottom)


def test_a_censoring_force_curve_fills_in_the_saturated_imprint():
    # 3 N a taxel saturates this film: presses of 15 to 50 N read the ceiling at their centre,
    # and the calibrated curve fills their force in from the rims.
    member = family_skin('saturating')
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 2)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert any('filled in from their rims' in note for note in notes)
    for force in (15.0, 30.0, 50.0):
        press = Press(0.0431, 0.0353, force, radius_m=0.004)
        (contact,) = scan(est, *render(member.model, [press], rng))
        assert contact.force_n == pytest.approx(force, rel=0.1)


def test_taxels_the_adc_cut_are_censored():
    # 1.1 % crosstalk on a 64 x 64 grid drives the centre of heavier presses to the ADC's full
    # scale, calibration presses and scored ones alike: those taxels keep a level shape, read
    # the force at full scale and are filled in by the censoring curves, both ways.
    member = family_skin('held_out:2@64')
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 4)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert all(curve.censor_counts > 0 for curve in est.calibration.force_curves)
    scored = np.flatnonzero(data.split == 0)
    cut = [i for i in scored if (data.bottom[i] >= 4095).any()]
    assert cut
    for i in scored:
        (contact,) = scan(est, data.top[i], data.bottom[i])
        if i in cut:
            force = math.sqrt(sum(v * v for v in contact.force_xyz_n))
            assert force == pytest.approx(data.force_n[i], rel=0.05)


def _reading_through(curve: ForceCurve) -> ContactEstimator:
    # Untared, both layers read through the curve, the taxels sense the whole skin: a contact's
    # force is its layers' summed taxel force, filled in and with its rim load.
    return ContactEstimator(EstimatorConfig(fill_factor=1.0),
                            Calibration(force_curves=(curve, curve)))


def _imprint_force(est, counts) -> float:
    (contact,) = est.process(counts, counts.copy())
    return contact.force_n


def _cross(centre: float) -> np.ndarray:
    # Four rim taxels of 50 counts (1 N on a curve of 2 N per 100 counts) around one centre.
    counts = np.zeros((8, 8))
    counts[3, 4] = counts[5, 4] = counts[4, 3] = counts[4, 5] = 50.0
    counts[4, 4] = centre
    return counts


@pytest.mark.parametrize('activation_n', [0.0, 0.1])
def test_a_saturated_imprint_is_filled_in_from_its_rim_the_activation_besides_its_bump(
        activation_n):
    # The centre reads 95 counts (1.9 N), over the 90 at which the curve censors: a lower bound.
    # A bump of 0.6 taxels (too narrow to fit its own: the calibration's is kept) is fitted to
    # the rim's force above the activation; the centre carries the activation plus the bump's
    # height, above the 1.9 N it reads.
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 0.6, activation_n=activation_n)
    phi_rim = math.exp(-0.5 / 0.6 ** 2)  # the unit bump one taxel from the centre
    above = 1.0 - activation_n
    expected = 4 * 1.0 + activation_n + above / phi_rim
    assert _imprint_force(_reading_through(curve), _cross(95.0)) == pytest.approx(
        expected, rel=1e-9)


def test_a_wider_imprint_than_the_calibrations_bump_is_filled_in_by_its_own_spread():
    # Hard case: a Gaussian imprint of 2 taxels' spread, its centre over the censoring ceiling
    # (read at 95 counts), on a curve whose bump is 1.5 taxels: wide enough for each imprint's
    # rim to tell its own spread. The force is the imprint's over the taxels read (those under
    # the 40-count threshold read nothing). The calibration's narrower bump, its height fixed by
    # the same rim, would put far more on the saturated centre and read it high.
    rows, cols = np.indices((15, 15))
    counts = 200.0 * np.exp(-((rows - 7) ** 2 + (cols - 7) ** 2) / (2 * 2.0 ** 2))
    read = counts >= 40.0
    truth = 0.02 * counts[read].sum()
    seen = np.where(read, np.where(counts >= 90.0, 95.0, counts), 0.0)
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 1.5)
    assert _imprint_force(_reading_through(curve), seen) == pytest.approx(truth, rel=0.01)


def test_the_rim_load_is_added_to_each_imprint_and_at_most_doubles_a_faint_one():
    # A curve that learned 2 N of rim load (force no taxel reads): added to a press's 5.6 N; a
    # faint imprint (one taxel of 60 counts, 1.2 N) is no press and reads twice its own force.
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0), rim_load_n=2.0)
    est = _reading_through(curve)
    assert _imprint_force(est, _cross(80.0)) == pytest.approx(4 * 1.0 + 1.6 + 2.0, rel=1e-9)
    faint = np.zeros((8, 8))
    faint[4, 4] = 60.0
    assert _imprint_force(est, faint) == pytest.approx(2 * 1.2, rel=1e-9)


def test_gains_scale_the_force():
    model = SkinModel(noise_counts=0)
    top, bottom = render(model, [Press(0.04, 0.04, 12.0, math.radians(30), 1.0)],
                         np.random.default_rng(3))
    gain = np.full((16, 16), 1.25)
    est = ContactEstimator(calibration=Calibration(gains=(gain, 0.5 * gain)))
    (contact,) = scan(est, top, bottom)
    assert contact.force_n == pytest.approx(
        0.5 * 1.25 * ContactEstimator().process(top, bottom)[0].force_n)


def tared_with_dead_taxel(model, rng, spot):
    frames = [render(model, [], rng) for _ in range(8)]
    tops = np.stack([t for t, _ in frames])
    tops[:, spot[0], spot[1]] = 0
    return ContactEstimator().with_tare(tops, np.stack([b for _, b in frames]))


def test_dead_taxels_are_filled_and_revived():
    model = SkinModel()
    rng = np.random.default_rng(4)
    est = tared_with_dead_taxel(model, rng, (8, 8))
    assert est.conditioning.dead_masks()[0][8, 8]
    # A press beside the dead taxel: it is filled in from its neighbours.
    top, bottom = render(model, [Press(0.0425, 0.0325, 10.0, 0.5, 2.0)], rng)
    top[8, 8] = 0
    scan(est, top, bottom)
    # A press on it that reads: the taxel was only resting below zero and is alive again.
    top, bottom = render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng)
    scan(est, top, bottom)
    assert not est.conditioning.dead_masks()[0][8, 8]


@pytest.mark.parametrize('row', [0, 1, 8])
def test_a_dead_taxel_between_two_peaks_is_no_dip(row):
    # Two 4 mm tips two taxels apart make one imprint with peaks in columns 7 and 9; the dead
    # taxel between them, filled in low, is taken on the path between the peaks as its higher
    # neighbour: one contact. Near the map's edge too, where the loaded taxels' box is cut.
    model = SkinModel(noise_counts=0)
    rng = np.random.default_rng(row)
    est = tared_with_dead_taxel(model, rng, (row, 8))
    for centre_m, gap_m in ((0.04, 0.01), (0.04125, 0.0105)):
        y = (row + 0.2) * 0.005
        presses = [Press(centre_m - gap_m / 2, y, 12.0, 0.0, 0.0, 0.004),
                   Press(centre_m + gap_m / 2, y, 11.0, 0.0, 0.0, 0.004)]
        top, bottom = render(model, presses, rng)
        top[row, 8] = 0
        assert len(scan(est, top, bottom)) == 1


@pytest.mark.parametrize('rows, cols', [(16, 16), (7, 12), (20, 17), (3, 40)])
def test_crosstalk_is_taken_on_short_and_long_lines(rows, cols):
    # Leak lifts every line through a press over the touch threshold: the kernel sorts lines
    # of up to 16 taxels with a network and selects the median of longer ones, and settles
    # lines away from the press without either; integer counts tie often. The press is found
    # where it is, whatever its lines carried.
    rng = np.random.default_rng(rows * cols)
    r, c = np.mgrid[:rows, :cols]
    est = ContactEstimator()
    for _ in range(4):
        y, x = rng.uniform(0, rows - 1), rng.uniform(0, cols - 1)
        maps = []
        for blur in (1.0, 2.0):
            press = 2500.0 * np.exp(-((r - y) ** 2 + (c - x) ** 2) / (2 * blur))
            leak = (0.03 * press.sum(axis=1, keepdims=True)
                    + 0.02 * press.sum(axis=0, keepdims=True))
            maps.append(np.round(press + leak + rng.integers(0, 25, (rows, cols))))
        top, bottom = maps
        assert ((top >= 40).sum(axis=1) >= 0.5 * min(rows, cols)).any()
        strongest = scan(est, top, bottom)[0]
        assert strongest.x_m / 0.005 == pytest.approx(x, abs=0.5)
        assert strongest.y_m / 0.005 == pytest.approx(y, abs=0.5)


@pytest.mark.parametrize('top_dtype, bottom_dtype', [
    ('float64', 'float64'), ('int64', 'int64'), ('float32', 'float32'), ('>u2', '>u2'),
    ('uint16', 'float64')])
def test_counts_of_other_dtypes_give_the_contacts_of_uint16_counts(top_dtype, bottom_dtype):
    # uint16 maps (the driver's and the datasets') go to the kernel as they are, any other pair
    # as float64 after its checks: the same counts give the same contacts to the bit, taxels at
    # the ADC's full scale included.
    data = make_scene('multi', 'saturating', np.random.default_rng(3), size=3)
    est = ContactEstimator(EstimatorConfig(pitch_m=data.pitch_m))
    est = est.with_tare(data.tare_top, data.tare_bottom)
    full_scale = est.config.fsr.full_scale
    assert data.top.dtype == np.uint16 and data.top.max() < full_scale
    found = 0
    for top, bottom in zip(data.top, data.bottom):
        # the flat tops of the saturated imprints, clipped by the ADC
        top, bottom = (np.where(m >= 0.95 * m.max(), full_scale, m).astype(np.uint16)
                       for m in (top, bottom))
        other = (top.astype(top_dtype), bottom.astype(bottom_dtype))
        want, got = est.process(top, bottom), est.process(*other)
        assert [figures(c).tolist() for c in got] == [figures(c).tolist() for c in want]
        assert est.measure_shifts(*other) == est.measure_shifts(top, bottom)
        found += len(want)
    assert found >= 3


def test_empty_maps_give_no_contact():
    est = ContactEstimator()
    zeros = np.zeros((16, 16), dtype=np.uint16)
    assert est.process(zeros, zeros) == []
    assert est.measure_shifts(zeros, zeros) == []


def test_all_taxels_loaded_give_one_contact_at_the_centre_without_direction():
    full = np.full((16, 16), 3000, dtype=np.uint16)
    est = ContactEstimator()
    (contact,) = scan(est, full, full)
    assert (contact.x_m, contact.y_m) == pytest.approx((7.5 * 0.005, 7.5 * 0.005))
    assert contact.area_m2 == pytest.approx(256 * 0.005 ** 2)
    assert not contact.direction_valid


@pytest.mark.parametrize('max_contacts, expected', [(0, 0), (1, 1), (32, 2)])
def test_max_contacts_caps_the_contacts(max_contacts, expected):
    model = SkinModel(noise_counts=0)
    top, bottom = render(model, [Press(0.02, 0.02, 10.0), Press(0.06, 0.06, 8.0)],
                         np.random.default_rng(5))
    est = ContactEstimator(EstimatorConfig(max_contacts=max_contacts))
    assert len(scan(est, top, bottom)) == expected


def test_a_single_row_map_gives_the_same_contact():
    line = np.zeros((1, 12))
    line[0, 3:6] = (200.0, 900.0, 300.0)
    below = np.zeros((1, 12))
    below[0, 4:8] = (150.0, 500.0, 600.0, 100.0)
    est = ContactEstimator()
    (contact,) = scan(est, line, below)
    assert contact.y_m == 0.0 and contact.x_m == pytest.approx(
        0.005 * (3 * 200 + 4 * 900 + 5 * 300) / 1400)


def test_noise_only_frames_are_nan_free():
    model = SkinModel(noise_counts=30.0)
    rng = np.random.default_rng(6)
    est = ContactEstimator(EstimatorConfig(threshold_counts=20.0))
    for _ in range(5):
        scan(est, *render(model, [], rng))


@pytest.mark.parametrize('top, message', [
    (np.full((16, 16), np.nan), 'top contains NaN'),
    (np.full((16, 16), -1.0), 'top contains negative'),
    (np.zeros((16, 15)), 'shapes differ'),
    (np.zeros((16, 16), dtype=bool), 'integer or float'),
])
def test_bad_maps_raise_what_is_wrong_and_the_next_scan_works(top, message):
    est = ContactEstimator()
    good = np.zeros((16, 16))
    est.process(good, good)
    with pytest.raises(ValueError, match=message):
        est.process(top, good)
    assert est.process(good, good) == []


def test_an_untared_estimator_serves_each_shape_a_tared_one_only_its_own():
    # No state follows the first scan: each new shape gets a kernel of its own.
    est = ContactEstimator()
    est.process(np.zeros((16, 16)), np.zeros((16, 16)))
    assert est.process(np.zeros((8, 8)), np.zeros((8, 8))) == []
    tared = est.with_tare(np.zeros((2, 16, 16)), np.zeros((2, 16, 16)))
    with pytest.raises(ValueError, match='expect'):
        tared.process(np.zeros((8, 8)), np.zeros((8, 8)))


def test_nested_lists_are_maps_too():
    model = SkinModel(noise_counts=0)
    top, bottom = render(model, [Press(0.04, 0.04, 10.0, 0.6, 0.3)], np.random.default_rng(7))
    est = ContactEstimator()
    assert scan(est, top.tolist(), bottom.tolist())


def test_a_whole_map_reference_gives_every_contact_its_shift():
    # The paper's method (a reference, never a node's) runs on the whole raw maps in Python;
    # the kernel's pipeline around it takes its one shift for every contact.
    data = make_scene('multi', 'default', np.random.default_rng(1), size=2)
    seed = REFERENCES['seed']
    est = ContactEstimator(EstimatorConfig(pitch_m=data.pitch_m), shift=seed)
    est = est.with_tare(data.tare_top, data.tare_bottom)
    for top, bottom in zip(data.top, data.bottom):
        whole = seed.function(np.stack((top, bottom)).astype(np.float64))
        shifts = est.measure_shifts(top, bottom)
        assert shifts and scan(est, top, bottom)
        for shift in shifts:
            assert shift == pytest.approx((whole.dx * data.pitch_m, whole.dy * data.pitch_m))


def test_a_windowed_reference_shift_runs_in_the_kernels_pipeline():
    # A reference on each contact's counts window (the bench's scikit-image one is such).
    data = make_scene('multi', 'default', np.random.default_rng(2), size=2)
    windows = []

    def half_a_taxel(window):
        windows.append(window)
        return 0.5, -0.25, 1.0

    windowed = Method('windowed', half_a_taxel, False, 'half a taxel, whatever the window')
    est = ContactEstimator(EstimatorConfig(pitch_m=data.pitch_m), shift=windowed)
    est = est.with_tare(data.tare_top, data.tare_bottom)
    for top, bottom in zip(data.top, data.bottom):
        windows.clear()
        shifts = est.measure_shifts(top, bottom)
        assert len(shifts) == len(windows) > 0
        assert all(w.ndim == 3 and w.shape[0] == 2 and w.any() for w in windows)
        assert shifts == [pytest.approx((0.5 * data.pitch_m, -0.25 * data.pitch_m))] * len(shifts)


def test_what_a_reference_raises_is_raised():
    def broken(window):
        raise ZeroDivisionError('a broken reference')

    est = ContactEstimator(shift=Method('broken', broken, False, 'raises'))
    top, bottom = render(SkinModel(noise_counts=0), [Press(0.04, 0.04, 10.0)],
                         np.random.default_rng(1))
    with pytest.raises(ZeroDivisionError, match='broken'):
        est.process(top, bottom)
    assert est.process(np.zeros((16, 16)), np.zeros((16, 16))) == []


def test_a_missing_kernel_stops_the_estimators_maker_naming_the_fix():
    # The import needs no kernel; making an estimator does, and says how to build it.
    code = ('from skin_driver.core.estimation.scan.pipeline import ContactEstimator\n'
            "print('imported', flush=True)\n"
            'ContactEstimator()\n')
    env = {**os.environ, 'SKIN_KERNEL_LIBRARY': '/nonexistent/libskin_kernel.so.0'}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env)
    assert out.stdout == 'imported\n' and out.returncode != 0
    assert 'KernelMissing' in out.stderr and 'make setup' in out.stderr
    assert '/nonexistent/libskin_kernel.so.0' in out.stderr


# ---- the forward model's fit of one contact (sk_model_fit) ----
WINDOW = (10, 10)


def _start(counts, truth, model=FILM):
    # A first shift 0.3 taxels off on each axis, as a first method's would be.
    return start_of(counts / 100.0, (truth[model_dx] + 0.3, truth[model_dy] - 0.3), model)


@pytest.mark.parametrize('model, truth', [
    (FILM, model_press(0.5, 0.0)),                              # half a taxel: the worst locking
    (FILM, model_press(1.3, -0.7, radius=1.4)),
    (FILM, model_press(0.3, 0.4, aspect=1.6, orientation=0.6)),  # an elliptical tip, turned
    (replace(FILM, cover_spread_m=0.0, layer_spread_m=0.0), model_press(0.6, 0.2)),  # no blur
    (replace(FILM, cover_spread_m=0.0015, turn_on_pa=20000.0, film_step=0.25),  # a film's cliffs
     model_press(0.4, -0.3, force=12.0, radius=1.2)),
])
def test_the_forward_model_fits_a_contact(model, truth):
    # The model's own press under the ADC's noise: the fit finds its shift.
    counts = noisy(render_counts(model, WINDOW, truth, 24))
    fit = fit_contact(model, counts, None, _start(counts, truth, model))
    assert fit.u[model_dx] == pytest.approx(truth[model_dx], abs=0.01)
    assert fit.u[model_dy] == pytest.approx(truth[model_dy], abs=0.01)


@pytest.mark.parametrize('dx, dy', [(0.5, 0.0), (0.25, -0.5), (1.3, 0.7)])
def test_a_noise_free_press_of_the_model_is_recovered(dx, dy):
    # Hard case: half a taxel, where the imprint's sampling on cells biases a centroid most.
    # Without noise the misfit's least is the press itself: place, force, shift and radius.
    truth = model_press(dx, dy)
    counts = render_counts(FILM, WINDOW, truth, 24)
    fit = fit_contact(FILM, counts, None, _start(counts, truth))
    recovered = [model_x, model_y, model_force, model_dx, model_dy, model_radius]
    np.testing.assert_allclose(fit.u[recovered], truth[recovered], rtol=0, atol=1e-4)
    assert fit.misfit < 1.0


def test_censored_taxels_count_only_where_the_model_reads_below_them():
    # The censored readings are lower bounds: cut 50 counts below the ceiling, the fit must not
    # follow them down. Read as values, the cut peak pulls the force low.
    truth = model_press(0.7, -0.4, force=200.0)
    counts = render_counts(FILM, WINDOW, truth, 24)
    censored = counts >= 0.9 * counts.max()
    cut = np.where(censored, 0.9 * counts.max() - 50.0, counts)
    fit = fit_contact(FILM, cut, censored, _start(counts, truth))
    assert math.exp(fit.u[model_force]) == pytest.approx(200.0, rel=1e-3)
    assert fit.u[model_dx] == pytest.approx(0.7, abs=1e-3)
    assert fit.u[model_dy] == pytest.approx(-0.4, abs=1e-3)
    as_values = fit_contact(FILM, cut, None, _start(counts, truth))
    assert math.exp(as_values.u[model_force]) < 0.98 * 200.0


@pytest.mark.parametrize('dx, dy', [(0.5, 0.0), (0.25, -0.5), (1.3, 0.7)])
def test_the_fit_with_the_taxels_sensitivity_finds_the_shift_a_gain_pattern_would_bias(dx, dy):
    # Hard case: taxels 10 % apart in sensitivity (FSR films do), the calibrated gains given.
    pattern = np.random.default_rng(2).uniform(0.9, 1.1, (2,) + WINDOW)
    truth = model_press(dx, dy)
    counts = render_counts(FILM, WINDOW, truth, 24, pattern)
    start = _start(counts, truth)
    fit = fit_contact(FILM, counts, None, start, sensitivity=pattern)
    assert fit.u[model_dx] == pytest.approx(dx, abs=1e-3)
    assert fit.u[model_dy] == pytest.approx(dy, abs=1e-3)
    # Without them the same fit is off by several thousandths of a taxel: the pattern's bias.
    blind = fit_contact(FILM, counts, None, start)
    assert max(abs(blind.u[model_dx] - dx), abs(blind.u[model_dy] - dy)) > 3e-3


def test_censored_taxels_and_taxel_sensitivities_are_fitted():
    # Hard case: the peak saturated (lower bounds cut low) on taxels 10 % apart in sensitivity,
    # under the ADC's noise.
    pattern = np.random.default_rng(2).uniform(0.9, 1.1, (2,) + WINDOW)
    counts = noisy(render_counts(FILM, WINDOW, model_press(0.7, 0.5, force=200.0), 24, pattern))
    censored = counts >= 0.9 * counts.max()
    cut = np.where(censored, 0.9 * counts.max() - 50.0, counts)
    start = start_of(counts / 100.0, (1.0, 0.2), FILM)
    fit = fit_contact(FILM, cut, censored, start, sensitivity=pattern)
    assert fit.u[model_dx] == pytest.approx(0.7, abs=0.01)
    assert fit.u[model_dy] == pytest.approx(0.5, abs=0.01)
