"""
One damped Gauss-Newton (Levenberg-Marquardt) solver for every Python fit of the package.

The taxel model's contact fit, its learning from presses and the simulator's oracle minimise a
sum of squared residuals over a few to a few hundred parameters. They differ only in how the
curvature is had (a forward-difference Jacobian, one given in closed form, or normal equations
assembled block by block) and in how far one move may go; the loop itself is this one.

Each trial solves ``(N + damping * (diag(N) + floor)) move = -g`` with ``N = J'J`` and
``g = J'r``, limits the move, and keeps it if it lowers ``r @ r``: the damping then falls
(times ``down``) and the curvature is taken again at the new point; else the damping rises
(times ``up``) and the same curvature is solved again. Marquardt's scaling by ``diag(N)``
makes the damping independent of the parameters' units; ``floor`` keeps a parameter the
residuals do not see from making the system singular.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Callable, Optional

import numpy as np

__all__ = ['Fit', 'forward_jacobian', 'levenberg_marquardt', 'scaled_into']


@dataclass(frozen=True)
class Fit:
    """
    A solver's outcome.

    ``x``: the parameters of least misfit found; ``cost``: their ``r @ r``; ``normal``: ``J'J``
    where the curvature was last taken (at ``x``, or at the point before a last move shorter
    than ``stop_move``), for the parameters' covariance; ``steps``: moves kept.
    """

    x: np.ndarray
    cost: float
    normal: np.ndarray
    steps: int


def forward_jacobian(residual: Callable, steps: np.ndarray) -> Callable:
    """Return ``jacobian(x, r)``: forward differences of ``residual`` with per-parameter steps."""
    steps = np.asarray(steps, dtype=np.float64)

    def jacobian(x: np.ndarray, r: np.ndarray) -> np.ndarray:
        jac = np.empty((r.size, x.size))
        for k, h in enumerate(steps):
            v = x.copy()
            v[k] += h
            jac[:, k] = (residual(v) - r) / h
        return jac
    return jacobian


def scaled_into(max_moves: np.ndarray) -> Callable:
    """Return ``limit(move)``: the move shrunk as a whole until no part exceeds its bound."""
    max_moves = np.asarray(max_moves, dtype=np.float64)

    def limit(move: np.ndarray) -> np.ndarray:
        return move / max(1.0, float(np.abs(move / max_moves).max()))
    return limit


def levenberg_marquardt(residual: Callable, x0, *, iterations: int,
                        jacobian: Optional[Callable] = None,
                        normal_equations: Optional[Callable] = None,
                        limit: Optional[Callable] = None, most_steps: Optional[int] = None,
                        patience: Optional[int] = None, stop_move: Optional[float] = None,
                        damping: float = 1e-3, floor: float = 1e-12, down: float = 0.3,
                        up: float = 10.0) -> Fit:
    """
    Return the :class:`Fit` minimising ``residual(x) @ residual(x)`` from ``x0``.

    The curvature comes from ``jacobian(x, r)`` (a matrix; :func:`forward_jacobian`) or from
    ``normal_equations(x, r)`` (``(J'J, J'r)`` assembled by the caller), exactly one of them.
    ``limit(move)`` bounds each move (:func:`scaled_into`). The solver stops after
    ``iterations`` trials, ``most_steps`` kept moves, ``patience`` trials rejected in a row,
    a kept move whose largest part is below ``stop_move``, or a singular system.
    """
    if (jacobian is None) == (normal_equations is None):
        raise ValueError('give exactly one of jacobian and normal_equations')
    if normal_equations is None:
        def normal_equations(x, r):
            jac = jacobian(x, r)
            return jac.T @ jac, jac.T @ r
    x = np.array(x0, dtype=np.float64)
    r = residual(x)
    cost = float(r @ r)
    normal, grad = normal_equations(x, r)
    steps = rejected = 0
    most_steps = math.inf if most_steps is None else most_steps
    patience = math.inf if patience is None else patience
    for _ in range(iterations):
        try:
            move = np.linalg.solve(normal + damping * np.diag(np.diag(normal) + floor), -grad)
        except np.linalg.LinAlgError:
            break
        if limit is not None:
            move = limit(move)
        trial = x + move
        r2 = residual(trial)
        cost2 = float(r2 @ r2)
        if cost2 < cost:
            x, r, cost = trial, r2, cost2
            damping *= down
            steps += 1
            rejected = 0
            if steps >= most_steps or (stop_move is not None
                                       and np.abs(move).max() < stop_move):
                break
            normal, grad = normal_equations(x, r)
        else:
            damping *= up
            rejected += 1
            if rejected >= patience:
                break
    return Fit(x, cost, normal, steps)
