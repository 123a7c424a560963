"""
A skin's own counts-to-force curve, fitted from presses of known normal force.

The assumed :class:`fsr.FsrModel` is only a guess at a real skin's FSR film, divider and ADC. A
press of known normal force ``F`` tells the sum of the curve over the taxels it loads:
``sum_i gain_i * g(c_i) = F * fill_factor**2`` (the pipeline divides the sensed sum by
``fill_factor**2``). The curve ``g`` is piecewise linear in the counts above baseline, a sum of
clipped ramps ``h_k(c) = clip(c - knot_k, 0, knot_{k+1} - knot_k)`` with non-negative weights
(the slope of each piece), so any non-decreasing curve can be fitted and no fit can decrease;
the weights come from non-negative least squares. Above the last knot the last slope goes on.

The fit covers the counts the presses reached: the knots sit at quantiles of the presses' peak
counts. It is refused, with a reason in newtons, when there are too few presses, when their
forces do not span a range (the curve would be a guess outside one point), when a heavier press
read fewer counts than a lighter one (the presses disagree with any increasing curve: a force was
wrong or a press missed the skin) or when the fit leaves large residuals. A piece that the fit
leaves flat keeps a negligible slope, so the curve always rises strictly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

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


@dataclass(frozen=True)
class ForceCurve:
    """Sensed taxel force (N) at the knots (counts above baseline); both start at 0."""

    counts: tuple
    force_n: tuple

    def __post_init__(self):
        """Reject curves that are not increasing from (0, 0)."""
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
        if (np.diff(f) <= 0).any():
            raise ValueError('force curve forces must increase (the curve must be monotone)')
        object.__setattr__(self, 'counts', tuple(float(v) for v in c))
        object.__setattr__(self, 'force_n', tuple(float(v) for v in f))

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])
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


def _basis(counts: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Return the clipped ramps of the counts, one column per piece (last one unclipped)."""
    lo = knots[:-1]
    width = np.diff(knots)
    ramps = np.clip(counts[:, None] - lo[None, :], 0.0, None)
    ramps[:, :-1] = np.minimum(ramps[:, :-1], width[None, :-1])
    return ramps


def fit_force_curve(press_counts: Sequence[np.ndarray], press_gains: Sequence[np.ndarray],
                    sensed_n: Sequence[float], known_n: Sequence[float]) -> CurveFit:
    """
    Fit one layer's curve; raise ValueError with the reason when it must be refused.

    ``press_counts[k]`` holds the counts above baseline of the taxels press k loaded (above
    threshold), ``press_gains[k]`` their gains, ``sensed_n[k]`` the force those taxels must
    sum to (known force times fill_factor**2) and ``known_n[k]`` the known force for messages.
    """
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
                                target[keep], known[keep]).curve
        fitted = np.array([float(np.dot(g, curve.counts_to_force(c)))
                           for c, g in zip(press_counts, press_gains)]) * known / target
        return CurveFit(curve, tuple(fitted.tolist()), tuple((fitted - known).tolist()),
                        int(keep.sum()))
    _check_monotone(press_counts, press_gains, known)
    pooled = np.concatenate([np.asarray(c, dtype=np.float64) for c in press_counts])
    inner = np.unique(np.concatenate((np.quantile(peaks, _PEAK_QUANTILES),
                                      np.quantile(pooled, _POOLED_QUANTILES))))
    inner = inner[inner > 0]
    # Fewer pieces than presses: the presses pin every piece down.
    pieces = max(3, n - 2)
    if inner.size > pieces:
        inner = inner[np.round(np.linspace(0, inner.size - 1, pieces)).astype(int)]
    knots = np.concatenate(([0.0], inner))
    # Relative errors: a light press counts as much as a heavy one.
    row_weight = 1.0 / target
    design = np.stack([
        (np.asarray(g, dtype=np.float64)[:, None]
         * _basis(np.asarray(c, dtype=np.float64), knots)).sum(axis=0)
        for c, g in zip(press_counts, press_gains)])
    # Scale the columns so that NNLS weighs every piece alike.
    scale = np.maximum(design.max(axis=0), 1e-12)
    slopes = _nnls(design / scale * row_weight[:, None], target * row_weight) / scale
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
    force_at_knots = np.concatenate(([0.0], np.cumsum(slopes * np.diff(knots))))
    curve = ForceCurve(tuple(knots), tuple(force_at_knots))
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), n)
