"""
A skin's own counts-to-force curve, fitted from presses of known normal force.

The assumed :class:`fsr.FsrModel` is only a guess at a real skin's FSR film, divider and ADC. A
press of known normal force ``F`` tells the sum of the curve over the taxels it loads:
``sum_i gain_i * g(c_i) = F * fill_factor**2`` (the pipeline divides the sensed sum by
``fill_factor**2``). The curve is ``g(c) = sum_k w_k h_k(u(c))``, where ``u`` is the force the
assumed model gives the counts (without its saturation) and ``h_k(u) = clip(u - knot_k, 0,
knot_{k+1} - knot_k)`` are clipped ramps (the last one unclipped). The weights, the slopes of
the pieces, come from non-negative least squares, so no fit can decrease. The fit corrects the
assumed curve: where the presses say little, at the rim of a contact, the assumed shape stays,
and a skin that matches the assumption keeps it.

The fit covers the counts the presses reached: the knots sit at quantiles of the presses' peak
and taxel forces, and the curve is stored as knots in counts up to the highest count pressed;
past it the last slope goes on. It is refused, with a reason in newtons, when there are too few
presses, when their forces do not span a range (the curve would be a guess outside one point),
when a heavier press read fewer counts than a lighter one (the presses disagree with any
increasing curve: a force was wrong or a press missed the skin) or when the fit leaves large
residuals. A flat first piece is merged into the next; other flat pieces keep a negligible
slope.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .fsr import FsrModel

__all__ = ['ForceCurve', 'CurveFit', 'fit_force_curve', 'MIN_PRESSES', 'MIN_FORCE_SPAN']

MIN_PRESSES = 6
# The largest known force must be this many times the smallest: a range, not a point.
MIN_FORCE_SPAN = 3.0
MAX_RELATIVE_RESIDUAL = 0.25
# A press this many times heavier than another must read more counts.
MONOTONE_MARGIN = 1.5
# Presses whose peak counts reach this share of the highest peak may be saturated.
SATURATION_SHARE = 0.99
_PEAK_QUANTILES = (0.0, 0.5, 1.0)
_POOLED_QUANTILES = (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 0.9)
FLAT_SLOPE = 1e-6
_GRID = 129


@dataclass(frozen=True)
class ForceCurve:
    """Sensed taxel force (N) at the knots (counts above baseline): from (0, 0), never falling."""

    counts: tuple
    force_n: tuple

    def __post_init__(self):
        """Reject curves that fall or do not start at (0, 0)."""
        c = np.asarray(self.counts, dtype=np.float64)
        f = np.asarray(self.force_n, dtype=np.float64)
        if c.ndim != 1 or c.shape != f.shape or c.size < 2:
            raise ValueError('a force curve needs two or more knots of counts and force')
        if not (np.isfinite(c).all() and np.isfinite(f).all()):
            raise ValueError('force curve knots must be finite')
        if c[0] != 0 or f[0] != 0:
            raise ValueError('a force curve starts at 0 counts, 0 N')
        if (np.diff(c) <= 0).any():
            raise ValueError('force curve counts must increase')
        if (np.diff(f) < 0).any() or f[-1] <= 0:
            raise ValueError('force curve forces must not decrease (the curve must be monotone)')
        object.__setattr__(self, 'counts', tuple(float(v) for v in c))
        object.__setattr__(self, 'force_n', tuple(float(v) for v in f))

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])  # 0 past a saturation
        return np.where(c <= knots[-1], np.interp(c, knots, force),
                        force[-1] + slope * (c - knots[-1]))

    def to_dict(self) -> dict:
        """Return the knots as plain lists (for YAML)."""
        return {'counts': list(self.counts), 'force_n': list(self.force_n)}

    @classmethod
    def from_dict(cls, doc) -> 'ForceCurve':
        """Build a curve from :meth:`to_dict` output."""
        if not isinstance(doc, dict) or set(doc) != {'counts', 'force_n'}:
            raise ValueError('a force curve is a mapping with counts and force_n lists')
        for key in ('counts', 'force_n'):
            values = doc[key]
            if not isinstance(values, list) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                raise ValueError(f'force curve {key} must be a list of numbers')
        return cls(tuple(doc['counts']), tuple(doc['force_n']))


@dataclass(frozen=True)
class CurveFit:
    """
    A fitted curve and, per press, the force it gives back and its residual (N).

    ``used`` presses shaped the curve; the others saturated the layer.
    """

    curve: ForceCurve
    fitted_n: tuple
    residuals_n: tuple
    used: int


def _check_monotone(press_counts, press_gains, known: np.ndarray) -> None:
    """Refuse presses where clearly more force read fewer counts."""
    total = np.array([float(np.dot(g, c)) for c, g in zip(press_counts, press_gains)])
    # Near saturation the counts hardly grow, and places differ a little: only a clear
    # difference in force must show.
    clash = (known[None, :] > MONOTONE_MARGIN * known[:, None]) & (total[None, :] < total[:, None])
    if clash.any():
        i, j = (int(v[0]) for v in np.nonzero(clash))
        raise ValueError(
            f'the presses disagree with an increasing force curve: {known[j]:.2f} N read '
            f'fewer counts than {known[i]:.2f} N; check the known forces and their order, '
            'and press squarely on the skin')


def _nnls(a: np.ndarray, b: np.ndarray, max_rounds: int = 100) -> np.ndarray:
    """Return x >= 0 minimising |a x - b| (Lawson and Hanson's active set; a has few columns)."""
    x = np.zeros(a.shape[1])
    free = np.zeros(a.shape[1], dtype=bool)
    for _ in range(max_rounds):
        gradient = a.T @ (b - a @ x)
        candidates = np.flatnonzero(~free & (gradient > 1e-12 * max(1.0, np.abs(b).max())))
        if candidates.size == 0:
            break
        free[candidates[np.argmax(gradient[candidates])]] = True
        while True:
            z = np.zeros_like(x)
            z[free] = np.linalg.lstsq(a[:, free], b, rcond=None)[0]
            if (z[free] > 0).all():
                x = z
                break
            # Step towards z until a free weight reaches 0, and hold that one at 0.
            going = free & (z <= 0)
            step = np.min(x[going] / np.maximum(x[going] - z[going], 1e-300))
            x = x + step * (z - x)
            free &= x > 1e-15
            x[~free] = 0.0
    return x


def _basis(u: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Return the clipped ramps of u, one column per piece (last one unclipped)."""
    lo = knots[:-1]
    width = np.diff(knots)
    ramps = np.clip(u[:, None] - lo[None, :], 0.0, None)
    ramps[:, :-1] = np.minimum(ramps[:, :-1], width[None, :-1])
    return ramps


def fit_force_curve(press_counts: Sequence[np.ndarray], press_gains: Sequence[np.ndarray],
                    sensed_n: Sequence[float], known_n: Sequence[float],
                    assumed: FsrModel = None, full_scale: int = None) -> CurveFit:
    """
    Fit one layer's curve; raise ValueError with the reason when it must be refused.

    ``press_counts[k]`` holds the counts above baseline of the taxels press k loaded (above
    threshold), ``press_gains[k]`` their gains, ``sensed_n[k]`` the force those taxels must
    sum to (known force times fill_factor**2) and ``known_n[k]`` the known force for messages.
    The curve corrects ``assumed`` (default :class:`FsrModel`): it is a monotone piecewise
    linear function of the assumed force, which keeps the assumed shape where the presses say
    little (a contact's rim) and is the identity on a skin that matches the assumption.
    """
    assumed = assumed or FsrModel()
    full_scale = assumed.full_scale if full_scale is None else int(full_scale)
    known = np.asarray(known_n, dtype=np.float64)
    target = np.asarray(sensed_n, dtype=np.float64)
    n = len(press_counts)
    if n < MIN_PRESSES:
        raise ValueError(f'{n} press{"es" if n != 1 else ""} of known force; the force curve '
                         f'needs at least {MIN_PRESSES}')
    if not (np.isfinite(known).all() and (known > 0).all()):
        raise ValueError('every known force must be a positive number of newtons')
    if known.max() < MIN_FORCE_SPAN * known.min():
        raise ValueError(f'the presses span only {known.min():.2f} to {known.max():.2f} N; '
                         f'press over a range, the largest at least {MIN_FORCE_SPAN:g} times '
                         'the smallest')
    empty = [k for k, c in enumerate(press_counts) if len(c) == 0]
    if empty:
        raise ValueError(f'press {empty[0] + 1} ({known[empty[0]]:.2f} N) loaded no taxel')
    peaks = np.array([float(np.max(c)) for c in press_counts])
    # A saturated layer reads the same peak under more force: those presses say nothing about
    # the curve, which is then fitted over the presses below saturation.
    capped = peaks >= SATURATION_SHARE * peaks.max()
    if capped.sum() >= 2 and known[capped].max() > 1.2 * known[capped].min():
        keep = ~capped
        if keep.sum() < MIN_PRESSES or known[keep].max() < MIN_FORCE_SPAN * known[keep].min():
            raise ValueError(f'the layer saturates from {known[capped].min():.2f} N on; press '
                             f'more lightly, {MIN_PRESSES} or more presses below that, the '
                             f'largest at least {MIN_FORCE_SPAN:g} times the smallest')
        curve = fit_force_curve([c for c, k in zip(press_counts, keep) if k],
                                [g for g, k in zip(press_gains, keep) if k],
                                target[keep], known[keep], assumed, full_scale).curve
        fitted = np.array([float(np.dot(g, curve.counts_to_force(c)))
                           for c, g in zip(press_counts, press_gains)]) * known / target
        return CurveFit(curve, tuple(fitted.tolist()), tuple((fitted - known).tolist()),
                        int(keep.sum()))
    _check_monotone(press_counts, press_gains, known)
    forces = [assumed.counts_to_force(np.asarray(c, dtype=np.float64), saturate=False)
              for c in press_counts]
    peaks_f = np.array([float(np.max(f)) for f in forces])
    pooled = np.concatenate(forces)
    inner = np.unique(np.concatenate((np.quantile(peaks_f, _PEAK_QUANTILES),
                                      np.quantile(pooled, _POOLED_QUANTILES))))
    inner = inner[inner > 0]
    # Fewer pieces than presses: the presses pin every piece down.
    pieces = max(3, n - 2)
    if inner.size > pieces:
        inner = inner[np.round(np.linspace(0, inner.size - 1, pieces)).astype(int)]
    knots = np.concatenate(([0.0], inner))
    # Relative errors: a light press counts as much as a heavy one.
    row_weight = 1.0 / target
    while True:
        design = np.stack([
            (np.asarray(g, dtype=np.float64)[:, None] * _basis(f, knots)).sum(axis=0)
            for f, g in zip(forces, press_gains)])
        # Scale the columns so that NNLS weighs every piece alike.
        scale = np.maximum(design.max(axis=0), 1e-12)
        slopes = _nnls(design / scale * row_weight[:, None], target * row_weight) / scale
        # A flat first piece would zero the rim of every imprint, which the shift between the
        # layers is measured on: merge it into the next until the curve rises from 0.
        if slopes[0] > FLAT_SLOPE * slopes.max() or knots.size <= 2:
            break
        knots = np.delete(knots, 1)
    if not (slopes > 0).any():
        raise ValueError('no increasing force curve fits the presses; check the known forces')
    # A flat piece (an FSR that barely conducts reads counts but little force) keeps a slope
    # too small to matter, so that the curve still rises strictly and can be stored.
    slopes = np.maximum(slopes, FLAT_SLOPE * slopes.max())
    fitted_sensed = design @ slopes
    fitted = fitted_sensed * known / target
    residuals = fitted - known
    worst = int(np.argmax(np.abs(residuals) / known))
    if abs(residuals[worst]) > MAX_RELATIVE_RESIDUAL * known[worst]:
        raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                         f'{fitted[worst]:.2f} N; the presses disagree with one curve '
                         '(a wrong known force, or two things touching?)')
    # Stored in counts: the correction of the assumed force, sampled over the counts pressed;
    # past them the curve goes on with its last slope.
    grid = np.linspace(0.0, min(float(peaks.max()), full_scale), _GRID)
    corrected = _basis(assumed.counts_to_force(grid, saturate=False), knots) @ slopes
    curve = ForceCurve(tuple(grid), tuple(np.maximum.accumulate(corrected)))
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), n)
