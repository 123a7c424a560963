"""
Cut a stream of per-scan contacts into presses and judge whether a press was normal (alpha = 0).

Calibration needs the layer shift of presses made straight down. Under a normal press the shift
between the layers is the skin's fixed offset and does not grow with force; under a tilted press
it grows in proportion to the tangential force. So a press looks normal when its shift at full
force is the same as at half force, within a tolerance.

A calibration with a known load needs what the skin read at full load: the plateau of a press is
its scans within ``PLATEAU_SHARE`` of the peak force, and a caller may attach anything to each
scan (counts, a reference sensor's wrench) to get it back for the plateau.
"""

from dataclasses import dataclass, field
import math
from typing import Any, List, Optional, Tuple

PLATEAU_SHARE = 0.97


@dataclass(frozen=True)
class Press:
    """
    One completed press: its peak force and layer shift (raw, before calibration).

    ``plateau_shift_m`` is the mean shift over the plateau scans, ``plateau`` what the caller
    attached to them, in order.
    """

    peak_force_n: float
    shift_m: Tuple[float, float]
    shift_growth_m: float
    scans: int
    looks_normal: bool
    plateau_shift_m: Tuple[float, float] = (0.0, 0.0)
    plateau: tuple = ()


@dataclass
class _Open:
    samples: List[Tuple[float, float, float, Any]] = field(default_factory=list)


class PressSegmenter:
    """
    Feed it the strongest contact of every scan; it returns each press when the skin is released.

    A press starts when the force rises above start_force_n and ends after release_scans scans
    below it. Its shift is the force-weighted mean over the scans above half the peak force. A
    press whose force hardly changed cannot be judged and never looks normal.
    """

    def __init__(self, start_force_n: float = 0.5, release_scans: int = 3,
                 normal_tolerance_m: float = 0.0005, min_scans: int = 3):
        if start_force_n <= 0 or release_scans < 1 or normal_tolerance_m <= 0 or min_scans < 1:
            raise ValueError('start_force_n and normal_tolerance_m must be > 0, '
                             'release_scans and min_scans >= 1')
        self.start_force_n = start_force_n
        self.release_scans = release_scans
        self.normal_tolerance_m = normal_tolerance_m
        self.min_scans = min_scans
        self._open: Optional[_Open] = None
        self._quiet = 0

    def add(self, force_n: float, shift_m: Optional[Tuple[float, float]],
            payload: Any = None) -> Optional[Press]:
        """
        Add one scan (force 0 or shift None when nothing touches); return a finished press.

        ``payload`` comes back in :attr:`Press.plateau` when the scan is on the plateau.
        """
        touching = (shift_m is not None and math.isfinite(force_n)
                    and force_n >= self.start_force_n
                    and all(math.isfinite(v) for v in shift_m))
        if touching:
            if self._open is None:
                self._open = _Open()
            self._open.samples.append((float(force_n), float(shift_m[0]), float(shift_m[1]),
                                       payload))
            self._quiet = 0
            return None
        if self._open is None:
            return None
        self._quiet += 1
        if self._quiet < self.release_scans:
            return None
        samples, self._open, self._quiet = self._open.samples, None, 0
        return self._summarise(samples) if len(samples) >= self.min_scans else None

    def _summarise(self, samples) -> Press:
        peak = max(s[0] for s in samples)
        top = [s for s in samples if s[0] >= PLATEAU_SHARE * peak]
        plateau = {'plateau_shift_m': (sum(s[1] for s in top) / len(top),
                                       sum(s[2] for s in top) / len(top)),
                   'plateau': tuple(s[3] for s in top)}
        strong = [s for s in samples if s[0] >= 0.5 * peak]
        weight = sum(s[0] for s in strong)
        sx = sum(s[0] * s[1] for s in strong) / weight
        sy = sum(s[0] * s[2] for s in strong) / weight
        # The shift is offset + compliance * tangential force, so a straight line of shift
        # against force over the press has zero slope exactly when the press is normal.
        # growth = slope * peak is the part of the shift that the press itself caused.
        loaded = [s for s in samples if s[0] >= 0.2 * peak]
        n = len(loaded)
        mean_f = sum(s[0] for s in loaded) / n
        var_f = sum((s[0] - mean_f) ** 2 for s in loaded) / n
        if var_f < (0.1 * peak) ** 2:
            # The force hardly changed: nothing tells a tilt from an offset.
            return Press(peak, (sx, sy), math.inf, len(samples), False, **plateau)
        slopes = []
        for axis in (1, 2):
            mean_s = sum(s[axis] for s in loaded) / n
            cov = sum((s[0] - mean_f) * (s[axis] - mean_s) for s in loaded) / n
            slopes.append(cov / var_f)
        growth = math.hypot(*slopes) * peak
        return Press(peak_force_n=peak, shift_m=(sx, sy), shift_growth_m=growth,
                     scans=len(samples), looks_normal=growth <= self.normal_tolerance_m,
                     **plateau)
