"""
Fit a skin's own force curve (:class:`forcecurve.ForceCurve`) to presses of known normal force.

Every taxel is evidence. A taxel whose film saturated (its counts at the layer's ceiling, which
the heaviest presses pile up at) is censored: it tells a lower bound on its force, and the
imprint's unsaturated rim tells the rest (:mod:`imprint`: a bump fitted to the rim, whose width
the fit chooses with the curve). The sum of a press stays linear in the scale and the rim load,
so censored and free taxels are fitted together (non-negative least squares of relative
errors, for each exponent of a search in log steps). Whether the layer is censored at all, and
with which bump, is chosen by the presses: the choice that fits them best. A taxel the ADC
clipped (the conditioning puts it at full scale) is a lower bound whatever fits best: once a press
has one, the layer is censored, and the curve is flat from the highest count read below full
scale.

The fit is refused, with a reason in newtons, when there are too few presses, when their forces do
not span a range (the curve would be a guess outside one point), when a press loaded no taxel, or
when no curve fits the presses within ``MAX_RELATIVE_RESIDUAL`` (the refusal names the press
furthest off: a wrong known force, or a press that missed the skin).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..model.forcecurve import ForceCurve
from ..model.fsr import FsrModel
from ..model.imprint import bump, MIN_FITTED_SPREAD

__all__ = ['CurveFit', 'check_known_forces', 'fit_force_curve', 'MIN_PRESSES', 'MIN_FORCE_SPAN']

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
_POWERS = (2.0, 3.0, 4.0, 6.0)


@dataclass(frozen=True)
class CurveFit:
    """
    A fitted curve and, per press, the force it gives back and its residual (N).

    ``censored`` presses had saturated taxels, filled in from their rims. ``left_out`` are the
    indices of presses that disagreed with the curve the others make and were not fitted; their
    ``fitted_n`` is what the last fit that still held them gave.
    """

    curve: ForceCurve
    fitted_n: tuple
    residuals_n: tuple
    censored: int
    left_out: tuple = ()


def _solve(gram: list, c: list, cols: tuple):
    """Return the least squares solution on ``cols`` (normal equations, Cramer), or None."""
    # Unrolled per size: the fit solves this a hundred thousand times a calibration, and
    # building the sub-matrices as lists cost more than the arithmetic.
    if len(cols) == 1:
        i, = cols
        return [c[i] / gram[i][i]] if gram[i][i] > 0 else None
    if len(cols) == 2:
        i, j = cols
        a, b, d, e = gram[i][i], gram[i][j], gram[j][i], gram[j][j]
        r0, r1 = c[i], c[j]
        det = a * e - b * d
        if not abs(det) > 1e-12 * max(abs(a), abs(b), abs(d), abs(e)) ** 2:
            return None
        # Cramer's rule: column i replaced by the right-hand side.
        return [(r0 * e - b * r1) / det, (a * r1 - r0 * d) / det]
    i, j, k = cols
    gi, gj, gk = gram[i], gram[j], gram[k]
    a, b, e = gi[i], gi[j], gi[k]
    d, f, g = gj[i], gj[j], gj[k]
    h, m, n = gk[i], gk[j], gk[k]
    r0, r1, r2 = c[i], c[j], c[k]
    det = _det(a, b, e, d, f, g, h, m, n)
    if not abs(det) > 1e-12 * max(abs(a), abs(b), abs(e), abs(d), abs(f), abs(g), abs(h),
                                  abs(m), abs(n)) ** 3:
        return None
    return [_det(r0, b, e, r1, f, g, r2, m, n) / det, _det(a, r0, e, d, r1, g, h, r2, n) / det,
            _det(a, b, r0, d, f, r1, h, m, r2) / det]


def _det(a, b, c, d, e, f, g, h, i) -> float:
    """Return the determinant of the 3 x 3 matrix of rows (a, b, c), (d, e, f), (g, h, i)."""
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


# Every subset of a few columns, in the order _nnls tries them (column j in bit j).
_SUBSETS = {k: [tuple(j for j in range(k) if mask >> j & 1) for mask in range(1, 1 << k)]
            for k in (1, 2, 3)}


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
    for cols in _SUBSETS[k]:
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

    A taxel at full scale was clipped by the ADC (the conditioning puts every such taxel there):
    its reading tells no more than the highest count any unclipped taxel read, which it takes, so
    the
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
        where that is larger (both grow with the scale alike, so which does is fixed here). The
        activation, every conducting taxel's alike, is no part of the bump: the pipeline fills
        in with the curve's activation plus the bump fitted to the free taxels' force above it.
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
    full scale was clipped by the ADC (the conditioning puts every such taxel there): a lower
    bound for certain, so once a press has one, every choice censors it (none is no choice), and
    the film's own ceiling below full scale, the highest count read under it, is tried too.
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


def _bump_activation(censor: float, bump_shape: tuple, activation: float) -> float:
    """
    Return the activation the pipeline leaves out of a saturated imprint's bump.

    The fit bumps the power part only (:meth:`_Layout.sums`), with the calibration's bump; the
    pipeline fills in alike: the activation plus the bump fitted to the free taxels' force above
    it. A bump wide enough for each imprint to fit its own spread at run time
    (``imprint.MIN_FITTED_SPREAD``) is no fixed bump the fit could model: there the bump is
    fitted to the whole force, activation included: taking the activation out there reads
    presses whose taxels the ADC clipped on a fine grid with crosstalk.
    """
    return activation if censor and bump_shape[0] < MIN_FITTED_SPREAD else 0.0


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
                    assumed: FsrModel = None, full_scale: int = None, left_out: tuple = (),
                    may_leave_out: bool = True) -> CurveFit:
    """
    Fit one layer's curve; raise ValueError with the reason when it must be refused.

    ``press_counts[k]`` is press k's map of counts above baseline on the layer (0 where
    untouched; a 1-D array of loaded taxels has no geometry and is never censored),
    ``press_gains[k]`` the gains there, ``sensed_n[k]`` the force those taxels must sum to
    (known force times fill_factor**2) and ``known_n[k]`` the known force for messages. The
    curve is the force ``assumed`` (default :class:`FsrModel`) gives the counts, raised to a
    power and scaled (module docstring): the identity on a skin that matches the assumption.

    Presses indexed in ``left_out`` are not fitted (another layer's fit judged their known force
    wrong). With ``may_leave_out`` false no other press is left out: a layer whose presses then
    disagree is refused rather than fitted on fewer, lower-spanning presses.
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
    # One press that disagrees (a wrong known force, two things touching) would bend the curve
    # for all: the worst is left out and the rest refitted, while most presses still agree.
    kept = [k for k in range(len(presses)) if k not in left_out]
    fitted = np.zeros_like(known)
    fewest = max(MIN_PRESSES, (len(presses) + 1) // 2)
    while True:
        censor, bump_shape, exponent, (scale, activation, rim_load, fitted_sensed) = _best_choice(
            [presses[k] for k in kept], target[kept], full_scale)
        fitted[kept] = fitted_sensed * known[kept] / target[kept]
        relative = np.abs(fitted[kept] - known[kept]) / known[kept]
        worst = kept[int(np.argmax(relative))]
        if relative.max() <= MAX_RELATIVE_RESIDUAL:
            break
        rest = [k for k in kept if k != worst]
        if not may_leave_out:
            raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                             f'{fitted[worst]:.2f} N; the presses disagree with one curve')
        if len(rest) < fewest or known[rest].max() < MIN_FORCE_SPAN * known[rest].min():
            left = len(presses) - len(kept)
            raise ValueError(f'press {worst + 1} of {known[worst]:.2f} N is fitted as '
                             f'{fitted[worst]:.2f} N{_left_out_note(left)}; too few presses '
                             'agree with one curve (a wrong known force, or two things '
                             'touching?)')
        kept = rest
    residuals = fitted - known
    presses = [presses[k] for k in kept]
    # Stored in counts, sampled over the counts pressed; past them the last slope goes on (flat
    # past the highest count read below full scale when a press was clipped: _presses).
    top = max(float(p.counts.max()) for p in presses)
    grid = np.linspace(0.0, min(top, full_scale), _GRID)
    power = _power_part(assumed, np.minimum(grid, highest))
    forces = np.where(grid > 0, scale * power ** exponent + activation, 0.0)
    curve = ForceCurve(tuple(grid), tuple(np.maximum.accumulate(forces)), censor, *bump_shape,
                       rim_load_n=rim_load, activation_n=_bump_activation(censor, bump_shape,
                                                                          activation))
    censored = sum(bool((p.counts >= censor).any()) for p in presses) if censor else 0
    left_out = tuple(k for k in range(len(known)) if k not in kept)
    return CurveFit(curve, tuple(float(v) for v in fitted),
                    tuple(float(v) for v in residuals), censored, left_out)


def _left_out_note(count: int) -> str:
    return f' with {count} other{"s" if count != 1 else ""} left out' if count else ''
