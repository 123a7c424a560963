"""
Simulation physics of the two-layer FSR skin: indenter pressure, layer shift, FSR and ADC.

The model follows the seed paper's construction (two 16 x 16 FSR matrices, ~5 mm taxels, an elastic
layer between them, a 12-bit ADC reading each FSR through a voltage divider):

* An indenter of contact radius ``radius_m`` pressing with total force ``force_n`` tilted by
  ``alpha`` from the skin normal loads the top layer with a Hertz pressure profile
  ``p(r) = p0 * sqrt(1 - r**2 / a**2)`` whose integral is the normal part ``force_n * cos(alpha)``.
  An elliptical indenter has semi-axes ``radius_m`` and ``radius_m * aspect``, the first turned
  by ``orientation_rad`` from +x.
* Each taxel integrates the pressure over its active square (``fill_factor * pitch`` wide), so a
  contact that moves by a fraction of a taxel changes the map.
* The bottom layer sees the same profile blurred by the elastic layer (Gaussian of ``spread_m``)
  and displaced along the tangential force (the seed's convention):
  ``shift = misalignment + compliance * force_n * sin(alpha) * (cos(beta), sin(beta))``.
* Each taxel's force, times its own gain (``gain_spread``: FSRs differ by up to that fraction),
  becomes ADC counts through the film (:class:`.fsr.FsrFilm`); then come an amplifier offset
  with a per-taxel spread (``baseline_spread_counts``), row/column crosstalk of the passive
  matrix (a share ``crosstalk`` of the load of every other taxel on the same row and column),
  Gaussian noise, dead taxels and 12-bit clipping. Per-taxel gains and offsets are fixed by the
  skin's ``seed``.

Optional physics of real films and tips (all off by default, so older skins render unchanged):

* ``turn_on_pa``: the film is open where its local pressure (after the cover's or the layer's
  blur) is below this; a taxel senses only the load where it is exceeded, and with
  ``turn_on_ohm`` its resistance steps from open to that value as soon as any of it conducts:
  imprints get cliffs at their rims.
* ``hertz_reference_n``: a soft hemispherical tip whose contact radius grows as the cube root
  of the normal force (Hertz); ``Press.radius_m`` is the radius at this normal force.
* ``normal_shift_m_per_n``: the bottom imprint also moves with the normal load (an anisotropic
  or pre-sheared layer), so the zero shift depends on how hard one presses.
* The film's resistance floor ``FsrFilm.r_min_ohm`` is a hard saturation already.
* ``drift`` (:mod:`.drift`): creep under load and drift of the offsets over time; only
  :func:`render_held`, which takes a time, renders it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
import math
from typing import Sequence

import numpy as np

from .contact import hertz_pressure, pad_sum, spread, taxel_operator
from .drift import creep_factor, Drift, offset_counts
from .fsr import FsrFilm

__all__ = ['SkinModel', 'Press', 'render', 'render_plate', 'render_force', 'render_expected',
           'expected_counts', 'layer_shift_m', 'taxel_spread', 'contact_radius_m', 'render_held',
           'drift_spread']


@dataclass(frozen=True)
class Press:
    """One indenter acting on the skin; position in the skin frame, angles in radians."""

    x_m: float
    y_m: float
    force_n: float
    alpha_rad: float = 0.0
    beta_rad: float = 0.0
    radius_m: float = 0.0025
    aspect: float = 1.0
    orientation_rad: float = 0.0

    def __post_init__(self):
        """Reject non-finite or out-of-range values."""
        for name in ('x_m', 'y_m', 'force_n', 'alpha_rad', 'beta_rad', 'radius_m', 'aspect',
                     'orientation_rad'):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f'Press.{name} must be finite')
        if self.force_n < 0:
            raise ValueError('Press.force_n must be non-negative')
        if self.radius_m <= 0 or self.aspect <= 0:
            raise ValueError('Press.radius_m and Press.aspect must be positive')
        if not 0 <= self.alpha_rad < math.pi / 2:
            raise ValueError('Press.alpha_rad must be in [0, pi/2)')

    @property
    def normal_force_n(self) -> float:
        """Return the force component along the skin normal."""
        return self.force_n * math.cos(self.alpha_rad)

    @property
    def tangential_force_n(self) -> float:
        """Return the magnitude of the tangential force component."""
        return self.force_n * math.sin(self.alpha_rad)


@dataclass(frozen=True)
class SkinModel:
    """
    Geometry, mechanics and electronics of a simulated two-layer skin.

    Defaults match the seed's prototype: 16 x 16 taxels at 5 mm; a 10 N press tilted by 45 degrees
    shifts the layers by about one taxel; a 10 N press reads well below saturation. The elastic
    layer soft enough for that shift is a few millimetres thick, so it spreads the pressure by a
    Gaussian of ``spread_m`` = 2 mm; the protective cover and FSR film spread the top layer's
    pressure by ``cover_spread_m`` = 1 mm. ``fill_factor`` is the sensitive fraction of the pitch.
    ``dead_taxels`` holds ``(row, col)`` (both layers) or ``(layer, row, col)`` with layer 0 = top,
    1 = bottom; a dead taxel reads 0. ``gain_spread`` (a fraction, uniform in +-) and
    ``baseline_spread_counts`` (standard deviation) make taxels differ; ``seed`` fixes which.
    """

    rows: int = 16
    cols: int = 16
    pitch_m: float = 0.005
    compliance_m_per_n: float = 7.0e-4
    spread_m: float = 0.002
    noise_counts: float = 6.0
    crosstalk: float = 0.0
    dead_taxels: tuple = ()
    misalignment_m: tuple = (0.0, 0.0)
    fsr: FsrFilm = field(default_factory=FsrFilm)
    fill_factor: float = 0.9
    baseline_counts: float = 20.0
    cover_spread_m: float = 0.001
    gain_spread: float = 0.0
    baseline_spread_counts: float = 0.0
    seed: int = 0
    turn_on_pa: float = 0.0
    turn_on_ohm: float = 0.0
    hertz_reference_n: float = 0.0
    normal_shift_m_per_n: tuple = (0.0, 0.0)
    drift: Drift = Drift()

    def __post_init__(self):
        """Reject inconsistent parameters."""
        if int(self.rows) < 1 or int(self.cols) < 1:
            raise ValueError('SkinModel rows and cols must be at least 1')
        for name in ('pitch_m', 'compliance_m_per_n', 'spread_m', 'noise_counts', 'crosstalk',
                     'fill_factor', 'baseline_counts', 'cover_spread_m', 'gain_spread',
                     'baseline_spread_counts', 'turn_on_pa', 'turn_on_ohm',
                     'hertz_reference_n'):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f'SkinModel.{name} must be finite and non-negative')
        if self.gain_spread >= 1:
            raise ValueError('SkinModel.gain_spread must be below 1')
        if self.pitch_m <= 0 or not 0 < self.fill_factor <= 1:
            raise ValueError('SkinModel needs pitch_m > 0 and 0 < fill_factor <= 1')
        for name in ('misalignment_m', 'normal_shift_m_per_n'):
            v = getattr(self, name)
            if len(v) != 2 or not all(math.isfinite(x) for x in v):
                raise ValueError(f'SkinModel.{name} must be two finite numbers')
        if not isinstance(self.fsr, FsrFilm):
            # The driver's assumed film is another thing: the truth is the simulator's own.
            raise TypeError('SkinModel.fsr must be a core.sim.fsr.FsrFilm, '
                            f'not {type(self.fsr).__name__}')
        if self.turn_on_ohm > 0 and not self.turn_on_pa > 0:
            # Without a turn-on pressure every blur tail would step the film on.
            raise ValueError('SkinModel.turn_on_ohm needs turn_on_pa > 0')
        for t in self.dead_taxels:
            if len(t) not in (2, 3):
                raise ValueError('dead_taxels entries are (row, col) or (layer, row, col)')


def layer_shift_m(model: SkinModel, press: Press) -> tuple:
    """Return the (x, y) displacement of the bottom map relative to the top one, in metres."""
    t = model.compliance_m_per_n * press.tangential_force_n
    fz = press.normal_force_n
    return (model.misalignment_m[0] + model.normal_shift_m_per_n[0] * fz
            + t * math.cos(press.beta_rad),
            model.misalignment_m[1] + model.normal_shift_m_per_n[1] * fz
            + t * math.sin(press.beta_rad))


def contact_radius_m(model: SkinModel, press: Press) -> float:
    """Return the contact radius of the press: its own, or grown with the load (Hertz)."""
    if model.hertz_reference_n <= 0:
        return press.radius_m
    load = max(press.normal_force_n, 1e-6) / model.hertz_reference_n
    return press.radius_m * load ** (1.0 / 3.0)


def _support(coords: np.ndarray, centre: float, radius: float) -> tuple:
    """Return the index range of the fine samples within ``radius`` of ``centre`` on one axis."""
    inside = np.flatnonzero((coords - centre) ** 2 < radius * radius)
    if inside.size == 0:
        return 0, 0
    return int(inside[0]), int(inside[-1]) + 1


# A press held at full force is the same press frame after frame: rendered once (a plate over
# the whole skin takes milliseconds, more than a frame's share of a loaded machine).
@lru_cache(maxsize=32)
def _press_maps(model: SkinModel, press: Press) -> tuple:
    """Return per-taxel force maps (top, bottom) of one press, before the FSR (read-only)."""
    pitch = model.pitch_m
    top = np.zeros((model.rows, model.cols))
    bottom = np.zeros_like(top)
    fz = press.normal_force_n
    if fz <= 0:
        return top, bottom
    sx, sy = layer_shift_m(model, press)
    radius = contact_radius_m(model, press)
    if radius != press.radius_m:
        press = Press(press.x_m, press.y_m, press.force_n, press.alpha_rad, press.beta_rad,
                      radius, press.aspect, press.orientation_rad)
    a = press.radius_m * max(press.aspect, 1.0)
    h = min(pitch / 24.0, press.radius_m * min(press.aspect, 1.0) / 12.0)
    sub = int(math.ceil(pitch / h))
    h = pitch / sub
    # The cover spreads the pressure on the top layer; the elastic layer adds its own spread.
    cover = model.cover_spread_m
    sigma = math.hypot(cover, model.spread_m)
    fill = float(model.fill_factor)
    for layer, (cx, cy), blur in ((top, (press.x_m, press.y_m), cover),
                                  (bottom, (press.x_m + sx, press.y_m + sy), sigma)):
        reach = a + 4.0 * blur + h
        c0 = int(math.floor((cx - reach) / pitch + 0.5))
        c1 = int(math.floor((cx + reach) / pitch + 0.5)) + 1
        r0 = int(math.floor((cy - reach) / pitch + 0.5))
        r1 = int(math.floor((cy + reach) / pitch + 0.5)) + 1
        if c1 <= 0 or r1 <= 0 or c0 >= model.cols or r0 >= model.rows:
            continue
        # Pressure further off the skin than the blur reaches loads no taxel: a plate larger
        # than the skin is evaluated over the skin and that margin only (in time for every
        # frame), its total force taken from the whole disc.
        margin = int(math.ceil(4.0 * blur / pitch)) + 1
        clipped = (c0 < -margin or r0 < -margin or c1 > model.cols + margin
                   or r1 > model.rows + margin)
        c0, r0 = max(c0, -margin), max(r0, -margin)
        c1, r1 = min(c1, model.cols + margin), min(r1, model.rows + margin)
        xs = (c0 - 0.5) * pitch + (np.arange((c1 - c0) * sub) + 0.5) * h
        ys = (r0 - 0.5) * pitch + (np.arange((r1 - r0) * sub) + 0.5) * h
        # The Hertz profile is zero outside the disc: evaluate it on the disc's bounding box only.
        x0, x1 = _support(xs, cx, a)
        y0, y1 = _support(ys, cy, a)
        fine = hertz_pressure(xs[x0:x1], ys[y0:y1], (cx, cy), press.radius_m, press.aspect,
                              press.orientation_rad)
        # The integral of the Hertz profile over its ellipse is 2/3 pi a b (in samples of h^2).
        total = (2.0 / 3.0 * math.pi * press.radius_m ** 2 * press.aspect / (h * h)
                 if clipped else fine.sum())
        if total <= 0:
            # The disc fell between fine samples; put the whole force on the nearest sample.
            y0 = int(np.argmin(np.abs(ys - cy)))
            x0 = int(np.argmin(np.abs(xs - cx)))
            y1, x1 = y0 + 1, x0 + 1
            fine = np.ones((1, 1))
            total = 1.0
        blur_px = blur / h if blur > 0 else 0.0
        if model.turn_on_pa > 0:
            cells = _sensed_cells(model, fine * (fz / total), (r1 - r0, c1 - c0), sub,
                                  (y0, y1, x0, x1), blur_px, h)
        else:
            op_y = taxel_operator(r1 - r0, sub, fill, blur_px)
            op_x = op_y if c1 - c0 == r1 - r0 else taxel_operator(c1 - c0, sub, fill, blur_px)
            cells = (op_y[:, y0:y1] @ fine @ op_x[:, x0:x1].T) * (fz / total)
        rr0, cc0 = max(r0, 0), max(c0, 0)
        rr1, cc1 = min(r1, model.rows), min(c1, model.cols)
        layer[rr0:rr1, cc0:cc1] += cells[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0]
    top.flags.writeable = False
    bottom.flags.writeable = False
    return top, bottom


def _sensed_cells(model: SkinModel, fine: np.ndarray, cells: tuple, sub: int, support: tuple,
                  blur_px: float, h: float) -> np.ndarray:
    """
    Return the force per taxel that the film senses where it is turned on.

    ``fine`` holds newtons per fine sample on the support box of the window. The turn-on acts
    on the local pressure after the blur, so the blur and the cell sums cannot fold into one
    operator: blur on the fine grid, zero below the turn-on, then sum per cell.
    """
    y0, y1, x0, x1 = support
    rows, cols = cells
    if blur_px > 0:
        by, bx = spread(rows * sub, blur_px), spread(cols * sub, blur_px)
        load = by[:, y0:y1] @ fine @ bx[:, x0:x1].T
    else:
        load = np.zeros((rows * sub, cols * sub))
        load[y0:y1, x0:x1] = fine
    load = np.where(load > model.turn_on_pa * h * h, load, 0.0)
    fill = float(model.fill_factor)
    return pad_sum(rows, sub, fill) @ load @ pad_sum(cols, sub, fill).T


def render_force(model: SkinModel, presses: Sequence[Press]) -> tuple:
    """Return noise-free per-taxel normal force maps (top, bottom) in newtons."""
    top = np.zeros((model.rows, model.cols))
    bottom = np.zeros_like(top)
    for p in presses:
        t, b = _press_maps(model, p)
        top += t
        bottom += b
    return top, bottom


@lru_cache(maxsize=64)
def taxel_spread(model: SkinModel) -> tuple:
    """Return per-layer (gain, baseline offset) maps, 2 x rows x cols each, fixed by the seed."""
    rng = np.random.default_rng(model.seed)
    shape = (2, model.rows, model.cols)
    gain = 1.0 + model.gain_spread * rng.uniform(-1.0, 1.0, shape)
    offset = model.baseline_counts + model.baseline_spread_counts * rng.standard_normal(shape)
    gain.flags.writeable = False
    offset.flags.writeable = False
    return gain, offset


@lru_cache(maxsize=64)
def drift_spread(model: SkinModel) -> tuple:
    """Return per-layer (creep rate, offset drift factor) maps, 2 x rows x cols, by the seed."""
    # A stream of its own: the gains and offsets of a seed stay those it always had.
    rng = np.random.default_rng([model.seed, 0xD71F7])
    shape = (2, model.rows, model.cols)
    d = model.drift
    rate = d.creep_per_decade * (1.0 + d.creep_spread * rng.uniform(-1.0, 1.0, shape))
    factor = 1.0 + d.offset_spread * rng.standard_normal(shape)
    rate.flags.writeable = False
    factor.flags.writeable = False
    return rate, factor


def _film_counts(model: SkinModel, force: np.ndarray, layer: int,
                 drift: np.ndarray = None) -> np.ndarray:
    """Return noise-free counts of one layer's force map: FSR, step, offset, crosstalk."""
    gain, offset = taxel_spread(model)
    if drift is not None:
        offset = offset + drift
    fsr = model.fsr
    counts = fsr.force_to_counts(force * gain[layer])
    if model.turn_on_ohm > 0:
        step = fsr.full_scale * fsr.r_series_ohm / (fsr.r_series_ohm + model.turn_on_ohm)
        counts = np.where(force > 0, np.maximum(counts, step), counts)
    counts = counts + offset[layer]
    if model.crosstalk > 0:
        # Crosstalk: a passive matrix reads a little of every taxel sharing the row or the column.
        shared = counts.sum(axis=1, keepdims=True) + counts.sum(axis=0, keepdims=True) - 2 * counts
        counts = counts + model.crosstalk * shared
    return counts


def _kill_dead(model: SkinModel, counts: np.ndarray, layer: int) -> np.ndarray:
    for t in model.dead_taxels:
        if len(t) == 3 and int(t[0]) != layer:
            continue
        r, c = int(t[-2]), int(t[-1])
        if 0 <= r < model.rows and 0 <= c < model.cols:
            counts[r, c] = 0.0
    return counts


def _electronics(model: SkinModel, force: np.ndarray, layer: int,
                 rng: np.random.Generator, drift: np.ndarray = None) -> np.ndarray:
    counts = _film_counts(model, force, layer, drift)
    if model.noise_counts > 0:
        counts = counts + rng.normal(0.0, model.noise_counts, counts.shape)
    counts = _kill_dead(model, counts, layer)
    return np.clip(np.rint(counts), 0, model.fsr.full_scale).astype(np.uint16)


def expected_counts(model: SkinModel, top_force: np.ndarray, bottom_force: np.ndarray
                    ) -> np.ndarray:
    """Return the (2, rows, cols) noise-free float counts of two force maps (no rounding)."""
    return np.stack([np.clip(_kill_dead(model, _film_counts(model, f, layer), layer), 0,
                             model.fsr.full_scale)
                     for layer, f in enumerate((top_force, bottom_force))])


def render_expected(model: SkinModel, presses: Sequence[Press]) -> np.ndarray:
    """Return the (2, rows, cols) noise-free float counts of the presses (no rounding)."""
    return expected_counts(model, *render_force(model, presses))


def render(model: SkinModel, presses: Sequence[Press],
           rng: np.random.Generator) -> tuple:
    """Return (top, bottom) uint16 ADC count maps (rows x cols, 0..4095) of the presses."""
    top_f, bottom_f = render_force(model, presses)
    return _electronics(model, top_f, 0, rng), _electronics(model, bottom_f, 1, rng)


def render_plate(model: SkinModel, load_n: float, rng: np.random.Generator) -> tuple:
    """
    Return (top, bottom) uint16 ADC count maps of a rigid plate loading every taxel evenly.

    ``load_n`` is each taxel's share of the plate's weight (newtons on its active pad). The
    blur of an even pressure is even, so both layers take it whole; a film that turns on takes
    it only above its turn-on pressure.
    """
    pressure = load_n / (model.fill_factor * model.pitch_m) ** 2
    sensed = load_n if pressure > model.turn_on_pa else 0.0
    force = np.full((model.rows, model.cols), float(sensed))
    return _electronics(model, force, 0, rng), _electronics(model, force, 1, rng)


def render_held(model: SkinModel, presses: Sequence[Press], ages_s: Sequence[float],
                time_s: float, rng: np.random.Generator) -> tuple:
    """
    Return (top, bottom) uint16 maps at ``time_s`` after the tare, of presses held for a time.

    ``ages_s`` is each press's equivalent age under load (:func:`drift.held_age`): its taxels
    sense its force times their creep factor. Every offset has drifted by ``time_s``
    (:mod:`.drift`). With ``Drift()`` this is :func:`render` of the presses.
    """
    top = np.zeros((model.rows, model.cols))
    bottom = np.zeros_like(top)
    rate, factor = drift_spread(model)
    for press, age in zip(presses, ages_s):
        t, b = _press_maps(model, press)
        top += t * creep_factor(model.drift, rate[0], age)
        bottom += b * creep_factor(model.drift, rate[1], age)
    common = offset_counts(model.drift, time_s)
    return (_electronics(model, top, 0, rng, common * factor[0]),
            _electronics(model, bottom, 1, rng, common * factor[1]))
