"""
A skin's own counts-to-force curve, fitted from presses of known normal force.

The assumed :class:`fsr.FsrModel` is only a guess at a real skin's FSR film, divider and ADC. A
press of known normal force ``F`` tells the sum of the curve over the taxels it loads:
``sum_i gain_i * g(c_i) + rim_load = F * fill_factor**2`` (the pipeline divides the sensed sum by
``fill_factor**2``).

The curve is ``g(c) = scale * u(c) ** exponent + activation`` on a conducting taxel, where
``u`` is the force the assumed model gives the counts less its activation force (without its
saturation). An FSR's conductance grows as a power of its force past the force at which it
starts to conduct, and the divider and the ADC turn conductance into counts alike on every
skin, so the force of one such film is the force the assumed film gives the same counts raised
to a power and scaled, whatever the film's resistances, exponent and series resistor: three
numbers to learn, which a few presses pin down over the whole range. A curve of many free
pieces (the previous fit) bent to the calibration presses and missed the presses of other
indenters; the power keeps the shape of the law between the presses and past them. It is
monotone by construction.

The rim load: the rim of every imprint carries load that no taxel reads, below the touch
threshold or below the pressure at which a film turns on. For an imprint of a given shape, the
part of its load under a pressure is about that pressure times the imprint's area, whatever the
force: a constant per imprint, so one more non-negative number of the fit, added to every
imprint's sum at run time by the compiled kernel (``skin_kernel/src/kernel.c``), never more than
the imprint reads: a faint imprint (a few taxels over the threshold, or noise) is no press, and
must not become one.

The curve is stored as knots in counts up to the highest count pressed, with the censoring
ceiling, the bump's width and the rim load; past the knots the last slope goes on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ['ForceCurve']

_KEYS = ('counts', 'force_n', 'censor_counts', 'spread_taxels', 'bump_power', 'rim_load_n',
         'activation_n')


@dataclass(frozen=True)
class ForceCurve:
    """
    Sensed taxel force (N) at the knots (counts above baseline): from (0, 0), never falling.

    ``censor_counts`` > 0: taxels reading that many counts or more saturated; the kernel fills
    their force in by a bump of ``spread_taxels`` and ``bump_power`` (:mod:`imprint`).
    0: none. ``rim_load_n``: the sensed force at the rim of every imprint that no taxel reads,
    added to each imprint's sum (module docstring). ``activation_n``: the force every conducting
    taxel carries (the curve's activation), no part of a saturated imprint's bump.
    """

    counts: tuple
    force_n: tuple
    censor_counts: float = 0.0
    spread_taxels: float = 0.0
    bump_power: float = 2.0
    rim_load_n: float = 0.0
    activation_n: float = 0.0

    def __post_init__(self):
        """Reject curves that fall or do not start at (0, 0), and a censoring without bump."""
        c = np.asarray(self.counts, dtype=np.float64)
        f = np.asarray(self.force_n, dtype=np.float64)
        if c.ndim != 1 or c.shape != f.shape or c.size < 2:
            raise ValueError('a force curve needs two or more knots of counts and force')
        if not (np.isfinite(c).all() and np.isfinite(f).all()):
            raise ValueError('force curve knots must be finite')
        if c[0] != 0 or f[0] != 0:
            raise ValueError('a force curve starts at 0 counts, 0 N')
        if (np.diff(c) <= 0).any():
            raise ValueError('force curve counts must increase')
        if (np.diff(f) < 0).any() or f[-1] <= 0:
            raise ValueError('force curve forces must not decrease (the curve must be monotone)')
        for name in ('censor_counts', 'spread_taxels', 'rim_load_n', 'activation_n'):
            v = getattr(self, name)
            if isinstance(v, bool) or not (np.isfinite(v) and v >= 0):
                raise ValueError(f'force curve {name} must be a non-negative number, got {v!r}')
        if not (isinstance(self.bump_power, (int, float)) and 1.0 <= self.bump_power <= 16.0):
            raise ValueError(f'force curve bump_power must be in [1, 16], got {self.bump_power!r}')
        if (self.censor_counts > 0) != (self.spread_taxels > 0):
            raise ValueError('a censored force curve needs both censor_counts and spread_taxels')
        object.__setattr__(self, 'counts', tuple(float(v) for v in c))
        object.__setattr__(self, 'force_n', tuple(float(v) for v in f))
        object.__setattr__(self, 'censor_counts', float(self.censor_counts))
        object.__setattr__(self, 'spread_taxels', float(self.spread_taxels))
        object.__setattr__(self, 'bump_power', float(self.bump_power))
        object.__setattr__(self, 'rim_load_n', float(self.rim_load_n))
        object.__setattr__(self, 'activation_n', float(self.activation_n))

    def counts_to_force(self, counts) -> np.ndarray:
        """Return the sensed force of ``counts`` above baseline; the last slope goes on."""
        c = np.maximum(np.asarray(counts, dtype=np.float64), 0.0)
        knots, force = self.counts, self.force_n
        slope = (force[-1] - force[-2]) / (knots[-1] - knots[-2])  # 0 past a saturation
        return np.where(c <= knots[-1], np.interp(c, knots, force),
                        force[-1] + slope * (c - knots[-1]))

    def to_dict(self) -> dict:
        """Return the knots (and any censoring) as plain values (for YAML)."""
        out = {'counts': list(self.counts), 'force_n': list(self.force_n)}
        if self.censor_counts:
            out.update(censor_counts=self.censor_counts, spread_taxels=self.spread_taxels,
                       bump_power=self.bump_power)
            if self.activation_n:
                out['activation_n'] = self.activation_n
        if self.rim_load_n:
            out['rim_load_n'] = self.rim_load_n
        return out

    @classmethod
    def from_dict(cls, doc) -> 'ForceCurve':
        """Build a curve from :meth:`to_dict` output."""
        if not isinstance(doc, dict) or not {'counts', 'force_n'} <= set(doc) <= set(_KEYS):
            raise ValueError('a force curve is a mapping with counts and force_n lists (and '
                             'censor_counts, spread_taxels, bump_power, rim_load_n, activation_n)')
        for key in ('counts', 'force_n'):
            values = doc[key]
            if not isinstance(values, list) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
                raise ValueError(f'force curve {key} must be a list of numbers')
        extra = {k: doc[k] for k in _KEYS[2:] if k in doc}
        for k, v in extra.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f'force curve {k} must be a number, got {v!r}')
        return cls(tuple(doc['counts']), tuple(doc['force_n']), **extra)
