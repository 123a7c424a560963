"""Tests of the shift estimators, run by the estimator's kernel, and their registry."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift import methods as direction
from skin_driver.core.sim.physics import Press, render, SkinModel

REQUIRED = ('centroid', 'poc', 'taxel_fit')


def _pair(dx_m, dy_m, model=None):
    model = model or SkinModel(noise_counts=0.0, spread_m=0.002)
    t = math.hypot(dx_m, dy_m)
    alpha = math.atan(t / (model.compliance_m_per_n * 10.0)) if t else 0.0
    force = math.hypot(10.0, t / model.compliance_m_per_n)
    press = Press(0.037, 0.038, force, alpha, math.atan2(dy_m, dx_m), 0.0025)
    return render(model, [press], np.random.default_rng(0))


def _shift(top, bottom, name):
    """Return the shift (taxels) of the strongest contact: a registered method or a reference."""
    if name in direction.REFERENCES:
        return direction.REFERENCES[name].function(np.stack((top, bottom)).astype(np.float64))
    shifts = ContactEstimator(EstimatorConfig(method=name)).measure_shifts(top, bottom)
    if not shifts:
        return direction.NO_SHIFT
    return direction.ShiftEstimate(shifts[0][0] / 0.005, shifts[0][1] / 0.005, 1.0)


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


@pytest.mark.parametrize('name', ['poc', 'centroid', 'taxel_fit'])
def test_sub_taxel_shift_of_physical_maps(name):
    # Sampling biases the raw shift by a few hundredths of a taxel at a given spot; the seed's
    # calibration (a normal press at the same spot) removes it.
    ref = _shift(*_pair(0.0, 0.0), name)
    est = _shift(*_pair(0.0035, -0.002), name)
    assert (est.dx - ref.dx, est.dy - ref.dy) == pytest.approx((0.7, -0.4), abs=0.05)


def test_the_centroid_beats_the_papers_reference_on_direction():
    errs = {'centroid': [], 'seed': []}
    refs = {name: _shift(*_pair(0.0, 0.0), name) for name in errs}
    for beta in np.radians(np.arange(0, 360, 45)):
        top, bottom = _pair(0.004 * math.cos(beta), 0.004 * math.sin(beta))
        for name in errs:
            est = _shift(top, bottom, name)
            got = math.atan2(est.dy - refs[name].dy, est.dx - refs[name].dx)
            errs[name].append(abs((math.degrees(got - beta) + 180) % 360 - 180))
    assert np.mean(errs['centroid']) < 1.0
    assert np.mean(errs['centroid']) < np.mean(errs['seed'])


@pytest.mark.parametrize('name', REQUIRED)
def test_empty_maps_give_no_shift(name):
    assert ContactEstimator(EstimatorConfig(method=name)).measure_shifts(
        np.zeros((6, 6)), np.zeros((6, 6))) == []


def test_the_papers_reference_gives_no_shift_for_an_empty_layer():
    top, bottom = _pair(0.0015, -0.001)
    seed = direction.REFERENCES['seed'].function
    assert seed(np.stack((top, np.zeros_like(top)))) == direction.NO_SHIFT
    assert seed(np.stack((np.zeros_like(top), bottom))) == direction.NO_SHIFT


def test_only_the_slow_model_fit_carries_a_caution_and_skips_scans_on_live_hosts():
    cautions = {name: direction.get_method(name).caution for name in direction.method_names()}
    assert 'newest scan' in cautions.pop('model_fit')
    assert set(cautions.values()) == {''}
    slow = [n for n in direction.method_names() if not direction.get_method(n).every_scan]
    assert slow == ['model_fit']
