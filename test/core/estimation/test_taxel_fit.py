"""Tests of the taxel_fit shift estimator: no sampling bias, any resolution, robust fallbacks."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import estimate_shift, get_method
from skin_driver.core.estimation.shift.taxelfit import cell_fit_shift, fit_cell_profiles
from skin_driver.core.sim.physics import Press, render, SkinModel


def _shift_errors(method: str, model: SkinModel, shift_taxels: float = 0.6) -> list:
    """Return the x shift errors (taxels) of presses stepped across one taxel, noise-free."""
    est = ContactEstimator(EstimatorConfig(method=method, fsr=model.fsr))
    tare = [render(model, [], np.random.default_rng(i)) for i in range(4)]
    est = est.with_tare(np.stack([t for t, _ in tare]), np.stack([b for _, b in tare]))
    tangential = shift_taxels * model.pitch_m / model.compliance_m_per_n
    errors = []
    # Off the symmetric places (a press midway between taxels ties two noise-free readings).
    for phase in np.linspace(0.03, 0.97, 8):
        x = (7.0 + phase) * model.pitch_m
        press = Press(x, 0.0371, math.hypot(8.0, tangential), math.atan2(tangential, 8.0), 0.0,
                      0.003)
        shifts = est.measure_shifts(*render(model, [press], np.random.default_rng(0)))
        errors.append(shifts[0][0] / model.pitch_m - shift_taxels)
    return errors


def test_no_sampling_bias_where_the_centroid_has_it():
    # A sharp top imprint (3 mm tip, 0.5 mm cover) sampled at eight places across a taxel.
    model = SkinModel(noise_counts=0.0, cover_spread_m=0.0005)
    fit = np.abs(_shift_errors('taxel_fit', model))
    plain = np.abs(_shift_errors('centroid', model))
    assert plain.max() > 0.05
    assert fit.max() < 0.5 * plain.max()


def test_fitted_centre_of_a_cell_integrated_gaussian_is_exact():
    cells = np.arange(9) + 0.5
    lo, hi = cells - 1.0, cells
    centre, width = 4.3, 0.7
    from statistics import NormalDist
    nd = NormalDist(centre, width)
    profile = np.array([[nd.cdf(h) - nd.cdf(low) for low, h in zip(lo, hi)]]) * 100.0
    mu, s, explained = fit_cell_profiles(profile, np.ones_like(profile))
    assert mu[0] == pytest.approx(centre, abs=1e-4) and s[0] == pytest.approx(width, abs=1e-3)
    assert explained[0] == pytest.approx(1.0, abs=1e-6)


def _cell_imprint(cx: float, cy: float, width: float, n: int = 9) -> np.ndarray:
    """Return a unit Gaussian imprint integrated over the cells of an n x n window."""
    from statistics import NormalDist
    edges = np.arange(n + 1) - 0.5
    gx, gy = (np.diff([NormalDist(c, width).cdf(e) for e in edges]) for c in (cx, cy))
    return np.outer(gy, gx)


def test_a_films_turn_on_step_at_the_rim_does_not_pull_the_centre():
    # A film that turns on at a pressure reads at least its step on any conducting rim taxel
    # (here 8 % of the peak force, 28 % of the peak counts on a square-root curve): six of the
    # bottom imprint's twelve taxels sit on the step, more of them on one side. At their step
    # force they pulled the fitted shift 0.05 taxel; at half of it, 0.026.
    top = _cell_imprint(4.0, 4.0, 0.6)
    true_bottom = _cell_imprint(4.2, 4.1, 0.5)
    step = 0.08 * true_bottom.max()
    bottom = np.where(true_bottom > 0.002 * true_bottom.max(),
                      np.maximum(true_bottom, step), 0.0)
    force = np.stack((top, bottom))
    counts = np.sqrt(force / force.max(axis=(1, 2), keepdims=True))
    dx, dy, _, _ = cell_fit_shift(force, counts)
    assert dx == pytest.approx(0.2, abs=0.035) and dy == pytest.approx(0.1, abs=0.035)


def test_empty_layer_gives_no_shift_and_odd_shapes_fall_back_to_the_centroid():
    maps = np.zeros((2, 5, 5))
    maps[0, 2, 2] = 1.0
    assert cell_fit_shift(maps) is None
    assert estimate_shift(maps[0], maps[1], 'taxel_fit').confidence == 0.0
    # A ring (no Gaussian explains it): the centre stays the centroid, in the window.
    ring = np.zeros((2, 7, 7))
    ring[:, 1, 1:6] = ring[:, 5, 1:6] = ring[:, 1:6, 1] = ring[:, 1:6, 5] = 1.0
    dx, dy, _, _ = cell_fit_shift(ring)
    assert dx == pytest.approx(0.0, abs=1e-9) and dy == pytest.approx(0.0, abs=1e-9)
    assert get_method('taxel_fit').linear


def _cell_gaussian(centre: float, width: float, cells: int) -> np.ndarray:
    """Return a unit-mass Gaussian of ``centre`` and ``width`` integrated over ``cells`` cells."""
    from statistics import NormalDist
    nd = NormalDist(centre, width)
    return np.array([nd.cdf(i + 0.5) - nd.cdf(i - 0.5) for i in range(cells)])


def test_an_imprint_cut_by_the_map_edge_keeps_its_centre_past_the_edge():
    # A round bottom imprint of width 1.1 taxels centred a taxel past the map's left edge
    # (column -1.0): only its right tail is on the map, cells under 0.5 % of its load read
    # nothing (the touch threshold). Its profile along y is whole and tells the width.
    # Expected: the bottom's centre at -1.0, the shift 4.0 taxels to the left of the top at
    # column 3.0 (a free fit of the cut profile trades width for centre: a shift of -2.7 that
    # explains the cells as well).
    h, w = 7, 7
    maps = np.zeros((2, h, w))
    maps[0] = np.outer(_cell_gaussian(3.0, 0.6, h), _cell_gaussian(3.0, 0.6, w))
    maps[1] = np.outer(_cell_gaussian(3.0, 1.1, h), _cell_gaussian(-1.0, 1.1, w))
    maps[maps < 0.005] = 0.0
    dx, dy, explained, _ = cell_fit_shift(maps)
    assert dx == pytest.approx(-4.0, abs=0.05) and dy == pytest.approx(0.0, abs=0.02)
    assert explained > 0.95


def _imprint(shape: tuple, centre: tuple, width: float, mass: float, floor: float = 1e-3
             ) -> np.ndarray:
    """Return a 2-D Gaussian integrated over unit cells, (x, y) centre, loads under floor cut."""
    from statistics import NormalDist
    along = [np.diff([NormalDist(c, width).cdf(e) for e in np.arange(n + 1) - 0.5])
             for c, n in zip(centre, (shape[1], shape[0]))]
    layer = mass * np.outer(along[1], along[0])
    return np.where(layer > floor, layer, 0.0)


def test_a_saturated_layer_is_placed_by_its_rim():
    # The bottom imprint (0.9 taxel wide, 30 N) reads a ceiling of 3 N at its centre: those
    # taxels carry no shape, the rim does. Expected: the shift of the true centres.
    top = _imprint((11, 11), (5.0, 5.0), 0.8, 2.0)
    bottom = _imprint((11, 11), (5.35, 5.2), 0.9, 30.0)
    capped = np.minimum(bottom, 3.0)
    maps = np.stack((top, capped))
    censored = np.stack((np.zeros_like(top, dtype=bool), bottom >= 3.0))
    dx, dy, _, _ = cell_fit_shift(maps, None, censored)
    error = math.hypot(dx - 0.35, dy - 0.2)
    assert error < 0.005
    # Without the marks the capped plateau is taken for the imprint's shape, and misplaces it.
    plain_dx, plain_dy, _, _ = cell_fit_shift(maps)
    assert math.hypot(plain_dx - 0.35, plain_dy - 0.2) > 5.0 * error


def test_a_sharp_saturated_top_imprint_takes_the_bottom_layers_mass():
    # A sharp top imprint (0.3 taxel, 20 N) reads the ceiling of 3 N at its centre and leaves
    # too little rim to fit its mass; the unsaturated bottom imprint carries the same 20 N.
    # Expected: the shift of the true centres, which the marginal fits of the plateau miss.
    top = _imprint((9, 9), (4.2, 4.1), 0.3, 20.0, 0.05)
    bottom = _imprint((9, 9), (4.5, 4.0), 0.9, 20.0, 0.05)
    maps = np.stack((np.minimum(top, 3.0), bottom))
    censored = np.stack((top >= 3.0, np.zeros_like(top, dtype=bool)))
    assert int(((maps[0] > 0) & ~censored[0]).sum()) < 8
    dx, dy, _, _ = cell_fit_shift(maps, None, censored)
    error = math.hypot(dx - 0.3, dy + 0.1)
    assert error < 0.01
    plain_dx, plain_dy, _, _ = cell_fit_shift(maps)
    assert math.hypot(plain_dx - 0.3, plain_dy + 0.1) > 5.0 * error


def test_a_cut_profiles_uncertainty_grows_as_its_centre_leaves_the_map():
    # A whole top imprint at column 3 and a bottom imprint 1.1 taxels wide whose centre moves
    # from column 3 (whole: no cut variance) to 1.0 (its tail cut at the edge) and -1.0 (past
    # the edge, its centre placed by the width it takes from the other axis). Expected: 0, then
    # under a tenth of a taxel (1 sigma), then more than a third: a shift of a taxel is then
    # within the noise.
    h, w = 7, 7
    variances = []
    for column in (3.0, 1.0, -1.0):
        maps = np.zeros((2, h, w))
        maps[0] = np.outer(_cell_gaussian(3.0, 0.6, h), _cell_gaussian(3.0, 0.6, w))
        maps[1] = np.outer(_cell_gaussian(3.0, 1.1, h), _cell_gaussian(column, 1.1, w))
        maps[maps < 0.005] = 0.0
        variances.append(cell_fit_shift(maps)[3])
    assert variances[0] == 0.0
    assert 0.0 < math.sqrt(variances[1]) < 0.1
    assert math.sqrt(variances[2]) > 1.0 / 3.0


def test_a_border_press_is_as_sure_as_its_cut_fit():
    # A press 0.4 taxel inside the map's first column, its layers shifted by 0.8 taxel: pushed
    # inward or along the edge, the bottom imprint lies on the map and its fit holds; pushed
    # outward, the bottom imprint's centre lies past the edge, placed by the width it takes.
    # Expected: the first two valid within 3 deg, the third far less sure (pi: no direction).
    model = SkinModel()
    est = ContactEstimator(EstimatorConfig(fsr=model.fsr))
    tare = [render(model, [], np.random.default_rng(i)) for i in range(8)]
    est = est.with_tare(np.stack([t for t, _ in tare]), np.stack([b for _, b in tare]))
    tangential = 0.8 * model.pitch_m / model.compliance_m_per_n
    sigmas = {}
    for beta_deg in (0.0, 90.0, 180.0):
        press = Press(0.4 * model.pitch_m, 0.0371, math.hypot(10.0, tangential),
                      math.atan2(tangential, 10.0), math.radians(beta_deg), 0.003)
        contact = est.process(*render(model, [press], np.random.default_rng(3)))[0]
        sigmas[beta_deg] = contact.azimuth_sigma_rad
        if beta_deg < 180.0:
            assert contact.direction_valid
            assert abs(math.degrees(contact.azimuth_rad) - beta_deg) < 3.0
    assert sigmas[180.0] > 3.0 * max(sigmas[0.0], sigmas[90.0])
