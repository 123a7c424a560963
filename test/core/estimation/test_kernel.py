"""
The compiled kernel (skin_kernel, through kernel.py) against the pipeline's Python description.

Every comparison runs one estimator both ways on the same state (``with_compiled``) and asks
for the same contacts, in the same order, with the same figures to 1e-9 (relative, or absolute
below 1): the two follow the same operations in the same order nearly everywhere and agree to
the bit there; where the reference sums through BLAS (centroids, mixture moments) the order
differs and they part by a few ulp (at most 2e-13 relative over the family when measured). The
Gauss-Newton fit of narrow windows is ill-conditioned enough to turn a changed order of
operations into 1e-5 taxels; 1e-9 catches that and any real divergence.
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
from skin_driver.core.estimation.model.taxelmodel import (
    DX as model_dx, DY as model_dy, fit_contact, LOG_ASPECT as model_aspect,
    LOG_FORCE as model_force, LOG_RADIUS as model_radius, ORIENTATION as model_orientation,
    render_counts, start_of, TaxelModel, X as model_x, Y as model_y)
from skin_driver.core.estimation.scan.kernel import fit_contact as compiled_fit_contact
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import centroid, Method, REFERENCES
from skin_driver.core.sim.experiments import calibrated_scene, make_scene
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.core.sim.skins import family_skin, skin_names

TOLERANCE = 1e-9
# Noise specks of one to three taxels: three-parameter fits on so few cells are ill-conditioned
# enough to grow a few ulp into 1e-8 taxels (measured); still far below any meaningful shift.
SPECK_TOLERANCE = 1e-6
SCENES = ('random', 'multi', 'border')


def figures(contact) -> np.ndarray:
    return np.array([contact.x_m, contact.y_m, contact.force_n, contact.area_m2,
                     *contact.shift_m, contact.azimuth_rad, contact.azimuth_sigma_rad,
                     contact.alpha_rad, *contact.force_xyz_n, contact.confidence,
                     contact.direction_valid], dtype=np.float64)


def assert_same(compiled, described, top, bottom, tolerance=TOLERANCE, speck_tolerance=None):
    """
    Assert both estimators find the same contacts and shifts in one frame pair.

    ``speck_tolerance``: the shifts of every pair (``measure_shifts``, noise specks included)
    to that tolerance instead.
    """
    got, want = compiled.process(top, bottom), described.process(top, bottom)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        # The same type with the same fields, however the kernel's Contact is made.
        assert type(g) is type(w) and vars(g).keys() == vars(w).keys()
        a, b = figures(g), figures(w)
        assert np.isfinite(a).all()
        np.testing.assert_allclose(a, b, rtol=tolerance, atol=tolerance)
    shifts = speck_tolerance or tolerance
    np.testing.assert_allclose(np.reshape(compiled.measure_shifts(top, bottom), (-1, 2)),
                               np.reshape(described.measure_shifts(top, bottom), (-1, 2)),
                               rtol=shifts, atol=shifts * compiled.config.pitch_m)
    return got


def both_ways(est: ContactEstimator) -> tuple:
    return est.with_compiled(True), est.with_compiled(False)


def scene_estimators(skin, kind, frames, method='taxel_fit', seed=1, tared=True):
    data = make_scene(kind, skin, np.random.default_rng(seed), size=frames)
    est = ContactEstimator(EstimatorConfig(method=method, pitch_m=data.pitch_m))
    if tared and data.tare_top is not None:
        est = est.with_tare(data.tare_top, data.tare_bottom)
    return data, both_ways(est)


@pytest.mark.parametrize('skin', skin_names() + ['held_out:1', 'held_out:2', 'held_out:3'])
@pytest.mark.parametrize('kind', SCENES)
def test_family_frames_give_the_same_contacts(skin, kind):
    data, (compiled, described) = scene_estimators(skin, kind, 4)
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


@pytest.mark.parametrize('skin', ['default', 'crosstalk', 'harsh', 'held_out:2@64'])
def test_untared_estimators_give_the_same_contacts(skin):
    # Before a tare the line-leak gate is the touch threshold (crosstalk.leak_gate): shut on
    # the default skin's presses, open where crosstalk lifts lines over it. Rest readings over
    # the threshold (untared offsets) are noise specks, whose shifts agree to SPECK_TOLERANCE.
    data, (compiled, described) = scene_estimators(skin, 'multi', 3, tared=False)
    assert not compiled.conditioner.state(data.top.shape[1:]).tared
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom, speck_tolerance=SPECK_TOLERANCE)


@pytest.mark.parametrize('skin', ['default@32', 'soft@32', 'default@64'])
def test_finer_grids_give_the_same_contacts(skin):
    data, (compiled, described) = scene_estimators(skin, 'multi', 2)
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


@pytest.mark.parametrize('skin', ['crosstalk', 'noisy', 'soft', 'default@32'])
@pytest.mark.parametrize('method', ['centroid', 'poc'])
@pytest.mark.parametrize('kind', ['multi', 'border'])
def test_the_other_methods_give_the_same_contacts(skin, method, kind):
    data, (compiled, described) = scene_estimators(skin, kind, 3, method=method)
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


@pytest.mark.parametrize('skin', ['saturating', 'film', 'noisy', 'held_out:2'])
def test_calibrated_estimators_give_the_same_contacts(skin):
    # Calibrated as the evaluator does: offset, force curves (censoring on the saturating skin,
    # gains where the skin has them) and compliance, all from the scene's own frames.
    data = make_scene('paper', skin, np.random.default_rng(2), size=1)
    compiled, described = both_ways(prepared_estimator(data, 'taxel_fit')[0])
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


@pytest.mark.parametrize('x_m, radius_m', [(0.0, 0.004), (0.005, 0.002)])
def test_the_normal_force_at_the_edge_is_chosen_alike(x_m, radius_m):
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
    compiled, described = both_ways(est)
    (contact,) = assert_same(compiled, described, top, bottom)
    if x_m > 0:
        # The bottom sum reads the press within 2 %; the top one would read it 9 % high.
        assert contact.force_n == pytest.approx(20.0, rel=0.02)


@pytest.mark.parametrize('skin', ['film', 'held_out:6', 'loaded'])
def test_rim_loads_of_a_force_calibration_are_added_alike(skin):
    # Force-calibrated from 16 normal presses of known force: these skins' curves learn a rim
    # load (forcecurve) that the kernel adds itself to every unsaturated imprint.
    member = family_skin(skin)
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 4)
    est = prepared_estimator(data, 'taxel_fit')[0]
    assert any(curve.rim_load_n > 0 for curve in est.calibration.force_curves)
    compiled, described = both_ways(est)
    scored = np.flatnonzero(data.split == 0)
    for top, bottom in zip(data.top[scored], data.bottom[scored]):
        assert_same(compiled, described, top, bottom)


def test_a_censoring_force_curve_fills_in_the_saturated_imprint_alike():
    # 3 N a taxel saturates this film: presses of 15 to 50 N read the ceiling at their centre,
    # and the calibrated curve fills their force in from the rims (forcecurve, in Python).
    member = family_skin('saturating')
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 2)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert any('filled in from their rims' in note for note in notes)
    compiled, described = both_ways(est)
    for force in (15.0, 30.0, 50.0):
        press = Press(0.0431, 0.0353, force, radius_m=0.004)
        (contact,) = assert_same(compiled, described, *render(member.model, [press], rng))
        assert contact.force_n == pytest.approx(force, rel=0.1)


@pytest.mark.parametrize('kind', SCENES)
def test_a_calibrated_censoring_skin_gives_the_same_contacts(kind):
    # The kernel fills each saturated imprint in itself (imprint.c): the spread search picks
    # the same spread, and the sums agree, on every scored frame of the family's scenes.
    member = family_skin('saturating')
    data = calibrated_scene(kind, member, np.random.default_rng(5), 6)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert any('filled in from their rims' in note for note in notes)
    compiled, described = both_ways(est)
    for i in np.flatnonzero(data.split == 0):
        assert_same(compiled, described, data.top[i], data.bottom[i])


def test_taxels_the_adc_cut_are_censored_alike():
    # 1.1 % crosstalk on a 64 x 64 grid drives the centre of heavier presses to the ADC's full
    # scale, calibration presses and scored ones alike: those taxels keep a level shape, read
    # the force at full scale and are filled in by the censoring curves, both ways.
    member = family_skin('held_out:2@64')
    rng = np.random.default_rng(3)
    data = calibrated_scene('random', member, rng, 4)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert all(curve.censor_counts > 0 for curve in est.calibration.force_curves)
    compiled, described = both_ways(est)
    scored = np.flatnonzero(data.split == 0)
    cut = [i for i in scored if (data.bottom[i] >= 4095).any()]
    assert cut
    for i in scored:
        (contact,) = assert_same(compiled, described, data.top[i], data.bottom[i])
        if i in cut:
            force = math.sqrt(sum(v * v for v in contact.force_xyz_n))
            assert force == pytest.approx(data.force_n[i], rel=0.05)


def test_gains_scale_the_force_alike():
    model = SkinModel(noise_counts=0)
    top, bottom = render(model, [Press(0.04, 0.04, 12.0, math.radians(30), 1.0)],
                         np.random.default_rng(3))
    gain = np.full((16, 16), 1.25)
    compiled, described = both_ways(ContactEstimator(calibration=Calibration(
        gains=(gain, 0.5 * gain))))
    (contact,) = assert_same(compiled, described, top, bottom)
    assert contact.force_n == pytest.approx(
        0.5 * 1.25 * ContactEstimator().process(top, bottom)[0].force_n)


def tared_with_dead_taxel(model, rng, spot):
    frames = [render(model, [], rng) for _ in range(8)]
    tops = np.stack([t for t, _ in frames])
    tops[:, spot[0], spot[1]] = 0
    return ContactEstimator().with_tare(tops, np.stack([b for _, b in frames]))


def test_dead_taxels_are_filled_and_revived_alike():
    model = SkinModel()
    rng = np.random.default_rng(4)
    est = tared_with_dead_taxel(model, rng, (8, 8))
    assert est.conditioner.dead_masks()[0][8, 8]
    compiled, described = both_ways(est)
    # A press beside the dead taxel: it is filled in from its neighbours.
    top, bottom = render(model, [Press(0.0425, 0.0325, 10.0, 0.5, 2.0)], rng)
    top[8, 8] = 0
    assert_same(compiled, described, top, bottom)
    # A press on it that reads: the taxel was only resting below zero and is alive again.
    top, bottom = render(model, [Press(0.0425, 0.0425, 10.0, 0.5, 2.0)], rng)
    assert_same(compiled, described, top, bottom)
    assert not compiled.conditioner.dead_masks()[0][8, 8]
    assert not described.conditioner.dead_masks()[0][8, 8]


@pytest.mark.parametrize('row', [0, 1, 8])
def test_a_dead_taxel_between_two_peaks_is_no_dip_alike(row):
    # Two 4 mm tips two taxels apart make one imprint with peaks in columns 7 and 9; the dead
    # taxel between them, filled in low, is taken on the path between the peaks as its higher
    # neighbour: one contact. Near the map's edge too, where the loaded taxels' box is cut.
    model = SkinModel(noise_counts=0)
    rng = np.random.default_rng(row)
    est = tared_with_dead_taxel(model, rng, (row, 8))
    compiled, described = both_ways(est)
    for centre_m, gap_m in ((0.04, 0.01), (0.04125, 0.0105)):
        y = (row + 0.2) * 0.005
        presses = [Press(centre_m - gap_m / 2, y, 12.0, 0.0, 0.0, 0.004),
                   Press(centre_m + gap_m / 2, y, 11.0, 0.0, 0.0, 0.004)]
        top, bottom = render(model, presses, rng)
        top[row, 8] = 0
        assert len(assert_same(compiled, described, top, bottom)) == 1


@pytest.mark.parametrize('rows, cols', [(16, 16), (7, 12), (20, 17), (3, 40)])
def test_line_leak_is_taken_alike_on_short_and_long_lines(rows, cols):
    # Leak lifts every line through a press over the touch threshold (crosstalk.py): the
    # kernel sorts lines of up to 16 taxels with a network and selects the median of longer
    # ones, and settles lines away from the press without either; integer counts tie often.
    rng = np.random.default_rng(rows * cols)
    r, c = np.mgrid[:rows, :cols]
    compiled, described = both_ways(ContactEstimator())
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
        assert_same(compiled, described, top, bottom, speck_tolerance=SPECK_TOLERANCE)


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
        # the flat tops of the saturated imprints cut by the ADC
        top, bottom = (np.where(m >= 0.95 * m.max(), full_scale, m).astype(np.uint16)
                       for m in (top, bottom))
        other = (top.astype(top_dtype), bottom.astype(bottom_dtype))
        want, got = est.process(top, bottom), est.process(*other)
        assert [figures(c).tolist() for c in got] == [figures(c).tolist() for c in want]
        assert est.measure_shifts(*other) == est.measure_shifts(top, bottom)
        found += len(want)
    assert found >= 3


def test_empty_maps_give_no_contact():
    compiled = ContactEstimator()
    zeros = np.zeros((16, 16), dtype=np.uint16)
    assert compiled.process(zeros, zeros) == []
    assert compiled.measure_shifts(zeros, zeros) == []


def test_all_taxels_loaded_give_one_contact_at_the_centre_without_direction():
    full = np.full((16, 16), 3000, dtype=np.uint16)
    compiled, described = both_ways(ContactEstimator())
    (contact,) = assert_same(compiled, described, full, full)
    assert (contact.x_m, contact.y_m) == pytest.approx((7.5 * 0.005, 7.5 * 0.005))
    assert contact.area_m2 == pytest.approx(256 * 0.005 ** 2)
    assert not contact.direction_valid


@pytest.mark.parametrize('max_contacts, expected', [(0, 0), (1, 1), (32, 2)])
def test_max_contacts_caps_the_contacts(max_contacts, expected):
    model = SkinModel(noise_counts=0)
    top, bottom = render(model, [Press(0.02, 0.02, 10.0), Press(0.06, 0.06, 8.0)],
                         np.random.default_rng(5))
    est = ContactEstimator(EstimatorConfig(max_contacts=max_contacts))
    compiled, described = both_ways(est)
    assert len(assert_same(compiled, described, top, bottom)) == expected


def test_a_single_row_map_gives_the_same_contact():
    line = np.zeros((1, 12))
    line[0, 3:6] = (200.0, 900.0, 300.0)
    below = np.zeros((1, 12))
    below[0, 4:8] = (150.0, 500.0, 600.0, 100.0)
    compiled, described = both_ways(ContactEstimator())
    (contact,) = assert_same(compiled, described, line, below)
    assert contact.y_m == 0.0 and contact.x_m == pytest.approx(
        0.005 * (3 * 200 + 4 * 900 + 5 * 300) / 1400)


def test_noise_only_frames_are_nan_free():
    model = SkinModel(noise_counts=30.0)
    rng = np.random.default_rng(6)
    compiled, described = both_ways(ContactEstimator(EstimatorConfig(threshold_counts=20.0)))
    for _ in range(5):
        for contact in assert_same(compiled, described, *render(model, [], rng),
                                   tolerance=SPECK_TOLERANCE):
            assert np.isfinite(figures(contact)).all()


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
    compiled, described = both_ways(ContactEstimator())
    assert assert_same(compiled, described, top.tolist(), bottom.tolist())


def test_a_reference_shift_keeps_the_python_path():
    # The paper's method (a reference, never a node's) is not compiled: both ways run Python.
    data = make_scene('random', 'default', np.random.default_rng(1), size=2)
    est = ContactEstimator(EstimatorConfig(pitch_m=data.pitch_m), shift=REFERENCES['seed'])
    compiled, described = both_ways(est.with_tare(data.tare_top, data.tare_bottom))
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


def test_a_windowed_reference_shift_runs_in_the_kernels_pipeline():
    # A reference on each contact's counts window (the bench's scikit-image one is such).
    data = make_scene('multi', 'default', np.random.default_rng(2), size=2)
    windowed = Method('windowed', centroid, False, 'the centroid as a reference')
    est = ContactEstimator(EstimatorConfig(pitch_m=data.pitch_m), shift=windowed)
    compiled, described = both_ways(est.with_tare(data.tare_top, data.tare_bottom))
    for top, bottom in zip(data.top, data.bottom):
        assert_same(compiled, described, top, bottom)


def test_a_missing_kernel_stops_the_estimators_maker_naming_the_fix():
    # The Python description needs no kernel; the runtime path does, and says how to build it.
    code = ('from skin_driver.core.estimation.scan.pipeline import ContactEstimator\n'
            'ContactEstimator(compiled=False)\n'
            "print('description made', flush=True)\n"
            'ContactEstimator()\n')
    env = {**os.environ, 'SKIN_KERNEL_LIBRARY': '/nonexistent/libskin_kernel.so.0'}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env)
    assert out.stdout == 'description made\n' and out.returncode != 0
    assert 'KernelMissing' in out.stderr and 'make setup' in out.stderr
    assert '/nonexistent/libskin_kernel.so.0' in out.stderr


# ---- the forward model's fit of one contact (sk_model_fit) against taxelmodel.fit_contact ----
FILM = TaxelModel(pitch_m=0.005, fill_factor=0.9, cover_spread_m=0.001, layer_spread_m=0.002,
                  film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01)
WINDOW = (10, 10)


def _press(dx, dy, force=20.0, radius=0.8, aspect=1.0, orientation=0.0):
    u = np.zeros(8)
    u[model_x], u[model_y], u[model_dx], u[model_dy] = 4.3, 5.1, dx, dy
    u[model_force], u[model_radius] = math.log(force), math.log(radius)
    u[model_aspect], u[model_orientation] = math.log(aspect), orientation
    return u


def _noisy(counts):
    # With the ADC's noise the misfit has a clear least: noise-free, it falls to rounding noise,
    # where two orders of summation walk apart (and a round tip's turn means nothing at all).
    return counts + np.random.default_rng(0).normal(0.0, 5.0, counts.shape)


def _assert_fits_alike(model, counts, censored, start, sensitivity=None):
    python = fit_contact(model, counts, censored, start, sensitivity=sensitivity)
    compiled = compiled_fit_contact(model, counts, censored, start, sensitivity=sensitivity)
    np.testing.assert_allclose(compiled.u[:model_orientation], python.u[:model_orientation],
                               rtol=0, atol=TOLERANCE)
    # A nearly round tip's turn is barely defined (the misfit hardly moves with it): a few ulp
    # of another order of summation move it by up to 1e-8 rad (measured), nothing else.
    assert compiled.u[model_orientation] == pytest.approx(python.u[model_orientation], abs=1e-6)
    assert compiled.misfit == pytest.approx(python.misfit, rel=TOLERANCE)
    return compiled


@pytest.mark.parametrize('model, truth', [
    (FILM, _press(0.5, 0.0)),                                  # half a taxel: the worst locking
    (FILM, _press(1.3, -0.7, radius=1.4)),
    (FILM, _press(0.3, 0.4, aspect=1.6, orientation=0.6)),     # an elliptical tip, turned
    (replace(FILM, cover_spread_m=0.0, layer_spread_m=0.0), _press(0.6, 0.2)),  # no blur at all
    (replace(FILM, cover_spread_m=0.0015, turn_on_pa=20000.0, film_step=0.25),  # a film's cliffs
     _press(0.4, -0.3, force=12.0, radius=1.2)),
])
def test_the_forward_model_fits_a_contact_alike(model, truth):
    counts = _noisy(render_counts(model, WINDOW, truth, 24))
    start = start_of(counts / 100.0, (truth[model_dx] + 0.3, truth[model_dy] - 0.3), model)
    fit = _assert_fits_alike(model, counts, None, start)
    # The model's own press under the ADC's noise: the fit finds its shift.
    assert fit.u[model_dx] == pytest.approx(truth[model_dx], abs=0.01)
    assert fit.u[model_dy] == pytest.approx(truth[model_dy], abs=0.01)


def test_censored_taxels_and_taxel_sensitivities_are_fitted_alike():
    # Hard case: the peak saturated (lower bounds cut low) on taxels 10 % apart in sensitivity.
    pattern = np.random.default_rng(2).uniform(0.9, 1.1, (2,) + WINDOW)
    counts = _noisy(render_counts(FILM, WINDOW, _press(0.7, 0.5, force=200.0), 24, pattern))
    censored = counts >= 0.9 * counts.max()
    cut = np.where(censored, 0.9 * counts.max() - 50.0, counts)
    start = start_of(counts / 100.0, (1.0, 0.2), FILM)
    fit = _assert_fits_alike(FILM, cut, censored, start, pattern)
    assert fit.u[model_dx] == pytest.approx(0.7, abs=0.01)
    assert fit.u[model_dy] == pytest.approx(0.5, abs=0.01)


@pytest.mark.parametrize('gains', [False, True])
def test_model_fit_fits_each_contact_compiled_as_its_description_does(gains):
    # The whole pipeline with a calibration that carries a taxel model (and taxels 10 % apart
    # in sensitivity, their gains calibrated): both paths alike.
    truth = _press(0.6, -0.4)
    truth[model_x], truth[model_y] = 7.2, 8.4
    pattern = np.random.default_rng(3).uniform(0.9, 1.1, (2, 16, 16)) if gains else None
    top, bottom = _noisy(render_counts(FILM, (16, 16), truth, 24, pattern)).clip(0.0, None)
    calibration = Calibration(taxel_model=FILM,
                              gains=None if pattern is None else tuple(1.0 / pattern))
    est = ContactEstimator(EstimatorConfig(method='model_fit'), calibration)
    compiled, python = (est.process(top, bottom),
                        est.with_compiled(False).process(top, bottom))
    assert len(compiled) == len(python) == 1
    np.testing.assert_allclose(figures(compiled[0]), figures(python[0]), rtol=TOLERANCE,
                               atol=TOLERANCE)
