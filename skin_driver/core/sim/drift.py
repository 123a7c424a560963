"""
Time in the simulated skin: creep of a loaded FSR and drift of an unloaded taxel's offset.

* **Creep.** Under a constant load an FSR's conductance keeps rising roughly with the logarithm
  of the time under load (makers of FSR inks quote 2.5-30 % over 48 hours). A taxel loaded for
  an equivalent age ``a`` senses its force times ``1 + rate * log10(1 + a / settle_s)``: the
  rise settles over ``settle_s`` after a step, then grows by ``rate`` per decade of time. The
  rate differs from taxel to taxel (uniform within +-``creep_spread`` of the skin's rate). After
  unloading the film recovers: the age decays as ``exp(-t / recovery_s)``, so a press soon after
  a long one starts where the film has got to.
* **Offset drift.** An unloaded taxel's offset wanders with temperature (a swing of
  ``thermal_counts`` over ``thermal_period_s``) and age (``offset_counts_per_hour``), each
  taxel by its own factor (normal about 1, ``offset_spread`` its standard deviation).

Everything is a closed form of the time and of the load's history, so a scene held for hours is
rendered at the frames it scores only. ``Drift()`` is none at all: a skin without it, or a
frame rendered without a time, is the skin it always was.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

__all__ = ['Drift', 'creep_factor', 'offset_counts', 'held_age']


@dataclass(frozen=True)
class Drift:
    """A skin's creep under load and drift of its offsets (per decade, seconds, counts)."""

    creep_per_decade: float = 0.0
    creep_spread: float = 0.0
    settle_s: float = 1.0
    recovery_s: float = 60.0
    offset_counts_per_hour: float = 0.0
    thermal_counts: float = 0.0
    thermal_period_s: float = 4.0 * 3600.0
    offset_spread: float = 0.0

    def __post_init__(self):
        """Reject values that are not finite or out of range."""
        for name in ('creep_per_decade', 'creep_spread', 'settle_s', 'recovery_s',
                     'offset_counts_per_hour', 'thermal_counts', 'thermal_period_s',
                     'offset_spread'):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f'Drift.{name} must be finite')
        if self.creep_per_decade < 0 or not 0 <= self.creep_spread < 1:
            raise ValueError('Drift needs creep_per_decade >= 0 and 0 <= creep_spread < 1')
        if min(self.settle_s, self.recovery_s, self.thermal_period_s) <= 0:
            raise ValueError('Drift.settle_s, recovery_s and thermal_period_s must be positive')
        if self.thermal_counts < 0 or self.offset_spread < 0:
            raise ValueError('Drift.thermal_counts and offset_spread must be non-negative')

    @property
    def creeps(self) -> bool:
        """Return whether a loaded taxel creeps at all."""
        return self.creep_per_decade > 0

    @property
    def drifts(self) -> bool:
        """Return whether an unloaded taxel's offset moves at all."""
        return self.offset_counts_per_hour != 0 or self.thermal_counts > 0

    def over_48_hours(self) -> float:
        """Return the rise of a taxel's reading under a load held 48 h (the makers' figure)."""
        return self.creep_per_decade * math.log10(1.0 + 48.0 * 3600.0 / self.settle_s)


def creep_factor(drift: Drift, rate, age_s):
    """Return the factor on a taxel's sensed force after ``age_s`` under load (arrays too)."""
    return 1.0 + rate * np.log10(1.0 + np.maximum(age_s, 0.0) / drift.settle_s)


def offset_counts(drift: Drift, time_s: float) -> float:
    """Return the common offset drift (counts) at ``time_s`` after the skin's tare (time 0)."""
    t = float(time_s)
    return (drift.offset_counts_per_hour * t / 3600.0
            + drift.thermal_counts * math.sin(2.0 * math.pi * t / drift.thermal_period_s))


def held_age(drift: Drift, loads: list, time_s: float) -> float:
    """
    Return a taxel's equivalent age under load at ``time_s`` (seconds).

    ``loads`` are the (on, off) times of its loads in order, off may be inf: the age grows by
    one second a second while loaded and decays by ``exp(-t / recovery_s)`` while unloaded.
    """
    age, last = 0.0, -math.inf
    for on, off in loads:
        if on >= time_s:
            break
        if last > -math.inf:
            age *= math.exp(-(on - last) / drift.recovery_s)
        end = min(off, time_s)
        age += end - on
        last = end
        if off >= time_s:
            return age
    if last > -math.inf:
        age *= math.exp(-(time_s - last) / drift.recovery_s)
    return age
