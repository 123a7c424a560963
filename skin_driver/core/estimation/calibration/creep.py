"""
Creep calibration: hold a known load for a few minutes, fit how the skin's reading rises.

An FSR's conductance rises roughly with the logarithm of the time under load. The estimator
divides each loaded taxel's force by ``1 + per_decade * log10(1 + age / settle_s)`` (the creep
law, written once in the kernel: ``sk_creep``, bound as :func:`..scan.kernel.creep`); this fits
``per_decade`` and ``settle_s`` of the user's skin from the force the estimator reads, without
creep compensation, while one load is held still:
``F(t) = F0 * (1 + per_decade * log10(1 + t / settle_s))``, ``t`` from the load's arrival.
For each settling time on a grid the model is linear in ``F0`` and ``F0 * per_decade``; the
least misfit wins. ``recovery_s`` (how fast a film forgets once unloaded) is not seen in a hold:
it stays the estimator's, unless the load is taken off and put back after a rest, when what
the film still remembers 1 s into the second press gives it.

A :class:`CreepSession` takes each scan's time and contacts and says how far the hold has got;
it refuses what is not a still hold: no load, a load that comes off, moves or changes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
import math

import numpy as np

from ..scan.kernel import creep, DriftNumbers
from ...common.validate import check_number

__all__ = ['CreepFit', 'CreepError', 'CreepSession', 'fit_creep', 'fit_recovery', 'MIN_HOLD_S']

# A hold shorter than this leaves the log's slope to the noise of the first seconds; a few
# minutes (the action's default) see the rate over two decades.
MIN_HOLD_S = 5.0
# The settling times tried (seconds): a few per decade from a tenth to half a minute.
_SETTLE_GRID = np.exp(np.linspace(math.log(0.1), math.log(30.0), 49))
# A still load moves less than this many taxels and changes by less than this share of itself
# beyond what creep explains.
_MAX_MOVE_TAXELS = 0.5
_MAX_MISFIT = 0.03
# A load has arrived once it reads this share of what it reads _SETTLED_S on.
_ARRIVED = 0.97
_SETTLED_S = 2.0
# The second press: read 1 s after it arrived (the mean of the scans this close to 1 s), done
# once held _SECOND_S; the hold is this share of the progress.
_AROUND_1S = 0.3
_SECOND_S = 1.3
_HOLD_SHARE = 0.8
# A recovery is told only from a creep this large at release, within these bounds (s).
_MIN_RECOVERY_CREEP = 0.02
_RECOVERY_RANGE_S = (5.0, 3600.0)


class CreepError(ValueError):
    """The scans were not a still, held load; the message says what was wrong."""


@dataclass(frozen=True)
class CreepFit:
    """A skin's creep: rise per decade of time under load, settling and recovery times (s)."""

    per_decade: float
    settle_s: float
    recovery_s: float = 60.0
    load_n: float = 0.0
    hold_s: float = 0.0
    misfit: float = 0.0
    made_utc: str = ''

    def __post_init__(self):
        """Reject non-finite or negative values."""
        check_number(self.per_decade, 'creep per_decade', non_negative=True)
        check_number(self.settle_s, 'creep settle_s', positive=True)
        check_number(self.recovery_s, 'creep recovery_s', positive=True)
        for name in ('load_n', 'hold_s', 'misfit'):
            check_number(getattr(self, name), f'creep {name}', non_negative=True)

    def factor(self, age_s):
        """Return the reading's rise after ``age_s`` under load (1 at arrival), the kernel's."""
        return creep(DriftNumbers(creep_per_decade=self.per_decade, settle_s=self.settle_s),
                     age_s)

    def over_48_hours(self) -> float:
        """Return the rise over 48 h of load, the makers' figure (a share)."""
        return float(self.factor(48 * 3600.0) - 1.0)

    def describe(self) -> str:
        """Return one line for a log or a report."""
        return (f'creep {100 * self.per_decade:.2f} % per decade (settles in '
                f'{self.settle_s:.2f} s; {100 * self.over_48_hours():.1f} % over 48 h), from '
                f'{self.load_n:.1f} N held {self.hold_s:.0f} s')

    def to_dict(self) -> dict:
        """Return the fields as plain values (the calibration file's ``creep``)."""
        return {k: (v if isinstance(v, str) else float(v)) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, doc) -> 'CreepFit':
        """Return the fit of a calibration file's ``creep`` mapping."""
        if not isinstance(doc, dict):
            raise ValueError('creep must be a mapping')
        return cls(float(doc['per_decade']), float(doc['settle_s']),
                   float(doc.get('recovery_s', 60.0)), float(doc.get('load_n', 0.0)),
                   float(doc.get('hold_s', 0.0)), float(doc.get('misfit', 0.0)),
                   str(doc.get('made_utc') or ''))


def fit_creep(ages_s, forces_n, recovery_s: float = 60.0) -> CreepFit:
    """
    Return the creep that best explains ``forces_n`` read ``ages_s`` after the load arrived.

    Raises CreepError when the series is too short or the load is not explained by creep (it
    changed). ``misfit`` is the RMS of the residuals as a share of the load.
    """
    t = np.asarray(ages_s, dtype=np.float64)
    f = np.asarray(forces_n, dtype=np.float64)
    keep = np.isfinite(t) & np.isfinite(f) & (t >= 0)
    t, f = t[keep], f[keep]
    if t.size < 5 or not np.any(f > 0):
        raise CreepError('no load held: fewer than 5 scans with a contact')
    if t.max() < MIN_HOLD_S:
        raise CreepError(f'held {t.max():.0f} s; hold the load still for at least '
                         f'{MIN_HOLD_S:.0f} s (a few minutes is better)')
    best = None
    for settle in _SETTLE_GRID:
        # the law's decades of time under load: its rise at a creep of 1 per decade, less 1
        decades = creep(DriftNumbers(creep_per_decade=1.0, settle_s=settle), t) - 1.0
        design = np.stack([np.ones_like(t), decades], axis=1)
        coef, *_ = np.linalg.lstsq(design, f, rcond=None)
        residual = f - design @ coef
        cost = float(residual @ residual)
        if best is None or cost < best[0]:
            best = (cost, settle, coef)
    cost, settle, (f0, slope) = best
    if not f0 > 0:
        raise CreepError('the load read no force at its arrival')
    misfit = math.sqrt(cost / t.size) / f0
    if misfit > _MAX_MISFIT:
        raise CreepError(f'the load changed by {100 * misfit:.1f} % beyond what creep explains '
                         '(a moving or changing load); hold it still and calibrate again')
    return CreepFit(max(float(slope / f0), 0.0), float(settle), float(recovery_s), float(f0),
                    float(t.max()), float(misfit))


def fit_recovery(fit: CreepFit, held_s: float, rest_s: float, ratio: float):
    """
    Return the recovery time that explains a re-press, or None when the creep is too small.

    After ``held_s`` under load and ``rest_s`` unloaded, a second press read ``ratio`` times
    what the first read, each 1 s after it arrived: the film remembered an age ``a`` with
    ``c(a + 1) = ratio c(1)`` (``c``: :meth:`CreepFit.factor`, inverted here), and
    ``a = held_s exp(-rest_s / recovery)``.
    """
    if not (fit.per_decade > 0 and held_s > 0 and rest_s > 0 and math.isfinite(ratio)):
        return None
    if fit.factor(held_s) - 1.0 < _MIN_RECOVERY_CREEP:
        return None  # the rise at release is within the noise of two readings
    x = (ratio * float(fit.factor(1.0)) - 1.0) / fit.per_decade
    remembered = fit.settle_s * (10.0 ** x - 1.0) - 1.0
    if remembered >= held_s:
        return _RECOVERY_RANGE_S[1]
    if remembered <= held_s * math.exp(-rest_s / _RECOVERY_RANGE_S[0]):
        return _RECOVERY_RANGE_S[0]
    recovery = rest_s / math.log(held_s / remembered)
    return min(max(recovery, _RECOVERY_RANGE_S[0]), _RECOVERY_RANGE_S[1])


class CreepSession:
    """
    The scans of one creep calibration: a single load put on, held still ``hold_s``.

    :meth:`add` takes each scan's time and contacts (objects with ``x_m``, ``y_m``,
    ``force_n``) and returns the share of the calibration done (0..1); it raises CreepError as
    soon as the load comes off or moves during the hold. With ``rest_s``, the load is then taken
    off for about that long and put back (:attr:`phase` says which is due): how much the film
    still remembers 1 s into the second press gives the recovery time (:func:`fit_recovery`).
    :meth:`finish` fits the creep (:func:`fit_creep`).
    """

    def __init__(self, hold_s: float = 180.0, pitch_m: float = 0.005,
                 recovery_s: float = 60.0, rest_s: float = 0.0):
        """Expect a hold of ``hold_s`` seconds (at least MIN_HOLD_S), then a rest of rest_s."""
        self.hold_s = max(float(hold_s), MIN_HOLD_S)
        self.pitch_m = float(pitch_m)
        self.recovery_s = float(recovery_s)
        self.rest_s = max(float(rest_s), 0.0)
        self._start = None
        self._where = None
        self._ages, self._forces = [], []
        self.phase = 'hold'
        self._released = self._again = None
        self._second = []  # (age, force) of the second press

    def _after_hold(self, time_s: float, contacts) -> float:
        """Take a scan after the hold (release, rest, second press); return the share done."""
        if self.phase == 'release' and not contacts:
            self.phase, self._released = 'rest', time_s
        elif self.phase == 'rest' and contacts:
            self.phase, self._again = 'repress', time_s
        if self.phase == 'repress':
            if len(contacts) != 1:
                raise CreepError('the second press came off or was not one load; press it '
                                 'again and hold it two seconds')
            age = time_s - self._again
            self._second.append((age, float(contacts[0].force_n)))
            if age >= _SECOND_S:
                self.phase = 'done'
        return 1.0 if self.phase == 'done' else _HOLD_SHARE

    @property
    def held_s(self) -> float:
        """Return how long the load has been held so far."""
        return self._ages[-1] if self._ages else 0.0

    def add(self, time_s: float, contacts) -> float:
        """Add one scan; return the share of the calibration done."""
        if self.phase != 'hold':
            return self._after_hold(float(time_s), contacts)
        if not contacts:
            if self._start is not None:
                raise CreepError(f'the load came off after {self.held_s:.1f} s; hold it still '
                                 f'for {self.hold_s:.0f} s')
            return 0.0
        if len(contacts) > 1:
            raise CreepError(f'{len(contacts)} contacts; hold one load')
        c = contacts[0]
        if self._start is None:
            self._start, self._where = float(time_s), (c.x_m, c.y_m)
        moved = math.hypot(c.x_m - self._where[0], c.y_m - self._where[1]) / self.pitch_m
        if moved > _MAX_MOVE_TAXELS:
            raise CreepError(f'the load moved by {moved:.1f} taxels after '
                             f'{float(time_s) - self._start:.1f} s; hold it still')
        self._ages.append(float(time_s) - self._start)
        self._forces.append(float(c.force_n))
        if self.held_s >= self.hold_s:
            self.phase = 'release' if self.rest_s > 0 else 'done'
        share = min(self.held_s / self.hold_s, 1.0)
        return share if self.rest_s <= 0 else share * _HOLD_SHARE

    @property
    def done(self) -> bool:
        """Return whether the load has been held long enough (and put back, with a rest)."""
        return self.phase == 'done'

    def finish(self) -> CreepFit:
        """Return the fitted creep; CreepError when the hold is not enough for one."""
        if self._start is None:
            raise CreepError('no load held: no scan had a contact')
        if self.held_s < self.hold_s:
            raise CreepError(f'held {self.held_s:.0f} s of the {self.hold_s:.0f} s asked; hold '
                             'the load still that long')
        ages, forces = np.array(self._ages), np.array(self._forces)
        # The load's arrival (a hand or a robot puts it down over a fraction of a second) is no
        # creep: the fit starts once the reading is within a few percent of what it reads two
        # seconds on. The ages still count from the first scan that read it, as the
        # estimator's do.
        later = forces[(ages >= _SETTLED_S) & (ages <= _SETTLED_S + 1.0)]
        reference = float(np.median(later)) if later.size else forces[-1]
        arrived = int(np.argmax(forces >= _ARRIVED * reference))
        fit = fit_creep(ages[arrived:], forces[arrived:], self.recovery_s)
        if self.phase != 'done' or self.rest_s <= 0:
            return fit
        second = np.array(self._second)
        first = forces[np.abs(ages - 1.0) <= _AROUND_1S]
        again = second[np.abs(second[:, 0] - 1.0) <= _AROUND_1S, 1]
        if not (first.size and again.size):
            return fit
        recovery = fit_recovery(fit, self.held_s, self._again - self._released,
                                float(np.mean(again) / np.mean(first)))
        return fit if recovery is None else replace(fit, recovery_s=recovery)
