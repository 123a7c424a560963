"""
Scenes: YAML scripts of presses that drive the simulated skin.

A scene file is a mapping::

    name: seed                 # optional, defaults to the file name
    description: ...           # optional
    model: {rows: 16, cols: 16, pitch_m: 0.005, noise_counts: 4.0, crosstalk: 0.0,
            dead_taxels: [[3, 4]], misalignment_m: [0.0, 0.0], fsr: {r_series_ohm: 1000}}
    skin: soft                 # or a skin of the family (core/sim/skins.py) instead of model
    repeat: 3                  # play the script this many times (default 1)
    period_s: 20.0             # length of one repetition (default: end of the last press)
    defaults: {x_m: 0.0375, y_m: 0.0375, radius_m: 0.004}   # merged into every press
    presses:
      - {time_s: 0.5, force_n: 10, alpha_deg: 45, beta_deg: 90, duration_s: 1.0, ramp_s: 0.2,
         label: tilted}       # label: optional, a name for a group of presses
    generator: {kind: random, seed: 1, count: 20, ...}     # optional, adds generated presses
    drift: {creep_per_decade: 0.05, offset_counts_per_hour: 360}   # optional (below)
    mount: {xyz: [0.1, 0.0, 0.3], rpy: [0.0, 1.5708, 0.0]}     # optional (below)

Generators: ``kind: random`` (presses at random spots, ranges given per field) and ``kind: paper``
(the paper's protocol as :func:`.paper.paper_presses` defines it: ``repeats``,
``leading_normal``, ``normal_per_repeat``, ``force_n`` (default: the skin's ``paper_force_n``),
one press every ``interval_s`` from ``start_s``).

``drift`` makes a live board render creep and offset drift over time (:mod:`.drift`): a
mapping of :class:`Drift` fields (the skin's drift, whatever the model had), or ``true`` for
the drift of the ``skin`` named (the family's skins have one). A press creeps by its
equivalent age under load (:func:`.drift.held_age` over the presses of every repetition whose
discs overlap it, so a press soon after another at that spot starts where the film got to);
the offsets drift with the board's clock, which runs on when a looped scene starts again.
``mount`` is the skin frame's pose on its parent link (``xyz`` in metres, ``rpy`` in radians,
as in a URDF joint): :meth:`Scene.mount_points` gives where the presses labelled ``mount``
touch in the parent frame, the points a mount calibration is given.

``model`` keys are the fields of :class:`skin_driver.core.sim.physics.SkinModel`.  Angles are in
degrees in the file only; everything a scene returns is SI with angles in radians.  A press's force
ramps up linearly over ``ramp_s``, holds, and ramps down over the last ``ramp_s`` of its
``duration_s``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import functools
import importlib.resources
import math
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from .drift import Drift, held_age
from .fsr import FsrFilm
from .paper import PAPER_FORCE_N, paper_presses
from .physics import Press, SkinModel
from .skins import family_skin

PRESS_FIELDS = ('time_s', 'x_m', 'y_m', 'force_n', 'alpha_deg', 'beta_deg', 'radius_m',
                'duration_s')
DEFAULT_RAMP_S = 0.1
_TOP_LEVEL = ('name', 'description', 'model', 'skin', 'repeat', 'period_s', 'defaults',
              'presses', 'generator', 'drift', 'mount')


@dataclass(frozen=True)
class ScenePress:
    """One scripted press: where, how hard, which way, when and for how long."""

    time_s: float
    x_m: float
    y_m: float
    force_n: float
    alpha_deg: float
    beta_deg: float
    radius_m: float
    duration_s: float
    ramp_s: float = DEFAULT_RAMP_S
    label: str = ''

    @property
    def end_s(self) -> float:
        """Return the time at which the press has ended."""
        return self.time_s + self.duration_s

    def envelope(self, t: float) -> float:
        """Return the fraction (0..1) of the full force acting at scene time t."""
        if not self.time_s < t < self.end_s:
            return 0.0
        if self.ramp_s <= 0:
            return 1.0
        return min(1.0, (t - self.time_s) / self.ramp_s, (self.end_s - t) / self.ramp_s)

    def press(self, fraction: float = 1.0) -> Press:
        """Return the physics press at the given fraction of the full force."""
        return Press(x_m=self.x_m, y_m=self.y_m, force_n=self.force_n * fraction,
                     alpha_rad=math.radians(self.alpha_deg), beta_rad=math.radians(self.beta_deg),
                     radius_m=self.radius_m)


@dataclass(frozen=True)
class Scene:
    """A skin model and a script of presses, optionally repeated."""

    name: str
    model: SkinModel
    presses: tuple
    repeat: int = 1
    period_s: float = 0.0
    description: str = ''
    drifts: bool = False  # a live board renders the model's drift (creep, offsets) over time
    mount: tuple = ()  # (x, y, z, roll, pitch, yaw) of the skin frame on its parent, or none

    @property
    def duration_s(self) -> float:
        """Return the length of the whole scene, all repetitions included."""
        return self.period_s * self.repeat

    def active_at(self, t: float) -> list:
        """Return (press index, physics Press) for every press acting at scene time t."""
        if not math.isfinite(t) or t < 0 or self.period_s <= 0:
            return []
        k = math.floor(t / self.period_s)
        if k >= self.repeat:
            return []
        local = t - k * self.period_s
        active = []
        for i, p in enumerate(self.presses):
            e = p.envelope(local)
            if e > 0:
                active.append((i, p.press(e)))
        return active

    def presses_at(self, t: float) -> list:
        """Return the physics presses acting at scene time t."""
        return [p for _, p in self.active_at(t)]

    def labelled(self, label: str) -> list:
        """Return the presses of one label (one repetition), in the order of the script."""
        return [p for p in self.presses if p.label == label]

    def loads(self, index: int) -> tuple:
        """
        Return the (on, off) scene times, in order and merged, of the loads a press's film sees.

        Those are the press's own and those of every press whose disc overlaps its disc, in
        every repetition: the film under a press remembers them all (:func:`.drift.held_age`).
        """
        return _loads(self, index)

    def held_ages(self, t: float) -> list:
        """Return (physics Press, equivalent age under load, s) of every press acting at t."""
        drift = self.model.drift
        return [(press, held_age(drift, list(self.loads(i)), t))
                for i, press in self.active_at(t)]

    def mount_points(self, label: str = 'mount') -> list:
        """Return where each press of ``label`` touches, (x, y, z) m in the mount's parent."""
        if not self.mount:
            raise ValueError(f'scene {self.name!r} has no mount: give mount: {{xyz, rpy}}')
        x, y, z, roll, pitch, yaw = self.mount
        rotation = _rotation(roll, pitch, yaw)
        return [tuple(float(v) for v in rotation @ (p.x_m, p.y_m, 0.0) + (x, y, z))
                for p in self.labelled(label)]

    def hold_times(self) -> list:
        """Return (scene time, press index) at the middle of every press, all repetitions."""
        return [(k * self.period_s + p.time_s + p.duration_s / 2.0, i)
                for k in range(self.repeat) for i, p in enumerate(self.presses)]


@functools.lru_cache(maxsize=4096)
def _loads(scene: Scene, index: int) -> tuple:
    mine = scene.presses[index]
    near = [p for p in scene.presses
            if math.hypot(p.x_m - mine.x_m, p.y_m - mine.y_m) < p.radius_m + mine.radius_m]
    spans = sorted((k * scene.period_s + p.time_s, k * scene.period_s + p.end_s)
                   for k in range(scene.repeat) for p in near)
    merged = []
    for on, off in spans:
        if merged and on <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], off))
        else:
            merged.append((on, off))
    return tuple(merged)


def _rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Return the rotation matrix of URDF roll, pitch, yaw (about fixed x, y, z in turn)."""
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _drift(data: Any, model: SkinModel) -> tuple:
    """Return (model, whether it drifts) of a scene's drift key."""
    if data is None or data is False:
        return model, False
    if data is True:
        if not (model.drift.creeps or model.drift.drifts):
            raise ValueError('drift: true needs a skin that drifts (a skin of the family); '
                             'else give a mapping of Drift fields')
        return model, True
    names = [f.name for f in dataclasses.fields(Drift)]
    if not isinstance(data, Mapping) or set(data) - set(names):
        raise ValueError(f'drift: must be true or a mapping of {", ".join(names)}, got {data!r}')
    try:
        drift = Drift(**{k: _number('drift', k, v) for k, v in data.items()})
    except (TypeError, ValueError) as err:
        raise ValueError(f'drift: {err}') from None
    return dataclasses.replace(model, drift=drift), True


def _mount(data: Any) -> tuple:
    """Return (x, y, z, roll, pitch, yaw) of a scene's mount key, () without one."""
    if data is None:
        return ()
    if not isinstance(data, Mapping) or set(data) != {'xyz', 'rpy'} or not all(
            isinstance(data[k], (list, tuple)) and len(data[k]) == 3 for k in ('xyz', 'rpy')):
        raise ValueError(f'mount: must be {{xyz: [x, y, z], rpy: [roll, pitch, yaw]}}, got '
                         f'{data!r}')
    return tuple(_number('mount', k, v) for k in ('xyz', 'rpy') for v in data[k])


def _number(where: str, field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f'{where}: field {field!r} must be a number, got {value!r}')
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f'{where}: field {field!r} must be finite, got {value}')
    return value


def _press(index: int, entry: Any, defaults: Mapping) -> ScenePress:
    where = f'press {index}'
    if not isinstance(entry, Mapping):
        raise ValueError(f'{where}: must be a mapping of fields, got {entry!r}')
    merged = {**defaults, **entry}
    label = merged.pop('label', '')
    if not isinstance(label, str):
        raise ValueError(f"{where}: field 'label' must be a string, got {label!r}")
    allowed = PRESS_FIELDS + ('ramp_s', 'label')
    for key in merged:
        if key not in allowed:
            raise ValueError(f'{where}: unknown field {key!r}; fields are {", ".join(allowed)}')
    missing = [f for f in PRESS_FIELDS if f not in merged]
    if missing:
        raise ValueError(f'{where}: missing field {missing[0]!r}')
    v = {k: _number(where, k, merged[k]) for k in merged}
    v.setdefault('ramp_s', min(DEFAULT_RAMP_S, v['duration_s'] / 2.0))
    checks = (
        ('time_s', v['time_s'] >= 0, 'must be >= 0'),
        ('force_n', v['force_n'] > 0, 'must be > 0'),
        ('alpha_deg', 0 <= v['alpha_deg'] < 90, 'must be in [0, 90)'),
        ('radius_m', v['radius_m'] > 0, 'must be > 0'),
        ('duration_s', v['duration_s'] > 0, 'must be > 0'),
        ('ramp_s', 0 <= 2 * v['ramp_s'] <= v['duration_s'], 'must be in [0, duration_s / 2]'),
    )
    for field, ok, rule in checks:
        if not ok:
            raise ValueError(f'{where}: field {field!r} {rule}, got {v[field]}')
    return ScenePress(**v, label=label)


def _model(data: Any) -> SkinModel:
    if data is None:
        return SkinModel()
    if not isinstance(data, Mapping):
        raise ValueError(f'model: must be a mapping of SkinModel fields, got {data!r}')
    names = {f.name for f in dataclasses.fields(SkinModel)}
    kwargs = {}
    for key, value in data.items():
        if key not in names:
            raise ValueError(f'model: unknown field {key!r}; fields are '
                             f'{", ".join(sorted(names))}')
        if key == 'fsr':
            fsr_names = {f.name for f in dataclasses.fields(FsrFilm)}
            if not isinstance(value, Mapping) or set(value) - fsr_names:
                raise ValueError(f'model: field fsr must be a mapping of {sorted(fsr_names)}')
            try:
                value = FsrFilm(**value)
            except (TypeError, ValueError) as err:
                raise ValueError(f'model: field fsr: {err}') from None
        elif key == 'dead_taxels':
            if not isinstance(value, (list, tuple)) or not all(
                    isinstance(t, (list, tuple)) and all(isinstance(i, int) for i in t)
                    for t in value):
                raise ValueError(f'model: field dead_taxels must be a list of [row, col] or '
                                 f'[layer, row, col] integer lists, got {value!r}')
            value = tuple(tuple(t) for t in value)
        elif key == 'misalignment_m':
            if not isinstance(value, (list, tuple)) or len(value) != 2:
                raise ValueError(f'model: field misalignment_m must be [x, y], got {value!r}')
            value = tuple(_number('model', key, x) for x in value)
        elif key in ('rows', 'cols'):
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 128:
                raise ValueError(f'model: field {key!r} must be an integer in 1..128, got '
                                 f'{value!r}')
        elif key == 'seed':
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(f'model: field seed must be an integer >= 0, got {value!r}')
        else:
            value = _number('model', key, value)
        kwargs[key] = value
    try:
        return SkinModel(**kwargs)
    except (TypeError, ValueError) as err:
        raise ValueError(f'model: {err}') from None


def _range(spec: Mapping, key: str, default: tuple) -> tuple:
    value = spec.get(key, default)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = (value, value)
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ValueError(f'generator: field {key!r} must be a number or [low, high], got '
                         f'{value!r}')
    low, high = (_number('generator', key, x) for x in value)
    if low > high:
        raise ValueError(f'generator: field {key!r} needs low <= high, got {value!r}')
    return low, high


def _check_fields(spec: Mapping, allowed: set) -> None:
    unknown = set(spec) - allowed
    if unknown:
        raise ValueError(f'generator: unknown field {sorted(unknown)[0]!r}; fields are '
                         f'{", ".join(sorted(allowed))}')


def _count(spec: Mapping, key: str, default: int) -> int:
    value = spec.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f'generator: field {key!r} must be a non-negative integer, got '
                         f'{value!r}')
    return value


def _generate_paper(spec: Mapping, model: SkinModel, first_index: int,
                    paper_force_n: float) -> list:
    """Return the paper's protocol (paper.paper_presses) as timed scene presses."""
    _check_fields(spec, {'kind', 'repeats', 'leading_normal', 'normal_per_repeat', 'force_n',
                         'start_s', 'interval_s', 'duration_s', 'ramp_s'})
    counts = {k: _count(spec, k, d)
              for k, d in (('repeats', 1), ('leading_normal', 0), ('normal_per_repeat', 1))}
    timing = {k: _number('generator', k, spec.get(k, d)) for k, d in (
        ('force_n', paper_force_n), ('start_s', 0.25), ('interval_s', 1.5), ('duration_s', 1.0),
        ('ramp_s', 0.2))}
    presses = paper_presses(model, timing['force_n'], counts['repeats'],
                            leading_normal=counts['leading_normal'],
                            normal_per_repeat=counts['normal_per_repeat'])
    out = []
    for j, p in enumerate(presses):
        entry = {'time_s': timing['start_s'] + j * timing['interval_s'], 'x_m': p.x_m,
                 'y_m': p.y_m, 'force_n': p.force_n, 'alpha_deg': math.degrees(p.alpha_rad),
                 'beta_deg': math.degrees(p.beta_rad), 'radius_m': p.radius_m,
                 'duration_s': timing['duration_s'], 'ramp_s': timing['ramp_s']}
        out.append(_press(first_index + j, entry, {}))
    return out


def _generate(spec: Any, model: SkinModel, first_index: int,
              paper_force_n: float = PAPER_FORCE_N) -> list:
    """Return presses made by a generator entry (kind: random or paper)."""
    if not isinstance(spec, Mapping) or spec.get('kind') not in ('random', 'paper'):
        raise ValueError(f'generator: only {{kind: random, ...}} and {{kind: paper, ...}} are '
                         f'known, got {spec!r}')
    if spec['kind'] == 'paper':
        return _generate_paper(spec, model, first_index, paper_force_n)
    _check_fields(spec, {'kind', 'seed', 'count', 'start_s', 'interval_s', 'duration_s',
                         'ramp_s', 'force_n', 'alpha_deg', 'beta_deg', 'radius_m', 'margin_m'})
    count = _count(spec, 'count', 20)
    seed = _count(spec, 'seed', 0)
    start = _number('generator', 'start_s', spec.get('start_s', 0.5))
    interval = _number('generator', 'interval_s', spec.get('interval_s', 1.0))
    duration = _number('generator', 'duration_s', spec.get('duration_s', 0.6))
    margin = _number('generator', 'margin_m', spec.get('margin_m', model.pitch_m))
    default_ranges = (('force_n', (2.0, 15.0)), ('alpha_deg', (0.0, 60.0)),
                      ('beta_deg', (0.0, 360.0)), ('radius_m', (0.002, 0.006)))
    ranges = {k: _range(spec, k, d) for k, d in default_ranges}
    rng = np.random.default_rng(seed)
    x_hi = (model.cols - 1) * model.pitch_m
    y_hi = (model.rows - 1) * model.pitch_m
    entries = []
    for _ in range(count):
        entry = {k: float(rng.uniform(*r)) for k, r in ranges.items()}
        entry['x_m'] = float(rng.uniform(min(margin, x_hi / 2), max(x_hi - margin, x_hi / 2)))
        entry['y_m'] = float(rng.uniform(min(margin, y_hi / 2), max(y_hi - margin, y_hi / 2)))
        entries.append(entry)
    presses = []
    for j, entry in enumerate(entries):
        entry.update(time_s=start + j * interval, duration_s=duration)
        if 'ramp_s' in spec:
            entry['ramp_s'] = spec['ramp_s']
        entry['alpha_deg'] = min(entry['alpha_deg'], 89.0)
        presses.append(_press(first_index + j, entry, {}))
    return presses


def scene_from_dict(data: Any, name: str = 'scene') -> Scene:
    """
    Build and validate a scene from its parsed YAML mapping.

    Raise ValueError naming the press index and field (or the top-level key) that is wrong.
    """
    if not isinstance(data, Mapping):
        raise ValueError(f'scene {name!r}: must be a mapping, got {type(data).__name__}')
    for key in data:
        if key not in _TOP_LEVEL:
            raise ValueError(f'scene {name!r}: unknown key {key!r}; keys are '
                             f'{", ".join(_TOP_LEVEL)}')
    paper_force_n = PAPER_FORCE_N
    if data.get('skin') is not None:
        if data.get('model') is not None:
            raise ValueError(f'scene {name!r}: give either model or skin, not both')
        try:
            member = family_skin(str(data['skin']))
        except ValueError as err:
            raise ValueError(f'skin: {err}') from None
        model, paper_force_n = member.model, member.paper_force_n
    else:
        model = _model(data.get('model'))
    defaults = data.get('defaults') or {}
    if not isinstance(defaults, Mapping):
        raise ValueError(f'defaults: must be a mapping of press fields, got {defaults!r}')
    entries = data.get('presses') or []
    if not isinstance(entries, list):
        raise ValueError(f'presses: must be a list, got {type(entries).__name__}')
    presses = [_press(i, e, defaults) for i, e in enumerate(entries)]
    if data.get('generator') is not None:
        presses += _generate(data['generator'], model, len(presses), paper_force_n)
    if not presses:
        raise ValueError(f'scene {name!r}: has no presses')
    repeat = data.get('repeat', 1)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f'repeat: must be an integer >= 1, got {repeat!r}')
    last_end = max(p.end_s for p in presses)
    period = data.get('period_s')
    period = last_end if period is None else _number('scene', 'period_s', period)
    if period < last_end:
        raise ValueError(f'period_s: must be at least the end of the last press ({last_end} s), '
                         f'got {period}')
    description = data.get('description', '')
    model, drifts = _drift(data.get('drift'), model)
    return Scene(name=str(data.get('name', name)), model=model, presses=tuple(presses),
                 repeat=repeat, period_s=period, description=str(description), drifts=drifts,
                 mount=_mount(data.get('mount')))


def bundled_scene_names(folder: str = '') -> list:
    """Return the names of the scenes shipped with the package (in its ``folder`` of scenes)."""
    where = importlib.resources.files('skin_driver') / 'scenes'
    if folder:
        where = where / folder
    return sorted(p.name[:-5] for p in where.iterdir() if p.name.endswith('.yaml'))


def find_scene(name_or_path: str | os.PathLike, folder: str = '', kind: str = 'scene') -> Path:
    """
    Return the file of a bundled scene name (with or without .yaml) or of an existing path.

    ``folder`` is the package's folder of such scenes under scenes/ ('' for plain scenes),
    ``kind`` what the messages call them.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    stem = path.name[:-5] if path.name.endswith('.yaml') else path.name
    if str(name_or_path) in (stem, stem + '.yaml'):
        where = importlib.resources.files('skin_driver') / 'scenes'
        candidate = (where / folder if folder else where) / (stem + '.yaml')
        if candidate.is_file():
            return Path(str(candidate))
    raise ValueError(f'no {kind} file or bundled {kind} named {str(name_or_path)!r}; bundled '
                     f'{kind}s are {", ".join(bundled_scene_names(folder))}')


def read_scene_file(path: Path, kind: str = 'scene') -> tuple:
    """Return (the YAML data, the scene's name) of a scene file; bad YAML raises ValueError."""
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise ValueError(f'{kind} {str(path)!r} is not valid YAML: {err}') from None
    return data, path.name[:-5] if path.name.endswith('.yaml') else path.name


def load_scene(name_or_path: str | os.PathLike) -> Scene:
    """Load and validate a scene from a bundled name or a YAML file path."""
    data, name = read_scene_file(find_scene(name_or_path))
    return scene_from_dict(data, name=name)
