"""
Golden outputs: stored scans of the simulated family and the contacts the estimator gave them.

Each case is an estimator (method, pitch, a stored calibration, a tare from stored frames) and
a few stored scans (golden/scans.npz); golden/contacts.json holds the contacts it reported. The
tolerances are what a numpy, OpenBLAS or compiler upgrade may change and no real change of the
algorithm hides in: locations, areas and forces to 1e-6 relative (sums in another order part
by a few ulp; the imprint's centroid and its force are sums); the calibrated shift to 1e-6 m
absolute (2e-4 taxels at the family's 5 mm pitch: the narrow fits are ill-conditioned enough to
grow a changed order of operations to 1e-5 taxels, and an algorithm change moves them by 1e-2
taxels or more); directions (azimuth, its sigma, alpha) to 1e-3 rad, the shift's error over its
length; confidences to 1e-3; validity, the count and the order of the contacts exactly.

After a deliberate change of the algorithm, write them again and review the diff:
``PYTHONPATH=test tools/with-env.sh python test/core/estimation/test_golden.py --write``.
"""

import argparse
import json
import pathlib

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.model.taxelmodel import render_counts, X, Y
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_lab.experiments import make_scene
from taxel_presses import FILM, noisy, press

GOLDEN = pathlib.Path(__file__).resolve().parent / 'golden'
SCANS = GOLDEN / 'scans.npz'
CONTACTS = GOLDEN / 'contacts.json'

RELATIVE = 1e-6      # locations, areas, forces
SHIFT_M = 1e-6       # the calibrated shift, metres
ANGLE_RAD = 1e-3     # azimuth, its sigma, alpha
CONFIDENCE = 1e-3
TARE_FRAMES = 4      # of each scene's no-touch frames, stored: the golden tare


def _family_cases() -> list:
    """Return (name, skin, scene, method, calibrated, frames) of the cases drawn from scenes."""
    cases = []
    for skin in ('default', 'soft', 'stiff', 'crosstalk', 'saturating', 'noisy', 'sharp',
                 'film', 'loaded', 'held_out:2'):
        for scene in ('random', 'multi', 'border'):
            cases.append((f'{skin}-{scene}', skin, scene, 'taxel_fit', False, 2))
    for skin in ('crosstalk', 'soft'):
        for method in ('centroid', 'poc'):
            cases.append((f'{skin}-multi-{method}', skin, 'multi', method, False, 2))
    cases.append(('default@32-multi', 'default@32', 'multi', 'taxel_fit', False, 1))
    for skin in ('saturating', 'film', 'noisy'):
        cases.append((f'{skin}-paper-calibrated', skin, 'paper', 'taxel_fit', True, 2))
    return cases


def _model_fit_cases() -> list:
    """Return (name, calibration, top, bottom) of model_fit with a known taxel model."""
    out = []
    for gains in (False, True):
        truth = press(0.6, -0.4)
        truth[X], truth[Y] = 7.2, 8.4
        pattern = np.random.default_rng(3).uniform(0.9, 1.1, (2, 16, 16)) if gains else None
        maps = noisy(render_counts(FILM, (16, 16), truth, 24, pattern)).clip(0.0, None)
        calibration = Calibration(taxel_model=FILM,
                                  gains=None if pattern is None else tuple(1.0 / pattern))
        out.append((f'model_fit-gains-{gains}', calibration, maps[0], maps[1]))
    return out


def estimator_of(case: dict, arrays, calibration_path) -> ContactEstimator:
    """Return the estimator a stored case describes."""
    config = EstimatorConfig(method=case['method'], pitch_m=case['pitch_m'])
    calibration = Calibration.load_yaml(calibration_path) if calibration_path else None
    est = ContactEstimator(config, calibration)
    name = case['name']
    if f'{name}/tare_top' in arrays:
        est = est.with_tare(arrays[f'{name}/tare_top'], arrays[f'{name}/tare_bottom'])
    return est


def figures_of(contact) -> dict:
    return {'x_m': contact.x_m, 'y_m': contact.y_m, 'force_n': contact.force_n,
            'area_m2': contact.area_m2, 'shift_m': list(contact.shift_m),
            'azimuth_rad': contact.azimuth_rad, 'azimuth_sigma_rad': contact.azimuth_sigma_rad,
            'alpha_rad': contact.alpha_rad, 'force_xyz_n': list(contact.force_xyz_n),
            'confidence': contact.confidence, 'direction_valid': contact.direction_valid}


def write() -> None:
    """Write the golden scans and contacts from the estimator as it is now."""
    GOLDEN.mkdir(exist_ok=True)
    arrays, cases = {}, []
    for name, skin, scene, method, calibrated, frames in _family_cases():
        data = make_scene(scene, skin, np.random.default_rng(1), size=2 if calibrated else 4)
        calibration = None
        if calibrated:
            calibration = prepared_estimator(data, method)[0].calibration
        if data.tare_top is not None:
            arrays[f'{name}/tare_top'] = data.tare_top[:TARE_FRAMES]
            arrays[f'{name}/tare_bottom'] = data.tare_bottom[:TARE_FRAMES]
        scans = [i for i in range(data.frames) if data.split is None or data.split[i] == 0]
        scans = scans[-frames:]
        arrays[f'{name}/top'] = data.top[scans]
        arrays[f'{name}/bottom'] = data.bottom[scans]
        cases.append({'name': name, 'method': method, 'pitch_m': data.pitch_m,
                      'calibration': calibration})
    for name, calibration, top, bottom in _model_fit_cases():
        arrays[f'{name}/top'] = top[None]
        arrays[f'{name}/bottom'] = bottom[None]
        cases.append({'name': name, 'method': 'model_fit', 'pitch_m': 0.005,
                      'calibration': calibration})
    np.savez_compressed(SCANS, **arrays)
    stored = np.load(SCANS)
    doc = []
    for case in cases:
        calibration = case.pop('calibration')
        path = None
        if calibration is not None:
            path = GOLDEN / f'{case["name"].replace(":", "_")}.yaml'
            calibration.save_yaml(path)
            case['calibration'] = path.name
        est = estimator_of(case, stored, path)
        name = case['name']
        case['scans'] = [[figures_of(c) for c in est.process(t, b)]
                         for t, b in zip(stored[f'{name}/top'], stored[f'{name}/bottom'])]
        doc.append(case)
    CONTACTS.write_text(json.dumps(doc, indent=1) + '\n')


def _stored_cases() -> list:
    return json.loads(CONTACTS.read_text()) if CONTACTS.exists() else []


@pytest.fixture(scope='module')
def stored():
    return np.load(SCANS)


@pytest.mark.parametrize('case', _stored_cases(), ids=lambda case: case['name'])
def test_the_stored_scans_give_the_stored_contacts(case, stored):
    path = GOLDEN / case['calibration'] if case.get('calibration') else None
    est = estimator_of(case, stored, path)
    name = case['name']
    for top, bottom, want in zip(stored[f'{name}/top'], stored[f'{name}/bottom'],
                                 case['scans']):
        got = [figures_of(c) for c in est.process(top, bottom)]
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert g['direction_valid'] == w['direction_valid']
            for key in ('x_m', 'y_m', 'force_n', 'area_m2', 'force_xyz_n'):
                np.testing.assert_allclose(g[key], w[key], rtol=RELATIVE, atol=1e-12,
                                           err_msg=key)
            np.testing.assert_allclose(g['shift_m'], w['shift_m'], rtol=0, atol=SHIFT_M)
            for key in ('azimuth_rad', 'azimuth_sigma_rad', 'alpha_rad'):
                np.testing.assert_allclose(g[key], w[key], rtol=0, atol=ANGLE_RAD,
                                           err_msg=key)
            np.testing.assert_allclose(g['confidence'], w['confidence'], rtol=0,
                                       atol=CONFIDENCE)


def test_the_golden_file_covers_every_method_and_a_calibration():
    cases = _stored_cases()
    assert {c['method'] for c in cases} == {'taxel_fit', 'centroid', 'poc', 'model_fit'}
    assert sum(bool(c.get('calibration')) for c in cases) >= 4
    assert sum(len(s) for c in cases for s in c['scans']) >= 60


if __name__ == '__main__':
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--write', action='store_true', help='write the golden files again')
    if parser.parse_args().write:
        write()
        print(f'wrote {SCANS} and {CONTACTS}')
