"""
Turn raw ADC counts of both layers into per-taxel force maps.

Per taxel and layer: subtract the baseline (tare), zero what is below the noise threshold, convert
the remaining counts to force through the FSR divider model (:class:`fsr.FsrModel`) or through the
skin's own fitted curve (:class:`forcecurve.ForceCurve`, set by a force calibration), multiply
by the optional per-taxel gain, and replace dead or stuck taxels by the mean of their live
neighbours so that a dead taxel inside a contact does not fake a shift between the layers.

A taxel read at the ADC's full scale was cut there: its tared count (the raw one less baseline
and line leak) is a lower bound on its load, not a value, whatever was taken off it, and the
lines with most load lose most leak, so a cut plateau would come out as a crater. For the
imprint's shape it takes the layer's highest tared count (a level plateau, as high as anything
read); for the force it is censored: :func:`mark_clipped` puts it at full scale, at or past the
ceiling of every force curve, where a fitted curve is flat (:mod:`forcecurve`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np

from .crosstalk import leak_gate, leak_share, remove_line_leak
from ..model.fsr import FsrModel
from ...common.validate import check_map, check_number, check_pair, check_stack

__all__ = ['ConditioningConfig', 'Conditioner', 'ConditionerState', 'mark_clipped']


@dataclass(frozen=True)
class ConditioningConfig:
    """
    Parameters of the counts-to-force conversion.

    ``threshold_counts`` is the minimum reading above baseline that counts as touch;
    after :meth:`Conditioner.tare` the per-taxel threshold is raised to ``noise_sigmas`` times
    the measured noise when that is larger. ``remove_crosstalk`` takes the load that leaks along
    the rows and columns of a passive matrix out of every scan (:mod:`crosstalk`).
    """

    fsr: FsrModel = field(default_factory=FsrModel)
    threshold_counts: float = 40.0
    noise_sigmas: float = 5.0
    fill_dead: bool = True
    remove_crosstalk: bool = True

    def __post_init__(self):
        """Validate the thresholds."""
        check_number(self.threshold_counts, 'threshold_counts', non_negative=True)
        check_number(self.noise_sigmas, 'noise_sigmas', non_negative=True)


def mark_clipped(counts: np.ndarray, clipped: np.ndarray, full_scale: float) -> np.ndarray:
    """
    Return touch ``counts`` with their loaded ``clipped`` taxels at ``full_scale``.

    What a force curve censors (:mod:`forcecurve`): a cut reading sits at or above any curve's
    ceiling. ``clipped`` (same shape, :meth:`Conditioner.clipped`) None: ``counts`` itself.
    """
    if clipped is None:
        return counts
    return np.where(clipped & (counts > 0), float(full_scale), counts)


class _Layer:
    """Per-layer calibration state."""

    def __init__(self, shape):
        self.baseline = np.zeros(shape)
        self.threshold = None
        self.noise = None
        self.gain = None
        self.dead = np.zeros(shape, dtype=bool)


class _ForceTable:
    """
    Force at every integer count of the ADC, looked up with linear interpolation.

    The result equals ``np.interp(c, counts, force)`` bit for bit (same slope, same formula), but
    indexes the table directly instead of searching it, which is several times faster on the
    scattered counts of a contact.
    """

    def __init__(self, counts_to_force, full_scale: int):
        self.counts = np.arange(full_scale + 1, dtype=np.float64)
        self.force = counts_to_force(self.counts)
        # A zero slope past the last count keeps readings above full scale at the last force.
        self.slope = np.append(np.diff(self.force), 0.0)
        self.last = float(full_scale)

    def __call__(self, c: np.ndarray) -> np.ndarray:
        """Return the force of ``c`` counts above baseline (``c`` >= 0)."""
        c = np.minimum(c, self.last)
        j = c.astype(np.intp)
        return self.slope[j] * (c - j) + self.force[j]


class _DeadFill:
    """Replace dead taxels by the mean of their live neighbours (or by 0 without filling)."""

    def __init__(self, dead: np.ndarray, fill: bool):
        self.dead = dead.copy()
        self.fill = fill
        self.live = (~dead).astype(np.float64)
        # The count of live neighbours depends on the mask only: computed once.
        self.count = cv2.boxFilter(self.live, -1, (3, 3), normalize=False,
                                   borderType=cv2.BORDER_CONSTANT)

    def __call__(self, force: np.ndarray) -> np.ndarray:
        if not self.fill:
            return np.where(self.dead, 0.0, force)
        total = cv2.boxFilter(force * self.live, -1, (3, 3), normalize=False,
                              borderType=cv2.BORDER_CONSTANT)
        mean = np.divide(total, self.count, out=np.zeros_like(total), where=self.count > 0)
        return np.where(self.dead, mean, force)


class _Stacked:
    """Both layers' calibration as (2, rows, cols) arrays, rebuilt whenever a setter runs."""

    def __init__(self, layers, fill_dead: bool, tared: bool):
        self.baseline = np.stack([layer.baseline for layer in layers])
        self.threshold = np.stack([layer.threshold for layer in layers])
        self.noise = np.stack([layer.noise for layer in layers])
        self.leak_gate = leak_gate(self.noise, self.threshold, tared)
        gains = [layer.gain for layer in layers]
        self.gain = None
        if any(g is not None for g in gains):
            # A layer without gain gets 1.0, which leaves its forces bit for bit unchanged.
            self.gain = np.stack([np.ones(self.baseline.shape[1:]) if g is None else g
                                  for g in gains])
        self.dead = [(i, _DeadFill(layer.dead, fill_dead)) for i, layer in enumerate(layers)
                     if layer.dead.any()]


class ConditionerState(NamedTuple):
    """A conditioner's per-taxel arrays, (2, rows, cols) each, and force tables (copies)."""

    baseline: np.ndarray
    threshold: np.ndarray
    noise: np.ndarray
    gain: np.ndarray     # None when no gain is set
    dead: np.ndarray     # bool
    tables: np.ndarray   # (2, full_scale + 1): each layer's force at every count
    tared: bool          # the noise and rest reading measured (crosstalk.leak_gate)


class Conditioner:
    """Per-taxel baseline, gain, dead-taxel mask and counts-to-force for both layers."""

    def __init__(self, config: ConditioningConfig = None, shape: tuple = None):
        """Create a conditioner; ``shape`` fixes the map shape, else the first frame does."""
        self.config = config or ConditioningConfig()
        self._shape = None
        self._layers = None
        self._stack = None
        self._tared = False
        assumed = _ForceTable(self.config.fsr.counts_to_force, self.config.fsr.full_scale)
        # One table per layer: a fitted curve (forcecurve.ForceCurve) replaces the assumed one.
        self._tables = (assumed, assumed)
        self._assumed = assumed
        if shape is not None:
            self._reset(tuple(int(s) for s in shape))

    @property
    def shape(self):
        """Return the map shape this conditioner is set up for, or None."""
        return self._shape

    def copy(self, config: ConditioningConfig = None) -> 'Conditioner':
        """
        Return an independent copy, optionally under another ``config``.

        The tare (baseline, noise, dead taxels), gains and fitted force curves carry over; a new
        config's threshold applies to the measured noise as a tare would have applied it.
        """
        new = Conditioner(config or self.config)
        if config is None or config.fsr == self.config.fsr:
            new._tables = tuple(new._assumed if t is self._assumed else t for t in self._tables)
        if self._layers is not None:
            new._reset(self._shape)
            new._tared = self._tared
            for mine, theirs in zip(self._layers, new._layers):
                theirs.baseline = mine.baseline.copy()
                theirs.dead = mine.dead.copy()
                theirs.gain = None if mine.gain is None else mine.gain.copy()
                if config is None:
                    theirs.noise, theirs.threshold = mine.noise.copy(), mine.threshold.copy()
                elif self._tared:
                    theirs.noise = mine.noise.copy()
                    theirs.threshold = np.maximum(new.config.threshold_counts,
                                                  new.config.noise_sigmas * mine.noise)
        return new

    def _reset(self, shape):
        if len(shape) != 2 or min(shape) < 1:
            raise ValueError(f'map shape must be two positive integers, got {shape}')
        self._shape = shape
        self._stack = None
        self._layers = (_Layer(shape), _Layer(shape))
        # Until a tare measures it, the noise is taken as the one the threshold was set for.
        guess = self.config.threshold_counts / max(self.config.noise_sigmas, 1.0)
        for layer in self._layers:
            layer.threshold = np.full(shape, float(self.config.threshold_counts))
            layer.noise = np.full(shape, float(guess))

    def _ensure(self, shape):
        if self._shape is None:
            self._reset(tuple(shape))
        elif tuple(shape) != self._shape:
            raise ValueError(f'maps have shape {tuple(shape)}, conditioner expects {self._shape}')

    def tare(self, top_frames, bottom_frames) -> None:
        """
        Set baseline, noise threshold and dead/stuck masks from frames taken with no touch.

        Both arguments are stacks N x rows x cols of raw counts (N >= 1). A taxel is dead when it
        reads 0 in every frame while the layer's median baseline is above 0.5 counts, and stuck
        when its reading never changes while the layer's median noise is above zero (needs N > 1).
        """
        stacks = (check_stack(top_frames, 'top_frames'),
                  check_stack(bottom_frames, 'bottom_frames'))
        if stacks[0].shape != stacks[1].shape:
            raise ValueError(f'top_frames and bottom_frames shapes differ: '
                             f'{stacks[0].shape} vs {stacks[1].shape}')
        self._ensure(stacks[0].shape[1:])
        for layer, frames in zip(self._layers, stacks):
            frames = frames.astype(np.float64)
            mean = frames.mean(axis=0)
            std = frames.std(axis=0)
            dead = (frames.max(axis=0) == 0) & (np.median(mean) > 0.5)
            if frames.shape[0] > 1 and np.median(std) > 0:
                dead |= std == 0
            layer.baseline = np.where(dead, 0.0, mean)
            layer.threshold = np.maximum(self.config.threshold_counts,
                                         self.config.noise_sigmas * std)
            layer.noise = std
            layer.dead = dead
        self._tared = True
        self._stack = None

    def set_gain(self, top_gain, bottom_gain) -> None:
        """Set per-taxel multiplicative force gains (1 = nominal); None clears them."""
        for layer, gain, name in zip(self._layers or (None, None), (top_gain, bottom_gain),
                                     ('top_gain', 'bottom_gain')):
            if gain is not None:
                g = check_map(gain, name)
                self._ensure(g.shape)
        for i, gain in enumerate((top_gain, bottom_gain)):
            self._layers[i].gain = None if gain is None else np.array(gain, dtype=np.float64)
        self._stack = None

    def set_force_curves(self, top_curve, bottom_curve) -> None:
        """
        Convert counts with fitted curves (objects with ``counts_to_force``) per layer.

        None for a layer goes back to the assumed FSR model of the configuration.
        """
        full_scale = self.config.fsr.full_scale
        self._tables = tuple(
            self._assumed if curve is None else _ForceTable(curve.counts_to_force, full_scale)
            for curve in (top_curve, bottom_curve))

    def gain_maps(self) -> np.ndarray:
        """Return both layers' gains as one (2, rows, cols) array (1 where none is set)."""
        st = self._stacked()
        return np.ones(st.baseline.shape) if st.gain is None else st.gain.copy()

    def sensitivity_maps(self) -> np.ndarray:
        """
        Return both layers' per-taxel sensitivity (the inverse of the gains), None without gains.

        A taxel of sensitivity 1.1 reads the load of 1.1 nominal ones: what a forward model of
        the taxels multiplies its load by before the film (:mod:`taxelmodel`).
        """
        st = self._stacked()
        return None if st.gain is None else 1.0 / st.gain

    def set_dead(self, top_dead, bottom_dead) -> None:
        """Mark dead or stuck taxels (boolean maps, True = ignore and fill from neighbours)."""
        for i, (mask, name) in enumerate(((top_dead, 'top_dead'), (bottom_dead, 'bottom_dead'))):
            m = np.asarray(mask)
            if m.dtype != bool or m.ndim != 2:
                raise ValueError(f'{name} must be a 2-D boolean array, got {m.dtype} {m.shape}')
            self._ensure(m.shape)
            self._layers[i].dead = m.copy()
        self._stack = None

    def dead_masks(self) -> tuple:
        """Return copies of the (top, bottom) dead-taxel masks."""
        if self._layers is None:
            return None, None
        return self._layers[0].dead.copy(), self._layers[1].dead.copy()

    def _stacked(self) -> _Stacked:
        if self._stack is None:
            self._stack = _Stacked(self._layers, self.config.fill_dead, self._tared)
        return self._stack

    def state(self, shape: tuple) -> ConditionerState:
        """Return copies of what conditions ``shape`` maps (the compiled kernel's copy of it)."""
        self._ensure(tuple(shape))
        st = self._stacked()
        return ConditionerState(st.baseline.copy(), st.threshold.copy(), st.noise.copy(),
                                None if st.gain is None else st.gain.copy(),
                                np.stack(self.dead_masks()),
                                np.stack([table.force for table in self._tables]), self._tared)

    def count_noise(self) -> np.ndarray:
        """Return the (2, rows, cols) 1-sigma count noise of every taxel (measured by the tare)."""
        return self._stacked().noise

    def condition(self, top_counts, bottom_counts) -> tuple:
        """Return (top, bottom) per-taxel force maps in newtons (float64, new arrays)."""
        t, b = check_pair(top_counts, bottom_counts)
        force = self.force_of(self.touch_counts(t, b), self.clipped(t, b))
        return force[0], force[1]

    def touch_counts(self, t: np.ndarray, b: np.ndarray) -> np.ndarray:
        """
        Return the tared counts of both layers as a new (2, rows, cols) array (maps checked).

        Line leak removed, readings under the touch threshold zeroed, taxels the ADC cut at
        the layer's highest count (module docstring), dead taxels filled from their neighbours.
        These are the sensor's own readings, free of any assumption about the FSR curve: the
        shape of an imprint, hence its location and the layer shift, is measured on them, and
        a force calibration fits its curve to them (with the cut taxels marked, :meth:`clipped`).
        """
        if self._shape != t.shape:
            self._ensure(t.shape)
        st = self._stacked()
        c = np.empty(st.baseline.shape)
        np.subtract(t, st.baseline[0], out=c[0])
        np.subtract(b, st.baseline[1], out=c[1])
        if self.config.remove_crosstalk:
            remove_line_leak(c, st.leak_gate)
        c[c < st.threshold] = 0.0
        self._level_clipped(c, t, b)
        if st.dead:
            self._revive(c, st)
            st = self._stacked()
            for i, fill in st.dead:
                c[i] = fill(c[i])
        return c

    def leak_share(self, t: np.ndarray, b: np.ndarray) -> float:
        """
        Return the line leak a scan of one press shows, as a share of a line's load (NaN: none).

        Measured on the tared counts, before the per-scan clean-up takes it out
        (:func:`crosstalk.leak_share`): a force calibration keeps it for the gains' plate.
        """
        t, b = np.asarray(t, dtype=np.float64), np.asarray(b, dtype=np.float64)
        if self._shape != t.shape:
            self._ensure(t.shape)
        st = self._stacked()
        return leak_share(np.stack((t - st.baseline[0], b - st.baseline[1])), st.leak_gate)

    def _level_clipped(self, c: np.ndarray, t: np.ndarray, b: np.ndarray) -> None:
        """Put the taxels the ADC cut at their layer's highest tared count, in place."""
        clipped = self.clipped(t, b)
        if clipped is None:
            return
        for layer, cut in zip(c, clipped):
            if cut.any():
                layer[cut & (layer > 0)] = layer.max()

    def clipped(self, top_counts, bottom_counts) -> np.ndarray:
        """Return where raw maps read the ADC's full scale, (2, rows, cols), or None if nowhere."""
        full = self.config.fsr.full_scale
        t, b = np.asarray(top_counts), np.asarray(bottom_counts)
        if t.max() < full and b.max() < full:
            return None
        return np.stack((t >= full, b >= full))

    def _revive(self, c: np.ndarray, st: _Stacked) -> None:
        """Unmark taxels taken for dead that read a touch: they only rest below zero counts."""
        for i, fill in st.dead:
            alive = fill.dead & (c[i] > 0)
            if alive.any():
                self._layers[i].dead = fill.dead & ~alive
                self._stack = None

    def force_of(self, counts: np.ndarray, clipped: np.ndarray = None) -> np.ndarray:
        """
        Return the per-taxel force (N, gains applied) of a (2, rows, cols) touch-count stack.

        The taxels ``clipped`` marks (:meth:`clipped`, or None) read the force at full scale.
        """
        counts = mark_clipped(counts, clipped, self.config.fsr.full_scale)
        st = self._stacked()
        # Most taxels are untouched: only the loaded ones are converted, the rest keep the force
        # of zero counts, which the FSR model defines as 0.
        loaded = np.flatnonzero(counts)
        force = np.zeros(counts.shape)
        flat_c, flat_f = counts.ravel(), force.ravel()
        top, bottom = self._tables
        if top is bottom:
            flat_f[loaded] = top(flat_c[loaded])
        else:
            split = int(np.searchsorted(loaded, counts[0].size))
            flat_f[loaded[:split]] = top(flat_c[loaded[:split]])
            flat_f[loaded[split:]] = bottom(flat_c[loaded[split:]])
        if st.gain is not None:
            force *= st.gain
        return force
