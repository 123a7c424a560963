"""
The contact estimation pipeline used by the ROS nodes, the evaluator and the benchmark.

raw counts (top, bottom) -> conditioning (tare, threshold, FSR model -> force per taxel)
-> contacts (segmentation, sub-taxel centroid, force, area, window)
-> shift between the layers in each window (named estimator from :mod:`direction`)
-> calibrated shift ``s = raw - (x_p, y_p)`` -> azimuth ``atan2(s_y, s_x)``
-> tangential force ``|s| / compliance`` -> polar angle and 3-D force.

Skin frame: x along columns, y along rows, z out of the skin. Pressing into the skin is a force
along -z, so ``force_xyz_n[2] = -force_n`` (``force_n`` is the normal magnitude, >= 0). The
tangential components point along the azimuth, the direction in which the top layer is pushed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math

import numpy as np

from .calibration import Calibration
from .conditioning import ConditioningConfig, Conditioner
from .contacts import contact_windows, segment
from .direction import DEFAULT_METHOD, NO_SHIFT, get_method
from .physics import FsrModel
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
    ``force_scale``: multiplies the summed taxel forces, e.g. to account for insensitive gaps.
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
    ``alpha_rad`` is 0.
    """

    x_m: float
    y_m: float
    force_n: float
    area_m2: float
    shift_m: tuple
    azimuth_rad: float
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
        self.calibration = calibration or Calibration()
        self.conditioner = conditioner or Conditioner(ConditioningConfig(
            fsr=self.config.fsr, threshold_counts=self.config.threshold_counts,
            noise_sigmas=self.config.noise_sigmas))
        self._method = get_method(self.config.method)

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
        tf, bf = self.conditioner.condition_checked(t, b)
        segments, labels = segment(tf, bf, cfg.pitch_m, cfg.min_contact_force_n,
                                   cfg.window_margin)
        segments = segments[:cfg.max_contacts]
        out = []
        whole = None
        for seg in segments:
            if self._method.whole_map:
                if whole is None:
                    whole = self._method.function(t.astype(np.float64), b.astype(np.float64))
                est = whole
            else:
                tw, bw = contact_windows(tf, bf, labels, seg)
                est = self._method.function(tw, bw)
            if not (math.isfinite(est.dx) and math.isfinite(est.dy)):
                est = NO_SHIFT
            out.append((seg, est))
        return out

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
            normal = seg.force_n * cfg.force_scale
            conf = min(max(_finite(est.confidence), 0.0), 1.0)
            valid = (conf >= cfg.min_confidence and cfg.min_shift_m <= magnitude
                     and math.hypot(raw_x, raw_y) <= cfg.max_shift_m)
            if valid:
                azimuth = math.atan2(sy, sx)
                tangential = magnitude / compliance
                alpha = math.atan2(tangential, normal)
                fx, fy = tangential * math.cos(azimuth), tangential * math.sin(azimuth)
            else:
                azimuth = alpha = fx = fy = 0.0
            contacts.append(Contact(
                x_m=seg.x_m, y_m=seg.y_m, force_n=normal, area_m2=seg.area_m2,
                shift_m=(_finite(sx), _finite(sy)), azimuth_rad=azimuth, alpha_rad=alpha,
                force_xyz_n=(fx, fy, -normal), confidence=conf, direction_valid=bool(valid)))
        return contacts
