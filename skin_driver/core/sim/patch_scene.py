"""
Scenes of several patches on a robot: one script of presses, each patch's board rendered apart.

A patch scene is a layout (:func:`skin_driver.core.robot.patches.layout_from_dict`: the common
frame, the links' poses in it, each patch's link and mount) and a scene's model and presses
(:mod:`.scene`), each press given on the surface of one patch::

    common_frame: base_link
    links: {forearm_link: {xyz: [0.4, 0.0, 0.3], rpy: [0.0, 0.4, 0.3]}}
    patches:
      forearm_a: {parent_frame: forearm_link, xyz: [0.0, -0.04, 0.04], rpy: [0.0, 0.0, 0.0]}
      forearm_b: {parent_frame: forearm_link, xyz: [0.08, -0.04, 0.04], rpy: [0.0, 0.0, 0.0]}
    model: {rows: 16, cols: 16, pitch_m: 0.005}     # every patch's (or skin: <family member>)
    presses:
      - {patch: forearm_a, time_s: 0.5, x_m: 0.04, y_m: 0.0375, to_x_m: 0.12, to_y_m: 0.0375,
         force_n: 8, alpha_deg: 0, beta_deg: 0, radius_m: 0.004, duration_s: 4.0}

``x_m``, ``y_m``, ``alpha_deg`` and ``beta_deg`` are in the frame of ``patch`` (default: the
first patch); the press may lie beyond that patch's edge, on the plane it shares with a
neighbour. With ``to_x_m``/``to_y_m`` the press slides there at constant speed over its
duration. Every patch whose surface holds the press point (within :data:`PLANE_TOLERANCE_M` of
its plane) and into which the force presses renders the press in its own frame: a press near a
seam shows on both patches, each with the part of it that lies on its taxels, as two boards
side by side would read it. :meth:`PatchScene.view` is the :class:`~.scene.Scene` a
:class:`~.board.SimulatedSkin` of one patch plays; :meth:`PatchScene.point` the press's centre in
the common frame (the truth a test holds the patches node's contacts to).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import os
from pathlib import Path
from typing import Any, Mapping, Optional, Tuple

from .physics import Press
from .scene import (bundled_scene_names, find_scene, read_scene_file, Scene,
                    scene_from_dict)
from ..robot.patches import Layout, layout_from_dict, Pose

# The package's folder of patch scenes, under scenes/.
PATCH_SCENES = 'patches'

__all__ = ['PatchScene', 'PatchView', 'PLANE_TOLERANCE_M', 'patch_scene_from_dict',
           'load_patch_scene', 'bundled_patch_scene_names']

# How far off a patch's plane a press point may be and still be rendered on it.
PLANE_TOLERANCE_M = 0.001
_SCENE_KEYS = ('name', 'description', 'model', 'skin', 'repeat', 'period_s', 'defaults',
               'presses')
_PATCH_PRESS_KEYS = ('patch', 'to_x_m', 'to_y_m')


@dataclass(frozen=True)
class _Path:
    """Where one press is given: its patch and where it slides to (its start if it stays)."""

    patch: str
    to_x_m: float
    to_y_m: float


@dataclass(frozen=True)
class PatchView(Scene):
    """The scene one patch's board plays: the patch scene's presses, in that patch's frame."""

    source: Optional['PatchScene'] = None
    patch: str = ''

    def active_at(self, t: float) -> list:
        """Return (press index, physics Press in this patch's frame) of the presses on it."""
        return self.source.active_on(self.patch, t)


class PatchScene:
    """A layout of patches and a script of presses on them (see the module's text)."""

    def __init__(self, layout: Layout, base: Scene, paths: Tuple[_Path, ...]):
        self.layout = layout
        self.base = base
        self.paths = paths
        self.name = base.name
        self.model = base.model
        self._tree = layout.tree()
        self._poses: dict = {}

    @property
    def duration_s(self) -> float:
        """Return the length of the whole scene, all repetitions included."""
        return self.base.duration_s

    @property
    def patch_names(self) -> list:
        """Return the names of the patches, in the layout's order."""
        return [p.name for p in self.layout.patches]

    def view(self, patch: str) -> PatchView:
        """Return the scene of one patch's board; raise KeyError for an unknown patch."""
        self.layout.patch(patch)
        base = self.base
        return PatchView(name=f'{base.name}:{patch}', model=base.model, presses=base.presses,
                         repeat=base.repeat, period_s=base.period_s,
                         description=base.description, source=self, patch=patch)

    def pose(self, target: str, source: str) -> Pose:
        """Return the pose of frame ``source`` in ``target`` (a patch's frame: its name)."""
        key = (target, source)
        found = self._poses.get(key)
        if found is None:
            found = self._poses[key] = self._tree.pose(target, source)
        return found

    def _local(self, t: float) -> Optional[float]:
        base = self.base
        if not math.isfinite(t) or t < 0 or base.period_s <= 0:
            return None
        k = math.floor(t / base.period_s)
        return None if k >= base.repeat else t - k * base.period_s

    def _centre(self, index: int, local: float) -> Tuple[float, float]:
        """Return the press's centre on its own patch at scene-local time ``local``."""
        p, path = self.base.presses[index], self.paths[index]
        frac = min(1.0, max(0.0, (local - p.time_s) / p.duration_s))
        return (p.x_m + frac * (path.to_x_m - p.x_m), p.y_m + frac * (path.to_y_m - p.y_m))

    def point(self, index: int, t: float, frame: Optional[str] = None) -> Tuple[float, ...]:
        """Return the centre of press ``index`` at scene time t in ``frame`` (default: common)."""
        local = self._local(t)
        if local is None:  # before the scene it has not moved, after it it has arrived
            local = self.base.period_s if t > 0 else 0.0
        x, y = self._centre(index, local)
        frame = frame or self.layout.common_frame
        return self.pose(frame, self.paths[index].patch).point((x, y, 0.0))

    def active_on(self, patch: str, t: float) -> list:
        """Return (press index, physics Press in ``patch``'s frame) acting on it at time t."""
        local = self._local(t)
        if local is None:
            return []
        active = []
        for i, p in enumerate(self.base.presses):
            envelope = p.envelope(local)
            if envelope <= 0:
                continue
            press = self._on(patch, i, local, envelope)
            if press is not None:
                active.append((i, press))
        return active

    def _on(self, patch: str, index: int, local: float, envelope: float) -> Optional[Press]:
        p, path = self.base.presses[index], self.paths[index]
        pose = self.pose(patch, path.patch)
        x, y, z = pose.point(self._centre(index, local) + (0.0,))
        if abs(z) > PLANE_TOLERANCE_M:
            return None
        alpha, beta = math.radians(p.alpha_deg), math.radians(p.beta_deg)
        # The force on the skin: tangential along beta, normal into the skin (-z).
        fx, fy, fz = pose.rotate((math.sin(alpha) * math.cos(beta),
                                  math.sin(alpha) * math.sin(beta), -math.cos(alpha)))
        if fz >= -1e-9:
            return None  # it does not press into this patch
        tangential = math.hypot(fx, fy)
        return Press(x_m=x, y_m=y, force_n=p.force_n * envelope,
                     alpha_rad=math.atan2(tangential, -fz),
                     beta_rad=math.atan2(fy, fx) if tangential > 1e-12 else 0.0,
                     radius_m=p.radius_m)


def _number(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value):
        raise ValueError(f'{where}: field {key!r} must be a finite number, got {value!r}')
    return float(value)


def patch_scene_from_dict(data: Any, name: str = 'scene') -> PatchScene:
    """Build and validate a patch scene; raise ValueError naming the key or press that is wrong."""
    if not isinstance(data, Mapping):
        raise ValueError(f'patch scene {name!r}: must be a mapping, got {type(data).__name__}')
    layout = layout_from_dict(data, extra_keys=_SCENE_KEYS)
    names = [p.name for p in layout.patches]
    defaults = data.get('defaults') or {}
    if not isinstance(defaults, Mapping):
        raise ValueError(f'defaults: must be a mapping of press fields, got {defaults!r}')
    entries = data.get('presses') or []
    if not isinstance(entries, list):
        raise ValueError(f'presses: must be a list, got {type(entries).__name__}')
    presses, paths = [], []
    for i, entry in enumerate(entries):
        if not isinstance(entry, Mapping):
            raise ValueError(f'press {i}: must be a mapping of fields, got {entry!r}')
        merged = {**defaults, **entry}
        patch = merged.get('patch', names[0])
        if patch not in names:
            raise ValueError(f'press {i}: patch {patch!r} is not in the layout; patches: '
                             f'{", ".join(names)}')
        presses.append({k: v for k, v in entry.items() if k not in _PATCH_PRESS_KEYS})
        paths.append((patch, {k: _number(f'press {i}', k, merged[k])
                              for k in ('to_x_m', 'to_y_m') if k in merged}))
    base = scene_from_dict({**{k: data[k] for k in _SCENE_KEYS if k in data},
                            'defaults': {k: v for k, v in defaults.items()
                                         if k not in _PATCH_PRESS_KEYS},
                            'presses': presses}, name=name)
    resolved = tuple(_Path(patch, to.get('to_x_m', p.x_m), to.get('to_y_m', p.y_m))
                     for (patch, to), p in zip(paths, base.presses))
    return PatchScene(layout, base, resolved)


def bundled_patch_scene_names() -> list:
    """Return the names of the patch scenes shipped with the package."""
    return bundled_scene_names(PATCH_SCENES)


def find_patch_scene(name_or_path: str | os.PathLike) -> Path:
    """Return the file of a bundled patch scene name or of an existing path."""
    return find_scene(name_or_path, PATCH_SCENES, 'patch scene')


def load_patch_scene(name_or_path: str | os.PathLike) -> PatchScene:
    """Load and validate a patch scene from a bundled name or a YAML file path."""
    data, name = read_scene_file(find_patch_scene(name_or_path), 'patch scene')
    return patch_scene_from_dict(data, name=name)
