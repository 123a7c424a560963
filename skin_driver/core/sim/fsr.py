"""
The simulated skin's FSR film, its divider and its ADC: how a taxel's load becomes counts.

This is the truth the driver's assumed film (``core.estimation.model.fsr.FsrModel``) guesses at.
Both describe a film by the same seven numbers, so a scene names a film once and the bench can
tell an estimator the true one, and the default film of both is the seed prototype's. The
simulator states the law as the film's resistance; the estimator works in its conductance
and only needs the inverse.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

__all__ = ['FsrFilm']


@dataclass(frozen=True)
class FsrFilm:
    """
    A force-sensitive resistor above a series resistor, the ADC reading the series resistor.

    Past ``activation_n`` the film's resistance falls as a power of the load: ``r_max_ohm`` at
    ``force_at_r_max_n`` above the activation, ``r_min_ohm`` at ``force_at_r_min_n``, and no lower
    (the film saturates). Below the activation it is open. Forces are per taxel, in newtons.
    """

    # The film: open up to its activation load, then two points of its power law.
    activation_n: float = 0.01
    force_at_r_max_n: float = 0.2
    r_max_ohm: float = 3500.0
    force_at_r_min_n: float = 20.0
    r_min_ohm: float = 300.0
    # The divider and the converter.
    r_series_ohm: float = 1000.0
    adc_bits: int = 12

    def __post_init__(self):
        """Reject a film whose law is undefined."""
        for name in ('r_series_ohm', 'r_min_ohm', 'r_max_ohm', 'force_at_r_max_n',
                     'force_at_r_min_n'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'FsrFilm.{name} must be finite and positive')
        if self.r_min_ohm >= self.r_max_ohm:
            raise ValueError('FsrFilm needs r_min_ohm < r_max_ohm')
        if self.force_at_r_max_n >= self.force_at_r_min_n:
            raise ValueError('FsrFilm needs force_at_r_max_n < force_at_r_min_n')
        if not (math.isfinite(self.activation_n)
                and 0 <= self.activation_n < self.force_at_r_max_n):
            raise ValueError('FsrFilm.activation_n must be in [0, force_at_r_max_n)')
        if int(self.adc_bits) not in range(1, 17):
            raise ValueError('FsrFilm.adc_bits must be between 1 and 16')

    @property
    def full_scale(self) -> int:
        """Return the ADC's largest code."""
        return 2 ** int(self.adc_bits) - 1

    @property
    def saturation_counts(self) -> float:
        """Return what the ADC reads when the film is at its floor ``r_min_ohm``."""
        return self._divider(self.r_min_ohm)

    def _slope(self) -> float:
        # How many decades the resistance falls per decade of load.
        return (math.log(self.r_max_ohm) - math.log(self.r_min_ohm)) / (
            math.log(self.force_at_r_min_n) - math.log(self.force_at_r_max_n))

    def _divider(self, resistance_ohm):
        return self.full_scale * self.r_series_ohm / (self.r_series_ohm + resistance_ohm)

    def resistance_ohm(self, force_n: np.ndarray) -> np.ndarray:
        """Return the film's resistance under each load (``inf`` where it is open)."""
        load = np.asarray(force_n, dtype=np.float64) - self.activation_n
        resistance = np.full(load.shape, np.inf)
        pressed = load > 0
        resistance[pressed] = self.r_max_ohm * (load[pressed] / self.force_at_r_max_n) ** (
            -self._slope())
        return np.maximum(resistance, self.r_min_ohm)

    def force_to_counts(self, force_n: np.ndarray) -> np.ndarray:
        """Return the noise-free float counts the ADC reads under each taxel load."""
        return self._divider(self.resistance_ohm(force_n))

    def counts_to_force(self, counts: np.ndarray) -> np.ndarray:
        """
        Return the load that reads ``counts`` (0 for none, the floor's load when saturated).

        The lab weighs a plate with it ("about half the range"); the skin never needs it.
        """
        reading = np.clip(np.asarray(counts, dtype=np.float64), 0.0, self.saturation_counts)
        load = np.zeros(reading.shape)
        on = reading > 0
        resistance = self.r_series_ohm * (self.full_scale - reading[on]) / reading[on]
        load[on] = (self.activation_n + self.force_at_r_max_n
                    * (self.r_max_ohm / resistance) ** (1.0 / self._slope()))
        return np.minimum(load, self.force_at_r_min_n + self.activation_n)
