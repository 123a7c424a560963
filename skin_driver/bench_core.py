"""
ROS-free parts of the benchmark: accuracy against speed, the seed's experiment and scaling.

Every timing is taken in this process, on the core it is pinned to, with the estimators
interleaved frame by frame in a shuffled order, so that machine noise hits them all alike.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .core.estimation.fsr import FsrModel
from .core.estimation.pipeline import ContactEstimator, EstimatorConfig
from .core.estimation.shift import Method, method_names, NO_SHIFT, ShiftEstimate
from .core.sim.experiments import make_random_experiment, make_seed_experiment
from .core.sim.physics import Press, render, SkinModel
from .evaluate import evaluate, format_table, PAPER_TABLE

PATCH_M = 0.08
SEED_PITCH_M = 0.005
SKIMAGE = 'skimage_pcc'
SKIMAGE_UPSAMPLE = 100


def skimage_shift(maps: np.ndarray) -> ShiftEstimate:
    """Estimate the shift with scikit-image's upsampled phase cross-correlation (reference)."""
    from skimage.registration import phase_cross_correlation
    top, bottom = maps
    if not (top.any() and bottom.any()):
        return NO_SHIFT
    # Registering top onto bottom gives the displacement of bottom, (dy, dx).
    (dy, dx), _, _ = phase_cross_correlation(bottom, top, upsample_factor=SKIMAGE_UPSAMPLE)
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return NO_SHIFT
    # It has no validity decision of its own: its estimates are taken as trusted.
    return ShiftEstimate(float(dx), float(dy), 1.0)


def bench_methods(with_reference: bool = True) -> list:
    """Return the estimator names benchmarked: the registered ones, then the reference."""
    return method_names() + ([SKIMAGE] if with_reference else [])


def make_estimator(name: str, model: SkinModel, calibration=None) -> ContactEstimator:
    """Return the pipeline with estimator ``name`` (a registered one or the skimage reference)."""
    registered = name if name != SKIMAGE else 'centroid'
    # The no-shear floor follows the pitch (the default's 0.25 mm is 1/20 of the seed's taxel),
    # so that small shifts on fine grids are judged by the estimator, not by a fixed threshold.
    config = EstimatorConfig(method=registered, pitch_m=model.pitch_m, fsr=model.fsr,
                             min_shift_m=0.05 * model.pitch_m)
    est = ContactEstimator(config, calibration)
    if name == SKIMAGE:
        # Bench only: the reference is never a runtime estimator, so it is swapped in here.
        est._method = Method(SKIMAGE, skimage_shift, False, 'scikit-image, upsampled x100')
    return est


def skin_for_grid(n: int, noise_counts: float = 6.0) -> SkinModel:
    """
    Return an n x n skin over the seed's 80 mm patch: finer pitch, same materials.

    A smaller FSR carries a smaller share of the load; made of the same material, it reads the
    same counts at the same pressure, so its force range scales with its area.
    """
    pitch = PATCH_M / n
    area = (pitch / SEED_PITCH_M) ** 2
    base = FsrModel()
    fsr = FsrModel(force_at_r_max_n=base.force_at_r_max_n * area,
                   force_at_r_min_n=base.force_at_r_min_n * area,
                   activation_n=base.activation_n * area)
    return SkinModel(rows=n, cols=n, pitch_m=pitch, noise_counts=noise_counts, fsr=fsr)


def _angle_error(estimate_rad: float, truth_rad: float) -> float:
    return abs(math.degrees((estimate_rad - truth_rad + math.pi) % (2 * math.pi) - math.pi))


def _tare(est_list, model, rng, frames=12) -> None:
    maps = [render(model, [], rng) for _ in range(frames)]
    tops, bottoms = np.stack([m[0] for m in maps]), np.stack([m[1] for m in maps])
    for est in est_list:
        est.tare(tops, bottoms)


def _press_for_shift(model, shift_taxels, rng) -> Press:
    """Return a random press whose layer shift is ``shift_taxels`` taxels along a random beta."""
    margin = 0.015
    x = rng.uniform(margin, PATCH_M - margin)
    y = rng.uniform(margin, PATCH_M - margin)
    normal = rng.uniform(5.0, 15.0)
    tangential = shift_taxels * model.pitch_m / model.compliance_m_per_n
    alpha = math.atan2(tangential, normal)
    return Press(x, y, math.hypot(normal, tangential), alpha, rng.uniform(-math.pi, math.pi),
                 rng.uniform(0.0015, 0.0035))


def _timed(est, top, bottom) -> tuple:
    start = time.perf_counter()
    contacts = est.process(top, bottom)
    return time.perf_counter() - start, contacts


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
            ests = {m: make_estimator(m, model) for m in methods}
            _tare(ests.values(), model, rng)
            warm = render(model, [_press_for_shift(model, 1.0, rng)], rng)
            for est in ests.values():
                est.process(*warm)
            for shift in shifts:
                errors = {m: [] for m in methods}
                costs = {m: [] for m in methods}
                for _ in range(frames):
                    press = _press_for_shift(model, shift, rng)
                    top, bottom = render(model, [press], rng)
                    for m in rng.permutation(methods):
                        elapsed, contacts = _timed(ests[m], top, bottom)
                        costs[m].append(elapsed)
                        if contacts and contacts[0].direction_valid:
                            errors[m].append(_angle_error(contacts[0].azimuth_rad,
                                                          press.beta_rad))
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
        est = ContactEstimator(EstimatorConfig(method=name, pitch_m=data.pitch_m))
        est.tare(data.tare_top, data.tare_bottom)
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


def _contact_slots(model, count) -> list:
    """Return ``count`` well separated press positions (3 x 3 lattice over the patch)."""
    ticks = [0.2 * PATCH_M, 0.5 * PATCH_M, 0.8 * PATCH_M]
    slots = [(x, y) for y in ticks for x in ticks]
    return slots[:count]


def _calibrated(name, model, rng):
    est = make_estimator(name, model)
    _tare([est], model, rng)
    return est


def _interleaved_cost(ests, frames, rng, repeats) -> dict:
    costs = {m: [] for m in ests}
    for est in ests.values():
        est.process(*frames[0])
    for _ in range(repeats):
        for top, bottom in frames:
            for m in rng.permutation(list(ests)):
                costs[m].append(_timed(ests[m], top, bottom)[0])
    return {m: {'median_us': 1e6 * float(np.median(c)), 'mean_us': 1e6 * float(np.mean(c)),
                'p90_us': 1e6 * float(np.percentile(c, 90))} for m, c in costs.items()}


def scaling(grids, contact_counts, methods, frames, repeats, seed=0, log=print) -> dict:
    """Return pipeline cost (contacts included) against taxel count and against contacts."""
    rng = np.random.default_rng(seed)
    by_grid = []
    for n in grids:
        model = skin_for_grid(n)
        ests = {m: _calibrated(m, model, rng) for m in methods}
        maps = [render(model, [_press_for_shift(model, 1.0, rng)], rng) for _ in range(frames)]
        cost = _interleaved_cost(ests, maps, rng, repeats)
        by_grid += [{'grid': n, 'taxels': n * n, 'method': m, **c} for m, c in cost.items()]
        log(f'  scaling: {n}x{n} done')
    by_contacts = []
    for n in (grids[0], grids[-1]):
        model = skin_for_grid(n)
        ests = {m: _calibrated(m, model, rng) for m in methods}
        for k in contact_counts:
            maps = []
            for _ in range(frames):
                presses = [Press(x, y, rng.uniform(5, 15), math.radians(40),
                                 rng.uniform(-math.pi, math.pi), 0.003)
                           for x, y in _contact_slots(model, k)]
                maps.append(render(model, presses, rng))
            found = float(np.mean([len(ests[methods[0]].process(*m)) for m in maps]))
            cost = _interleaved_cost(ests, maps, rng, repeats)
            by_contacts += [{'grid': n, 'contacts': k, 'contacts_found': found, 'method': m,
                             **c} for m, c in cost.items()]
        log(f'  scaling: contacts at {n}x{n} done')
    return {'by_grid': by_grid, 'by_contacts': by_contacts}
