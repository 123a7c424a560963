"""
The floor of the direction estimate: the simulator's own forward model fitted to each frame.

For a frame whose presses and skin are known (FSR curve, turn-on, true per-taxel gains and
offsets, crosstalk, dead taxels), the oracle fits each press's position, normal force,
tangential layer displacement and indenter size to the frame's counts by damped Gauss-Newton
(Levenberg-Marquardt) on the noise-free float counts of :func:`physics.expected_counts`, started
at the truth. What it cannot undo is only the noise and the rounding of the counts, so its
azimuth error is about the least the frames allow; the evaluator and the benchmark report every
estimator's error in units of it. It knows the skin: it is for evaluation only, never a driver's
estimator. It does not know the indenter's size, which no driver is told: where two taxels
cannot tell an imprint's width from its place (a narrow or cliff-rimmed imprint), the floor
says so. Its shape (aspect, orientation) is kept.

Cost: each iteration renders every press once more per parameter (six per press), so a frame
costs tens of renders, milliseconds to tens of milliseconds; callers may skip it.
"""

from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np
from skin_driver.core.common import least_squares
from skin_driver.core.estimation.scan.pipeline import Contact
from skin_driver.core.sim.physics import expected_counts, Press, render_force, SkinModel

__all__ = ['ORACLE', 'fit_presses', 'oracle_contacts', 'oracle_run']

ORACLE = 'oracle'

# Parameters per press: x, y (taxels), log normal force, tangential displacement x, y (taxels),
# log indenter radius.
_PER_PRESS = 6
# Finite-difference steps: a fiftieth of a taxel averages over the fine grid's steps (a 3 %
# larger radius moves a 2.5 mm disc's rim by a fiftieth of a 5 mm taxel).
_STEP = np.array((0.02, 0.02, 0.01, 0.02, 0.02, 0.03))
_ITERATIONS = 8
# The most one step may move each parameter (a trust region): where the frame does not hold a
# parameter (a bottom imprint shifted off the map leaves its shift free) the damped step would
# otherwise run away on a flat misfit.
_MAX_STEP = np.array((0.5, 0.5, 0.5, 1.0, 1.0, 0.3))


def _press_of(model: SkinModel, like: Press, u: np.ndarray) -> Press:
    """Return the press with parameters ``u`` and ``like``'s indenter shape."""
    pitch = model.pitch_m
    normal = math.exp(u[2])
    tx, ty = u[3] * pitch, u[4] * pitch
    tangential = math.hypot(tx, ty) / model.compliance_m_per_n
    return Press(u[0] * pitch, u[1] * pitch, math.hypot(normal, tangential),
                 math.atan2(tangential, normal), math.atan2(ty, tx) if tangential > 0 else 0.0,
                 like.radius_m * math.exp(u[5]), like.aspect, like.orientation_rad)


def _parameters(model: SkinModel, press: Press) -> np.ndarray:
    """Return the fit's parameters of a press (the truth it starts at)."""
    pitch = model.pitch_m
    t = model.compliance_m_per_n * press.tangential_force_n / pitch
    return np.array((press.x_m / pitch, press.y_m / pitch,
                     math.log(max(press.normal_force_n, 1e-6)),
                     t * math.cos(press.beta_rad), t * math.sin(press.beta_rad), 0.0))


class _Frame:
    """Residuals of one frame's model, with each press's force maps kept apart."""

    def __init__(self, model: SkinModel, presses: Sequence[Press], counts: np.ndarray):
        self.model = model
        self.presses = list(presses)
        self.counts = np.asarray(counts, dtype=np.float64)
        self.scale = 1.0 / max(model.noise_counts, 1.0)
        self._last = None  # (parameters, force maps) of the last residual taken

    def forces(self, u: np.ndarray) -> list:
        return [np.stack(render_force(self.model, [_press_of(self.model, p, u[k])]))
                for k, p in enumerate(self.presses)]

    def of(self, forces: list) -> np.ndarray:
        total = np.sum(forces, axis=0)
        return ((expected_counts(self.model, total[0], total[1]) - self.counts)
                * self.scale).ravel()

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Return the residuals of the flat parameters ``x`` (K x 6, row by row)."""
        forces = self.forces(x.reshape(-1, _PER_PRESS))
        self._last = (x.copy(), forces)
        return self.of(forces)

    def jacobian(self, x: np.ndarray, r0: np.ndarray) -> np.ndarray:
        # The solver asks at the point it has just taken the residuals of: their maps serve.
        last, forces = self._last if self._last is not None else (None, None)
        u = x.reshape(-1, _PER_PRESS)
        if last is None or not np.array_equal(last, x):
            forces = self.forces(u)
        # Each parameter moves only its own press's maps: re-render that press alone.
        jac = np.empty((r0.size, x.size))
        for k, p in enumerate(self.presses):
            others = forces[:k] + forces[k + 1:]
            for j in range(_PER_PRESS):
                v = u[k].copy()
                v[j] += _STEP[j]
                moved = np.stack(render_force(self.model, [_press_of(self.model, p, v)]))
                jac[:, k * _PER_PRESS + j] = (self.of(others + [moved]) - r0) / _STEP[j]
        return jac


def fit_presses(model: SkinModel, presses: Sequence[Press], counts: np.ndarray) -> tuple:
    """
    Fit the presses' parameters to one frame's (2, rows, cols) counts, started at the truth.

    Returns (K x 6 parameters: x, y in taxels, log normal force, tangential displacement x, y in
    taxels, log of the indenter radius over the true one; their K x 6 standard errors from the
    fit's curvature).
    """
    frame = _Frame(model, presses, counts)
    u = np.array([_parameters(model, p) for p in presses])
    fit = least_squares.levenberg_marquardt(
        frame.residual, u.ravel(), iterations=_ITERATIONS, jacobian=frame.jacobian,
        limit=least_squares.scaled_into(np.tile(_MAX_STEP, len(presses))), stop_move=1e-4,
        floor=1e-9)
    u = fit.x.reshape(u.shape)
    try:
        covariance = np.linalg.inv(fit.normal)
        sigma = np.sqrt(np.clip(np.diag(covariance), 0.0, None)).reshape(u.shape)
    except np.linalg.LinAlgError:
        sigma = np.full(u.shape, math.inf)
    return u, sigma


def oracle_contacts(model: SkinModel, presses: Sequence[Press], counts: np.ndarray) -> list:
    """
    Return the oracle's contacts of one frame (strongest first), as the pipeline reports them.

    Each press gives one contact at its fitted place, with its fitted normal force and the
    azimuth of its fitted tangential displacement; the azimuth sigma comes from the fit's
    curvature, and a displacement whose standard error reaches its length has no valid
    direction (the frame does not hold it). An empty press list gives no contact.
    """
    if not presses:
        return []
    u, sigma = fit_presses(model, presses, counts)
    pitch = model.pitch_m
    out = []
    for (x, y, log_fz, tx, ty, _), (_, _, _, sx, sy, _) in zip(u.tolist(), sigma.tolist()):
        normal = math.exp(log_fz)
        length = math.hypot(tx, ty)
        tangential = length * pitch / model.compliance_m_per_n
        fx, fy = ((tangential * tx / length, tangential * ty / length) if length > 0
                  else (0.0, 0.0))
        spread = math.hypot(sx, sy) / math.sqrt(2.0)
        # A shift the frame does not hold (its standard error as long as itself) has no azimuth.
        known = math.isfinite(spread) and spread < length
        out.append(Contact(
            x_m=x * pitch, y_m=y * pitch, force_n=normal, area_m2=0.0,
            shift_m=(tx * pitch, ty * pitch), azimuth_rad=math.atan2(ty, tx),
            azimuth_sigma_rad=math.atan2(spread, length) if math.isfinite(spread) else math.pi,
            alpha_rad=math.atan2(tangential, normal), force_xyz_n=(fx, fy, -normal),
            confidence=1.0 if known else 0.0, direction_valid=known))
    out.sort(key=lambda c: -c.force_n)
    return out


def oracle_run(model: SkinModel, presses: Sequence, data) -> tuple:
    """
    Return (contacts per frame, microseconds per frame) of the oracle over ``data``'s frames.

    ``presses`` holds each frame's true presses, in the dataset's order.
    """
    if len(presses) != data.frames:
        raise ValueError(f'the oracle needs the presses of all {data.frames} frames, '
                         f'got {len(presses)}')
    start = time.perf_counter()
    contacts = [oracle_contacts(model, presses[i], np.stack((data.top[i], data.bottom[i])))
                for i in range(data.frames)]
    return contacts, (time.perf_counter() - start) / max(data.frames, 1) * 1e6
