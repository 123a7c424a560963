"""
Skin calibration: layer offset, compliance, force curves and taxel gains, and their YAML file.

``(x_p, y_p)`` is the mean shift between the layers under presses along the normal (alpha = 0),
the seed's calibration point; the azimuth is measured from it. When those presses span a range
of normal forces and their shift follows the force measurably (a layer that shears under a
normal load), the zero moves with it: ``zero_slope_m_per_n`` (x, y) per newton of normal force
around ``zero_ref_n``, the presses' mean force (:func:`calibrate_zero`,
:meth:`Calibration.zero_m`).

The compliance (metres of layer shift per newton of tangential force) turns the shear shift into
a tangential force and hence the polar angle. Calibrate it by pressing with known tilted forces
(for instance a force gauge or a robot at a known alpha): collect the calibrated shifts
``s_i = raw_shift_i - (x_p, y_p)`` and the tangential forces ``T_i = F_i sin(alpha_i)``, then
:func:`compliance_from_presses` returns the least-squares slope ``sum(|s_i| T_i) / sum(T_i**2)``.

``force_curves`` (top, bottom) replace the assumed FSR model once a force calibration has run
(:mod:`forcecurve`); ``gains`` (top, bottom maps) even out taxels that read more or less than
their neighbours (:mod:`gains`). ``taxel_model`` is the skin's forward model learned from the
force calibration's presses when the estimator in use fits one (``model_fit``, :mod:`taxelmodel`);
``crosstalk_share`` the passive matrix's crosstalk along a line, as a share of the line's load,
that the same presses showed (:func:`session.crosstalk_share_of`; 0 where none did), which a
plate for the gains needs.

A calibration knows its skin (:class:`SkinIdentity`: grid, pitch, the name the user gives it
and, when the board said who it is, the board's unique ID and name) and when each part was made
(offset, force, compliance, gains, direction, creep, mount). Loaded for another skin, it is refused
(:class:`CalibrationMismatch`): applying a calibration to the wrong skin gives wrong forces and
directions without a word. A calibration made on one board is refused on a board with another
unique ID; one bound to no board (made before boards said who they are, or on a version-1
stream) loads anywhere its grid fits, and one bound to a board loads on a board that does not
say who it is (:meth:`Calibration.board_binding` says which, for a note or a warning). The file
is versioned YAML: version 3 adds the skin and the time of each part (its skin may carry
``board_uid`` and ``board_name``, which older readers ignore), version 2 the curves, the gains
and ``made_utc``; versions 1 and 2 still load (they name no skin, so nothing is checked).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
import datetime
import math
import os

import numpy as np
import yaml

from .creep import CreepFit
from .direction import DirectionCorrection
from ..model.forcecurve import ForceCurve
from ..model.taxelmodel import TaxelModel
from ...common.atomic import write_atomically
from ...common.boardinfo import UID_PATTERN
from ...common.validate import check_map, check_number

__all__ = ['Calibration', 'CalibrationMismatch', 'SkinIdentity', 'PARTS', 'calibrate_from_shifts',
           'calibrate_zero', 'compliance_from_presses', 'utc_now']

_FORMAT = 'skin_driver/calibration'
_VERSION = 3
_VERSIONS = (1, 2, 3)
# The parts of a calibration, each made by its own session, and the fields each one sets.
PARTS = {'offset': ('x_p_m', 'y_p_m', 'std_x_m', 'std_y_m', 'presses', 'zero_slope_m_per_n',
                    'zero_ref_n'),
         'force': ('force_curves', 'force_presses', 'taxel_model', 'crosstalk_share'),
         'compliance': ('compliance_m_per_n', 'compliance_presses'),
         'gains': ('gains',),
         'direction': ('direction',),
         'creep': ('creep',),
         'mount': ('mount',)}
# Pitches that differ by less than this share are the same.
_PITCH_TOLERANCE = 1e-6
_FIELDS = ('x_p_m', 'y_p_m', 'std_x_m', 'std_y_m', 'presses', 'compliance_m_per_n')
_COUNTS = ('presses', 'force_presses', 'compliance_presses')


def utc_now() -> str:
    """Return the time now as ISO 8601 UTC, to the second (when a calibration was made)."""
    return datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ')


class CalibrationMismatch(ValueError):
    """A calibration file made for another skin (grid, pitch or board)."""


@dataclass(frozen=True)
class SkinIdentity:
    """
    The skin a calibration belongs to: grid, pitch and the board's identity.

    ``board_id`` is what the user names the skin ('' when unnamed). ``board_uid`` (24 lowercase
    hex digits) and ``board_name`` are what the board itself said in its board information
    frame (docs/protocol.md; '' when it said nothing, as a version-1 board never does). Two
    skins differ when their grid or pitch differ, or both have a name or both a uid and those
    differ.
    """

    rows: int
    cols: int
    pitch_m: float
    board_id: str = ''
    board_uid: str = ''
    board_name: str = ''

    def __post_init__(self):
        """Reject a grid, pitch or board identity that cannot be a skin's."""
        for name in ('rows', 'cols'):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or not 1 <= v <= 1024:
                raise ValueError(f'skin {name} must be an integer in 1..1024, got {v!r}')
        check_number(self.pitch_m, 'skin pitch_m', positive=True)
        if not isinstance(self.board_id, str):
            raise ValueError(f'skin board_id must be a string, got {self.board_id!r}')
        if not isinstance(self.board_uid, str) or (
                self.board_uid and not UID_PATTERN.fullmatch(self.board_uid)):
            raise ValueError(f'skin board_uid must be 24 lowercase hex digits or empty, got '
                             f'{self.board_uid!r}')
        if not isinstance(self.board_name, str):
            raise ValueError(f'skin board_name must be a string, got {self.board_name!r}')
        object.__setattr__(self, 'rows', int(self.rows))
        object.__setattr__(self, 'cols', int(self.cols))
        object.__setattr__(self, 'pitch_m', float(self.pitch_m))

    def describe(self) -> str:
        """Return e.g. '16 x 16 taxels at 5.000 mm pitch, board skin-A, on nucleo uid 00...'."""
        board = f', board {self.board_id}' if self.board_id else ''
        on = f', on {self.board()}' if self.board_uid else ''
        return (f'{self.rows} x {self.cols} taxels at {1000 * self.pitch_m:.3f} mm pitch'
                f'{board}{on}')

    def board(self) -> str:
        """Return e.g. 'board nucleo-f446re uid 0039...', or '' when the board said nothing."""
        if not self.board_uid:
            return ''
        return f'board {self.board_name or "(unnamed)"} uid {self.board_uid}'

    def mismatch(self, other: 'SkinIdentity') -> str:
        """Return how ``other`` differs from this skin ('' when it is the same one)."""
        if self.board_uid and other.board_uid and self.board_uid != other.board_uid:
            return f'made on {self.board()}; this skin is on {other.board()}'
        same = ((self.rows, self.cols) == (other.rows, other.cols)
                and abs(self.pitch_m - other.pitch_m) <= _PITCH_TOLERANCE * self.pitch_m
                and (not self.board_id or not other.board_id or self.board_id == other.board_id))
        return '' if same else f'made for {self.describe()}, this skin is {other.describe()}'

    @classmethod
    def from_dict(cls, doc) -> 'SkinIdentity':
        """Build the identity from its YAML mapping."""
        if not isinstance(doc, dict) or not {'rows', 'cols', 'pitch_m'} <= set(doc):
            raise ValueError('skin must be a mapping with rows, cols and pitch_m')
        return cls(doc['rows'], doc['cols'], doc['pitch_m'], str(doc.get('board_id') or ''),
                   str(doc.get('board_uid') or ''), str(doc.get('board_name') or ''))


def _curves(value):
    if value is None:
        return None
    if len(value) != 2 or not all(isinstance(c, ForceCurve) for c in value):
        raise ValueError('force_curves must be (top, bottom) ForceCurve objects')
    return tuple(value)


def _gains(value):
    if value is None:
        return None
    if len(value) != 2:
        raise ValueError('gains must be (top, bottom) maps')
    maps = [check_map(g, name) for g, name in zip(value, ('top gains', 'bottom gains'))]
    if maps[0].shape != maps[1].shape:
        raise ValueError('top and bottom gains differ in shape')
    for m in maps:
        if not (m > 0).all():
            raise ValueError('gains must be positive')
    # Nested tuples keep the calibration immutable and comparable with ==.
    return tuple(tuple(tuple(float(v) for v in row) for row in m) for m in maps)


@dataclass(frozen=True)
class SkinMount:
    """
    The skin's pose on its parent link, as a mount calibration from touches found it.

    ``xyz_m`` and ``rpy_rad`` (fixed-axis roll, pitch, yaw) place the skin frame on
    ``parent_frame``; ``residual_m`` is the touches' RMS miss, ``touches`` how many there were.
    """

    parent_frame: str
    xyz_m: tuple
    rpy_rad: tuple
    residual_m: float
    touches: int
    made_utc: str = ''

    def __post_init__(self):
        """Reject an empty parent, non-finite numbers and wrong lengths."""
        if not isinstance(self.parent_frame, str) or not self.parent_frame:
            raise ValueError('mount parent_frame must be a non-empty string')
        for name in ('xyz_m', 'rpy_rad'):
            values = tuple(float(v) for v in getattr(self, name))
            if len(values) != 3:
                raise ValueError(f'mount {name} must be 3 numbers')
            object.__setattr__(self, name, tuple(check_number(v, f'mount {name}')
                                                 for v in values))
        object.__setattr__(self, 'residual_m', check_number(float(self.residual_m),
                                                            'mount residual_m',
                                                            non_negative=True))
        if isinstance(self.touches, bool) or int(self.touches) != self.touches:
            raise ValueError(f'mount touches must be an integer, got {self.touches!r}')

    @classmethod
    def from_dict(cls, doc) -> 'SkinMount':
        """Return the mount of a calibration file's ``mount`` mapping."""
        if not isinstance(doc, dict):
            raise ValueError('mount must be a mapping')
        return cls(str(doc['parent_frame']), tuple(doc['xyz_m']), tuple(doc['rpy_rad']),
                   float(doc['residual_m']), int(doc['touches']), str(doc.get('made_utc') or ''))


@dataclass(frozen=True)
class Calibration:
    """
    Everything a skin was calibrated with; a field left at its default was not calibrated.

    ``compliance_m_per_n`` = 0: the estimator uses its configured compliance. ``force_curves``
    None: the assumed FSR model. ``gains`` None: every taxel at 1. ``presses``,
    ``force_presses`` and ``compliance_presses`` count the presses behind each part;
    ``made_utc`` is when the newest part was made and ``part_utc`` when each part was (ISO
    8601, '' when unknown or never); ``skin`` the skin it belongs to (None: unknown).
    """

    x_p_m: float = 0.0
    y_p_m: float = 0.0
    std_x_m: float = 0.0
    std_y_m: float = 0.0
    presses: int = 0
    compliance_m_per_n: float = 0.0
    force_curves: tuple = None
    gains: tuple = None
    force_presses: int = 0
    compliance_presses: int = 0
    made_utc: str = ''
    skin: SkinIdentity = None
    part_utc: tuple = ('',) * len(PARTS)
    zero_slope_m_per_n: tuple = (0.0, 0.0)
    zero_ref_n: float = 0.0
    taxel_model: TaxelModel = None
    crosstalk_share: float = 0.0
    mount: 'SkinMount' = None
    direction: DirectionCorrection = None
    creep: CreepFit = None

    def __post_init__(self):
        """Reject non-finite or negative values and malformed curves or gains."""
        check_number(self.x_p_m, 'x_p_m')
        check_number(self.y_p_m, 'y_p_m')
        check_number(self.std_x_m, 'std_x_m', non_negative=True)
        check_number(self.std_y_m, 'std_y_m', non_negative=True)
        check_number(self.compliance_m_per_n, 'compliance_m_per_n', non_negative=True)
        check_number(self.zero_ref_n, 'zero_ref_n', non_negative=True)
        check_number(self.crosstalk_share, 'crosstalk_share', non_negative=True)
        if len(self.zero_slope_m_per_n) != 2:
            raise ValueError('zero_slope_m_per_n must be (x, y) metres per newton')
        object.__setattr__(self, 'zero_slope_m_per_n', tuple(
            check_number(float(v), 'zero_slope_m_per_n') for v in self.zero_slope_m_per_n))
        for name in _COUNTS:
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 0:
                raise ValueError(f'{name} must be a non-negative integer, got {v!r}')
        if not isinstance(self.made_utc, str):
            raise ValueError(f'made_utc must be a string, got {self.made_utc!r}')
        if self.skin is not None and not isinstance(self.skin, SkinIdentity):
            raise ValueError(f'skin must be a SkinIdentity, got {self.skin!r}')
        stamps = tuple(self.part_utc)
        if len(stamps) > len(PARTS) or not all(isinstance(t, str) for t in stamps):
            raise ValueError(f'part_utc must be up to {len(PARTS)} strings ({", ".join(PARTS)})')
        # Fewer stamps (the four parts before direction, creep and mount had one): unknown.
        object.__setattr__(self, 'part_utc', stamps + ('',) * (len(PARTS) - len(stamps)))
        object.__setattr__(self, 'force_curves', _curves(self.force_curves))
        object.__setattr__(self, 'gains', _gains(self.gains))
        if self.taxel_model is not None and not isinstance(self.taxel_model, TaxelModel):
            raise ValueError(f'taxel_model must be a TaxelModel, got {self.taxel_model!r}')
        if self.mount is not None and not isinstance(self.mount, SkinMount):
            raise ValueError(f'mount must be a SkinMount, got {self.mount!r}')
        if self.direction is not None and not isinstance(self.direction, DirectionCorrection):
            raise ValueError(f'direction must be a DirectionCorrection, got {self.direction!r}')
        if self.creep is not None and not isinstance(self.creep, CreepFit):
            raise ValueError(f'creep must be a CreepFit, got {self.creep!r}')

    def zero_m(self, normal_force_n: float) -> tuple:
        """Return the raw shift (x, y) of a normal press of this force: where beta is 0 from."""
        load = normal_force_n - self.zero_ref_n
        return (self.x_p_m + self.zero_slope_m_per_n[0] * load,
                self.y_p_m + self.zero_slope_m_per_n[1] * load)

    def gain_maps(self):
        """Return the gains as (top, bottom) float arrays, or (None, None)."""
        if self.gains is None:
            return None, None
        return tuple(np.array(g, dtype=np.float64) for g in self.gains)

    def updated(self, **changes) -> 'Calibration':
        """Return a copy with ``changes`` applied; the parts they touch are stamped now."""
        now = utc_now()
        touched = [any(f in changes for f in fields) for fields in PARTS.values()]
        stamps = tuple(now if t else old for t, old in zip(touched, self.part_utc))
        return replace(self, **{'made_utc': now, 'part_utc': stamps, **changes})

    def made(self, part: str) -> str:
        """Return when ``part`` (one of PARTS) was made, '' when never or unknown."""
        return self.part_utc[list(PARTS).index(part)]

    def parts_in_force(self) -> tuple:
        """
        Return (part, made) of every part calibrated, in the order of PARTS.

        A part is in force when it was stamped or any of its fields differs from the default;
        ``made`` is '' when its time is unknown (a file older than its stamp).
        """
        default = Calibration()
        return tuple((part, self.made(part)) for part, fields in PARTS.items()
                     if self.made(part) or any(getattr(self, f) != getattr(default, f)
                                               for f in fields))

    def check_skin(self, skin: SkinIdentity) -> str:
        """Return why this calibration does not belong to ``skin`` ('' when it may)."""
        if self.skin is not None:
            problem = self.skin.mismatch(skin)
            if problem:
                return problem
        if self.gains is not None and (len(self.gains[0]), len(self.gains[0][0])) != (
                skin.rows, skin.cols):
            return (f'its gains are {len(self.gains[0])} x {len(self.gains[0][0])}, this skin '
                    f'is {skin.describe()}')
        return ''

    def board_binding(self, skin: SkinIdentity) -> tuple:
        """
        Return (warning, note) on how this calibration is bound to the board of ``skin``.

        Both are '' when it is bound to that very board or neither says who it is. A warning when
        it was made on a board and this one does not say who it is (a version-1 stream): it
        cannot be checked. A note when it is bound to no board and this board says who it is.
        A calibration from another board is no binding at all: :meth:`check_skin` refuses it.
        """
        made_on = self.skin.board_uid if self.skin is not None else ''
        if made_on and not skin.board_uid:
            return (f'calibration made on {self.skin.board()}; this board does not say who it '
                    'is (version-1 stream), so it cannot be checked', '')
        if skin.board_uid and not made_on:
            return ('', f'calibration bound to no board (made before boards said who they are, '
                        f'or on a version-1 stream); this skin is on {skin.board()}, which the '
                        'next calibration records')
        return '', ''

    def describe(self) -> str:
        """Return one line saying what is calibrated, for logs and diagnostics (SI units)."""
        parts = [f'x_p = {self.x_p_m:.6f} m, y_p = {self.y_p_m:.6f} m ({self.presses} presses)']
        if self.compliance_m_per_n:
            parts.append(f'compliance {self.compliance_m_per_n:.3e} m/N '
                         f'({self.compliance_presses} presses)')
        if self.force_curves:
            parts.append(f'force curve up to {self.force_curves[1].counts[-1]:.0f} counts '
                         f'({self.force_presses} presses)')
        if self.crosstalk_share:
            parts.append(f'crosstalk {100 * self.crosstalk_share:.2f} %')
        if self.gains:
            parts.append('taxel gains')
        if self.taxel_model:
            parts.append(f'taxel model ({self.taxel_model.presses} presses)')
        if self.direction:
            parts.append(self.direction.describe())
        if self.mount:
            parts.append(f'mounted on {self.mount.parent_frame} ({self.mount.touches} touches)')
        if self.creep:
            parts.append(self.creep.describe())
        if self.skin:
            parts.append(f'for {self.skin.describe()}')
        return '; '.join(parts) + (f'; made {self.made_utc}' if self.made_utc else '')

    def to_dict(self) -> dict:
        """Return the fields as plain Python values (numbers, strings, lists)."""
        out = {k: (int(getattr(self, k)) if k in _COUNTS else float(getattr(self, k)))
               for k in _FIELDS}
        out['force_presses'] = int(self.force_presses)
        out['compliance_presses'] = int(self.compliance_presses)
        out['made_utc'] = self.made_utc
        # Only the parts made: a part never calibrated names no key, so the file an older reader
        # knows stays as it was (no creep, direction or mount key where there is none).
        out['made'] = {part: t for part, t in zip(PARTS, self.part_utc) if t}
        # A board that said nothing leaves no empty keys: such a file reads as before.
        out['skin'] = None if self.skin is None else {
            k: v for k, v in asdict(self.skin).items() if v != '' or k == 'board_id'}
        out['zero_slope_m_per_n'] = [float(v) for v in self.zero_slope_m_per_n]
        out['zero_ref_n'] = float(self.zero_ref_n)
        out['force_curves'] = (None if self.force_curves is None else
                               {layer: c.to_dict() for layer, c in
                                zip(('top', 'bottom'), self.force_curves)})
        out['gains'] = (None if self.gains is None else
                        {layer: [list(row) for row in g] for layer, g in
                         zip(('top', 'bottom'), self.gains)})
        out['taxel_model'] = None if self.taxel_model is None else self.taxel_model.to_dict()
        out['crosstalk_share'] = float(self.crosstalk_share)
        if self.mount is not None:
            # Only when there is one: older readers see the file they know.
            out['mount'] = {k: list(v) if isinstance(v, tuple) else v
                            for k, v in asdict(self.mount).items()}
        if self.direction is not None:
            # Only when there is one, like the mount (issue #38's correction, direction.py).
            out['direction'] = self.direction.to_dict()
        if self.creep is not None:
            out['creep'] = self.creep.to_dict()
        return out

    def save_yaml(self, path, make_parents: bool = False) -> None:
        """Write the calibration to ``path`` atomically (temp file, fsync, rename)."""
        doc = {'format': _FORMAT, 'version': _VERSION, **self.to_dict()}
        write_atomically(path, lambda f: yaml.safe_dump(doc, f, sort_keys=False),
                         make_parents=make_parents)

    @classmethod
    def load_yaml(cls, path, skin: SkinIdentity = None) -> 'Calibration':
        """
        Read and validate a calibration written by :meth:`save_yaml` (version 1, 2 or 3).

        With ``skin``, a calibration made for another skin raises :class:`CalibrationMismatch`.
        """
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
        if doc.get('version', 1) not in _VERSIONS:
            raise ValueError(f'{path}: unsupported calibration version {doc.get("version")!r}')
        missing = [k for k in _FIELDS if k not in doc]
        if missing:
            raise ValueError(f'{path}: missing fields: {", ".join(missing)}')
        values = {}
        for k in (*_FIELDS, 'force_presses', 'compliance_presses'):
            if k not in doc:
                continue
            v = doc[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f'{path}: {k} must be a number, got {v!r}')
            values[k] = v
        try:
            values['made_utc'] = str(doc.get('made_utc') or '')
            made = doc.get('made') or {}
            if not isinstance(made, dict):
                raise ValueError('made must map each part to a time')
            values['part_utc'] = tuple(str(made.get(part) or '') for part in PARTS)
            if doc.get('skin') is not None:
                values['skin'] = SkinIdentity.from_dict(doc['skin'])
            if doc.get('zero_slope_m_per_n') is not None:
                values['zero_slope_m_per_n'] = tuple(float(v)
                                                     for v in doc['zero_slope_m_per_n'])
                values['zero_ref_n'] = float(doc.get('zero_ref_n', 0.0))
            curves = doc.get('force_curves')
            if curves is not None:
                values['force_curves'] = tuple(ForceCurve.from_dict(curves[layer])
                                               for layer in ('top', 'bottom'))
            gains = doc.get('gains')
            if gains is not None:
                values['gains'] = tuple(np.array(gains[layer], dtype=np.float64)
                                        for layer in ('top', 'bottom'))
            if doc.get('taxel_model') is not None:
                values['taxel_model'] = TaxelModel.from_dict(doc['taxel_model'])
            # Files written before the term was settled name the share leak_share.
            share = doc.get('crosstalk_share', doc.get('leak_share'))
            if share is not None:
                values['crosstalk_share'] = float(share)
            if doc.get('mount') is not None:
                values['mount'] = SkinMount.from_dict(doc['mount'])
            if doc.get('direction') is not None:
                values['direction'] = DirectionCorrection.from_dict(doc['direction'])
            if doc.get('creep') is not None:
                values['creep'] = CreepFit.from_dict(doc['creep'])
            cal = cls(**values)
            # Files written before the made map named them: the part's own time, if any.
            own = {'mount': cal.mount, 'creep': cal.creep}
            cal = replace(cal, part_utc=tuple(
                t or getattr(own.get(part), 'made_utc', '') or ''
                for part, t in zip(PARTS, cal.part_utc)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f'{path}: {exc}') from None
        problem = cal.check_skin(skin) if skin is not None else ''
        if problem:
            raise CalibrationMismatch(f'{path}: {problem}; this skin needs a calibration file '
                                      'of its own')
        return cal


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


# A slope of the zero with the normal force is kept only when it stands out of its own noise
# by this many standard errors; otherwise the zero is the plain mean.
_SLOPE_SIGNIFICANCE = 3.0
# Presses whose normal forces span less than this ratio (largest / smallest) cannot measure the
# layer's slope: what their shifts do over a few percent of force is the estimator's own bias
# at that spot, and a slope taken from it is extrapolated to forces they never had (the
# paper's protocol re-takes the zero at 20 N from presses within 3 % of each other; a slope
# fitted to them moved its 45 deg presses, 6 N lighter, by a quarter of a taxel).
_SLOPE_SPAN = 2.0


def calibrate_zero(shifts_m, normal_forces_n, max_std_m: float = 0.001,
                   prior_slope_m_per_n=(0.0, 0.0)) -> Calibration:
    """
    Return the calibration of the zero from normal presses: mean shift and, when measurable, slope.

    ``shifts_m`` K x 2 raw shifts, ``normal_forces_n`` the K measured normal forces. On each axis
    the shift is fitted as ``mean + slope * (F - mean F)``; a slope within
    ``_SLOPE_SIGNIFICANCE`` standard errors of zero is dropped, unless it is as close to
    ``prior_slope_m_per_n`` (the slope in force, a property of the layer). Presses made at
    about one force (forces spanning less than ``_SLOPE_SPAN``; the paper's protocol at its
    spot) measure no slope: they re-take the zero at their place and keep the slope that
    presses over a range of forces measured. ``std_x_m``, ``std_y_m`` are the spreads about the
    fitted zero. Errors as :func:`calibrate_from_shifts`.
    """
    plain = calibrate_from_shifts(shifts_m, max_std_m)
    s = np.asarray(shifts_m, dtype=np.float64).reshape(-1, 2)
    f = np.asarray(normal_forces_n, dtype=np.float64).ravel()
    if f.shape != (s.shape[0],) or not np.isfinite(f).all():
        raise ValueError(f'need one finite normal force per shift, got {f.shape}')
    prior = tuple(check_number(float(v), 'prior_slope_m_per_n') for v in prior_slope_m_per_n)
    ref = float(f.mean())
    df = f - ref
    spread = float(df @ df)
    if s.shape[0] < 4 or spread <= 0:
        return replace(plain, zero_ref_n=max(ref, 0.0), zero_slope_m_per_n=prior)
    at_one_force = f.max() < _SLOPE_SPAN * max(f.min(), 0.0)
    slopes, stds = [], []
    for axis in range(2):
        d = s[:, axis] - s[:, axis].mean()
        slope = float(d @ df) / spread
        rest = d - slope * df
        error = math.sqrt(float(rest @ rest) / (s.shape[0] - 2) / spread)
        if at_one_force:
            slope = prior[axis]
        elif abs(slope) <= _SLOPE_SIGNIFICANCE * error:
            slope = (prior[axis] if abs(slope - prior[axis]) <= _SLOPE_SIGNIFICANCE * error
                     else 0.0)
        slopes.append(slope)
        stds.append(float((d - slope * df).std()))
    return replace(plain, std_x_m=stds[0], std_y_m=stds[1], zero_slope_m_per_n=tuple(slopes),
                   zero_ref_n=max(ref, 0.0))


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
