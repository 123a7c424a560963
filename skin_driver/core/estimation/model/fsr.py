"""
The force-sensitive resistor read through a voltage divider: counts to force and back.

The estimation needs it to turn ADC counts into newtons. It is the driver's assumption; the
simulated skin's true film is its own (``core/sim/fsr.py``), named by the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

__all__ = ['FsrModel']


@dataclass(frozen=True)
class FsrModel:
    """
    Force-sensitive resistor read through a voltage divider by an ADC.

    The FSR resistance follows the usual power law ``R(F) = r_max * (F / force_at_r_max_n) ** -n``
    (conductance grows as a power of force), with ``n`` chosen so that ``R = r_min`` at
    ``force_at_r_min_n``; beyond that the resistance stays at ``r_min`` (the sensor saturates).
    Below ``activation_n`` the FSR is open. The divider puts the FSR above ``r_series_ohm`` and the
    ADC reads the voltage over the series resistor:
    ``counts = full_scale * r_series / (r_series + R)``. Forces are per taxel, in newtons.
    """

    r_series_ohm: float = 1000.0
    adc_bits: int = 12
    r_min_ohm: float = 300.0
    r_max_ohm: float = 3500.0
    force_at_r_max_n: float = 0.2
    force_at_r_min_n: float = 20.0
    activation_n: float = 0.01

    def __post_init__(self):
        """Reject parameters that make the law undefined."""
        values = (self.r_series_ohm, self.r_min_ohm, self.r_max_ohm, self.force_at_r_max_n,
                  self.force_at_r_min_n)
        if not all(math.isfinite(v) and v > 0 for v in values):
            raise ValueError('FsrModel resistances and forces must be finite and positive')
        if not self.r_min_ohm < self.r_max_ohm:
            raise ValueError('FsrModel needs r_min_ohm < r_max_ohm')
        if not self.force_at_r_max_n < self.force_at_r_min_n:
            raise ValueError('FsrModel needs force_at_r_max_n < force_at_r_min_n')
        if not (math.isfinite(self.activation_n)
                and 0 <= self.activation_n < self.force_at_r_max_n):
            raise ValueError('FsrModel activation_n must be in [0, force_at_r_max_n)')
        if not 1 <= int(self.adc_bits) <= 16:
            raise ValueError('FsrModel adc_bits must be between 1 and 16')

    @property
    def full_scale(self) -> int:
        """Return the largest ADC code."""
        return (1 << int(self.adc_bits)) - 1

    @property
    def exponent(self) -> float:
        """Return the power-law exponent n of the conductance versus force."""
        return (math.log(self.r_max_ohm / self.r_min_ohm)
                / math.log(self.force_at_r_min_n / self.force_at_r_max_n))

    @property
    def saturation_counts(self) -> float:
        """Return the counts reached when the FSR saturates at ``r_min_ohm``."""
        return self.full_scale * self.r_series_ohm / (self.r_series_ohm + self.r_min_ohm)

    def force_to_counts(self, force_n: np.ndarray) -> np.ndarray:
        """Convert per-taxel force (N) to noise-free float counts (0..saturation_counts)."""
        f = np.maximum(np.asarray(force_n, dtype=np.float64) - self.activation_n, 0.0)
        conductance = (f / self.force_at_r_max_n) ** self.exponent / self.r_max_ohm
        conductance = np.minimum(conductance, 1.0 / self.r_min_ohm)
        gs = conductance * self.r_series_ohm
        return self.full_scale * gs / (1.0 + gs)

    def counts_to_force(self, counts: np.ndarray, saturate: bool = True) -> np.ndarray:
        """
        Invert :meth:`force_to_counts`; saturated counts give ``force_at_r_min_n``.

        ``saturate=False`` follows the power law on past the saturation (up to one count below
        full scale): a skin that saturates later than this model reads such counts.
        """
        top = self.saturation_counts if saturate else self.full_scale - 1.0
        c = np.clip(np.asarray(counts, dtype=np.float64), 0.0, top)
        with np.errstate(divide='ignore', invalid='ignore'):
            gs = c / (self.full_scale - c)
            f = self.force_at_r_max_n * (gs * self.r_max_ohm / self.r_series_ohm) ** (
                1.0 / self.exponent)
        f = np.where(c > 0, f + self.activation_n, 0.0)
        return np.minimum(f, self.force_at_r_min_n + self.activation_n) if saturate else f
