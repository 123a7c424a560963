"""
Skin calibration: the layer offset (x_p, y_p) from normal presses and the layer compliance.

``(x_p, y_p)`` is the mean shift between the layers under presses along the normal (alpha = 0),
the seed's calibration point; the azimuth is measured from it.

The compliance (metres of layer shift per newton of tangential force) turns the shear shift into
a tangential force and hence the polar angle. Calibrate it by pressing with known tilted forces
(for instance a force gauge or a robot at a known alpha): collect the calibrated shifts
``s_i = raw_shift_i - (x_p, y_p)`` and the tangential forces ``T_i = F_i sin(alpha_i)``, then
:func:`compliance_from_presses` returns the least-squares slope ``sum(|s_i| T_i) / sum(T_i**2)``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math
import os

import numpy as np
import yaml

from .atomic import write_atomically
from .validate import check_number

__all__ = ['Calibration', 'calibrate_from_shifts', 'compliance_from_presses']

_FORMAT = 'skin_driver/calibration'
_VERSION = 1
_FIELDS = ('x_p_m', 'y_p_m', 'std_x_m', 'std_y_m', 'presses', 'compliance_m_per_n')


@dataclass(frozen=True)
class Calibration:
    """
    Layer offset and its spread from ``presses`` normal presses, plus the compliance.

    ``compliance_m_per_n`` = 0 means not calibrated (the estimator then uses its configured one).
    """

    x_p_m: float = 0.0
    y_p_m: float = 0.0
    std_x_m: float = 0.0
    std_y_m: float = 0.0
    presses: int = 0
    compliance_m_per_n: float = 0.0

    def __post_init__(self):
        """Reject non-finite or negative values."""
        check_number(self.x_p_m, 'x_p_m')
        check_number(self.y_p_m, 'y_p_m')
        check_number(self.std_x_m, 'std_x_m', non_negative=True)
        check_number(self.std_y_m, 'std_y_m', non_negative=True)
        check_number(self.compliance_m_per_n, 'compliance_m_per_n', non_negative=True)
        if isinstance(self.presses, bool) or int(self.presses) != self.presses or self.presses < 0:
            raise ValueError(f'presses must be a non-negative integer, got {self.presses!r}')

    def to_dict(self) -> dict:
        """Return the fields as plain Python numbers."""
        d = asdict(self)
        return {k: (int(d[k]) if k == 'presses' else float(d[k])) for k in _FIELDS}

    def save_yaml(self, path) -> None:
        """Write the calibration to ``path`` atomically (temp file, fsync, rename)."""
        doc = {'format': _FORMAT, 'version': _VERSION, **self.to_dict()}
        write_atomically(path, lambda f: yaml.safe_dump(doc, f, sort_keys=False))

    @classmethod
    def load_yaml(cls, path) -> 'Calibration':
        """Read and validate a calibration written by :meth:`save_yaml`."""
        path = os.fspath(path)
        try:
            with open(path, 'r', encoding='utf-8') as f:
                doc = yaml.safe_load(f)
        except yaml.YAMLError as exc:
            raise ValueError(f'{path}: not valid YAML: {exc}') from None
        if not isinstance(doc, dict):
            raise ValueError(f'{path}: expected a mapping of calibration fields')
        if doc.get('format', _FORMAT) != _FORMAT:
            raise ValueError(f'{path}: format is {doc.get("format")!r}, expected {_FORMAT!r}')
        if doc.get('version', _VERSION) != _VERSION:
            raise ValueError(f'{path}: unsupported calibration version {doc.get("version")!r}')
        missing = [k for k in _FIELDS if k not in doc]
        if missing:
            raise ValueError(f'{path}: missing fields: {", ".join(missing)}')
        values = {}
        for k in _FIELDS:
            v = doc[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f'{path}: {k} must be a number, got {v!r}')
            values[k] = v
        return cls(**values)


def calibrate_from_shifts(shifts_m, max_std_m: float = 0.001,
                          compliance_m_per_n: float = 0.0) -> Calibration:
    """
    Return the calibration from raw layer shifts (K x 2, metres) of normal presses.

    Raises ValueError when there are no presses, a shift is not finite, or the spread of the
    shifts along x or y exceeds ``max_std_m`` (the presses were not normal or the skin moved).
    """
    max_std = check_number(max_std_m, 'max_std_m', positive=True) if not (
        isinstance(max_std_m, float) and math.isinf(max_std_m)) else math.inf
    s = np.asarray(shifts_m, dtype=np.float64) if not isinstance(shifts_m, np.ndarray) \
        else shifts_m.astype(np.float64)
    if s.size == 0:
        raise ValueError('no normal presses to calibrate from')
    if s.ndim != 2 or s.shape[1] != 2:
        raise ValueError(f'shifts must be K x 2 (x, y) in metres, got shape {s.shape}')
    if not np.isfinite(s).all():
        raise ValueError('shifts contain NaN or inf')
    mean = s.mean(axis=0)
    std = s.std(axis=0)
    if std.max() > max_std:
        raise ValueError(f'normal-press shifts spread too much: std ({std[0]:.2e}, '
                         f'{std[1]:.2e}) m > max_std_m {max_std:.2e} m; '
                         'repeat the presses along the normal')
    return Calibration(float(mean[0]), float(mean[1]), float(std[0]), float(std[1]),
                       int(s.shape[0]), float(compliance_m_per_n))


def compliance_from_presses(shifts_m, tangential_force_n, offset_m=(0.0, 0.0)) -> float:
    """Return the layer compliance (m/N) from raw shifts (K x 2) and tangential forces (K)."""
    s = np.asarray(shifts_m, dtype=np.float64)
    t = np.asarray(tangential_force_n, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] != 2 or t.shape != (s.shape[0],) or s.shape[0] == 0:
        raise ValueError(f'need K x 2 shifts and K forces, got {s.shape} and {t.shape}')
    if not (np.isfinite(s).all() and np.isfinite(t).all()):
        raise ValueError('shifts or forces contain NaN or inf')
    if (t < 0).any():
        raise ValueError('tangential forces must be non-negative')
    den = float(t @ t)
    if den <= 0:
        raise ValueError('tangential forces are all zero; press at alpha > 0 to calibrate')
    mag = np.hypot(s[:, 0] - offset_m[0], s[:, 1] - offset_m[1])
    return float(mag @ t / den)
