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

Every taxel is evidence. A taxel whose film saturated (its counts at the layer's ceiling, which
the heaviest presses pile up at) is censored: it tells a lower bound on its force, and the
imprint's unsaturated rim tells the rest (:mod:`imprint`: a bump fitted to the rim, whose width
the fit chooses with the curve). The sum of a press stays linear in the slopes, so censored and
free taxels are fitted together. Whether the layer is censored at all, and with which bump, is
chosen by the presses: the choice that fits them best.

The curve is stored as knots in counts up to the highest count pressed, with the censoring
ceiling and the bump's width; past the knots the last slope goes on. The fit is refused, with
a reason in newtons, when there are too few presses, when their forces do not span a range (the
curve would be a guess outside one point), when a press loaded no taxel, or when no curve fits
the presses within ``MAX_RELATIVE_RESIDUAL`` (the refusal names the press furthest off: a
wrong known force, or a press that missed the skin). A flat first piece is merged into the
next; other flat pieces keep a negligible slope.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .fsr import FsrModel
from .imprint import bump, censored_force

__all__ = ['ForceCurve', 'CurveFit', 'check_known_forces', 'fit_force_curve', 'MIN_PRESSES',
           'MIN_FORCE_SPAN']

MIN_PRESSES = 6
# The largest known force must be this many times the smallest: a range, not a point.
MIN_FORCE_SPAN = 3.0
MAX_RELATIVE_RESIDUAL = 0.25
# Readings within this share of full scale of the highest one are at the ceiling (noise).
CENSOR_BAND = 0.02
_SPREADS = 16
# A censored fit is taken over an uncensored one when its relative misfit is this much smaller.
CENSOR_GAIN = 0.8
_PEAK_QUANTILES = (0.0, 0.5, 1.0)
_POOLED_QUANTILES = (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 0.9)
FLAT_SLOPE = 1e-6
_GRID = 129
_KEYS = ('counts', 'force_n', 'censor_counts', 'spread_taxels', 'bump_power')
_POWERS = (2.0, 3.0, 4.0, 6.0)


@dataclass(frozen=True)
class ForceCurve:
    """
    Sensed taxel force (N) at the knots (counts above baseline): from (0, 0), never falling.

    ``censor_counts`` > 0: taxels reading that many counts or more saturated; their force is
    filled in by a bump of ``spread_taxels`` and ``bump_power`` (:func:`imprint.censored_force`).
    0: none.
    """

    counts: tuple
    force_n: tuple
    censor_counts: float = 0.0
    spread_taxels: float = 0.0
    bump_power: float = 2.0

    def __post_init__(self):
        """Reject curves that fall or do not start at (0, 0), and a censoring without bump."""
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
        for name in ('censor_counts', 'spread_taxels'):
            v = getattr(self, name)
            if isinstance(v, bool) or not (np.isfinite(v) and v >= 0):
                raise ValueError(f'force curve {name} must be a non-negative number, got {v!r}')
        if not (isinstance(self.bump_power, (int, float)) and 1.0 <= self.bump_power <= 16.0):
            raise ValueError(f'force curve bump_power must be in [1, 16], got {self.bump_power!r}')
        if (self.censor_counts > 0) != (self.spread_taxels > 0):
            raise ValueError('a censored force curve needs both censor_counts and spread_taxels')
        object.__setattr__(self, 'counts', tuple(float(v) for v in c))
        object.__setattr__(self, 'force_n', tuple(float(v) for v in f))
        object.__setattr__(self, 'censor_counts', float(self.censor_counts))
        object.__setattr__(self, 'spread_taxels', float(self.spread_taxels))
        object.__setattr__(self, 'bump_power', float(self.bump_power))

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])  # 0 past a saturation
        return np.where(c <= knots[-1], np.interp(c, knots, force),
                        force[-1] + slope * (c - knots[-1]))

    def imprint_force(self, counts: np.ndarray, force: np.ndarray) -> float:
        """Return one imprint's summed force (2-D maps of counts and taxel forces), censored."""
        return censored_force(counts, force, self.censor_counts, self.spread_taxels,
                              self.bump_power)

    def to_dict(self) -> dict:
        """Return the knots (and any censoring) as plain values (for YAML)."""
        out = {'counts': list(self.counts), 'force_n': list(self.force_n)}
        if self.censor_counts:
            out.update(censor_counts=self.censor_counts, spread_taxels=self.spread_taxels,
                       bump_power=self.bump_power)
        return out

    @classmethod
    def from_dict(cls, doc) -> 'ForceCurve':
        """Build a curve from :meth:`to_dict` output."""
        if not isinstance(doc, dict) or not {'counts', 'force_n'} <= set(doc) <= set(_KEYS):
            raise ValueError('a force curve is a mapping with counts and force_n lists '
                             '(and censor_counts, spread_taxels, bump_power)')
        for key in ('counts', 'force_n'):
            values = doc[key]
            if not isinstance(values, list) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                raise ValueError(f'force curve {key} must be a list of numbers')
        extra = {k: doc[k] for k in _KEYS[2:] if k in doc}
        for k, v in extra.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f'force curve {k} must be a number, got {v!r}')
        return cls(tuple(doc['counts']), tuple(doc['force_n']), **extra)


@dataclass(frozen=True)
class CurveFit:
    """
    A fitted curve and, per press, the force it gives back and its residual (N).

    ``censored`` presses had saturated taxels, filled in from their rims.
    """

    curve: ForceCurve
    fitted_n: tuple
    residuals_n: tuple
    censored: int


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


@dataclass(frozen=True)
class _Press:
    """One press on one layer: its loaded taxels' counts, gains, assumed force and bump."""

    counts: np.ndarray
    gains: np.ndarray
    assumed_n: np.ndarray
    map_counts: np.ndarray

    def bump(self, shape: tuple) -> np.ndarray:
        return bump(self.map_counts, *shape)[self.map_counts > 0]


def _presses(press_counts, press_gains, assumed: FsrModel) -> list:
    out = []
    for k, (c, g) in enumerate(zip(press_counts, press_gains)):
        c = np.atleast_2d(np.asarray(c, dtype=np.float64))
        g = np.atleast_2d(np.asarray(g, dtype=np.float64))
        if c.shape != g.shape:
            raise ValueError(f'press {k + 1}: counts {c.shape} and gains {g.shape} differ')
        loaded = c > 0
        out.append(_Press(c[loaded], g[loaded],
                          assumed.counts_to_force(c[loaded], saturate=False), c))
    return out


def _row(press: _Press, knots: np.ndarray, censor: float, shape: tuple,
         slopes: np.ndarray = None) -> np.ndarray:
    """
    Return what each piece's slope adds to the press's sensed sum (linear in the slopes).

    A censored taxel adds the bump fitted to the free taxels, or its own reading where that is
    larger under ``slopes`` (all take the bump when no slopes are given yet).
    """
    taxels = press.gains[:, None] * _basis(press.assumed_n, knots)
    censored = press.counts >= censor if censor > 0 else np.zeros(press.counts.size, bool)
    if not censored.any():
        return taxels.sum(axis=0)
    free = ~censored
    phi = press.bump(shape)
    weight = float(phi[free] @ phi[free])
    if not weight > 0:
        return taxels.sum(axis=0)
    height = phi[free] @ taxels[free] / weight
    filled = phi[censored][:, None] * height[None, :]
    own = taxels[censored]
    if slopes is not None:
        filled = np.where((filled @ slopes > own @ slopes)[:, None], filled, own)
    return taxels[free].sum(axis=0) + filled.sum(axis=0)


def _knots(presses: list, censor: float, n: int) -> np.ndarray:
    """Return knots at quantiles of the free taxels' assumed forces and the presses' peaks."""
    forces = [p.assumed_n[p.counts < censor] if censor > 0 else p.assumed_n for p in presses]
    forces = [f for f in forces if f.size] or [p.assumed_n for p in presses]
    peaks = np.array([float(np.max(f)) for f in forces])
    inner = np.unique(np.concatenate((np.quantile(peaks, _PEAK_QUANTILES),
                                      np.quantile(np.concatenate(forces), _POOLED_QUANTILES))))
    inner = inner[inner > 0]
    # Fewer pieces than presses: the presses pin every piece down.
    pieces = max(3, n - 2)
    if inner.size > pieces:
        inner = inner[np.round(np.linspace(0, inner.size - 1, pieces)).astype(int)]
    return np.concatenate(([0.0], inner))


def _fit(presses: list, target: np.ndarray, censor: float, shape: tuple):
    """Return (knots, slopes, fitted sensed sums) of one censoring choice, or None."""
    knots = _knots(presses, censor, len(presses))
    # Relative errors: a light press counts as much as a heavy one.
    row_weight = 1.0 / target
    while True:
        slopes = None
        for _ in range(3):  # the censored taxels that take the bump depend on the slopes
            design = np.stack([_row(p, knots, censor, shape, slopes) for p in presses])
            # Scale the columns so that NNLS weighs every piece alike.
            scale = np.maximum(design.max(axis=0), 1e-12)
            slopes = _nnls(design / scale * row_weight[:, None], target * row_weight) / scale
        # A flat first piece would zero the rim of every imprint, which the shift between the
        # layers is measured on: merge it into the next until the curve rises from 0.
        if slopes[0] > FLAT_SLOPE * slopes.max() or knots.size <= 2:
            break
        knots = np.delete(knots, 1)
    if not (slopes > 0).any():
        return None
    # A flat piece (an FSR that barely conducts reads counts but little force) keeps a slope
    # too small to matter, so that the curve still rises strictly and can be stored.
    slopes = np.maximum(slopes, FLAT_SLOPE * slopes.max())
    design = np.stack([_row(p, knots, censor, shape, slopes) for p in presses])
    return knots, slopes, design @ slopes


def _censoring_choices(presses: list, full_scale: int, shape: tuple) -> list:
    """
    Return (censor counts, (bump spread, power)) choices: none, and a ceiling presses pile up at.

    The ceiling is the highest count read less a band for noise; it is a saturation only when
    two or more presses reach it (one press's peak is just the highest reading).
    """
    choices = [(0.0, (0.0, 2.0))]
    ceiling = max(float(p.counts.max()) for p in presses) - CENSOR_BAND * full_scale
    if sum(bool((p.counts >= ceiling).any()) for p in presses) >= 2:
        widest = max(1.0, 0.25 * max(shape))
        choices += [(ceiling, (float(s), p)) for p in _POWERS
                    for s in np.geomspace(0.3, widest, _SPREADS)]
    return choices


def check_known_forces(known_n) -> None:
    """Raise ValueError when these known forces cannot make a curve, whatever the presses."""
    known = np.asarray(known_n, dtype=np.float64).ravel()
    n = known.size
    if n < MIN_PRESSES:
        raise ValueError(f'{n} press{"es" if n != 1 else ""} of known force; the force curve '
                         f'needs at least {MIN_PRESSES}')
    if not (np.isfinite(known).all() and (known > 0).all()):
        raise ValueError('every known force must be a positive number of newtons')
    if known.max() < MIN_FORCE_SPAN * known.min():
        raise ValueError(f'the presses span only {known.min():.2f} to {known.max():.2f} N; '
                         f'press over a range, the largest at least {MIN_FORCE_SPAN:g} times '
                         'the smallest')


def fit_force_curve(press_counts: Sequence[np.ndarray], press_gains: Sequence[np.ndarray],
                    sensed_n: Sequence[float], known_n: Sequence[float],
                    assumed: FsrModel = None, full_scale: int = None) -> CurveFit:
    """
    Fit one layer's curve; raise ValueError with the reason when it must be refused.

    ``press_counts[k]`` is press k's map of counts above baseline on the layer (0 where
    untouched; a 1-D array of loaded taxels has no geometry and is never censored),
    ``press_gains[k]`` the gains there, ``sensed_n[k]`` the force those taxels must sum to
    (known force times fill_factor**2) and ``known_n[k]`` the known force for messages. The
    curve corrects ``assumed`` (default :class:`FsrModel`): it is a monotone piecewise linear
    function of the assumed force, which keeps the assumed shape where the presses say little
    (a contact's rim) and is the identity on a skin that matches the assumption.
    """
    assumed = assumed or FsrModel()
    full_scale = assumed.full_scale if full_scale is None else int(full_scale)
    known = np.asarray(known_n, dtype=np.float64)
    target = np.asarray(sensed_n, dtype=np.float64)
    check_known_forces(known)
    presses = _presses(press_counts, press_gains, assumed)
    empty = [k for k, p in enumerate(presses) if p.counts.size == 0]
    if empty:
        raise ValueError(f'press {empty[0] + 1} ({known[empty[0]]:.2f} N) loaded no taxel')
    shape = presses[0].map_counts.shape
    best = None
    for censor, bump_shape in _censoring_choices(presses, full_scale, shape):
        fit = _fit(presses, target, censor, bump_shape)
        if fit is None:
            continue
        misfit = float(np.sqrt(np.mean((fit[2] / target - 1.0) ** 2)))
        # Censoring adds a parameter (the bump): it must earn its keep.
        if censor:
            misfit /= CENSOR_GAIN
        if best is None or misfit < best[0]:
            best = (misfit, censor, bump_shape, fit)
    if best is None:
        raise ValueError('no increasing force curve fits the presses; check the known forces')
    _, censor, bump_shape, (knots, slopes, fitted_sensed) = best
    fitted = fitted_sensed * known / target
    residuals = fitted - known
    worst = int(np.argmax(np.abs(residuals) / known))
    if abs(residuals[worst]) > MAX_RELATIVE_RESIDUAL * known[worst]:
        raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                         f'{fitted[worst]:.2f} N; the presses disagree with one curve '
                         '(a wrong known force, or two things touching?)')
    # Stored in counts: the correction of the assumed force, sampled over the counts pressed;
    # past them the curve goes on with its last slope.
    top = max(float(p.counts.max()) for p in presses)
    grid = np.linspace(0.0, min(top, full_scale), _GRID)
    corrected = _basis(assumed.counts_to_force(grid, saturate=False), knots) @ slopes
    curve = ForceCurve(tuple(grid), tuple(np.maximum.accumulate(corrected)), censor,
                       *bump_shape)
    censored = sum(bool((p.counts >= censor).any()) for p in presses) if censor else 0
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), censored)
