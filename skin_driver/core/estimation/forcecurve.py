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
with which bump, is chosen by the presses: the choice that fits them best. A taxel the ADC cut
(the conditioning puts it at full scale) is a lower bound whatever fits best: once a press has
one, the layer is censored, and the curve is flat from the highest count read under the cut.

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
# The exponents searched: a coarse grid in log steps, then halved steps either side of the best.
_EXPONENTS = np.geomspace(0.2, 5.0, 13)
_REFINE_ROUNDS = 8
# Censoring choices refined after the coarse grid: the best few of it.
_REFINED_CHOICES = 4
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

    def with_rim(self, read: float) -> float:
        """
        Return an imprint's read force sum with the rim load that no taxel reads.

        Never more than the imprint reads: a faint imprint (a few taxels over the threshold, or
        noise) is no press, and must not become one.
        """
        return read + min(self.rim_load_n, read)

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])  # 0 past a saturation
        return np.where(c <= knots[-1], np.interp(c, knots, force),
                        force[-1] + slope * (c - knots[-1]))

    def imprint_force(self, counts: np.ndarray, force: np.ndarray) -> float:
        """Return one imprint's summed force (2-D counts and taxel forces), censored, rim added."""
        return self.with_rim(censored_force(counts, force, self.censor_counts,
                                            self.spread_taxels, self.bump_power))

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


def _solve(gram: list, c: list, cols: tuple):
    """Return the least squares solution on ``cols`` (normal equations, Cramer), or None."""
    g = [[gram[i][j] for j in cols] for i in cols]
    r = [c[i] for i in cols]
    if len(cols) == 1:
        return [r[0] / g[0][0]] if g[0][0] > 0 else None
    det = _det(g)
    if not abs(det) > 1e-12 * max(abs(v) for row in g for v in row) ** len(cols):
        return None
    # Cramer's rule: column i replaced by the right-hand side.
    return [_det([row[:i] + [v] + row[i + 1:] for row, v in zip(g, r)]) / det
            for i in range(len(cols))]


def _det(m: list) -> float:
    """Return the determinant of a 2 x 2 or 3 x 3 matrix (nested lists)."""
    if len(m) == 2:
        return m[0][0] * m[1][1] - m[0][1] * m[1][0]
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


def _nnls(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """
    Return x >= 0 minimising |a x - b| for a few columns: the best of every subset's solution.

    The optimum is the unconstrained least squares on its own non-zero columns, so the best
    non-negative solution among all subsets of columns is it.
    """
    k = a.shape[1]
    gram = (a.T @ a).tolist()
    c = (a.T @ b).tolist()
    best, best_cost = [0.0] * k, 0.0
    for mask in range(1, 1 << k):
        cols = tuple(j for j in range(k) if mask >> j & 1)
        x = _solve(gram, c, cols)
        if x is None or min(x) < 0:
            continue
        # |a x - b|^2 - |b|^2 = x' G x - 2 c' x, which at the subset's optimum is -c' x.
        cost = -sum(c[j] * v for j, v in zip(cols, x))
        if cost < best_cost:
            best_cost = cost
            best = [0.0] * k
            for j, v in zip(cols, x):
                best[j] = v
    return np.array(best)


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


def _highest_read(press_counts, full_scale: int) -> float:
    """
    Return the highest count read under full scale when a press reached it, else inf.

    A taxel at full scale was cut by the ADC (the conditioning puts every such taxel there): its
    reading tells no more than the highest count any uncut taxel read, which it takes, so the
    curve is flat from there to full scale instead of running off along the assumed law.
    """
    counts = [np.asarray(c, dtype=np.float64) for c in press_counts]
    if not any(c.size and c.max() >= full_scale for c in counts):
        return np.inf
    return max((float(c[c < full_scale].max()) for c in counts if (c < full_scale).any()),
               default=0.0)


def _presses(press_counts, press_gains, assumed: FsrModel, highest: float) -> list:
    """Return the presses' loaded taxels, each read at ``highest`` counts at most."""
    out = []
    for k, (c, g) in enumerate(zip(press_counts, press_gains)):
        c = np.atleast_2d(np.asarray(c, dtype=np.float64))
        g = np.atleast_2d(np.asarray(g, dtype=np.float64))
        if c.shape != g.shape:
            raise ValueError(f'press {k + 1}: counts {c.shape} and gains {g.shape} differ')
        loaded = c > 0
        out.append(_Press(c[loaded], g[loaded],
                          _power_part(assumed, np.minimum(c[loaded], highest)), c, {}))
    return out


def _power_part(assumed: FsrModel, counts: np.ndarray) -> np.ndarray:
    """Return the assumed force of the counts less its activation: the film's power law."""
    return np.maximum(assumed.counts_to_force(counts, saturate=False) - assumed.activation_n,
                      0.0)


class _Layout:
    """
    All presses' loaded taxels in one row, for one censoring choice: a sum per press is a count.

    ``filled`` marks the censored taxels that take the bump (their press has free taxels under
    the bump to fit its height to); the other censored taxels count as read.
    """

    def __init__(self, presses: list, censor: float, shape: tuple):
        self.n = len(presses)
        self.press = np.concatenate([np.full(p.counts.size, k) for k, p in enumerate(presses)])
        self.gains = np.concatenate([p.gains for p in presses])
        with np.errstate(divide='ignore'):
            self.log_force = np.log(np.concatenate([p.assumed_n for p in presses]))
        censored = (np.concatenate([p.counts for p in presses]) >= censor if censor > 0
                    else np.zeros(self.press.size, bool))
        self.phi = np.concatenate([p.bump(shape) if censor > 0 and (p.counts >= censor).any()
                                   else np.zeros(p.counts.size) for p in presses])
        free = ~censored
        self.weight = np.bincount(self.press[free], self.phi[free] ** 2, self.n)
        self.filled = censored & (self.weight[self.press] > 0)
        self.read = ~self.filled
        self.fitted = free & (self.weight[self.press] > 0)

    def sums(self, exponent: float) -> np.ndarray:
        """
        Return each press's sensed sum at unit scale (linear in the scale) for ``exponent``.

        A censored taxel adds the bump fitted to its press's free taxels, or its own reading
        where that is larger (both grow with the scale alike, so which does is fixed here).
        """
        taxels = self.gains * np.exp(exponent * self.log_force)
        sums = np.bincount(self.press[self.read], taxels[self.read], self.n)
        if self.filled.any():
            fitted = self.fitted
            height = np.bincount(self.press[fitted], (self.phi * taxels)[fitted], self.n)
            height = np.divide(height, self.weight, out=np.zeros(self.n), where=self.weight > 0)
            f = self.filled
            fill = np.maximum(self.phi[f] * height[self.press[f]], taxels[f])
            sums += np.bincount(self.press[f], fill, self.n)
        return sums


def _fit(layout: _Layout, counts: np.ndarray, target: np.ndarray, exponent: float):
    """
    Return (scale, activation, rim load, fitted sensed sums) of one censoring and exponent.

    The sum of a press is linear in the three: the power of its taxels' forces, their number
    (``counts``: each conducting taxel carries the activation force) and the imprint's rim load.
    """
    read = layout.sums(exponent)
    design = np.stack((read, counts, np.ones(read.size)), axis=1)
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


def _best_exponent(layout: _Layout, counts: np.ndarray, target: np.ndarray, grid,
                   rounds: int):
    """Return (misfit, exponent, fit) of the exponent that fits best: a grid, then halvings."""
    step = float(grid[1] / grid[0])
    best = None
    for _ in range(rounds + 1):
        for exponent in grid:
            fit = _fit(layout, counts, target, float(exponent))
            misfit = _misfit(fit, target)
            if best is None or misfit < best[0]:
                best = (misfit, float(exponent), fit)
        step = step ** 0.5
        grid = (best[1] / step, best[1] * step)
    return best


def _best_choice(presses: list, target: np.ndarray, full_scale: int) -> tuple:
    """
    Return (censor, bump shape, exponent, fit) of the censoring choice that fits best.

    Every choice is tried on the coarse grid of exponents; the few best are refined.
    """
    shape = presses[0].map_counts.shape
    counts = np.array([p.counts.size for p in presses], dtype=np.float64)
    tried = []
    for censor, bump_shape in _censoring_choices(presses, full_scale, shape):
        layout = _Layout(presses, censor, bump_shape)
        misfit = _best_exponent(layout, counts, target, _EXPONENTS, 0)[0]
        # Censoring adds a parameter (the bump): it must earn its keep.
        tried.append((misfit / CENSOR_GAIN if censor else misfit, censor, bump_shape, layout))
    tried.sort(key=lambda t: t[0])
    best = None
    for _, censor, bump_shape, layout in tried[:_REFINED_CHOICES]:
        misfit, exponent, fit = _best_exponent(layout, counts, target, _EXPONENTS,
                                               _REFINE_ROUNDS)
        if censor:
            misfit /= CENSOR_GAIN
        if best is None or misfit < best[0]:
            best = (misfit, censor, bump_shape, exponent, fit)
    return best[1:]


def _censoring_choices(presses: list, full_scale: int, shape: tuple) -> list:
    """
    Return (censor counts, (bump spread, power)) choices: none, and the ceilings presses reach.

    A ceiling is the highest count read less a band for noise; it is a saturation only when
    two or more presses reach it (one press's peak is just the highest reading). A taxel at
    full scale was cut by the ADC (the conditioning puts every such taxel there): a lower bound
    for certain, so once a press has one, every choice censors it (none is no choice), and the
    film's own ceiling below the cut, the highest count read under full scale, is tried too.
    """
    band = CENSOR_BAND * full_scale
    top = max(float(p.counts.max()) for p in presses)
    clipped = top >= full_scale
    choices = [] if clipped else [(0.0, (0.0, 2.0))]
    ceilings = [top - band]
    highest = _highest_read([p.counts for p in presses], full_scale)
    if clipped and highest > band:
        ceilings.insert(0, highest - band)
    widest = max(1.0, 0.25 * max(shape))
    for ceiling in ceilings:
        if clipped or sum(bool((p.counts >= ceiling).any()) for p in presses) >= 2:
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
    highest = _highest_read(press_counts, full_scale)
    presses = _presses(press_counts, press_gains, assumed, highest)
    empty = [k for k, p in enumerate(presses) if p.counts.size == 0]
    if empty:
        raise ValueError(f'press {empty[0] + 1} ({known[empty[0]]:.2f} N) loaded no taxel')
    censor, bump_shape, exponent, (scale, activation, rim_load, fitted_sensed) = _best_choice(
        presses, target, full_scale)
    fitted = fitted_sensed * known / target
    residuals = fitted - known
    worst = int(np.argmax(np.abs(residuals) / known))
    if abs(residuals[worst]) > MAX_RELATIVE_RESIDUAL * known[worst]:
        raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                         f'{fitted[worst]:.2f} N; the presses disagree with one curve '
                         '(a wrong known force, or two things touching?)')
    # Stored in counts, sampled over the counts pressed; past them the last slope goes on (flat
    # past the highest count read under a cut: _presses).
    top = max(float(p.counts.max()) for p in presses)
    grid = np.linspace(0.0, min(top, full_scale), _GRID)
    power = _power_part(assumed, np.minimum(grid, highest))
    forces = np.where(grid > 0, scale * power ** exponent + activation, 0.0)
    curve = ForceCurve(tuple(grid), tuple(np.maximum.accumulate(forces)), censor, *bump_shape,
                       rim_load_n=rim_load)
    censored = sum(bool((p.counts >= censor).any()) for p in presses) if censor else 0
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), censored)
