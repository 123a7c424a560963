"""
Several skin patches as one skin: poses, a small frame tree, and contacts carried between frames.

Each patch reports its contacts in its own frame (REP-103: x along the columns, y along the rows,
z out of the skin); a controller wants them in one frame of the robot. A patch is mounted on a
parent link by a fixed pose; the link sits in the common frame at a pose that is fixed
(parameters) or moves with the robot (/tf). :class:`FrameTree` joins them as tf does, without
tf2: each frame has at most one parent, and the pose of one frame in another is the product of
the poses along the path between them.

A contact's location is a point, its force and layer shift are vectors, and its torque is taken
about the origin of the frame it is given in; carried into another frame the torque picks up the
lever of the frame's offset (``t x F``), so that it stays the moment of the same force about the
new origin. The sum of the contacts' wrenches in a link's frame is the net wrench the link takes
from its skin, as a force/torque sensor at the link's origin would report it.

A *layout* names the patches (each one's namespace), the link each is mounted on with the mount
pose, the common frame and the links' fixed poses in it; :func:`layout_from_dict` reads one from
a mapping (a YAML file), :func:`node_parameters` turns it into the patches node's parameters.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import re
from typing import Iterable, Mapping, Optional, Sequence, Tuple

__all__ = ['Pose', 'FrameTree', 'UnknownTransform', 'carry_contact', 'sum_wrenches',
           'check_patch_name', 'check_frame_name', 'parameter_prefix', 'vector3',
           'PatchMount', 'Layout', 'layout_from_dict', 'node_parameters']

Vec = Tuple[float, float, float]


def _cross(a: Sequence[float], b: Sequence[float]) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _add(a: Sequence[float], b: Sequence[float]) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def vector3(value, name: str) -> Vec:
    """Return three finite floats from a sequence of three numbers; raise ValueError if not."""
    if isinstance(value, (str, bytes)) or not hasattr(value, '__len__') or len(value) != 3:
        raise ValueError(f'{name} must be three numbers, got {value!r}')
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f'{name} must be three finite numbers, got {list(value)!r}')
        out.append(float(v))
    return tuple(out)


@dataclass(frozen=True)
class Pose:
    """
    The pose of a frame in its parent: ``parent point = rotation @ point + translation``.

    ``rotation`` is a 3 x 3 rotation matrix as three rows; ``translation`` is in metres.
    """

    rotation: Tuple[Vec, Vec, Vec] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    translation: Vec = (0.0, 0.0, 0.0)

    def __post_init__(self):
        """Store plain floats, whatever sequence types were given."""
        object.__setattr__(self, 'rotation', tuple(tuple(float(v) for v in row)
                                                   for row in self.rotation))
        object.__setattr__(self, 'translation', tuple(float(v) for v in self.translation))

    @classmethod
    def from_xyz_rpy(cls, xyz: Sequence[float], rpy: Sequence[float]) -> Pose:
        """Return the pose of translation xyz and fixed-axis roll, pitch, yaw (URDF, REP-103)."""
        x, y, z = vector3(xyz, 'xyz')
        roll, pitch, yaw = vector3(rpy, 'rpy')
        cr, sr = math.cos(roll), math.sin(roll)
        cp, sp = math.cos(pitch), math.sin(pitch)
        cy, sy = math.cos(yaw), math.sin(yaw)
        # R = Rz(yaw) Ry(pitch) Rx(roll), as URDF's origin and tf's static publisher take rpy.
        rotation = ((cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
                    (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
                    (-sp, cp * sr, cp * cr))
        return cls(rotation, (x, y, z))

    @classmethod
    def from_quaternion(cls, xyz: Sequence[float], xyzw: Sequence[float]) -> Pose:
        """Return the pose of translation xyz and unit quaternion (x, y, z, w); normalised."""
        translation = vector3(xyz, 'translation')
        if len(xyzw) != 4 or not all(math.isfinite(float(v)) for v in xyzw):
            raise ValueError(f'a rotation quaternion must be four finite numbers, got '
                             f'{list(xyzw)!r}')
        qx, qy, qz, qw = (float(v) for v in xyzw)
        norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        if norm < 1e-9:
            raise ValueError('a rotation quaternion of length 0 is no rotation')
        qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
        rotation = ((1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw),
                     2 * (qx * qz + qy * qw)),
                    (2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz),
                     2 * (qy * qz - qx * qw)),
                    (2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw),
                     1 - 2 * (qx * qx + qy * qy)))
        return cls(rotation, translation)

    def quaternion(self) -> Tuple[float, float, float, float]:
        """Return the rotation's unit quaternion as x, y, z, w, with w >= 0."""
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = self.rotation
        trace = m00 + m11 + m22
        # Shepperd's method: divide by the largest of the four, never by a small number.
        if trace > max(m00, m11, m22):
            s = 2.0 * math.sqrt(1.0 + trace)
            q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
        elif m00 >= m11 and m00 >= m22:
            s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
            q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
        elif m11 >= m22:
            s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
            q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
        else:
            s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
            q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
        return tuple(-v for v in q) if q[3] < 0 else q

    def rotate(self, v: Sequence[float]) -> Vec:
        """Return the vector v (a force, a shift) expressed in the parent frame."""
        r0, r1, r2 = self.rotation
        return (r0[0] * v[0] + r0[1] * v[1] + r0[2] * v[2],
                r1[0] * v[0] + r1[1] * v[1] + r1[2] * v[2],
                r2[0] * v[0] + r2[1] * v[1] + r2[2] * v[2])

    def point(self, p: Sequence[float]) -> Vec:
        """Return the point p expressed in the parent frame."""
        return _add(self.rotate(p), self.translation)

    def wrench(self, force: Sequence[float], torque: Sequence[float]) -> Tuple[Vec, Vec]:
        """
        Return (force, torque) in the parent frame; torque about the parent's origin.

        ``torque`` is the moment about this frame's origin; moved to the parent's origin it adds
        the moment of the force about the offset between them (t x F).
        """
        f = self.rotate(force)
        return f, _add(self.rotate(torque), _cross(self.translation, f))

    def __matmul__(self, inner: Pose) -> Pose:
        """Return the pose of ``inner``'s frame in this pose's parent (this @ inner)."""
        rows = tuple(tuple(sum(self.rotation[i][k] * inner.rotation[k][j] for k in range(3))
                           for j in range(3)) for i in range(3))
        return Pose(rows, self.point(inner.translation))

    def inverse(self) -> Pose:
        """Return the pose of the parent in this frame."""
        rt = tuple(tuple(self.rotation[j][i] for j in range(3)) for i in range(3))
        t = Pose(rt).rotate(self.translation)
        return Pose(rt, (-t[0], -t[1], -t[2]))

    def rpy(self) -> Vec:
        """Return fixed-axis (roll, pitch, yaw) of the rotation, as from_xyz_rpy takes them."""
        r = self.rotation
        pitch = math.asin(max(-1.0, min(1.0, -r[2][0])))
        if abs(r[2][0]) < 1.0 - 1e-12:
            return math.atan2(r[2][1], r[2][2]), pitch, math.atan2(r[1][0], r[0][0])
        # Gimbal lock: only roll - yaw (or roll + yaw) is defined; put it all in yaw.
        return 0.0, pitch, math.atan2(-r[0][1], r[1][1])


IDENTITY = Pose()


class UnknownTransform(LookupError):
    """No chain of known transforms joins two frames; the message names where each one ends."""


@dataclass
class _Edge:
    parent: str
    pose: Pose
    source: str
    fixed: bool


class FrameTree:
    """
    Frames joined by poses, each frame with at most one parent: the part of tf a node needs.

    An edge set as ``fixed`` (from the node's parameters) is kept when another source (/tf)
    gives the same frame another parent or pose: :meth:`place` then returns False and changes
    nothing. Only the newest pose of each edge is kept (no history, no interpolation).
    """

    def __init__(self):
        self._edges: dict = {}

    def place(self, child: str, parent: str, pose: Pose, source: str = '',
              fixed: bool = False) -> bool:
        """
        Put ``child`` at ``pose`` on ``parent``; return False if a fixed edge keeps it.

        Raise ValueError for an empty name, a frame on itself or an edge that would close a loop.
        """
        if not child or not parent:
            raise ValueError(f'a transform needs two frame names, got {parent!r} -> {child!r}')
        if child == parent:
            raise ValueError(f'frame {child!r} cannot be its own parent')
        old = self._edges.get(child)
        if old is not None and old.fixed and not fixed:
            return False
        frame = parent
        for _ in range(len(self._edges) + 1):
            if frame == child:
                raise ValueError(f'{child!r} on {parent!r} would close a loop of transforms')
            edge = self._edges.get(frame)
            if edge is None:
                break
            frame = edge.parent
        self._edges[child] = _Edge(parent, pose, source, fixed)
        return True

    def remove(self, child: str) -> None:
        """Forget the edge that places ``child`` (if any)."""
        self._edges.pop(child, None)

    def parent_of(self, child: str) -> Optional[str]:
        """Return the frame ``child`` is placed on, or None."""
        edge = self._edges.get(child)
        return edge.parent if edge is not None else None

    def source_of(self, child: str) -> Optional[str]:
        """Return where the edge that places ``child`` came from, or None."""
        edge = self._edges.get(child)
        return edge.source if edge is not None else None

    def frames(self) -> set:
        """Return every frame the tree names."""
        return set(self._edges) | {e.parent for e in self._edges.values()}

    def _to_root(self, frame: str) -> Tuple[str, Pose]:
        """Return (root, pose of ``frame`` in the root)."""
        pose = IDENTITY
        for _ in range(len(self._edges) + 1):
            edge = self._edges.get(frame)
            if edge is None:
                return frame, pose
            pose = edge.pose @ pose
            frame = edge.parent
        raise ValueError('the frame tree has a loop')  # place() never lets one in

    def pose(self, target: str, source: str) -> Pose:
        """Return the pose of ``source`` in ``target``; raise UnknownTransform if not joined."""
        if target == source:
            return IDENTITY
        root_s, in_root_s = self._to_root(source)
        root_t, in_root_t = self._to_root(target)
        if root_s != root_t:
            raise UnknownTransform(
                f'no transform joins {source!r} to {target!r}: the known transforms lead from '
                f'{source!r} to {root_s!r} and from {target!r} to {root_t!r}')
        return in_root_t.inverse() @ in_root_s


def carry_contact(pose: Pose, location: Sequence[float], shift: Sequence[float],
                  force: Sequence[float], torque: Sequence[float]) -> Tuple[Vec, Vec, Vec, Vec]:
    """
    Return (location, shift, force, torque) of one contact in the parent frame of ``pose``.

    The location is a point, shift and force are vectors; the torque, given about the origin of
    the contact's frame, is returned about the parent's origin.
    """
    f, t = pose.wrench(force, torque)
    return pose.point(location), pose.rotate(shift), f, t


def sum_wrenches(wrenches: Iterable[Tuple[Sequence[float], Sequence[float]]]) -> Tuple[Vec, Vec]:
    """Return the sum of (force, torque) pairs given about one origin in one frame."""
    fx = fy = fz = tx = ty = tz = 0.0
    for f, t in wrenches:
        fx, fy, fz = fx + f[0], fy + f[1], fz + f[2]
        tx, ty, tz = tx + t[0], ty + t[1], tz + t[2]
    return (fx, fy, fz), (tx, ty, tz)


# ---- names and layouts ------------------------------------------------------------------------

_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*$')
_FRAME = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*$')


def check_patch_name(name) -> str:
    """
    Return a patch's name (its nodes' namespace, e.g. ``left`` or ``arm/left``), checked.

    Its parameters go under the name with '/' as '.', so every part must be a parameter name.
    """
    if not isinstance(name, str) or not _NAME.match(name.strip('/')):
        raise ValueError(f'patch name {name!r} is not a namespace of letters, digits and _ '
                         "(each part starting with a letter, parts joined by '/')")
    return name.strip('/')


def check_frame_name(name, what: str = 'frame') -> str:
    """Return a frame name usable in a topic and a parameter name, checked."""
    if not isinstance(name, str) or not _FRAME.match(name):
        raise ValueError(f'{what} {name!r} must be letters, digits and _ (not starting with a '
                         'digit): it names a topic and parameters')
    return name


def parameter_prefix(patch: str) -> str:
    """Return the prefix of a patch's parameters: its name with '/' as '.'."""
    return check_patch_name(patch).replace('/', '.')


@dataclass(frozen=True)
class PatchMount:
    """One patch: its name (namespace), the link it is mounted on and its pose there."""

    name: str
    parent_frame: str
    pose: Pose = IDENTITY
    xyz: Vec = (0.0, 0.0, 0.0)
    rpy: Vec = (0.0, 0.0, 0.0)
    port: str = ''


@dataclass(frozen=True)
class Layout:
    """Patches on links, the common frame and the links' fixed poses in it."""

    common_frame: str
    patches: Tuple[PatchMount, ...]
    links: Mapping[str, Tuple[Vec, Vec]] = field(default_factory=dict)

    def tree(self) -> FrameTree:
        """Return the frame tree of the links' and the patches' poses (patch frame: its name)."""
        tree = FrameTree()
        for link, (xyz, rpy) in self.links.items():
            tree.place(link, self.common_frame, Pose.from_xyz_rpy(xyz, rpy), 'layout', True)
        for patch in self.patches:
            tree.place(patch.name, patch.parent_frame, patch.pose, 'layout', True)
        return tree

    def patch(self, name: str) -> PatchMount:
        """Return the patch of this name; raise KeyError naming the patches there are."""
        for p in self.patches:
            if p.name == name:
                return p
        raise KeyError(f'no patch {name!r} in the layout; patches: '
                       f'{", ".join(p.name for p in self.patches)}')


_LAYOUT_KEYS = ('common_frame', 'links', 'patches')
_PATCH_KEYS = ('parent_frame', 'xyz', 'rpy', 'port')


def _mapping(value, where: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise ValueError(f'{where} must be a mapping, got {value!r}')
    return value


def layout_from_dict(data: Mapping, extra_keys: Sequence[str] = ()) -> Layout:
    """
    Read a layout from a mapping; raise ValueError naming the key or the patch that is wrong.

    ``common_frame`` (default base_link), ``patches``: {name: {parent_frame, xyz, rpy, port}}
    (xyz in m, rpy in rad, port optional), ``links``: {link: {xyz, rpy}} (the links' fixed poses
    in the common frame; a patch's parent that is neither the common frame nor a link here must
    come from /tf). ``extra_keys`` are top-level keys the caller reads itself (a scene's).
    """
    data = _mapping(data, 'a layout')
    for key in data:
        if key not in _LAYOUT_KEYS and key not in extra_keys:
            raise ValueError(f'layout: unknown key {key!r}; keys are '
                             f'{", ".join(_LAYOUT_KEYS + tuple(extra_keys))}')
    common = check_frame_name(data.get('common_frame', 'base_link'), 'common_frame')
    links = {}
    for link, spec in _mapping(data.get('links') or {}, 'links').items():
        check_frame_name(link, 'link')
        spec = _mapping(spec, f'links.{link}')
        unknown = set(spec) - {'xyz', 'rpy'}
        if unknown:
            raise ValueError(f'links.{link}: unknown key {sorted(unknown)[0]!r}; keys are xyz, '
                             'rpy')
        if link == common:
            raise ValueError(f'links.{link} is the common frame itself')
        links[link] = (vector3(spec.get('xyz', (0.0, 0.0, 0.0)), f'links.{link}.xyz'),
                       vector3(spec.get('rpy', (0.0, 0.0, 0.0)), f'links.{link}.rpy'))
    patches = []
    for name, spec in _mapping(data.get('patches') or {}, 'patches').items():
        name = check_patch_name(name)
        spec = _mapping(spec, f'patches.{name}')
        unknown = set(spec) - set(_PATCH_KEYS)
        if unknown:
            raise ValueError(f'patches.{name}: unknown key {sorted(unknown)[0]!r}; keys are '
                             f'{", ".join(_PATCH_KEYS)}')
        if 'parent_frame' not in spec:
            raise ValueError(f'patches.{name}: needs parent_frame, the link it is mounted on')
        parent = check_frame_name(spec['parent_frame'], f'patches.{name}.parent_frame')
        xyz = vector3(spec.get('xyz', (0.0, 0.0, 0.0)), f'patches.{name}.xyz')
        rpy = vector3(spec.get('rpy', (0.0, 0.0, 0.0)), f'patches.{name}.rpy')
        port = spec.get('port', '') or ''
        if not isinstance(port, str):
            raise ValueError(f'patches.{name}.port must be a path, got {port!r}')
        patches.append(PatchMount(name, parent, Pose.from_xyz_rpy(xyz, rpy), xyz, rpy, port))
    if not patches:
        raise ValueError('layout: patches is empty; name at least one patch')
    names = [p.name for p in patches]
    if len(set(names)) != len(names):
        raise ValueError('layout: two patches have one name')
    return Layout(common, tuple(patches), links)


def node_parameters(layout: Layout) -> dict:
    """Return the patches node's parameters for ``layout`` (a parameter file's mapping)."""
    params = {'common_frame': layout.common_frame,
              'patches': [p.name for p in layout.patches]}
    for p in layout.patches:
        prefix = parameter_prefix(p.name)
        params[f'{prefix}.parent_frame'] = p.parent_frame
        params[f'{prefix}.xyz'] = list(p.xyz)
        params[f'{prefix}.rpy'] = list(p.rpy)
    for link, (xyz, rpy) in layout.links.items():
        params[f'links.{link}.xyz'] = list(xyz)
        params[f'links.{link}.rpy'] = list(rpy)
    return params
