"""
The skin's pose on its parent link, from touches at points whose position on the link is known.

A robot (or a probe) touches the skin at a few points it knows in the parent frame; the skin
reports each touch's location in its own frame, where the surface is z = 0. The mount is the
rigid motion that carries the skin's points onto the parent's (least squares: the SVD solution
of Arun, Huang and Blostein, with the reflection excluded), its residual per touch is what the
two disagree by, and its uncertainty follows from that residual and the touches' geometry.

Touches on the skin's plane fix a pose only when they span the plane: three touches on a line
leave a rotation about that line free, so they are refused. So is a fit whose worst touch misses
by more than ``max_residual_m``: a slipped probe or a point given in the wrong order would
otherwise move the skin on the robot without a word.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional, Sequence, Tuple

import numpy as np

from .presses import PressSegmenter
from ...robot.patches import Pose

__all__ = ['MountFit', 'MountRefused', 'fit_mount', 'MountSession', 'urdf_snippet',
           'MIN_TOUCHES']

MIN_TOUCHES = 3
# Spread of the touches across their best line below which the rotation about it is not fixed.
MIN_SPREAD_M = 0.005
MAX_RESIDUAL_M = 0.003


class MountRefused(ValueError):
    """The touches cannot give a mount; the message says why and what to do."""


@dataclass(frozen=True)
class MountFit:
    """
    The skin frame's pose on the parent link: ``parent = rotation @ skin + translation_m``.

    ``residuals_m`` is each touch's miss (metres, in the order given); ``position_sigma_m`` and
    ``orientation_sigma_rad`` are 1-sigma bounds (the largest axis) of the pose's uncertainty.
    """

    translation_m: Tuple[float, float, float]
    rotation: Tuple[Tuple[float, float, float], ...]
    residuals_m: Tuple[float, ...]
    position_sigma_m: float
    orientation_sigma_rad: float

    @property
    def rpy_rad(self) -> Tuple[float, float, float]:
        """Return the fixed-axis roll, pitch, yaw (REP-103, as URDF's origin takes them)."""
        return Pose(self.rotation).rpy()

    @property
    def quaternion_xyzw(self) -> Tuple[float, float, float, float]:
        """Return the rotation as a unit quaternion x, y, z, w (w >= 0)."""
        return Pose(self.rotation).quaternion()

    @property
    def rms_residual_m(self) -> float:
        """Return the root mean square of the touches' misses."""
        r = np.array(self.residuals_m)
        return float(math.sqrt(np.mean(r * r)))

    def describe(self) -> str:
        """Return the pose and its quality in one line, millimetres and degrees."""
        x, y, z = (1000.0 * v for v in self.translation_m)
        roll, pitch, yaw = (math.degrees(a) for a in self.rpy_rad)
        return (f'xyz ({x:.1f}, {y:.1f}, {z:.1f}) mm, rpy ({roll:.2f}, {pitch:.2f}, {yaw:.2f}) '
                f'deg from {len(self.residuals_m)} touches: residual rms '
                f'{1000.0 * self.rms_residual_m:.2f} mm, worst '
                f'{1000.0 * max(self.residuals_m):.2f} mm; 1-sigma '
                f'{1000.0 * self.position_sigma_m:.2f} mm, '
                f'{math.degrees(self.orientation_sigma_rad):.2f} deg')


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _points(values, columns: int, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.ndim != 2 or a.shape[1] != columns:
        raise MountRefused(f'{name} must be a list of points with {columns} coordinates each, '
                           f'got shape {a.shape}')
    if not np.isfinite(a).all():
        raise MountRefused(f'{name} holds a value that is not finite')
    return a


def fit_mount(skin_xy_m: Sequence, parent_xyz_m: Sequence,
              max_residual_m: float = MAX_RESIDUAL_M,
              min_spread_m: float = MIN_SPREAD_M) -> MountFit:
    """
    Return the mount that carries each touch's skin location (x, y) onto its parent point.

    Raises MountRefused with the reason when there are fewer than MIN_TOUCHES touches, the
    counts differ, the touches lie on a line (their spread across it below ``min_spread_m``),
    or the worst touch misses by more than ``max_residual_m`` (it is named).
    """
    skin2 = _points(skin_xy_m, 2, 'the skin locations')
    parent = _points(parent_xyz_m, 3, 'the parent points')
    n = len(skin2)
    if n != len(parent):
        raise MountRefused(f'{n} touches on the skin but {len(parent)} parent points: give one '
                           'point per touch, in the order of the touches')
    if n < MIN_TOUCHES:
        raise MountRefused(f'{n} touches; a mount needs at least {MIN_TOUCHES} that do not lie on '
                           'one line (6 or more spread over the skin give a better one)')
    skin = np.column_stack((skin2, np.zeros(n)))
    ps, pp = skin.mean(axis=0), parent.mean(axis=0)
    spread = np.linalg.svd(skin2 - ps[:2], compute_uv=False)[-1] / math.sqrt(n)
    if spread < min_spread_m:
        raise MountRefused(f'the touches lie on a line (spread across it {1000 * spread:.1f} mm, '
                           f'under {1000 * min_spread_m:.1f} mm): the rotation about that line is '
                           'free; touch points spread over the skin')
    u, _, vt = np.linalg.svd((skin - ps).T @ (parent - pp))
    d = 1.0 if np.linalg.det(vt.T @ u.T) > 0 else -1.0
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    translation = pp - rotation @ ps
    miss = skin @ rotation.T + translation - parent
    residuals = np.linalg.norm(miss, axis=1)
    worst = int(np.argmax(residuals))
    if residuals[worst] > max_residual_m:
        raise MountRefused(f'touch {worst + 1} misses by {1000 * residuals[worst]:.1f} mm (limit '
                           f'{1000 * max_residual_m:.1f} mm; rms of all '
                           f'{1000 * math.sqrt(np.mean(residuals ** 2)):.1f} mm): check its '
                           'point and its order, or touch again')
    return MountFit(tuple(float(v) for v in translation),
                    tuple(tuple(float(v) for v in row) for row in rotation),
                    tuple(float(v) for v in residuals),
                    *_sigmas(skin, rotation, miss))


def _sigmas(skin: np.ndarray, rotation: np.ndarray, miss: np.ndarray) -> Tuple[float, float]:
    """
    Return the 1-sigma position and orientation bounds (largest axis) of the fitted pose.

    Gauss-Newton at the solution: a small turn w (parent frame) and move v change each miss by
    -[R p]x w + v; the misses' own scatter (3n - 6 degrees of freedom) is the noise.
    """
    n = len(skin)
    jac = np.zeros((3 * n, 6))
    for i, p in enumerate(skin):
        jac[3 * i:3 * i + 3, :3] = -_skew(rotation @ p)
        jac[3 * i:3 * i + 3, 3:] = np.eye(3)
    dof = 3 * n - 6
    variance = float(np.sum(miss * miss)) / dof if dof > 0 else math.inf
    try:
        cov = np.linalg.inv(jac.T @ jac) * variance
    except np.linalg.LinAlgError:
        return math.inf, math.inf
    # The position's uncertainty at the skin's origin; the turn's about the parent's axes.
    turn = np.linalg.eigvalsh(cov[:3, :3])[-1]
    move = np.linalg.eigvalsh(cov[3:, 3:])[-1]
    return float(math.sqrt(max(move, 0.0))), float(math.sqrt(max(turn, 0.0)))


def urdf_snippet(fit: MountFit, parent: str, child: str, rows: int, cols: int,
                 pitch_m: float) -> str:
    """Return the xacro call that mounts this skin (urdf/skin_patch.urdf.xacro) at ``fit``."""
    xyz = ' '.join(f'{v:.6g}' for v in fit.translation_m)
    rpy = ' '.join(f'{v:.6g}' for v in fit.rpy_rad)
    return (f'<xacro:skin_patch name="{child}" parent="{parent}" rows="{rows}" cols="{cols}"\n'
            f'                  pitch="{pitch_m:g}" xyz="{xyz}" rpy="{rpy}"/>')


class MountSession:
    """
    Touches in, a mount out: each press on the skin is paired with its point on the parent.

    The points come in the goal, one per touch in order, or per touch from the tool tip (the
    position last read when the press reached its peak). A touch's skin location is the
    force-weighted mean of its strongest contact's location over the press's plateau.
    """

    def __init__(self, touches: int, points_m: Sequence = (),
                 max_residual_m: float = MAX_RESIDUAL_M, start_force_n: float = 0.5):
        """Wait for ``touches`` presses; ``points_m`` gives their parent points (else the tip)."""
        if len(points_m) and len(points_m) != touches:
            raise MountRefused(f'{len(points_m)} points for {touches} touches: give one point '
                               'per touch, or none to read the tool tip')
        if touches < MIN_TOUCHES:
            raise MountRefused(f'{touches} touches; a mount needs at least {MIN_TOUCHES}')
        self.wanted = touches
        self._given = [tuple(float(v) for v in p) for p in points_m]
        self.max_residual_m = max_residual_m
        self._presses = PressSegmenter(start_force_n=start_force_n)
        self.skin_xy_m = []
        self.parent_xyz_m = []
        self.ignored = 0
        self.last_ignored = ''

    @property
    def done(self) -> bool:
        """Return whether every touch is in."""
        return len(self.skin_xy_m) >= self.wanted

    def add_scan(self, contacts, tool_point_m: Optional[Sequence[float]] = None) -> str:
        """
        Add one scan's contacts (strongest first) and the tool tip now; return a note per touch.

        A press with no tool tip to pair (none given in the goal, none read) is ignored, with
        the reason in the note.
        """
        if self.done:
            return ''
        strongest = contacts[0] if contacts else None
        payload = None
        if strongest is not None:
            payload = (strongest.x_m, strongest.y_m, strongest.force_n,
                       None if tool_point_m is None else tuple(float(v) for v in tool_point_m))
        press = self._presses.add(strongest.force_n if strongest else 0.0,
                                  (0.0, 0.0) if strongest else None, payload)
        if press is None:
            return ''
        plateau = [p for p in press.plateau if p is not None]
        weight = sum(p[2] for p in plateau)
        x = sum(p[0] * p[2] for p in plateau) / weight
        y = sum(p[1] * p[2] for p in plateau) / weight
        if self._given:
            point = self._given[len(self.skin_xy_m)]
        else:
            tips = [p[3] for p in plateau if p[3] is not None]
            if not tips:
                self.ignored += 1
                self.last_ignored = 'no tool tip position was read during the press'
                return f'touch ignored: {self.last_ignored}'
            point = tuple(float(np.mean([t[k] for t in tips])) for k in range(3))
        self.skin_xy_m.append((x, y))
        self.parent_xyz_m.append(point)
        return (f'touch {len(self.skin_xy_m)} of {self.wanted}: skin ({1000 * x:.1f}, '
                f'{1000 * y:.1f}) mm at parent ({", ".join(f"{1000 * v:.1f}" for v in point)}) mm')

    def finish(self) -> MountFit:
        """Return the mount of the touches in (raises MountRefused as :func:`fit_mount`)."""
        return fit_mount(self.skin_xy_m, self.parent_xyz_m, self.max_residual_m)
