"""
ROS-free parts of the benchmark: accuracy against speed, the seed's experiment, scaling, family.

Every timing is taken in this process, on the core it is pinned to, with the estimators
interleaved frame by frame in a shuffled order, so that machine noise hits them all alike.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.scan import kernel as compiled_kernel
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import (
    DEFAULT_METHOD, get_method, Method, method_names, NO_SHIFT, REFERENCES, resolve,
    ShiftEstimate)
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.core.sim.skins import family_skin, PATCH_M, skin_for_grid, skin_names
from skin_lab.bench.costs import alone_costs, back_to_back_us, interleaved_cost, timed
from skin_lab.evaluate.scoring import (angle_error_deg, direction_errors, evaluate, MethodRun,
                                       PAPER_TABLE, score_run)
from skin_lab.evaluate.tables import format_table
from skin_lab.experiments import (calibrated_scene, DIRECTION_KINDS, make_random_experiment,
                                  make_seed_experiment, press_for_shift)
from skin_lab.oracle import ORACLE, oracle_run

SKIMAGE = 'skimage_pcc'
SKIMAGE_UPSAMPLE = 100


def skimage_shift(maps: np.ndarray) -> ShiftEstimate:
    """Estimate the shift with scikit-image's upsampled phase cross-correlation (reference)."""
    from skimage.registration import phase_cross_correlation
    top, bottom = maps
    if not (top.any() and bottom.any()):
        return NO_SHIFT
    # Registering top onto bottom gives the displacement of bottom, (dy, dx). Its RMS error,
    # unused here, is undefined for a layer of zero mean and warns on every such frame.
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', UserWarning)
        (dy, dx), _, _ = phase_cross_correlation(bottom, top, upsample_factor=SKIMAGE_UPSAMPLE)
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return NO_SHIFT
    # It has no validity decision of its own: its estimates are taken as trusted.
    return ShiftEstimate(float(dx), float(dy), 1.0)


def centroid(maps: np.ndarray) -> ShiftEstimate:
    """Return the difference of the weighted centroids of a (2, h, w) stack (bench reference)."""
    cols = maps.sum(axis=1)
    rows = maps.sum(axis=2)
    mass = cols.sum(axis=1)
    if not (mass[0] > 0 and mass[1] > 0):
        return NO_SHIFT
    cx = cols @ np.arange(maps.shape[2], dtype=np.float64) / mass
    cy = rows @ np.arange(maps.shape[1], dtype=np.float64) / mass
    return ShiftEstimate(float(cx[1] - cx[0]), float(cy[1] - cy[0]), 1.0)


def scan_methods(modelled: bool = False) -> list:
    """
    Return the registered methods the bench runs: those of the compiled kernel, default first.

    ``model_fit`` (a modelled method) only with ``modelled``: it needs the taxel model a force
    calibration learns, and the uncalibrated sections would score ``taxel_fit`` under its name.
    """
    return [m for m in method_names()
            if m in compiled_kernel.METHODS and (modelled or not get_method(m).modelled)]


def bench_methods(with_reference: bool = True) -> list:
    """Return the estimator names benchmarked: the registered ones, then the reference."""
    return scan_methods() + list(REFERENCES) + ([SKIMAGE] if with_reference else [])


def make_estimator(name: str, model: SkinModel, calibration=None) -> ContactEstimator:
    """Return the pipeline with estimator ``name`` (a registered one or the skimage reference)."""
    registered, reference = resolve(name if name != SKIMAGE else 'centroid')
    # The no-shear floor follows the pitch (the default's 0.25 mm is 1/20 of the seed's taxel),
    # so that small shifts on fine grids are judged by the estimator, not by a fixed threshold.
    # The bench tells the estimator the skin's true film: the simulator's film and the
    # driver's assumed one are named by the same numbers.
    config = EstimatorConfig(method=registered, pitch_m=model.pitch_m,
                             fsr=FsrModel(**dataclasses.asdict(model.fsr)),
                             min_shift_m=0.05 * model.pitch_m)
    # Bench only: the reference is never a runtime estimator, so it is swapped in here.
    if name == SKIMAGE:
        reference = Method(SKIMAGE, skimage_shift, False, 'scikit-image, upsampled x100')
    return ContactEstimator(config, calibration, shift=reference)


def _tared(ests: dict, model, rng, frames=12) -> dict:
    """Return the estimators tared from the same no-touch frames of ``model``."""
    maps = [render(model, [], rng) for _ in range(frames)]
    tops, bottoms = np.stack([m[0] for m in maps]), np.stack([m[1] for m in maps])
    return {name: est.with_tare(tops, bottoms) for name, est in ests.items()}


def accuracy_speed(grids, shifts, noises, frames, methods, seed=0, log=print) -> list:
    """
    Return one row per (grid, noise, shift, method): mean azimuth error, valid share, cost.

    Each frame is rendered once and given to every method in a fresh shuffled order.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for n in grids:
        for noise in noises:
            model = skin_for_grid(n, noise)
            ests = _tared({m: make_estimator(m, model) for m in methods}, model, rng)
            warm = render(model, [press_for_shift(model, 1.0, rng)], rng)
            for est in ests.values():
                est.process(*warm)
            for shift in shifts:
                errors = {m: [] for m in methods}
                costs = {m: [] for m in methods}
                for _ in range(frames):
                    press = press_for_shift(model, shift, rng)
                    top, bottom = render(model, [press], rng)
                    for m in rng.permutation(methods):
                        elapsed, contacts = timed(ests[m], top, bottom)
                        costs[m].append(elapsed)
                        if contacts and contacts[0].direction_valid:
                            errors[m].append(angle_error_deg(
                                contacts[0].azimuth_rad, math.degrees(press.beta_rad)))
                for m in methods:
                    e = errors[m]
                    rows.append({'grid': n, 'noise_counts': noise, 'shift_taxels': shift,
                                 'method': m, 'frames': frames, 'valid': len(e),
                                 'mean_error_deg': float(np.mean(e)) if e else None,
                                 'median_us': 1e6 * float(np.median(costs[m])),
                                 'mean_us': 1e6 * float(np.mean(costs[m]))})
            log(f'  accuracy/speed: {n}x{n}, noise {noise:g} counts done')
    return rows


def pareto_summary(rows, methods, grids) -> list:
    """Return per (grid, method): error averaged over shifts and noises, valid share, cost."""
    out = []
    for n in grids:
        for m in methods:
            sel = [r for r in rows if r['grid'] == n and r['method'] == m]
            errs = [r['mean_error_deg'] for r in sel if r['mean_error_deg'] is not None]
            frames = sum(r['frames'] for r in sel)
            out.append({'grid': n, 'method': m,
                        'mean_error_deg': float(np.mean(errs)) if errs else None,
                        'valid_share': sum(r['valid'] for r in sel) / frames if frames else None,
                        'median_us': float(np.median([r['median_us'] for r in sel])),
                        'mean_us': float(np.mean([r['mean_us'] for r in sel]))})
    return out


def seed_experiment(repeats: int, random_frames: int, seed: int = 0) -> dict:
    """Return the seed's Table 1 (seed and default) and the random-press accuracy, with text."""
    data = make_seed_experiment(repeats=repeats, rng=np.random.default_rng(seed))
    report = evaluate(data)
    shifts = {}
    tilted = np.flatnonzero(data.alpha_deg > 0)
    for name in ('seed', method_names()[0]):
        registered, reference = resolve(name)
        est = ContactEstimator(EstimatorConfig(method=registered, pitch_m=data.pitch_m),
                               shift=reference).with_tare(data.tare_top, data.tare_bottom)
        pts = []
        for i in tilted:
            s = est.measure_shifts(data.top[i], data.bottom[i])
            if s:
                pts.append((s[0][0] / data.pitch_m, s[0][1] / data.pitch_m,
                            float(data.azimuth_deg[i])))
        shifts[name] = pts
    random_data = make_random_experiment(frames=random_frames, rng=np.random.default_rng(seed))
    random_report = evaluate(random_data)
    return {'seed_like': report, 'seed_like_text': format_table(report),
            'random': random_report, 'random_text': format_table(random_report),
            'raw_shifts_taxels': shifts, 'paper': {str(k): v for k, v in PAPER_TABLE.items()}}


def _contact_slots(count) -> list:
    """Return ``count`` well separated press positions (3 x 3 lattice over the patch)."""
    ticks = [0.2 * PATCH_M, 0.5 * PATCH_M, 0.8 * PATCH_M]
    slots = [(x, y) for y in ticks for x in ticks]
    return slots[:count]


def _tared_estimator(name, model, rng):
    return _tared({name: make_estimator(name, model)}, model, rng)[name]


def scaling(grids, contact_counts, methods, frames, repeats, seed=0, log=print) -> dict:
    """
    Return pipeline cost (contacts included) against taxel count and against contacts.

    With the default among ``methods``, its row per grid also has ``alone_median_us``: the same
    frames back to back, as a driver runs it. Interleaved with a millisecond of numpy per frame
    (the other estimators), the compiled call finds its caches cold and costs more.
    """
    rng = np.random.default_rng(seed)
    by_grid = []
    for n in grids:
        model = skin_for_grid(n)
        ests = {m: _tared_estimator(m, model, rng) for m in methods}
        maps = [render(model, [press_for_shift(model, 1.0, rng)], rng) for _ in range(frames)]
        cost = interleaved_cost(ests, maps, rng, repeats)
        if DEFAULT_METHOD in ests:
            cost[DEFAULT_METHOD]['alone_median_us'] = back_to_back_us(ests[DEFAULT_METHOD],
                                                                      maps, repeats)
        by_grid += [{'grid': n, 'taxels': n * n, 'method': m, **c} for m, c in cost.items()]
        log(f'  scaling: {n}x{n} done')
    by_contacts = []
    for n in (grids[0], grids[-1]):
        model = skin_for_grid(n)
        ests = {m: _tared_estimator(m, model, rng) for m in methods}
        for k in contact_counts:
            maps = []
            for _ in range(frames):
                presses = [Press(x, y, rng.uniform(5, 15), math.radians(40),
                                 rng.uniform(-math.pi, math.pi), 0.003)
                           for x, y in _contact_slots(k)]
                maps.append(render(model, presses, rng))
            found = float(np.mean([len(ests[methods[0]].process(*m)) for m in maps]))
            cost = interleaved_cost(ests, maps, rng, repeats)
            by_contacts += [{'grid': n, 'contacts': k, 'contacts_found': found, 'method': m,
                             **c} for m, c in cost.items()]
        log(f'  scaling: contacts at {n}x{n} done')
    return {'by_grid': by_grid, 'by_contacts': by_contacts}


# Bench-only reference: the centroid difference of the whole tared count maps, the simplest
# estimator a user could write (what the held-out figures compare against).
PLAIN_CENTROID = 'plain_centroid'


def family_methods(everything: bool = True) -> list:
    """
    Return the family benchmark's methods: default, seed, the plain centroid, the others.

    ``model_fit`` is among the others: each
    scene's calibration learns its taxel model (up to a minute a scene, in Python).
    """
    first = [DEFAULT_METHOD, 'seed', PLAIN_CENTROID]
    return first + ([m for m in scan_methods(True) if m not in first] if everything else [])


def plain_centroid_estimator(data, threshold_counts: float = 40.0) -> tuple:
    """
    Return (an estimator whose shift is the plain centroid difference of the tared counts, notes).

    The pipeline around it (contacts, force, calibration, validity) is the default's, prepared
    and calibrated as every method is (:func:`prepared.prepared_estimator`); only the shift is
    replaced, computed on the whole maps less the mean tare frame, counts under
    ``threshold_counts`` zeroed.
    """
    baseline = (np.stack((data.tare_top.mean(axis=0), data.tare_bottom.mean(axis=0)))
                if data.tare_top is not None else 0.0)

    def shift(raw: np.ndarray) -> ShiftEstimate:
        counts = raw - baseline
        counts[counts < threshold_counts] = 0.0
        return centroid(counts)

    plain = Method(PLAIN_CENTROID, shift, True, 'centroid difference of the tared count maps')
    return prepared_estimator(data, DEFAULT_METHOD, shift=plain)


def _family_row(skin, kind, data, run, costs) -> dict:
    """Return the headline figures of one method on one scene of one skin."""
    scored = score_run(data, run)
    summary, presses = scored['summary'], scored['presses']
    # Scenes of several presses are scored press by press; the others frame by frame.
    source = presses if kind == 'multi' else summary
    return {'skin': skin, 'scene': kind, 'method': run.method, 'frames': data.frames,
            'mean_error_deg': source['mean_error_deg'], 'valid_share': source['valid_share'],
            'large_shift_valid_share': summary['large_shift_valid_share'],
            'large_shift_frames': summary['large_shift_frames'],
            'separate_share_far': presses and presses['separate_share_far'],
            'merged_share_far': presses and presses['merged_share_far'],
            'separate_share_close': presses and presses['separate_share_close'],
            'median_us': 1e6 * float(np.median(costs)), 'mean_us': 1e6 * float(np.mean(costs))}


def _family_estimator(data, method: str) -> tuple:
    """Return (estimator ``method`` prepared for ``data``, its calibration notes)."""
    if method == PLAIN_CENTROID:
        return plain_centroid_estimator(data)
    return prepared_estimator(data, method)


def family(sizes: dict, methods: list, skins: list = None, seed: int = 0, log=print,
           oracle: bool = True, kinds: tuple = DIRECTION_KINDS) -> dict:
    """
    Score every method on every scene of every skin of the family, side by side.

    Each scene comes after the user's calibration (:func:`experiments.calibrated_scene`, the
    evaluator's ``--calibration-frames``): every method, the plain centroid included, calibrates
    force curves, offset and compliance from the same calibration frames through the live
    calibration sessions (:func:`prepared.prepared_estimator`), and in the paper's protocol
    re-takes the offset at its spot. Only the scored frames (split 0) are scored and timed, each
    going to every method in a fresh shuffled order (contacts included, on the core the process
    is pinned to). Returns per (skin, scene, method) rows, the cost per (skin, method) over all
    the skin's scored frames (the default's also back to back, :func:`alone_costs`, as
    ``alone``), each method's calibration notes per (skin, scene), and the
    default's (reported azimuth sigma, measured error) pairs. With ``oracle`` the floor
    (:mod:`skin_lab.oracle`, the simulator's own model fitted to each frame from the truth) is
    scored too, as method ``oracle``. ``kinds`` are the scenes scored (``sizes`` has theirs).
    """
    rng = np.random.default_rng(seed)
    # The order of the methods is drawn apart, so that the scenes are the same draws however
    # many frames each one scores.
    order = rng.spawn(1)[0]
    rows, costs, sigma, notes = [], [], [], []
    for skin in skins or skin_names():
        per_skin = {m: [] for m in methods}
        oracle_us = []
        alone = []
        for kind in kinds:
            truth = []
            data = calibrated_scene(kind, skin, rng, sizes[kind], truth)
            prepared = {m: _family_estimator(data, m) for m in methods}
            notes += [{'skin': skin, 'scene': kind, 'method': m, 'notes': list(n)}
                      for m, (_, n) in prepared.items()]
            ests = {m: est for m, (est, _) in prepared.items()}
            scored_frames = data.scored_frames()
            presses = [truth[i] for i in scored_frames]
            data = data.select(scored_frames)
            contacts = {m: [] for m in methods}
            times = {m: [] for m in methods}
            for i in range(data.frames):
                for m in order.permutation(methods):
                    elapsed, found = timed(ests[m], data.top[i], data.bottom[i])
                    times[m].append(elapsed)
                    contacts[m].append(found)
            if DEFAULT_METHOD in ests:
                alone.append((kind, ests[DEFAULT_METHOD],
                              [(data.top[i], data.bottom[i]) for i in range(data.frames)]))
            for m in methods:
                run = MethodRun(m, ests[m].calibration, contacts[m],
                                1e6 * float(np.mean(times[m])))
                rows.append(_family_row(skin, kind, data, run, times[m]))
                per_skin[m] += times[m]
                if m == DEFAULT_METHOD:
                    sigma += [(math.degrees(c.azimuth_sigma_rad), err, skin, kind)
                              for _, _, err, c in direction_errors(data, run) if err is not None]
            if oracle:
                found, us = oracle_run(family_skin(skin).model, presses, data)
                rows.append(_family_row(skin, kind, data,
                                        MethodRun(ORACLE, ests[methods[0]].calibration, found,
                                                  us), [1e-6 * us]))
                oracle_us.append(1e-6 * us)
        if oracle:
            per_skin[ORACLE] = oracle_us
        costs += [{'skin': skin, 'method': m, 'frames': len(t),
                   'median_us': 1e6 * float(np.median(t)), 'mean_us': 1e6 * float(np.mean(t)),
                   'p90_us': 1e6 * float(np.percentile(t, 90))}
                  | ({'alone': alone_costs(alone)} if m == DEFAULT_METHOD and alone else {})
                  for m, t in per_skin.items()]
        log(f'  family: {skin} done')
    methods = list(methods) + ([ORACLE] if oracle else [])
    return {'skins': {s: family_skin(s).description for s in (skins or skin_names())},
            'sizes': sizes, 'methods': methods, 'rows': rows, 'costs': costs,
            'calibration_notes': notes, 'sigma_vs_error': sigma,
            'worst': family_worst(rows, costs, methods)}


# The estimator the forward-model section scores beside the default and the oracle.
FORWARD = 'model_fit'


def forward_family(size: int, skins: list = None, seed: int = 0, log=print) -> dict:
    """
    Return ``model_fit`` and the default scored beside the oracle at ``size`` random spots a skin.

    The family's way (:func:`family`), random spots only: its calibration learns the skin in
    Python, up to a minute a scene, so the other scenes would take an hour more.
    """
    return family({'random': size}, [DEFAULT_METHOD, FORWARD], skins, seed, log,
                  kinds=('random',))


def _worst(rows, key, lowest: bool):
    """Return (value, skin) of the worst row by ``key`` (None values left out)."""
    rated = [(r[key], r['skin']) for r in rows if r[key] is not None]
    if not rated:
        return None, None
    return (min if lowest else max)(rated)


def family_worst(rows, costs, methods) -> dict:
    """
    Return each method's worst case over the skins: per scene, error, valid share and more.

    ``ratio_to_centroid``, ``ratio_to_seed`` and ``ratio_to_oracle`` are the largest ratios of
    the method's mean error to the plain centroid difference's, to seed's and to the oracle's on
    the same skin and scene.
    ``oracle_error_deg`` and ``oracle_valid_share`` are the oracle's error on the method's worst
    skin and its valid share on the skin of the method's lowest one (what the frames hold);
    ``multi``'s ``ratio_to_single`` is the largest ratio of the per-press error with two or
    three presses to the single-press error at random spots on the same skin (issue #16's 1.2).
    ``median_us`` is the dearest skin's median cost interleaved with the others,
    ``alone_median_us`` back to back (the default only; None for the others).
    """
    index = {(r['skin'], r['scene'], r['method']): r for r in rows}
    out = {}
    for m in methods:
        mine = [r for r in rows if r['method'] == m]
        entry = {}
        for kind in DIRECTION_KINDS:
            sel = [r for r in mine if r['scene'] == kind]
            error, error_skin = _worst(sel, 'mean_error_deg', lowest=False)
            valid, valid_skin = _worst(sel, 'valid_share', lowest=True)
            ratios = {}
            for ref in (PLAIN_CENTROID, 'seed', ORACLE):
                if ref == m:
                    ratios[ref] = (None, None)
                    continue
                pairs = [(r['mean_error_deg'] / index[(r['skin'], kind, ref)]['mean_error_deg'],
                          r['skin']) for r in sel
                         if (r['skin'], kind, ref) in index and r['mean_error_deg'] is not None
                         and index[(r['skin'], kind, ref)]['mean_error_deg']]
                ratios[ref] = max(pairs) if pairs else (None, None)
            entry[kind] = {'mean_error_deg': error, 'error_skin': error_skin,
                           'valid_share': valid, 'valid_skin': valid_skin,
                           'ratio_to_centroid': ratios[PLAIN_CENTROID][0],
                           'ratio_to_centroid_skin': ratios[PLAIN_CENTROID][1],
                           'ratio_to_seed': ratios['seed'][0],
                           'ratio_to_seed_skin': ratios['seed'][1],
                           'ratio_to_oracle': ratios[ORACLE][0],
                           'ratio_to_oracle_skin': ratios[ORACLE][1],
                           'oracle_error_deg': index.get((error_skin, kind, ORACLE),
                                                         {}).get('mean_error_deg'),
                           'oracle_valid_share': index.get((valid_skin, kind, ORACLE),
                                                           {}).get('valid_share')}
            if kind == 'multi':
                single = {r['skin']: r['mean_error_deg'] for r in mine if r['scene'] == 'random'}
                to_single = [(r['mean_error_deg'] / single[r['skin']], r['skin']) for r in sel
                             if r['mean_error_deg'] is not None and single.get(r['skin'])]
                ratio, skin = max(to_single, default=(None, None))
                entry[kind].update(ratio_to_single=ratio, ratio_to_single_skin=skin)
        large, large_skin = _worst(mine, 'large_shift_valid_share', lowest=True)
        # How many presses the worst share is of: one press at the border can make it 0 %.
        large_presses = max((r['large_shift_frames'] for r in mine if r['skin'] == large_skin
                             and r['large_shift_valid_share'] == large), default=None)
        separate, separate_skin = _worst(mine, 'separate_share_far', lowest=True)
        cost, cost_skin = _worst([c for c in costs if c['method'] == m], 'median_us',
                                 lowest=False)
        alone, alone_skin = _worst([{'skin': c['skin'], 'median_us': c['alone']['median_us']}
                                    for c in costs if c['method'] == m and 'alone' in c],
                                   'median_us', lowest=False)
        entry.update({'large_shift_valid_share': large, 'large_shift_skin': large_skin,
                      'large_shift_presses': large_presses,
                      'separate_share_far': separate, 'separate_skin': separate_skin,
                      'median_us': cost, 'cost_skin': cost_skin,
                      'alone_median_us': alone, 'alone_skin': alone_skin})
        out[m] = entry
    return out
