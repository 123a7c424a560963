"""
The floor of the direction estimate: the Cramér–Rao bound on beta of the simulator's own model.

For a frame whose presses and skin are known, the counts are the simulator's noise-free counts
(:func:`physics.expected_counts`) plus Gaussian noise of ``noise_counts`` and the ADC's rounding
(a twelfth of a count squared). The Fisher information of the presses' parameters (those the
oracle fits, :mod:`oracle`: place, log normal force, tangential displacement, log indenter
radius, six per press) is J^T J over that variance, J the counts' derivatives; the bound on an
unbiased estimate's variance of a press's azimuth beta = atan2(ty, tx) is g^T I^-1 g, g its
gradient. No estimator that does not know more than the frames can do better on average; the
oracle (the fit started at the truth) shows how near a fit of the true model gets.

The derivatives are central differences at the oracle's steps (a fiftieth of a taxel, which
averages over the render's fine grid) and at twice them: a bound whose two values differ by
more than ``STABLE_SHARE`` is marked unstable (a rim that a step crosses, a taxel that
saturates), and reported apart. The mean absolute error a Gaussian of the bound's spread gives is
sqrt(2 / pi) times it: that is the figure put beside the estimators' mean errors.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np
from skin_driver.core.sim.physics import Press, SkinModel

from .oracle import _Frame, _parameters, _PER_PRESS, _STEP

__all__ = ['BetaBound', 'beta_bounds', 'mean_bound_deg', 'STABLE_SHARE']

# Two step sizes whose bounds differ by more than this share: the derivatives are not stable.
STABLE_SHARE = 0.2
# sqrt(2 / pi): a zero-mean Gaussian's mean absolute value over its standard deviation.
_MEAN_ABS = math.sqrt(2.0 / math.pi)


class BetaBound(NamedTuple):
    """One tilted press's bound: the standard deviation of beta (degrees) and its stability."""

    sigma_deg: float
    stable: bool


def _jacobian(frame: _Frame, u: np.ndarray, scale: float) -> np.ndarray:
    """Return the counts' central-difference derivatives (taxels x parameters) at ``u``."""
    x = u.ravel()
    columns = []
    for j in range(x.size):
        step = _STEP[j % _PER_PRESS] * scale
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        columns.append((frame.residual(up) - frame.residual(down)) / (2.0 * step))
    # The residuals are counts over the oracle's scale; back to counts.
    return np.stack(columns, axis=1) / frame.scale


def _sigmas_deg(model: SkinModel, frame: _Frame, u: np.ndarray, scale: float) -> np.ndarray:
    jac = _jacobian(frame, u, scale)
    variance = model.noise_counts ** 2 + 1.0 / 12.0
    info = jac.T @ jac / variance
    try:
        covariance = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return np.full(len(u), math.inf)
    out = []
    for k, (_, _, _, tx, ty, _) in enumerate(u.tolist()):
        length2 = tx * tx + ty * ty
        if length2 <= 0:
            out.append(math.inf)  # a normal press: no azimuth
            continue
        g = np.zeros(u.size)
        g[k * _PER_PRESS + 3] = -ty / length2
        g[k * _PER_PRESS + 4] = tx / length2
        var = float(g @ covariance @ g)
        out.append(math.degrees(math.sqrt(var)) if var >= 0 else math.inf)
    return np.array(out)


def beta_bounds(model: SkinModel, presses: Sequence[Press]) -> list:
    """
    Return the :class:`BetaBound` of each tilted press of one frame (None for a normal one).

    All the frame's presses are estimated together (their imprints may overlap).
    """
    presses = list(presses)
    if not presses:
        return []
    u = np.array([_parameters(model, p) for p in presses])
    frame = _Frame(model, presses, np.zeros((2, model.rows, model.cols)))
    fine = _sigmas_deg(model, frame, u, 1.0)
    coarse = _sigmas_deg(model, frame, u, 2.0)
    out = []
    for p, a, b in zip(presses, fine, coarse):
        if not p.alpha_rad > 0:
            out.append(None)
            continue
        stable = bool(math.isfinite(a) and math.isfinite(b)
                      and abs(a - b) <= STABLE_SHARE * max(a, b))
        out.append(BetaBound(float(a), stable))
    return out


def mean_bound_deg(model: SkinModel, frames: Sequence[Sequence[Press]]) -> dict:
    """
    Return the floor over frames' tilted presses: the bound as a mean absolute error (degrees).

    ``mean_abs_error_deg`` is the mean over the presses whose derivatives are stable of sqrt(2 /
    pi) times each one's bound, at most 90 degrees (an azimuth the frame does not hold is a
    guess), ``median_sigma_deg`` their median standard deviation, ``stable_share`` the share of
    tilted presses they are.
    """
    bounds = [b for presses in frames for b in beta_bounds(model, presses) if b is not None]
    stable = np.array([b.sigma_deg for b in bounds if b.stable])
    return {'presses': len(bounds), 'stable_share': stable.size / len(bounds) if bounds else None,
            'mean_abs_error_deg': (float(np.minimum(_MEAN_ABS * stable, 90.0).mean())
                                   if stable.size else None),
            'median_sigma_deg': float(np.median(stable)) if stable.size else None}
