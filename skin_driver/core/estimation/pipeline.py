"""
The contact estimation pipeline used by the ROS nodes, the evaluator and the benchmark.

raw counts (top, bottom) -> conditioning (tare, threshold, FSR model -> force per taxel)
-> contacts (segmentation, sub-taxel centroid, force, area, window)
-> shift between the layers in each window (named estimator from :mod:`shift`)
-> calibrated shift ``s = raw - (x_p, y_p)`` -> azimuth ``atan2(s_y, s_x)``
-> tangential force ``|s| / compliance`` -> polar angle and 3-D force.

Normal force: the taxels sense only ``fill_factor**2`` of the skin area, so the summed taxel
forces of a contact are divided by it. The bottom layer's sum is used because the elastic layer
spreads the pressure over several taxels, which makes the sensed share independent of where the
contact sits (within 1 % in simulation); the top layer's share varies by +-5 % with the sub-taxel
position of a small indenter. At the map edge, where the wider bottom imprint is cut first, the
larger of the two sums is used.

Skin frame: x along columns, y along rows, z out of the skin. Pressing into the skin is a force
along -z, so ``force_xyz_n[2] = -force_n`` (``force_n`` is the normal magnitude, >= 0). The
tangential components point along the azimuth, the direction in which the top layer is pushed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from .calibration import Calibration
from .conditioning import Conditioner, ConditioningConfig
from .contacts import segment_stacked, window_stack
from .fsr import FsrModel
from .shift import DEFAULT_METHOD, get_method, NO_SHIFT
from .validate import check_number, check_pair

__all__ = ['EstimatorConfig', 'Contact', 'ContactEstimator']


@dataclass(frozen=True)
class EstimatorConfig:
    """
    Parameters of the pipeline (SI units).

    ``min_confidence``: estimates below it get ``direction_valid = False``.
    ``min_shift_m``: a calibrated shift shorter than this is no shear (alpha = 0, no direction).
    ``max_shift_m``: a shift longer than this is not physical for the skin; no direction.
    ``compliance_m_per_n``: layer shift per tangential newton, used when the calibration has none.
    ``force_scale``: extra factor on the normal force (a user's force calibration; 1 = none).
    ``fill_factor``: sensitive fraction of the pitch on each axis; normal force = summed taxel
    forces / fill_factor**2.
    """

    method: str = DEFAULT_METHOD
    pitch_m: float = 0.005
    compliance_m_per_n: float = 7.0e-4
    threshold_counts: float = 40.0
    noise_sigmas: float = 5.0
    min_contact_force_n: float = 0.05
    min_confidence: float = 0.3
    min_shift_m: float = 2.5e-4
    max_shift_m: float = 0.02
    window_margin: int = 1
    max_contacts: int = 32
    force_scale: float = 1.0
    fsr: FsrModel = field(default_factory=FsrModel)
    fill_factor: float = 0.9

    def __post_init__(self):
        """Validate every field and the method name."""
        get_method(self.method)
        check_number(self.pitch_m, 'pitch_m', positive=True)
        check_number(self.compliance_m_per_n, 'compliance_m_per_n', positive=True)
        check_number(self.threshold_counts, 'threshold_counts', non_negative=True)
        check_number(self.noise_sigmas, 'noise_sigmas', non_negative=True)
        check_number(self.min_contact_force_n, 'min_contact_force_n', non_negative=True)
        check_number(self.min_confidence, 'min_confidence', low=0.0, high=1.0)
        check_number(self.min_shift_m, 'min_shift_m', non_negative=True)
        check_number(self.max_shift_m, 'max_shift_m', positive=True)
        check_number(self.force_scale, 'force_scale', positive=True)
        check_number(self.fill_factor, 'fill_factor', low=0.05, high=1.0)
        for name in ('window_margin', 'max_contacts'):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 0:
                raise ValueError(f'{name} must be a non-negative integer, got {v!r}')


@dataclass(frozen=True)
class Contact:
    """
    One contact in the skin frame (SI units); never holds NaN or inf.

    ``shift_m`` is the calibrated layer shift; ``azimuth_rad`` (in (-pi, pi]) and the tangential
    part of ``force_xyz_n`` are meaningful only when ``direction_valid``; otherwise they are 0 and
    ``alpha_rad`` is 0. ``azimuth_sigma_rad`` is the 1-sigma uncertainty of the azimuth (pi when
    there is no direction).
    """

    x_m: float
    y_m: float
    force_n: float
    area_m2: float
    shift_m: tuple
    azimuth_rad: float
    azimuth_sigma_rad: float
    alpha_rad: float
    force_xyz_n: tuple
    confidence: float
    direction_valid: bool


def _finite(v: float) -> float:
    return float(v) if math.isfinite(v) else 0.0


class ContactEstimator:
    """Estimate contacts (location, force, direction) from raw top and bottom count maps."""

    def __init__(self, config: EstimatorConfig = None, calibration: Calibration = None,
                 conditioner: Conditioner = None):
        """Create the pipeline; ``conditioner`` may carry a tare, else a fresh one is made."""
        self.config = config or EstimatorConfig()
        self.conditioner = conditioner or Conditioner(ConditioningConfig(
            fsr=self.config.fsr, threshold_counts=self.config.threshold_counts,
            noise_sigmas=self.config.noise_sigmas))
        self.calibration = calibration or Calibration()
        self._method = get_method(self.config.method)

    @property
    def calibration(self) -> Calibration:
        """Return the calibration in force."""
        return self._calibration

    @calibration.setter
    def calibration(self, calibration: Calibration) -> None:
        """Put ``calibration`` in force, its force curves and gains in the conditioner too."""
        self.conditioner.set_force_curves(*(calibration.force_curves or (None, None)))
        top, bottom = calibration.gain_maps()
        if top is not None or self.conditioner.shape is not None:
            self.conditioner.set_gain(top, bottom)
        self._calibration = calibration

    @property
    def compliance_m_per_n(self) -> float:
        """Return the compliance in use: the calibrated one, else the configured one."""
        return self.calibration.compliance_m_per_n or self.config.compliance_m_per_n

    def tare(self, top_frames, bottom_frames) -> None:
        """Tare the conditioner from no-touch frames (N x rows x cols each)."""
        self.conditioner.tare(top_frames, bottom_frames)

    def _raw(self, top_counts, bottom_counts) -> list:
        """Return [(segment, ShiftEstimate)] for the contacts, strongest first."""
        t, b = check_pair(top_counts, bottom_counts)
        cfg = self.config
        maps = self.conditioner.condition_stacked(t, b)
        segments, labels, components = segment_stacked(maps, cfg.pitch_m,
                                                       cfg.min_contact_force_n, cfg.window_margin)
        method = self._method
        out = []
        whole = None
        for seg in segments[:cfg.max_contacts]:
            if method.whole_map:
                if whole is None:
                    whole = method.function(t.astype(np.float64), b.astype(np.float64))
                est = whole
            else:
                window = window_stack(maps, labels, seg, alone=components == 2)
                if method.stacked is not None:
                    est = method.stacked(window)
                else:
                    est = method.function(window[0], window[1])
            if not (math.isfinite(est.dx) and math.isfinite(est.dy)):
                est = NO_SHIFT
            out.append((seg, est))
        return out

    def _normal_force(self, seg) -> float:
        """Return the contact's normal force: sensed sum / fill_factor**2 (module docstring)."""
        cfg = self.config
        sensed = max(seg.force_n, seg.bottom_force_n) if seg.at_border else seg.bottom_force_n
        if sensed <= 0:
            sensed = seg.force_n
        return sensed * cfg.force_scale / (cfg.fill_factor * cfg.fill_factor)

    def measure_shifts(self, top_counts, bottom_counts) -> list:
        """
        Return the uncalibrated layer shifts (x, y) in metres of the contacts, strongest first.

        Use it on normal presses to feed :func:`calibration.calibrate_from_shifts`.
        """
        p = self.config.pitch_m
        return [(est.dx * p, est.dy * p) for _, est in self._raw(top_counts, bottom_counts)]

    def process(self, top_counts, bottom_counts) -> list:
        """Return the contacts in the two raw count maps, strongest (normal force) first."""
        cfg = self.config
        cal = self.calibration
        compliance = self.compliance_m_per_n
        pitch = cfg.pitch_m
        contacts = []
        for seg, est in self._raw(top_counts, bottom_counts):
            raw_x, raw_y = est.dx * pitch, est.dy * pitch
            sx, sy = raw_x - cal.x_p_m, raw_y - cal.y_p_m
            magnitude = math.hypot(sx, sy)
            normal = self._normal_force(seg)
            conf = min(max(_finite(est.confidence), 0.0), 1.0)
            valid = (conf >= cfg.min_confidence and cfg.min_shift_m <= magnitude
                     and math.hypot(raw_x, raw_y) <= cfg.max_shift_m)
            if valid:
                azimuth = math.atan2(sy, sx)
                tangential = magnitude / compliance
                alpha = math.atan2(tangential, normal)
                fx, fy = tangential * math.cos(azimuth), tangential * math.sin(azimuth)
                sigma = min(math.pi, math.atan2(0.05 * pitch, magnitude))
            else:
                azimuth = alpha = fx = fy = 0.0
                sigma = math.pi
            contacts.append(Contact(
                x_m=seg.x_m, y_m=seg.y_m, force_n=normal, area_m2=seg.area_m2,
                shift_m=(_finite(sx), _finite(sy)), azimuth_rad=azimuth,
                azimuth_sigma_rad=sigma, alpha_rad=alpha,
                force_xyz_n=(fx, fy, -normal), confidence=conf, direction_valid=bool(valid)))
        return contacts
