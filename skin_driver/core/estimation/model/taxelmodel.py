"""
A forward model of the taxels with the skin's own parameters, and its fit to presses.

Where ``taxel_fit`` (the kernel's taxel_fit.c) describes each imprint by Gaussians, this model
renders the counts a press gives and fits them (issue #16, docs/estimation.md "The forward
model"):

* the tip loads the top layer with a Hertz profile ``sqrt(1 - r**2)`` over an ellipse (semi-axes
  ``a`` and ``a * aspect``, turned by ``orientation``) whose integral is the normal force;
* the cover blurs it by a Gaussian (``cover_spread_m``); the bottom layer sees it blurred by
  the elastic layer too (``layer_spread_m``, added in quadrature) and displaced by the shift;
* each taxel sums the load over its active pad (``fill_factor`` of the pitch, :mod:`cellops`);
* the film turns a taxel's load ``f`` into counts through the divider:
  ``counts = full_scale * g / (1 + g)``, ``g = min(film_scale * (f - film_activation_n)**
  film_exponent, film_ceiling)`` (an FSR is open below its activation load; its conductance then
  grows as a power of force up to its resistance floor). The activation matters: the law is
  steep at small loads, so a blur's tails would read hundreds of counts without it;
* a film may also stay open where its local pressure (after the blur) is below
  ``turn_on_pa``: a taxel then reads only the load where it is exceeded, and with
  ``film_step`` (a conductance ratio like ``g``) it reads at least that as soon as any of it
  conducts. Imprints get cliffs at their rims; the blur and the cut then act on the fine
  grid, a few times the cost of a smooth film's render.

None of the skin's numbers is assumed: :mod:`taxellearn` learns them from the presses of known
force a force calibration records, and the calibration keeps them (:class:`TaxelModel`). A
scan's contact is fitted by the compiled kernel (``skin_kernel/src/model_fit.c``, bound as
:func:`skin_driver.core.estimation.scan.kernel.fit_contact`): Levenberg-Marquardt on its
window's tared counts, taxels the film or the ADC saturated taken as lower bounds; a round tip
first, then an elliptical one from four orientations, the least misfit kept (the misfit of
narrow imprints is rugged, so one start stops in side minima). This module keeps the pieces the
learning fits its presses with (:func:`residuals`, :func:`levenberg_marquardt`,
:func:`start_of`, :func:`best_radius`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math

import numpy as np

from .cellops import axis_operator, blur_block, gather
from ...common import least_squares
from ...common.validate import check_number

__all__ = ['TaxelModel', 'PressFit', 'hertz_profile', 'render_counts', 'residuals',
           'levenberg_marquardt', 'best_radius', 'start_of', 'sub_for']

# Per-press parameters: centre x, y (taxels of the window), log normal force (N), shift dx, dy
# (taxels), log tip radius (taxels), log aspect, orientation (rad).
X, Y, LOG_FORCE, DX, DY, LOG_RADIUS, LOG_ASPECT, ORIENTATION = range(8)
# Finite-difference steps and the largest step a Levenberg-Marquardt move may take, per
# parameter (taxels, log units, radians): a narrow imprint's misfit is rugged beyond them.
STEPS = np.array((0.02, 0.02, 0.01, 0.02, 0.02, 0.03, 0.03, 0.05))
MAX_MOVES = np.array((0.5, 0.5, 0.5, 1.0, 1.0, 0.3, 0.3, 0.5))
# Radii and aspects a fit may take (log units): beyond them a runaway fit renders huge grids.
_LOG_RADIUS = (math.log(0.05), math.log(4.0))
_LOG_ASPECT = (-0.9, 0.9)
# Fine samples per taxel: at least 24 (where this render equals the simulator's to 1e-11
# counts) and twelve over the smaller semi-axis.
_SUB = (24, 48)
_ROBUST_SHARE = 0.05
_RADIUS_SCALES = (0.5, 0.63, 0.8, 1.0, 1.25, 1.6)


@dataclass(frozen=True)
class TaxelModel:
    """
    A skin's taxels as the forward model sees them (module docstring); SI units.

    ``presses`` is how many presses taught it and ``misfit_counts`` their rms residual.
    """

    pitch_m: float
    fill_factor: float
    cover_spread_m: float
    layer_spread_m: float
    film_scale: float
    film_exponent: float
    film_ceiling: float
    film_activation_n: float = 0.0
    turn_on_pa: float = 0.0
    film_step: float = 0.0
    full_scale: float = 4095.0
    presses: int = 0
    misfit_counts: float = 0.0

    def __post_init__(self):
        """Reject a model that renders nothing sensible."""
        for name in ('pitch_m', 'film_scale', 'film_exponent', 'film_ceiling', 'full_scale'):
            check_number(getattr(self, name), f'taxel model {name}', positive=True)
        for name in ('cover_spread_m', 'layer_spread_m', 'film_activation_n', 'turn_on_pa',
                     'film_step', 'misfit_counts'):
            check_number(getattr(self, name), f'taxel model {name}', non_negative=True)
        if not 0 < self.fill_factor <= 1:
            raise ValueError(f'taxel model fill_factor must be in (0, 1], got {self.fill_factor}')

    def counts(self, force_n: np.ndarray) -> np.ndarray:
        """Return the film's counts for per-taxel loads (newtons)."""
        load = np.maximum(force_n - self.film_activation_n, 0.0)
        g = np.minimum(self.film_scale * load ** self.film_exponent,
                       self.film_ceiling)
        if self.film_step > 0:
            g = np.where(force_n > 0, np.maximum(g, self.film_step), g)
        return self.full_scale * g / (1.0 + g)

    def blurs_taxels(self) -> tuple:
        """Return the (top, bottom) Gaussian blur in taxels."""
        cover = self.cover_spread_m / self.pitch_m
        return cover, math.hypot(cover, self.layer_spread_m / self.pitch_m)

    def to_dict(self) -> dict:
        """Return the model as plain numbers (the calibration file)."""
        return {k: float(v) if k != 'presses' else int(v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, doc) -> 'TaxelModel':
        """Build the model from its mapping; raise ValueError on a missing or bad field."""
        if not isinstance(doc, dict):
            raise ValueError('taxel_model must be a mapping')
        names = set(cls.__dataclass_fields__)
        unknown = set(doc) - names
        if unknown:
            raise ValueError(f'taxel_model has unknown fields {sorted(unknown)}')
        return cls(**doc)


@dataclass(frozen=True)
class PressFit:
    """A fitted press: its parameters (see the module's indices) and its misfit (counts**2)."""

    u: np.ndarray
    misfit: float


def hertz_profile(x: np.ndarray, y: np.ndarray, cx: float, cy: float, a: float,
                  aspect: float = 1.0, orientation: float = 0.0) -> np.ndarray:
    """
    Return a Hertz tip's pressure shape ``sqrt(1 - r**2)`` on the grid of ``x`` by ``y``.

    The ellipse has semi-axes ``a`` and ``a * aspect``, the first turned by ``orientation``
    from +x; rows follow ``y``. The simulator's presses take the same shape (its own code).
    """
    if aspect == 1.0:
        r2 = (((x - cx) ** 2)[None, :] + ((y - cy) ** 2)[:, None]) / (a * a)
    else:
        c, s = math.cos(orientation), math.sin(orientation)
        dx, dy = (x - cx)[None, :], (y - cy)[:, None]
        b = a * aspect
        r2 = ((dx * c + dy * s) / a) ** 2 + ((dy * c - dx * s) / b) ** 2
    return np.sqrt(np.maximum(1.0 - r2, 0.0))


def _layer(shape: tuple, cx: float, cy: float, u: np.ndarray, blur: float, fill: float,
           sub: int, turn_on: float = 0.0) -> np.ndarray:
    """
    Return one layer's per-taxel load (the press's normal force spread over the window).

    ``turn_on``: the film's turn-on load per taxel area (newtons), 0 for none.
    """
    h, w = shape
    a = math.exp(min(max(u[LOG_RADIUS], _LOG_RADIUS[0]), _LOG_RADIUS[1]))
    aspect = math.exp(min(max(u[LOG_ASPECT], _LOG_ASPECT[0]), _LOG_ASPECT[1]))
    reach = a * max(aspect, 1.0)
    # The fine axes run past the window by what the blur and the tip reach, so that load just
    # off the window still blurs onto it.
    margin = int(math.ceil(reach + 4.0 * blur)) + 1
    step = 1.0 / sub

    def axis(centre, cells):
        # The fine samples within the tip's reach of its centre (index 0 is the first sample
        # of the cell ``-margin``): the profile is zero beyond them.
        origin = margin + 0.5
        lo = max(int(math.floor((centre - reach + origin) * sub - 0.5)), 0)
        hi = min(int(math.ceil((centre + reach + origin) * sub - 0.5)) + 1,
                 (cells + 2 * margin) * sub)
        if hi <= lo:
            return None
        return lo, (np.arange(lo, hi) + 0.5) * step - origin

    ax, ay = axis(cx, w), axis(cy, h)
    if ax is None or ay is None:
        return np.zeros(shape)
    (x0, xs), (y0, ys) = ax, ay
    fine = hertz_profile(xs, ys, cx, cy, a, aspect, u[ORIENTATION])
    total = fine.sum()
    if total <= 0:
        return np.zeros(shape)
    blur_px = blur * sub
    fine *= math.exp(u[LOG_FORCE]) / total
    if turn_on > 0:
        return _sensed(fine, (h, w), margin, sub, (y0, x0), fill, blur_px,
                       turn_on / (sub * sub))
    op_y = axis_operator(h + 2 * margin, sub, fill, blur_px)[margin:margin + h,
                                                             y0:y0 + ys.size]
    op_x = axis_operator(w + 2 * margin, sub, fill, blur_px)[margin:margin + w,
                                                             x0:x0 + xs.size]
    return op_y @ fine @ op_x.T


def _sensed(fine: np.ndarray, shape: tuple, margin: int, sub: int, start: tuple, fill: float,
            blur_px: float, threshold: float) -> np.ndarray:
    """
    Return the per-taxel load a turn-on film senses: blurred on the fine grid, cut, summed.

    ``fine`` holds newtons per fine sample from index ``start`` (y, x) of the extended axes;
    ``threshold`` is the turn-on load per fine sample.
    """
    reach = int(math.ceil(4.0 * blur_px)) + 1
    ops = []
    for n, cells, first in ((fine.shape[0], shape[0], start[0]),
                            (fine.shape[1], shape[1], start[1])):
        total = (cells + 2 * margin) * sub
        lo, hi = max(first - reach, 0), min(first + n + reach, total)
        spread = blur_block(lo, hi - lo, first, n, blur_px)
        sums = gather(cells + 2 * margin, sub, fill)[margin:margin + cells, lo:hi]
        ops.append((spread, sums))
    (spread_y, sums_y), (spread_x, sums_x) = ops
    load = spread_y @ fine @ spread_x.T
    load[load <= threshold] = 0.0
    return sums_y @ load @ sums_x.T


def render_counts(model: TaxelModel, shape: tuple, u: np.ndarray, sub: int,
                  sensitivity: np.ndarray = None) -> np.ndarray:
    """
    Return the (2, h, w) counts of one press ``u`` on a window of ``shape``.

    ``sensitivity`` (2, h, w) multiplies each taxel's load before the film: the inverse of the
    calibrated per-taxel gains (:mod:`gains`), None for even taxels.
    """
    top_blur, bottom_blur = model.blurs_taxels()
    fill = float(model.fill_factor)
    turn_on = model.turn_on_pa * model.pitch_m ** 2
    top = _layer(shape, u[X], u[Y], u, top_blur, fill, sub, turn_on)
    bottom = _layer(shape, u[X] + u[DX], u[Y] + u[DY], u, bottom_blur, fill, sub, turn_on)
    load = np.stack((top, bottom))
    return model.counts(load if sensitivity is None else load * sensitivity)


def residuals(model: TaxelModel, counts: np.ndarray, censored: np.ndarray, u: np.ndarray,
              sub: int, sensitivity: np.ndarray = None) -> np.ndarray:
    """
    Return the counts' residuals, a censored taxel's only where the model reads below it.

    Residuals beyond a twentieth of the ADC's range weigh as their length, not its square
    (pseudo-Huber): such a taxel is on the other side of a film's cliff (a rim taxel that a
    taxel's own gain turned on or off), not noise, and a few of them would outweigh the rest.
    """
    r = render_counts(model, counts.shape[1:], u, sub, sensitivity) - counts
    if censored is not None:
        r = np.where(censored & (r > 0), 0.0, r)
    scale = model.full_scale * _ROBUST_SHARE
    r = r.ravel() / scale
    return np.sign(r) * scale * np.sqrt(2.0 * (np.sqrt(1.0 + r * r) - 1.0))


def levenberg_marquardt(residual, u: np.ndarray, free: np.ndarray, iterations: int) -> tuple:
    """
    Return (u, misfit) minimising ``residual(u) @ residual(u)`` over the ``free`` parameters.

    Forward-difference Jacobian (steps :data:`STEPS`), each move scaled into :data:`MAX_MOVES`
    (:func:`skin_driver.core.common.least_squares.levenberg_marquardt`).
    """
    base = np.array(u, dtype=np.float64)
    idx = np.flatnonzero(free)

    def of(x):
        full = base.copy()
        full[idx] = x
        return full

    def free_residual(x):
        return residual(of(x))
    fit = least_squares.levenberg_marquardt(
        free_residual, base[idx], iterations=iterations,
        jacobian=least_squares.forward_jacobian(free_residual, STEPS[idx]),
        limit=least_squares.scaled_into(MAX_MOVES[idx]), stop_move=1e-4)
    return of(fit.x), fit.cost


def start_of(maps: np.ndarray, shift: tuple, model: TaxelModel) -> np.ndarray:
    """
    Return a press's start from its window's (2, h, w) force maps and a first shift (taxels).

    Centre: the top's centroid; force: the larger layer sum over the pad's share; radius: the
    top's second moment less the cover blur and the pad's own (a Hertz disc's is a**2 / 5).
    """
    top = maps[0]
    mass = top.sum()
    h, w = top.shape
    xs, ys = np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)
    cx = float(top.sum(axis=0) @ xs / mass)
    cy = float(top.sum(axis=1) @ ys / mass)
    var = float((top.sum(axis=0) @ (xs - cx) ** 2 + top.sum(axis=1) @ (ys - cy) ** 2)
                / (2.0 * mass))
    cover = model.blurs_taxels()[0]
    radius = math.sqrt(5.0 * max(var - cover * cover - 1.0 / 12.0, 0.01))
    force = max(float(maps[0].sum()), float(maps[1].sum())) / model.fill_factor ** 2
    u = np.zeros(8)
    u[X], u[Y], u[DX], u[DY] = cx, cy, shift[0], shift[1]
    u[LOG_FORCE] = math.log(max(force, 1e-3))
    u[LOG_RADIUS] = math.log(min(max(radius, 0.1), 3.0))
    return u


def sub_for(u: np.ndarray) -> int:
    """Return the fine samples per taxel for a press of ``u``'s size (fixed through a fit)."""
    small = math.exp(u[LOG_RADIUS]) * min(math.exp(u[LOG_ASPECT]), 1.0)
    return int(min(max(math.ceil(12.0 / max(small, 1e-3)), _SUB[0]), _SUB[1]))


def best_radius(residual, u: np.ndarray) -> np.ndarray:
    """
    Return ``u`` with the tip radius of least misfit among a few around its own.

    The moments a start takes its radius from misread flat-topped or stepped imprints, and a
    fit started at the wrong size stops on the film's cliffs.
    """
    best, least = u, math.inf
    for scale in _RADIUS_SCALES:
        v = u.copy()
        v[LOG_RADIUS] += math.log(scale)
        r = residual(v)
        cost = float(r @ r)
        if cost < least:
            best, least = v, cost
    return best
