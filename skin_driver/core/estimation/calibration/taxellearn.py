"""
Learn a skin's :class:`taxelmodel.TaxelModel` from presses of known normal force.

The presses a force calibration records (tared counts at full load, each with its known force)
hold the skin: the cover and layer blurs, the pads' fill and the film's law (with or without a
turn-on). One Levenberg-Marquardt fit takes them all together, the skin's seven (nine with a
turn-on) numbers shared and each
press's place, shift and tip radius its own, its normal force held at the known one (the film's
law and the force trade against each other otherwise). Learned on counts, not on force maps:
the film's curve read through a separate calibration misreads the imprints' rims, and that
error comes back as sampling bias (docs/estimation.md, "The forward model").

The fit starts from a film law given by the caller (the driver's assumed FSR) and a blur of a
fifth and two fifths of a taxel: starts only; what the presses say replaces them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Sequence

import numpy as np

from ..model.fsr import FsrModel
from ..model.taxelmodel import (fit_numbers, fit_press, LOG_FORCE, LOG_RADIUS, residuals,
                                start_of, sub_for, TaxelModel)
from ...common import least_squares

__all__ = ['LearningPress', 'learn_taxel_model', 'film_start']

# Per-press parameters the learning frees: centre, shift and radius (the force is known).
_FREE = np.array((True, True, False, True, True, True, False, False))
_SKIN_STEP = 0.01
_SKIN_MOVE = 0.3
# Starts of the blurs, taxels (cover, layer), and of the pads' fill: the misfit of narrow pads
# has a side minimum at a wide fill, so the learning starts from two and keeps the better.
_START_BLURS = (0.2, 0.4)
_START_FILLS = (0.9, 0.75)
_MARGIN = 2
# A film with a turn-on starts at 20 kPa over a 5 mm taxel's area (N); kept when it explains
# the presses better than the smooth film (a skin's film has one or not).
_START_TURN_ON = 0.5
# The share of the loaded taxels below the counts a step starts at.
_STEP_QUANTILE = 0.02
# The activation is learned in log units, so it starts above zero even for a film without one.
_LEAST_LOAD = 1e-4


@dataclass(frozen=True)
class LearningPress:
    """
    One press of known normal force, as a force calibration recorded it.

    Its tared counts (2, rows, cols), its censored taxels (same shape: the clipped ones) or
    None, its raw shift (taxels, dx along columns) as the estimator measured it, and the taxels'
    sensitivity (same shape: the inverse of the calibrated gains) or None for even taxels.
    """

    counts: np.ndarray
    censored: np.ndarray
    normal_force_n: float
    shift_taxels: tuple
    sensitivity: np.ndarray = None


def film_start(fsr: FsrModel) -> tuple:
    """
    Return (film_scale, film_exponent, film_ceiling, film_activation_n) of an FSR's law.

    The learning's start: the driver's assumed FSR.
    """
    n = fsr.exponent
    scale = fsr.r_series_ohm / fsr.r_max_ohm * fsr.force_at_r_max_n ** -n
    return scale, n, fsr.r_series_ohm / fsr.r_min_ohm, fsr.activation_n


def _model(pitch: float, full_scale: float, g: np.ndarray) -> TaxelModel:
    """Return the model of the skin parameters ``g`` (log units; 7, or 9 with a turn-on)."""
    cover, layer = math.exp(g[0]), math.exp(g[1])
    turn_on = {} if g.size == 7 else {'turn_on_pa': math.exp(g[7]) / (pitch * pitch),
                                      'film_step': math.exp(g[8])}
    return TaxelModel(pitch_m=pitch, fill_factor=1.0 / (1.0 + math.exp(-g[2])),
                      cover_spread_m=cover * pitch, layer_spread_m=layer * pitch,
                      film_scale=math.exp(g[3]), film_exponent=math.exp(g[4]),
                      film_ceiling=math.exp(g[5]), film_activation_n=math.exp(g[6]),
                      full_scale=full_scale, **turn_on)


def _window(press: LearningPress) -> tuple:
    """Return (counts, censored, sensitivity) cut to the press's imprints and a margin."""
    loaded = np.flatnonzero(press.counts.any(axis=0).any(axis=1))
    cols = np.flatnonzero(press.counts.any(axis=0).any(axis=0))
    h, w = press.counts.shape[1:]
    r0, r1 = max(loaded[0] - _MARGIN, 0), min(loaded[-1] + _MARGIN + 1, h)
    c0, c1 = max(cols[0] - _MARGIN, 0), min(cols[-1] + _MARGIN + 1, w)
    censored = (None if press.censored is None
                else np.asarray(press.censored, dtype=bool)[:, r0:r1, c0:c1])
    sensitivity = (None if press.sensitivity is None
                   else np.asarray(press.sensitivity, dtype=np.float64)[:, r0:r1, c0:c1])
    return np.asarray(press.counts, dtype=np.float64)[:, r0:r1, c0:c1], censored, sensitivity


def learn_taxel_model(presses: Sequence[LearningPress], pitch_m: float, film: tuple,
                      full_scale: float, iterations: int = 40, radii_out: list = None
                      ) -> TaxelModel:
    """
    Return the skin's taxel model learned from ``presses`` (module docstring).

    ``film`` is the (scale, exponent, ceiling, activation) to start from (:func:`film_start`).
    ``radii_out``, when given, is extended by the tip radius (taxels) fitted to each press
    that loaded both layers. Raises ValueError when no press has load on both layers.
    """
    windows = [(_window(p), p) for p in presses
               if np.asarray(p.counts)[0].any() and np.asarray(p.counts)[1].any()]
    if not windows:
        raise ValueError('no press loaded both layers: the taxel model cannot be learned')
    best = None
    for fill in _START_FILLS:
        found = _learn_from(windows, pitch_m, full_scale, _start(film, fill), iterations)
        if best is None or found[1] < best[1]:
            best = found
    # A film with a turn-on is learned from the smooth film's skin; its step starts at the
    # counts a loaded taxel reads at least (a smooth film's lowest reading is the touch
    # threshold, which makes a step too small to matter).
    loaded = np.concatenate([c[c > 0] for (c, _, _), _ in windows])
    low = float(np.quantile(loaded, _STEP_QUANTILE)) if loaded.size else 1.0
    turn_on = np.log((_START_TURN_ON, low / max(full_scale - low, 1.0)))
    found = _learn_from(windows, pitch_m, full_scale, np.concatenate((best[0], turn_on)),
                        iterations)
    if found[1] < best[1]:
        best = found
    g, cost, fitted = best
    if radii_out is not None:
        radii_out.extend(math.exp(u[LOG_RADIUS]) for u in fitted)
    taxels = sum(c.size for (c, _, _), _ in windows)
    return replace(_model(pitch_m, full_scale, g), presses=len(windows),
                   misfit_counts=math.sqrt(cost / taxels))


def _start(film: tuple, fill: float) -> np.ndarray:
    """Return the skin parameters of a smooth film to start from (log units)."""
    return np.array((math.log(_START_BLURS[0]), math.log(_START_BLURS[1]),
                     math.log(fill / (1.0 - fill)), math.log(film[0]), math.log(film[1]),
                     math.log(film[2]), math.log(max(film[3], _LEAST_LOAD))))


def _learn_from(windows: list, pitch: float, full_scale: float, g: np.ndarray,
                iterations: int) -> tuple:
    """Return (skin parameters, misfit, press parameters) of the joint fit started at ``g``."""
    model = _model(pitch, full_scale, g)
    presses_u, subs = [], []
    for (counts, censored, sensitivity), press in windows:
        u = start_of(counts, press.shift_taxels, model)
        u[LOG_FORCE] = math.log(press.normal_force_n)
        presses_u.append(fit_press(model, counts, censored, u, _FREE, 6, sensitivity).u)
        subs.append(sub_for(u))
    g, fitted, cost = _joint(pitch, full_scale, g, presses_u, subs, [w for w, _ in windows],
                             iterations)
    return g, cost, fitted


def _joint(pitch: float, full_scale: float, g: np.ndarray, presses_u: list, subs: list,
           windows: list, iterations: int) -> tuple:
    """
    Return (g, press parameters, misfit) of the joint fit of skin and presses.

    One vector holds the skin's numbers, then each press's free ones. The normal equations are
    assembled press by press (a press's parameters move only its own residuals), and a trial
    that fails is retried with more damping at most six times before the fit ends.
    """
    idx = np.flatnonzero(_FREE)
    steps, moves = fit_numbers().steps[idx], fit_numbers().max_moves[idx]
    ng, npress, count = g.size, idx.size, len(windows)
    size = ng + npress * count

    def presses_of(x):
        out = []
        for k, u in enumerate(presses_u):
            v = u.copy()
            v[idx] = x[ng + npress * k:ng + npress * (k + 1)]
            out.append(v)
        return out

    def each_residual(x):
        model = _model(pitch, full_scale, x[:ng])
        return [residuals(model, c, m, u, s, k)
                for (c, m, k), u, s in zip(windows, presses_of(x), subs)]

    def residual(x):
        return np.concatenate(each_residual(x))

    # Each press's residuals: one per taxel of its window's two layers.
    split = np.cumsum([counts.size for counts, _, _ in windows])[:-1]

    def normal_equations(x, r):
        parts = np.split(r, split)
        normal = np.zeros((size, size))
        grad = np.zeros(size)
        skin_jac = []
        for j in range(ng):
            shifted = x.copy()
            shifted[j] += _SKIN_STEP
            skin_jac.append([(a - b) / _SKIN_STEP for a, b in zip(each_residual(shifted), parts)])
        model = _model(pitch, full_scale, x[:ng])
        for k, ((counts, censored, sens), u, sub) in enumerate(zip(windows, presses_of(x),
                                                                   subs)):
            jp = np.empty((parts[k].size, npress))
            for col, (j, h) in enumerate(zip(idx, steps)):
                v = u.copy()
                v[j] += h
                jp[:, col] = (residuals(model, counts, censored, v, sub, sens) - parts[k]) / h
            jg = np.column_stack([skin_jac[j][k] for j in range(ng)])
            own = slice(ng + npress * k, ng + npress * (k + 1))
            normal[:ng, :ng] += jg.T @ jg
            normal[:ng, own] += jg.T @ jp
            normal[own, :ng] += jp.T @ jg
            normal[own, own] += jp.T @ jp
            grad[:ng] += jg.T @ parts[k]
            grad[own] += jp.T @ parts[k]
        return normal, grad

    def limit(move):
        skin_move = np.clip(move[:ng], -_SKIN_MOVE, _SKIN_MOVE)
        press_moves = move[ng:].reshape(count, npress)
        press_moves = press_moves / np.maximum(1.0, np.abs(press_moves / moves).max(axis=1))[
            :, None]
        return np.concatenate((skin_move, press_moves.ravel()))

    x0 = np.concatenate([g] + [u[idx] for u in presses_u])
    fit = least_squares.levenberg_marquardt(
        residual, x0, iterations=6 * iterations, normal_equations=normal_equations,
        limit=limit, most_steps=iterations, patience=6)
    return fit.x[:ng], presses_of(fit.x), fit.cost
