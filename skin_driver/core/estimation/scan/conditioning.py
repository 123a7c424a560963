"""
The state a scan is conditioned with, per taxel and layer.

The tare's baseline, noise and touch threshold, dead or stuck marks, the gains, and each
layer's force at every count: :class:`Conditioning` measures and holds it (a tare, gains,
fitted force curves). A compiled kernel is built from a copy of it (:meth:`Conditioning.state`)
and does the conditioning itself, once per scan (skin_kernel's condition.c and crosstalk.c,
bound by :mod:`kernel`): subtract the baseline, take the crosstalk out, zero what is below the
touch threshold, level the taxels the ADC clipped, fill dead taxels from their live neighbours and
turn counts into force. Python never conditions a scan a second way: the calibration asks a
kernel (:meth:`kernel.Kernel.condition`, :meth:`kernel.Kernel.force`).

The dead marks here are what a kernel is built with: those a tare found, or those a kernel
published (an estimator's snapshot, :attr:`pipeline.ContactEstimator.conditioning`). The live
marks are the kernel's alone: its scans revive them, and a kernel swapped in for another of the
same tare takes them over (:meth:`kernel.Kernel.carry_from`), never from here.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...common.validate import check_map, check_stack

__all__ = ['Conditioning', 'ConditioningState', 'CONDITIONING_FIELDS']


# What of an estimator's settings (pipeline.EstimatorConfig, the one home of them) conditions a
# scan: two settings alike in these condition alike.
CONDITIONING_FIELDS = ('fsr', 'threshold_counts', 'noise_sigmas', 'fill_dead', 'remove_crosstalk')


def _conditions(config) -> tuple:
    return tuple(getattr(config, name) for name in CONDITIONING_FIELDS)


class _Layer:
    """Per-layer calibration state."""

    def __init__(self, shape):
        self.baseline = np.zeros(shape)
        self.threshold = None
        self.noise = None
        self.gain = None
        self.dead = np.zeros(shape, dtype=bool)


def _force_table(counts_to_force, full_scale: int) -> np.ndarray:
    """Return the force at every integer count 0..full_scale (the kernel interpolates it)."""
    return counts_to_force(np.arange(full_scale + 1, dtype=np.float64))


class _Stacked:
    """Both layers' calibration as (2, rows, cols) arrays, rebuilt whenever a setter runs."""

    def __init__(self, layers):
        self.baseline = np.stack([layer.baseline for layer in layers])
        self.threshold = np.stack([layer.threshold for layer in layers])
        self.noise = np.stack([layer.noise for layer in layers])
        gains = [layer.gain for layer in layers]
        self.gain = None
        if any(g is not None for g in gains):
            # A layer without gain gets 1.0, which leaves its forces bit for bit unchanged.
            self.gain = np.stack([np.ones(self.baseline.shape[1:]) if g is None else g
                                  for g in gains])


class ConditioningState(NamedTuple):
    """The per-taxel arrays, (2, rows, cols) each, and force tables a kernel copies (copies)."""

    baseline: np.ndarray
    threshold: np.ndarray
    noise: np.ndarray
    gain: np.ndarray     # None when no gain is set
    dead: np.ndarray     # bool
    tables: np.ndarray   # (2, full_scale + 1): each layer's force at every count
    tared: bool          # the noise and rest reading measured: the kernel's crosstalk gate


class Conditioning:
    """Per-taxel baseline, noise, threshold, gain and dead marks, and force tables, both layers."""

    def __init__(self, config, shape: tuple = None):
        """
        Create an untared conditioning; ``shape`` fixes the map shape, else first use does.

        ``config`` is the estimator's :class:`pipeline.EstimatorConfig`: its fsr (the assumed
        force curve), ``threshold_counts``, the least reading above baseline that counts as
        touch, raised by a tare to ``noise_sigmas`` times a taxel's measured noise where that
        is larger, ``fill_dead`` and ``remove_crosstalk`` (:data:`CONDITIONING_FIELDS`).
        """
        self.config = config
        self._shape = None
        self._layers = None
        self._stack = None
        self._tared = False
        assumed = _force_table(self.config.fsr.counts_to_force, self.config.fsr.full_scale)
        # One table per layer: a fitted curve (forcecurve.ForceCurve) replaces the assumed one.
        self._tables = (assumed, assumed)
        self._assumed = assumed
        if shape is not None:
            self._reset(tuple(int(s) for s in shape))

    @property
    def shape(self):
        """Return the map shape this conditioning is set up for, or None."""
        return self._shape

    @property
    def tared(self) -> bool:
        """Return whether a tare set the baselines (False: the assumed baseline)."""
        return self._tared

    def copy(self, config=None) -> 'Conditioning':
        """
        Return an independent copy, optionally under another ``config``.

        The tare (baseline, noise, dead taxels), gains and fitted force curves carry over; a
        config that conditions otherwise (:data:`CONDITIONING_FIELDS`) has its threshold
        applied to the measured noise as a tare would have applied it.
        """
        new = Conditioning(config or self.config)
        if config is not None and _conditions(config) == _conditions(self.config):
            config = None  # conditions alike: the thresholds carry over as they are
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
            raise ValueError(f'maps have shape {tuple(shape)}, the tare and gains expect '
                             f'{self._shape}')

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
            self._assumed if curve is None else _force_table(curve.counts_to_force, full_scale)
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
            self._stack = _Stacked(self._layers)
        return self._stack

    def state(self, shape: tuple) -> ConditioningState:
        """Return copies of what conditions ``shape`` maps (the compiled kernel's copy of it)."""
        self._ensure(tuple(shape))
        st = self._stacked()
        return ConditioningState(st.baseline.copy(), st.threshold.copy(), st.noise.copy(),
                                 None if st.gain is None else st.gain.copy(),
                                 np.stack(self.dead_masks()), np.stack(self._tables),
                                 self._tared)
