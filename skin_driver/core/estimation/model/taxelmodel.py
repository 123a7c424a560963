"""
A forward model of the taxels with the skin's own parameters, and its fit to presses.

Where ``taxel_fit`` (the kernel's taxel_fit.c) describes each imprint by Gaussians, this model
renders the counts a press gives and fits them (issue #16, docs/estimation.md "The forward
model"):

* the tip loads the top layer with a Hertz profile ``sqrt(1 - r**2)`` over an ellipse (semi-axes
  ``a`` and ``a * aspect``, turned by ``orientation``) whose integral is the normal force;
* the cover blurs it by a Gaussian (``cover_spread_m``); the bottom layer sees it blurred by
  the elastic layer too (``layer_spread_m``, added in quadrature) and displaced by the shift;
* each taxel sums the load over its active pad (``fill_factor`` of the pitch);
* the film turns a taxel's load ``f`` into counts through the divider:
  ``counts = full_scale * g / (1 + g)``, ``g = min(film_scale * (f - film_activation_n)**
  film_exponent, film_ceiling)`` (an FSR is open below its activation load; its conductance then
  grows as a power of force up to its resistance floor). The activation matters: the law is
  steep at small loads, so a blur's tails would read hundreds of counts without it;
* a film may also stay open where its local pressure (after the blur) is below
  ``turn_on_pa``: a taxel then reads only the load where it is exceeded, and with
  ``film_step`` (a conductance ratio like ``g``) it reads at least that as soon as any of it
  conducts. Imprints get cliffs at their rims; the blur and the turn-on then act on the fine
  grid, a few times the cost of a smooth film's render.

None of the skin's numbers is assumed: :mod:`taxellearn` learns them from the presses of known
force a force calibration records, and the calibration keeps them (:class:`TaxelModel`). The
model is written once, in the compiled kernel (``skin_kernel/src/model_fit.c``): a scan's
contact is fitted there (bound as :func:`skin_driver.core.estimation.scan.kernel.fit_contact`:
Levenberg-Marquardt on its window's tared counts, taxels the film saturated or the ADC clipped
censored (taken as lower bounds); a round tip first, then an elliptical one from four
orientations, the least misfit kept: the misfit of narrow imprints is rugged, so one start
stops in side minima), and the learning renders and weighs its presses through the same code
(:func:`render_counts`, :func:`residuals`, :func:`start_of`, :func:`sub_for`:
``sk_model_render``, ...) and fits each press alone with the kernel's fit (:func:`fit_press`);
its joint fit of the skin and its presses takes the kernel's steps and moves
(:func:`fit_numbers`).
"""

from __future__ import annotations

import ctypes
from dataclasses import asdict, dataclass
from functools import lru_cache
import math
from typing import NamedTuple

import numpy as np

from ..scan.kernel import load_library, taxel_model_of
from ...common.validate import check_number

__all__ = ['TaxelModel', 'PressFit', 'FitNumbers', 'hertz_profile', 'render_counts',
           'residuals', 'fit_press', 'start_of', 'sub_for', 'fit_numbers']

# Per-press parameters: centre x, y (taxels of the window), log normal force (N), shift dx, dy
# (taxels), log tip radius (taxels), log aspect, orientation (rad).
X, Y, LOG_FORCE, DX, DY, LOG_RADIUS, LOG_ASPECT, ORIENTATION = range(8)


class FitNumbers(NamedTuple):
    """The kernel's fit numbers (``sk_model_steps``), per parameter in ``u``'s order."""

    steps: np.ndarray          # finite-difference steps
    max_moves: np.ndarray      # the largest a Levenberg-Marquardt move may take
    radius_scales: np.ndarray  # the tip radii tried around a start (:func:`fit_press`)


@lru_cache(maxsize=1)
def fit_numbers() -> FitNumbers:
    """
    Return the kernel's steps and moves of a press's parameters and its radius scales.

    (taxels, log units, radians): a narrow imprint's misfit is rugged beyond them.
    """
    out = FitNumbers(np.zeros(8), np.zeros(8), np.zeros(6))
    load_library().sk_model_steps(*(a.ctypes.data_as(ctypes.c_void_p) for a in out))
    for a in out:
        a.flags.writeable = False
    return out


def _address(array):
    return None if array is None else array.ctypes.data_as(ctypes.c_void_p)


def _window(array, shape: tuple, dtype) -> np.ndarray:
    """Return ``array`` (None: None) as a C-ordered (2, h, w) array of ``dtype``."""
    if array is None:
        return None
    return np.ascontiguousarray(np.broadcast_to(array, (2,) + tuple(shape)), dtype=dtype)


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
    from +x; rows follow ``y``. The simulator's presses take the same shape (its own code); the
    estimator's model renders it in the kernel (model_fit.c).
    """
    if aspect == 1.0:
        r2 = (((x - cx) ** 2)[None, :] + ((y - cy) ** 2)[:, None]) / (a * a)
    else:
        c, s = math.cos(orientation), math.sin(orientation)
        dx, dy = (x - cx)[None, :], (y - cy)[:, None]
        b = a * aspect
        r2 = ((dx * c + dy * s) / a) ** 2 + ((dy * c - dx * s) / b) ** 2
    return np.sqrt(np.maximum(1.0 - r2, 0.0))


def render_counts(model: TaxelModel, shape: tuple, u: np.ndarray, sub: int,
                  sensitivity: np.ndarray = None) -> np.ndarray:
    """
    Return the (2, h, w) counts of one press ``u`` on a window of ``shape`` (``sk_model_render``).

    ``sub``: fine samples a taxel. ``sensitivity`` (2, h, w) multiplies each taxel's load before
    the film: the inverse of the calibrated per-taxel gains (:mod:`gains`), None for even taxels.
    """
    h, w = (int(v) for v in shape)
    numbers = taxel_model_of(model)
    out = np.zeros((2, h, w))
    press = np.ascontiguousarray(u, dtype=np.float64)
    status = load_library().sk_model_render(ctypes.byref(numbers), h, w, _address(press),
                                            int(sub),
                                            _address(_window(sensitivity, (h, w), np.float64)),
                                            _address(out))
    if status != 0:
        raise MemoryError(f'skin_kernel: no memory to render a {h} x {w} window')
    return out


def residuals(model: TaxelModel, counts: np.ndarray, censored: np.ndarray, u: np.ndarray,
              sub: int, sensitivity: np.ndarray = None) -> np.ndarray:
    """
    Return the counts' residuals, a censored taxel's only where the model reads below it.

    The kernel's (``sk_model_residuals``), flattened: residuals beyond a twentieth of the ADC's
    range weigh as their length, not its square (pseudo-Huber): such a taxel is on the other
    side of a film's cliff (a rim taxel that a taxel's own gain turned on or off), not noise,
    and a few of them would outweigh the rest.
    """
    counts = np.ascontiguousarray(counts, dtype=np.float64)
    h, w = counts.shape[1:]
    numbers = taxel_model_of(model)
    press = np.ascontiguousarray(u, dtype=np.float64)
    out = np.zeros(counts.size)
    misfit = ctypes.c_double()
    status = load_library().sk_model_residuals(
        ctypes.byref(numbers), h, w, _address(counts),
        _address(_window(censored, (h, w), np.uint8)),
        _address(_window(sensitivity, (h, w), np.float64)), _address(press), int(sub),
        _address(out), ctypes.byref(misfit))
    if status != 0:
        raise MemoryError(f'skin_kernel: no memory to render a {h} x {w} window')
    return out


def fit_press(model: TaxelModel, counts: np.ndarray, censored: np.ndarray, u0: np.ndarray,
              free: np.ndarray, iterations: int, sensitivity: np.ndarray = None) -> PressFit:
    """
    Return the kernel's fit of press ``u0`` to a window's counts, only ``free`` parameters moved.

    ``sk_model_fit_free``: the tip radius of least misfit among a few around the start's, then
    Levenberg-Marquardt over the parameters ``free`` marks (8 bools in ``u``'s order) for at
    most ``iterations`` trials, at the fine samples :func:`sub_for` picks for ``u0``.
    ``censored`` and ``sensitivity`` as :func:`residuals`'.
    """
    counts = np.ascontiguousarray(counts, dtype=np.float64)
    h, w = counts.shape[1:]
    numbers = taxel_model_of(model)
    start = np.ascontiguousarray(u0, dtype=np.float64)
    flags = np.ascontiguousarray(free, dtype=np.intc)
    u = np.zeros(8)
    misfit = ctypes.c_double()
    status = load_library().sk_model_fit_free(
        ctypes.byref(numbers), h, w, _address(counts),
        _address(_window(censored, (h, w), np.uint8)),
        _address(_window(sensitivity, (h, w), np.float64)), _address(start), _address(flags),
        int(iterations), _address(u), ctypes.byref(misfit))
    if status != 0:
        raise MemoryError(f'skin_kernel: no memory to fit a {h} x {w} window')
    return PressFit(u, misfit.value)


def start_of(maps: np.ndarray, shift: tuple, model: TaxelModel) -> np.ndarray:
    """
    Return a press's start from its window's (2, h, w) force maps and a first shift (taxels).

    The kernel's (``sk_model_start``). Centre: the top's centroid; force: the larger layer sum
    over the pad's share; radius: the top's second moment less the cover blur and the pad's own
    (a Hertz disc's is a**2 / 5).
    """
    maps = np.ascontiguousarray(maps, dtype=np.float64)
    numbers = taxel_model_of(model)
    u = np.zeros(8)
    load_library().sk_model_start(ctypes.byref(numbers), _address(maps), maps.shape[1],
                                  maps.shape[2], _address(u))
    u[DX], u[DY] = shift[0], shift[1]
    return u


def sub_for(u: np.ndarray) -> int:
    """Return the fine samples per taxel for a press of ``u``'s size (``sk_model_sub``)."""
    return int(load_library().sk_model_sub(_address(np.ascontiguousarray(u,
                                                                         dtype=np.float64))))
