"""
Correction of the taxel-sampling bias of the layer shift, derived from the skin model.

Why: at a 5 mm pitch a small indenter loads the top layer on about one taxel, so the top map
hardly changes while the contact moves across that taxel (pixel locking). Every shift estimator
then reads a bias that is a periodic function of where the top imprint sits on the grid,
``delta(phi) = a1 sin(2 pi phi) + a2 sin(4 pi phi)`` per axis with ``phi`` the sub-taxel phase,
and whose amplitude shrinks as the imprint widens (about 0.13 taxel for a 3 mm indenter, 0.04 for
6 mm). The seed's single offset ``(x_p, y_p)`` cannot remove a bias that changes with location;
on small tilts (0.2 taxel of shift) it is worth several degrees of azimuth.

How: the bottom layer sees the pressure blurred by the elastic layer (2 mm), so it is almost free
of that aliasing: its centroid locates the contact and its spread measures the width of the
imprint. A table built once per skin model, by rendering noise-free normal presses over sub-taxel
phases, indenter radii and forces through the documented model (pitch, fill factor, cover and
layer spread, FSR divider, noise threshold) and running the chosen estimator on them, gives
``a1, a2`` against (bottom spread, normal force). Per contact and axis, Newton's method then solves
``raw = s + delta(x_bottom - s)`` for the shift ``s``. On a real skin, set the model parameters
of the skin (``EstimatorConfig``) so that the table describes it.
"""

from __future__ import annotations

from functools import lru_cache
import math

import numpy as np

from .conditioning import Conditioner, ConditioningConfig
from .contacts import contact_windows, segment
from .physics import FsrModel, Press, render, SkinModel

__all__ = ['SamplingCorrection', 'sampling_correction']

_FORCES_N = (2.5, 5.0, 10.0, 20.0)
_RADII_TAXELS = tuple(np.arange(0.15, 0.96, 0.075))
_PHASES = 16
_CROSS_PHASES = (0.15, 0.65)
_SPREAD_GRID = np.linspace(0.40, 1.20, 81)
_NEWTON_STEPS = 4
_TWO_PI = 2.0 * math.pi


class SamplingCorrection:
    """Bias amplitudes of one estimator on one skin model, on a (force, spread) grid."""

    def __init__(self, log_forces: np.ndarray, spreads: np.ndarray, amplitudes: np.ndarray):
        """Keep the table: amplitudes[force index, spread index] = (a1, a2) in taxels."""
        self._log_forces = [float(v) for v in log_forces]
        self._spread0 = float(spreads[0])
        self._spread_step = float(spreads[1] - spreads[0])
        self._spread_last = len(spreads) - 1
        self._a = amplitudes.tolist()

    def amplitudes(self, spread: float, force_n: float) -> tuple:
        """Return (a1, a2) for a bottom spread (taxels squared) and a normal force (N)."""
        lf = self._log_forces
        x = min(max(math.log(max(force_n, 1e-6)), lf[0]), lf[-1])
        i = 0
        while i < len(lf) - 2 and x > lf[i + 1]:
            i += 1
        tf = (x - lf[i]) / (lf[i + 1] - lf[i])
        pos = min(max((spread - self._spread0) / self._spread_step, 0.0), self._spread_last)
        j = min(int(pos), self._spread_last - 1)
        ts = pos - j
        out = []
        for k in (0, 1):
            lo = self._a[i][j][k] * (1 - ts) + self._a[i][j + 1][k] * ts
            hi = self._a[i + 1][j][k] * (1 - ts) + self._a[i + 1][j + 1][k] * ts
            out.append(lo * (1 - tf) + hi * tf)
        return out[0], out[1]

    @staticmethod
    def solve(raw: float, bottom: float, a1: float, a2: float) -> float:
        """Return s with ``raw = s + a1 sin(2 pi phi) + a2 sin(4 pi phi)``, phi = bottom - s."""
        s = raw
        for _ in range(_NEWTON_STEPS):
            phase = _TWO_PI * (bottom - s)
            g = s - raw + a1 * math.sin(phase) + a2 * math.sin(2.0 * phase)
            slope = 1.0 - _TWO_PI * (a1 * math.cos(phase) + 2.0 * a2 * math.cos(2.0 * phase))
            if slope < 0.1:
                # Past a fold of the bias curve the root is ambiguous: keep the last estimate.
                break
            s -= g / slope
        return s


def _bias_samples(model: SkinModel, conditioner: Conditioner, function, force_n: float,
                  radius_m: float) -> tuple:
    """Return (mean bottom spread, fitted (a1, a2)) of normal presses over sub-taxel phases."""
    rng = np.random.default_rng(0)
    pitch = model.pitch_m
    centre = (model.cols // 2 - 1) * pitch
    phases, biases, spreads = [], [], []
    for k in range(_PHASES):
        phi = (k + 0.5) / _PHASES
        for cross in _CROSS_PHASES:
            press = Press(centre + phi * pitch, centre + cross * pitch, force_n, 0.0, 0.0,
                          radius_m)
            tf, bf = conditioner.condition(*render(model, [press], rng))
            segments, labels = segment(tf, bf, pitch, 0.0, 1)
            if not segments:
                continue
            seg = segments[0]
            est = function(*contact_windows(tf, bf, labels, seg))
            phases += [phi, cross]
            biases += [est.dx, est.dy]
            spreads.append(seg.bottom_spread)
    if not spreads:
        return None, (0.0, 0.0)
    p = np.asarray(phases)
    basis = np.stack([np.sin(_TWO_PI * p), np.sin(2 * _TWO_PI * p)], axis=1)
    coef, *_ = np.linalg.lstsq(basis, np.asarray(biases), rcond=None)
    return float(np.mean(spreads)), (float(coef[0]), float(coef[1]))


@lru_cache(maxsize=16)
def sampling_correction(function, pitch_m: float, fill_factor: float, cover_spread_m: float,
                        layer_spread_m: float, threshold_counts: float,
                        fsr: FsrModel) -> SamplingCorrection:
    """Return the (cached) correction of ``function`` for the skin these parameters describe."""
    model = SkinModel(pitch_m=pitch_m, fill_factor=fill_factor, cover_spread_m=cover_spread_m,
                      spread_m=layer_spread_m, noise_counts=0.0, fsr=fsr)
    conditioner = Conditioner(ConditioningConfig(fsr=fsr, threshold_counts=threshold_counts),
                              (model.rows, model.cols))
    base = np.full((model.rows, model.cols), model.baseline_counts)
    conditioner.set_baseline(base, base)
    table = np.zeros((len(_FORCES_N), _SPREAD_GRID.size, 2))
    for i, force in enumerate(_FORCES_N):
        spreads, amps = [], []
        for radius in _RADII_TAXELS:
            spread, amp = _bias_samples(model, conditioner, function, force, radius * pitch_m)
            if spread is not None:
                spreads.append(spread)
                amps.append(amp)
        # The spread grows with the radius; keep it increasing for the interpolation.
        spreads = np.maximum.accumulate(np.asarray(spreads))
        amps = np.asarray(amps)
        for k in (0, 1):
            table[i, :, k] = np.interp(_SPREAD_GRID, spreads, amps[:, k])
    return SamplingCorrection(np.log(_FORCES_N), _SPREAD_GRID, table)
