"""Tests of the shift estimators and their registry."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.shift import methods as direction
from skin_driver.core.sim.physics import Press, render_force, SkinModel

REQUIRED = ('centroid', 'poc', 'taxel_fit')


def _pair(dx_m, dy_m, model=None):
    model = model or SkinModel(noise_counts=0.0, spread_m=0.002)
    t = math.hypot(dx_m, dy_m)
    alpha = math.atan(t / (model.compliance_m_per_n * 10.0)) if t else 0.0
    force = math.hypot(10.0, t / model.compliance_m_per_n)
    press = Press(0.037, 0.038, force, alpha, math.atan2(dy_m, dx_m), 0.0025)
    return render_force(model, [press])


def test_all_methods_registered_with_stable_names():
    for name in REQUIRED:
        assert direction.get_method(name).name == name
    assert direction.DEFAULT_METHOD == 'taxel_fit'
    assert direction.method_names() == ['taxel_fit', 'centroid', 'model_fit', 'poc']


def test_the_papers_method_is_a_reference_a_node_cannot_select():
    assert direction.REFERENCES['seed'].whole_map
    with pytest.raises(ValueError, match='unknown direction method'):
        direction.get_method('seed')
    method, override = direction.resolve('seed')
    assert method == direction.DEFAULT_METHOD and override is direction.REFERENCES['seed']
    assert direction.resolve('poc') == ('poc', None)


def test_unknown_method_lists_names():
    with pytest.raises(ValueError,
                       match='unknown direction method .*taxel_fit, centroid, model_fit, poc'):
        direction.get_method('nope')


@pytest.mark.parametrize('name', REQUIRED)
def test_integer_circular_shift_is_found(name):
    rng = np.random.default_rng(4)
    top = np.zeros((16, 16))
    top[5:10, 5:10] = rng.uniform(0.5, 1.0, (5, 5))
    bottom = np.roll(top, (1, 2), axis=(0, 1))
    est = direction.estimate_shift(top, bottom, name)
    assert (est.dx, est.dy) == pytest.approx((2.0, 1.0), abs=0.05)
    assert 0.0 <= est.confidence <= 1.0


@pytest.mark.parametrize('name', ['poc', 'centroid'])
def test_sub_taxel_shift_of_physical_maps(name):
    # Sampling biases the raw shift by a few hundredths of a taxel at a given spot; the seed's
    # calibration (a normal press at the same spot) removes it.
    ref = direction.estimate_shift(*_pair(0.0, 0.0), name)
    est = direction.estimate_shift(*_pair(0.0035, -0.002), name)
    assert (est.dx - ref.dx, est.dy - ref.dy) == pytest.approx((0.7, -0.4), abs=0.03)


def test_the_centroid_beats_the_papers_reference_on_direction():
    errs = {'centroid': [], 'seed': []}
    refs = {name: direction.estimate_shift(*_pair(0.0, 0.0), name) for name in errs}
    for beta in np.radians(np.arange(0, 360, 45)):
        top, bottom = _pair(0.004 * math.cos(beta), 0.004 * math.sin(beta))
        for name in errs:
            est = direction.estimate_shift(top, bottom, name)
            got = math.atan2(est.dy - refs[name].dy, est.dx - refs[name].dx)
            errs[name].append(abs((math.degrees(got - beta) + 180) % 360 - 180))
    assert np.mean(errs['centroid']) < 0.5
    assert np.mean(errs['centroid']) < np.mean(errs['seed'])


@pytest.mark.parametrize('name', REQUIRED)
def test_empty_maps_give_no_shift_and_zero_confidence(name):
    est = direction.estimate_shift(np.zeros((6, 6)), np.zeros((6, 6)), name)
    assert est == (0.0, 0.0, 0.0, 0.0)


def test_estimate_shift_validates():
    with pytest.raises(ValueError, match='shapes differ'):
        direction.estimate_shift(np.zeros((4, 4)), np.zeros((4, 5)))
    with pytest.raises(ValueError, match='NaN'):
        direction.estimate_shift(np.full((4, 4), np.nan), np.zeros((4, 4)))


@pytest.mark.parametrize('shape', [(5, 6), (9, 9), (20, 24)])
def test_dense_and_separable_band_spectra_agree(shape):
    # Small windows use one dense DFT matrix, large ones the separable products: same numbers.
    rng = np.random.default_rng(5)
    maps = rng.uniform(0.0, 1.0, (2,) + shape)
    plan = direction._plan(shape)
    dense = dict(plan)
    separable = dict(plan, dense=None)
    if dense['dense'] is None:
        ey, ex = plan['ey'], plan['ex']
        full = np.einsum('iy,xj->ijyx', ey, ex).reshape(-1, shape[0] * shape[1])
        dense['dense'] = np.ascontiguousarray(full[plan['keep']].T).view(np.float64)
    np.testing.assert_allclose(direction._band_cross(maps, dense),
                               direction._band_cross(maps, separable), rtol=1e-12, atol=1e-12)


def test_an_empty_layer_gives_no_shift():
    top, bottom = _pair(0.0015, -0.001)
    for name in ('centroid', 'poc'):
        method = direction.get_method(name).function
        assert method(np.stack((top, np.zeros_like(top)))) == direction.NO_SHIFT
        assert method(np.stack((np.zeros_like(top), bottom))) == direction.NO_SHIFT


def test_only_the_slow_model_fit_carries_a_caution_and_skips_scans_on_live_hosts():
    cautions = {name: direction.get_method(name).caution for name in direction.method_names()}
    assert 'newest scan' in cautions.pop('model_fit')
    assert set(cautions.values()) == {''}
    slow = [n for n in direction.method_names() if not direction.get_method(n).every_scan]
    assert slow == ['model_fit']
