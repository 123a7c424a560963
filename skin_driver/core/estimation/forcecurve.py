"""
A skin's own counts-to-force curve, fitted from presses of known normal force.

The assumed :class:`fsr.FsrModel` is only a guess at a real skin's FSR film, divider and ADC. A
press of known normal force ``F`` tells the sum of the curve over the taxels it loads:
``sum_i gain_i * g(c_i) + rim_load = F * fill_factor**2`` (the pipeline divides the sensed sum by
``fill_factor**2``).

The curve is ``g(c) = scale * u(c) ** exponent + activation`` on a conducting taxel, where
``u`` is the force the assumed model gives the counts less its activation force (without its
saturation). An FSR's conductance grows as a power of its force past the force at which it
starts to conduct, and the divider and the ADC turn conductance into counts alike on every
skin, so the force of one such film is the force the assumed film gives the same counts raised
to a power and scaled, whatever the film's resistances, exponent and series resistor: three
numbers to learn, which a few presses pin down over the whole range. A curve of many free
pieces (the previous fit) bent to the calibration presses and missed the presses of other
indenters; the power keeps the shape of the law between the presses and past them. It is
monotone by construction.

The rim load: the rim of every imprint carries load that no taxel reads, below the touch
threshold or below the pressure at which a film turns on. For an imprint of a given shape, the
part of its load under a pressure is about that pressure times the imprint's area, whatever the
force: a constant per imprint, so one more non-negative number of the fit, added to every
imprint's sum at run time (:meth:`ForceCurve.imprint_force`).

Every taxel is evidence. A taxel whose film saturated (its counts at the layer's ceiling, which
the heaviest presses pile up at) is censored: it tells a lower bound on its force, and the
imprint's unsaturated rim tells the rest (:mod:`imprint`: a bump fitted to the rim, whose width
the fit chooses with the curve). The sum of a press stays linear in the scale and the rim load,
so censored and free taxels are fitted together (non-negative least squares of relative
errors, for each exponent of a search in log steps). Whether the layer is censored at all, and
with which bump, is chosen by the presses: the choice that fits them best.

The curve is stored as knots in counts up to the highest count pressed, with the censoring
ceiling, the bump's width and the rim load; past the knots the last slope goes on. The fit is
refused, with a reason in newtons, when there are too few presses, when their forces do not
span a range (the curve would be a guess outside one point), when a press loaded no taxel, or
when no curve fits the presses within ``MAX_RELATIVE_RESIDUAL`` (the refusal names the press
furthest off: a wrong known force, or a press that missed the skin).
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
# The exponents searched: a coarse grid in log steps, then finer grids around the best.
_EXPONENTS = np.geomspace(0.2, 5.0, 15)
_REFINE_STEPS = 7
_REFINE_ROUNDS = 6
_GRID = 129
_KEYS = ('counts', 'force_n', 'censor_counts', 'spread_taxels', 'bump_power', 'rim_load_n')
_POWERS = (2.0, 3.0, 4.0, 6.0)


@dataclass(frozen=True)
class ForceCurve:
    """
    Sensed taxel force (N) at the knots (counts above baseline): from (0, 0), never falling.

    ``censor_counts`` > 0: taxels reading that many counts or more saturated; their force is
    filled in by a bump of ``spread_taxels`` and ``bump_power`` (:func:`imprint.censored_force`).
    0: none. ``rim_load_n``: the sensed force at the rim of every imprint that no taxel reads,
    added to each imprint's sum (module docstring).
    """

    counts: tuple
    force_n: tuple
    censor_counts: float = 0.0
    spread_taxels: float = 0.0
    bump_power: float = 2.0
    rim_load_n: float = 0.0

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
        for name in ('censor_counts', 'spread_taxels', 'rim_load_n'):
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
        object.__setattr__(self, 'rim_load_n', float(self.rim_load_n))

    def adjusts(self, counts: np.ndarray) -> bool:
        """Return whether an imprint of these counts sums to more than its taxels' forces."""
        saturated = bool(self.censor_counts) and np.max(counts) >= self.censor_counts
        return bool(self.rim_load_n) or bool(saturated)

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])  # 0 past a saturation
        return np.where(c <= knots[-1], np.interp(c, knots, force),
                        force[-1] + slope * (c - knots[-1]))

    def imprint_force(self, counts: np.ndarray, force: np.ndarray) -> float:
        """
        Return one imprint's summed force (2-D maps of counts and taxel forces), censored.

        The rim load is added, but never more than the imprint reads: a faint imprint (a few
        taxels over the threshold, or noise) is no press, and must not become one.
        """
        read = censored_force(counts, force, self.censor_counts, self.spread_taxels,
                              self.bump_power)
        return read + min(self.rim_load_n, read)

    def to_dict(self) -> dict:
        """Return the knots (and any censoring) as plain values (for YAML)."""
        out = {'counts': list(self.counts), 'force_n': list(self.force_n)}
        if self.censor_counts:
            out.update(censor_counts=self.censor_counts, spread_taxels=self.spread_taxels,
                       bump_power=self.bump_power)
        if self.rim_load_n:
            out['rim_load_n'] = self.rim_load_n
        return out

    @classmethod
    def from_dict(cls, doc) -> 'ForceCurve':
        """Build a curve from :meth:`to_dict` output."""
        if not isinstance(doc, dict) or not {'counts', 'force_n'} <= set(doc) <= set(_KEYS):
            raise ValueError('a force curve is a mapping with counts and force_n lists '
                             '(and censor_counts, spread_taxels, bump_power, rim_load_n)')
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


@dataclass(frozen=True)
class _Press:
    """One press on one layer: its loaded taxels' counts, gains, assumed force and bump."""

    counts: np.ndarray
    gains: np.ndarray
    assumed_n: np.ndarray
    map_counts: np.ndarray
    bumps: dict

    def bump(self, shape: tuple) -> np.ndarray:
        """Return the unit bump of this shape over the loaded taxels (kept: asked often)."""
        if shape not in self.bumps:
            self.bumps[shape] = bump(self.map_counts, *shape)[self.map_counts > 0]
        return self.bumps[shape]


def _presses(press_counts, press_gains, assumed: FsrModel) -> list:
    out = []
    for k, (c, g) in enumerate(zip(press_counts, press_gains)):
        c = np.atleast_2d(np.asarray(c, dtype=np.float64))
        g = np.atleast_2d(np.asarray(g, dtype=np.float64))
        if c.shape != g.shape:
            raise ValueError(f'press {k + 1}: counts {c.shape} and gains {g.shape} differ')
        loaded = c > 0
        out.append(_Press(c[loaded], g[loaded], _power_part(assumed, c[loaded]), c, {}))
    return out


def _power_part(assumed: FsrModel, counts: np.ndarray) -> np.ndarray:
    """Return the assumed force of the counts less its activation: the film's power law."""
    return np.maximum(assumed.counts_to_force(counts, saturate=False) - assumed.activation_n,
                      0.0)


def _read(press: _Press, exponent: float, censor: float, shape: tuple) -> float:
    """
    Return the press's sensed sum at unit scale (it is linear in the scale).

    A censored taxel adds the bump fitted to the free taxels, or its own reading where that is
    larger (both grow with the scale alike, so which is larger does not depend on it).
    """
    taxels = press.gains * press.assumed_n ** exponent
    censored = press.counts >= censor if censor > 0 else np.zeros(press.counts.size, bool)
    if not censored.any():
        return float(taxels.sum())
    free = ~censored
    phi = press.bump(shape)
    weight = float(phi[free] @ phi[free])
    if not weight > 0:
        return float(taxels.sum())
    height = float(phi[free] @ taxels[free]) / weight
    return float(taxels[free].sum() + np.maximum(phi[censored] * height, taxels[censored]).sum())


def _fit(presses: list, target: np.ndarray, censor: float, shape: tuple, exponent: float):
    """
    Return (scale, activation, rim load, fitted sensed sums) of one censoring and exponent.

    The sum of a press is linear in the three: the power of its taxels' forces, their number
    (each conducting taxel carries the activation force) and the imprint's rim load.
    """
    read = np.array([_read(p, exponent, censor, shape) for p in presses])
    design = np.stack((read, [p.counts.size for p in presses], np.ones(read.size)), axis=1)
    # Relative errors: a light press counts as much as a heavy one. The columns are scaled so
    # that the non-negative least squares weighs them alike.
    row_weight = 1.0 / target
    norm = np.maximum(design.max(axis=0), 1e-300)
    scale, activation, rim = _nnls(design / norm * row_weight[:, None],
                                   target * row_weight) / norm
    taxels = design[:, :2] @ (scale, activation)
    return scale, activation, rim, taxels + np.minimum(rim, taxels)


def _misfit(fit, target: np.ndarray) -> float:
    return float(np.sqrt(np.mean((fit[3] / target - 1.0) ** 2)))


def _best_exponent(presses: list, target: np.ndarray, censor: float, shape: tuple):
    """Return (misfit, exponent, fit) of the exponent that fits best: a grid, then finer ones."""
    grid = _EXPONENTS
    best = None
    for _ in range(_REFINE_ROUNDS + 1):
        for exponent in grid:
            fit = _fit(presses, target, censor, shape, float(exponent))
            misfit = _misfit(fit, target)
            if best is None or misfit < best[0]:
                best = (misfit, float(exponent), fit)
        step = float(grid[1] / grid[0])
        grid = np.geomspace(best[1] / step, best[1] * step, _REFINE_STEPS)
    return best


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
    curve is the force ``assumed`` (default :class:`FsrModel`) gives the counts, raised to a
    power and scaled (module docstring): the identity on a skin that matches the assumption.
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
        misfit, exponent, fit = _best_exponent(presses, target, censor, bump_shape)
        # Censoring adds a parameter (the bump): it must earn its keep.
        if censor:
            misfit /= CENSOR_GAIN
        if best is None or misfit < best[0]:
            best = (misfit, censor, bump_shape, exponent, fit)
    _, censor, bump_shape, exponent, (scale, activation, rim_load, fitted_sensed) = best
    fitted = fitted_sensed * known / target
    residuals = fitted - known
    worst = int(np.argmax(np.abs(residuals) / known))
    if abs(residuals[worst]) > MAX_RELATIVE_RESIDUAL * known[worst]:
        raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                         f'{fitted[worst]:.2f} N; the presses disagree with one curve '
                         '(a wrong known force, or two things touching?)')
    # Stored in counts, sampled over the counts pressed; past them the last slope goes on.
    top = max(float(p.counts.max()) for p in presses)
    grid = np.linspace(0.0, min(top, full_scale), _GRID)
    forces = np.where(grid > 0, scale * _power_part(assumed, grid) ** exponent + activation, 0.0)
    curve = ForceCurve(tuple(grid), tuple(np.maximum.accumulate(forces)), censor, *bump_shape,
                       rim_load_n=rim_load)
    censored = sum(bool((p.counts >= censor).any()) for p in presses) if censor else 0
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), censored)
