"""Conversions between the ROS-free core's values and ROS message objects."""

from array import array
import functools
import math
from typing import Iterable, Sequence, Tuple

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import (Point, Pose, Quaternion, Transform, TransformStamped, Vector3,
                               Wrench, WrenchStamped)
import numpy as np
from sensor_msgs.msg import Image
from skin_driver.core.estimation.data.recording import layers_of
from skin_driver.core.estimation.scan.heatmap import colour_map, grey_levels
from skin_driver.core.estimation.scan.wrench import net_wrench, torque_about_origin
from skin_msgs.action import (Calibrate, CalibrateCompliance, CalibrateDirection, CalibrateForce,
                              CalibrateGains)
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray


def make_header(stamp: Time, frame_id: str) -> Header:
    """Return a header for the skin frame at the given stamp."""
    return Header(stamp=stamp, frame_id=frame_id)


def skin_frame_to_msg(header: Header, sequence: int, device_time_us: int,
                      pitch_m: float, top: np.ndarray, bottom: np.ndarray) -> SkinFrame:
    """Pack one scan (two rows x cols count maps) into a SkinFrame message."""
    if top.shape != bottom.shape or top.ndim != 2:
        raise ValueError(
            f'layers must be two maps of one shape, got {top.shape} and {bottom.shape}')
    rows, cols = top.shape
    msg = SkinFrame(header=header, sequence=sequence & 0xFFFFFFFF,
                    device_time_us=int(device_time_us), rows=rows, cols=cols,
                    pitch=float(pitch_m))
    # An array('H') is stored as it is; a list would be range-checked element by element.
    msg.top = array('H', np.ascontiguousarray(top, dtype=np.uint16).tobytes())
    msg.bottom = array('H', np.ascontiguousarray(bottom, dtype=np.uint16).tobytes())
    return msg


def frame_pitch(pitch_m: float) -> float:
    """
    Return a taxel pitch as a SkinFrame carries it: the 7 significant digits of its float32.

    A driver's 0.005 arrives as 0.004999999888. Two pitches are one skin's when their
    frame_pitch is equal: the one rule of the estimator's pitch and the calibration's skin.
    """
    return float(f'{float(pitch_m):.7g}')


def skin_frame_layers(msg: SkinFrame) -> Tuple[np.ndarray, np.ndarray]:
    """Return the (top, bottom) count maps of a SkinFrame, checking that its sizes agree."""
    return layers_of(msg.rows, msg.cols, msg.top, msg.bottom)


def counts_to_image(header: Header, counts: np.ndarray) -> Image:
    """Return a mono16 image of one layer's raw counts (row 0 first, as the skin's y axis)."""
    data = np.ascontiguousarray(counts, dtype='<u2')
    rows, cols = data.shape
    return Image(header=header, height=rows, width=cols, encoding='mono16', is_bigendian=0,
                 step=cols * 2, data=data.tobytes())


def rgb_to_image(header: Header, rgb: np.ndarray) -> Image:
    """Return an rgb8 image from a rows x cols x 3 uint8 array."""
    data = np.ascontiguousarray(rgb, dtype=np.uint8)
    rows, cols, _ = data.shape
    return Image(header=header, height=rows, width=cols, encoding='rgb8', is_bigendian=0,
                 step=cols * 3, data=data.tobytes())


def _finite(value: float, name: str) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f'{name} is {value}; a contact message never carries NaN or inf')
    return value


def contact_fields(contact) -> tuple:
    """
    Return a core Contact's message fields in TactileContact's order, after the header.

    location x, y, z; magnitude; normal_force; azimuth; azimuth_sigma; polar; shift x, y, z;
    force x, y, z; torque x, y, z; area; confidence; direction_valid; held. Raise ValueError for a
    non-finite value: a contact message never carries NaN or inf. Fields a contact never sets
    (location.z, shift.z) are 0; the torque is r x F about the frame origin.
    """
    fx, fy, fz = (_finite(v, 'force') for v in contact.force_xyz_n)
    sx, sy = (_finite(v, 'shift') for v in contact.shift_m)
    x, y = _finite(contact.x_m, 'x'), _finite(contact.y_m, 'y')
    normal_force = _finite(contact.force_n, 'normal force')
    area = _finite(contact.area_m2, 'area')
    confidence = min(1.0, max(0.0, _finite(contact.confidence, 'confidence')))
    # What a contact without a direction carries (azimuth 0, sigma pi, polar 0) is the core's
    # rule (Contact): the message takes the contact's own values and its direction_valid.
    azimuth = _finite(contact.azimuth_rad, 'azimuth')
    sigma = _finite(contact.azimuth_sigma_rad, 'azimuth_sigma')
    polar = _finite(contact.alpha_rad, 'polar')
    return (x, y, 0.0, math.sqrt(fx * fx + fy * fy + fz * fz), normal_force, azimuth, sigma,
            polar, sx, sy, 0.0, fx, fy, fz, *torque_about_origin(x, y, (fx, fy, fz)), area,
            confidence, bool(contact.direction_valid),
            max(0.0, _finite(getattr(contact, 'held_s', 0.0), 'held')))


def contact_to_msg(header: Header, contact, out: TactileContact = None) -> TactileContact:
    """
    Convert a core Contact (:mod:`skin_driver.core.estimation.scan.pipeline`) into a message.

    With ``out`` the message is filled in place and returned: publish() serialises at once, so
    one message can carry scan after scan. A refused contact leaves ``out`` as it was.
    """
    return fill_contact(header, contact_fields(contact), out)


def fill_contact(header: Header, fields: tuple, out: TactileContact = None) -> TactileContact:
    """
    Return a TactileContact of one :func:`contact_fields` tuple (``out`` filled, if given).

    The one writer of the message object; :class:`cdr.SerializedMessages` writes the same
    fields as bytes and checks itself against this.
    """
    (x, y, _, magnitude, normal_force, azimuth, sigma, polar, sx, sy, _, fx, fy, fz, tx, ty, tz,
     area, confidence, direction_valid, held) = fields
    msg = TactileContact() if out is None else out
    msg.header = header
    msg.location.x, msg.location.y = x, y
    msg.magnitude = magnitude
    msg.normal_force = normal_force
    msg.azimuth, msg.azimuth_sigma, msg.polar = azimuth, sigma, polar
    msg.shift.x, msg.shift.y = sx, sy
    force = msg.wrench.force
    force.x, force.y, force.z = fx, fy, fz
    torque = msg.wrench.torque
    torque.x, torque.y, torque.z = tx, ty, tz
    msg.area = area
    msg.confidence = confidence
    msg.direction_valid = direction_valid
    msg.held = held
    return msg


class ContactArrayWriter:
    """
    Fill one TactileContactArray (and its contacts) scan after scan instead of building anew.

    For a publisher's hot path: publish() serialises the message at once, so the next scan may
    overwrite it. Building the messages afresh makes Python objects per contact and scan, which
    rclpy then converts field by field.
    """

    def __init__(self):
        self.array = TactileContactArray()
        self._pool = []

    def fill(self, header: Header, contacts: Sequence, sequence: int = 0,
             device_time_us: int = 0) -> TactileContactArray:
        """Return the array holding these contacts (strongest first) of one scan."""
        pool = self._pool
        while len(pool) < len(contacts):
            pool.append(TactileContact())
        filled = [contact_to_msg(header, c, pool[i]) for i, c in enumerate(contacts)]
        array = self.array
        array.header = header
        array.sequence = sequence & 0xFFFFFFFF
        array.device_time_us = int(device_time_us)
        array.contacts = filled
        return array


def contacts_to_array(header: Header, contacts: Sequence, sequence: int = 0,
                      device_time_us: int = 0) -> TactileContactArray:
    """Convert core contacts (strongest first) of one scan into a new TactileContactArray."""
    return ContactArrayWriter().fill(header, contacts, sequence, device_time_us)


def wrench_stamped(header: Header, contacts: Sequence) -> WrenchStamped:
    """
    Return the net wrench of all contacts of one scan, as a force/torque sensor would report it.

    The force is the sum of the contacts' forces, the torque the sum of their r x F about the
    frame origin; zero when nothing touches. Two fingers pinching report what the skin carries,
    not the strongest finger.
    """
    fx, fy, fz, tx, ty, tz = net_wrench_fields(contacts)
    return WrenchStamped(header=header, wrench=Wrench(force=Vector3(x=fx, y=fy, z=fz),
                                                      torque=Vector3(x=tx, y=ty, z=tz)))


def net_wrench_fields(contacts: Sequence) -> tuple:
    """Return the net wrench of core contacts as (fx, fy, fz, tx, ty, tz), all finite."""
    force, torque = net_wrench(contacts)
    return (*(_finite(v, 'force') for v in force), *(_finite(v, 'torque') for v in torque))


def mount_transform(stamp: Time, parent: str, child: str, xyz: Sequence[float],
                    rpy: Sequence[float]) -> TransformStamped:
    """Return the pose of ``child`` on ``parent``: translation xyz, fixed-axis roll-pitch-yaw."""
    half = [0.5 * float(a) for a in rpy]
    (cr, cp, cy), (sr, sp, sy) = ([math.cos(a) for a in half], [math.sin(a) for a in half])
    rotation = Quaternion(x=sr * cp * cy - cr * sp * sy, y=cr * sp * cy + sr * cp * sy,
                          z=cr * cp * sy - sr * sp * cy, w=cr * cp * cy + sr * sp * sy)
    x, y, z = (float(v) for v in xyz)
    return TransformStamped(header=Header(stamp=stamp, frame_id=parent), child_frame_id=child,
                            transform=Transform(translation=Vector3(x=x, y=y, z=z),
                                                rotation=rotation))


def mount_pose(xyz: Sequence[float], rpy: Sequence[float]) -> Pose:
    """Return the mount ``xyz``, fixed-axis ``rpy`` as a Pose (as mount_transform places it)."""
    t = mount_transform(Time(), '', '', xyz, rpy).transform
    return Pose(position=Point(x=t.translation.x, y=t.translation.y, z=t.translation.z),
                orientation=t.rotation)


def heatmap_markers(header: Header, force_map: np.ndarray, pitch_m: float, contacts: Iterable,
                    full_scale_n: float) -> MarkerArray:
    """
    Return rviz markers in the skin frame: the taxel grid coloured by force, and the contacts.

    Each contact gets an arrow along its force (ending at the contact, coming from where the
    push comes from) and a label with magnitude and azimuth.
    """
    return MarkerArray(markers=grid_markers(header, force_map, pitch_m, full_scale_n)
                       + contact_markers(header, contacts, pitch_m))


def grid_markers(header: Header, force_map: np.ndarray, pitch_m: float,
                 full_scale_n: float) -> list:
    """Return the markers that clear the skin's and draw the taxel grid coloured by force."""
    rows, cols = force_map.shape
    grid = Marker(header=header, ns='taxels', id=0, type=Marker.CUBE_LIST, action=Marker.ADD)
    grid.pose.orientation.w = 1.0
    grid.scale = Vector3(x=pitch_m * 0.9, y=pitch_m * 0.9, z=pitch_m * 0.1)
    # Points and colours are shared, never changed, so rviz's 15 Hz costs no object per taxel.
    grid.points = list(_grid_points(rows, cols, float(pitch_m)))
    palette = _palette()
    grid.colors = [palette[level] for level in grey_levels(force_map, full_scale_n).ravel()]
    return [Marker(header=header, ns='skin', action=Marker.DELETEALL), grid]


def contact_markers(header: Header, contacts: Iterable, pitch_m: float,
                    arrow_m_per_n: float = 0.002) -> list:
    """Return an arrow along each contact's force and a label with its magnitude and azimuth."""
    markers = []
    for i, contact in enumerate(contacts):
        tip = Point(x=float(contact.x_m), y=float(contact.y_m), z=0.0)
        fx, fy, fz = (float(v) for v in contact.force_xyz_n)
        tail = Point(x=tip.x - fx * arrow_m_per_n, y=tip.y - fy * arrow_m_per_n,
                     z=-fz * arrow_m_per_n)
        arrow = Marker(header=header, ns='force', id=i, type=Marker.ARROW, action=Marker.ADD,
                       points=[tail, tip], color=ColorRGBA(r=0.1, g=0.8, b=1.0, a=1.0))
        arrow.pose.orientation.w = 1.0
        arrow.scale = Vector3(x=pitch_m * 0.3, y=pitch_m * 0.6, z=pitch_m * 0.8)
        label = Marker(header=header, ns='label', id=i, type=Marker.TEXT_VIEW_FACING,
                       action=Marker.ADD, color=ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0))
        label.pose.position = Point(x=tail.x, y=tail.y, z=tail.z + pitch_m)
        label.pose.orientation.w = 1.0
        label.scale.z = pitch_m * 1.2
        label.text = f'{contact.force_n:.1f} N'
        if contact.direction_valid:
            label.text += f' β {math.degrees(contact.azimuth_rad):.0f}°'
        markers += [arrow, label]
    return markers


@functools.lru_cache(maxsize=4)
def _grid_points(rows: int, cols: int, pitch_m: float) -> tuple:
    return tuple(Point(x=c * pitch_m, y=r * pitch_m, z=0.0)
                 for r in range(rows) for c in range(cols))


@functools.lru_cache(maxsize=1)
def _palette() -> tuple:
    """Return the ColorRGBA of each grey level 0..255 of colour_map."""
    return tuple(ColorRGBA(r=float(r), g=float(g), b=float(b), a=float(a))
                 for r, g, b, a in palette_rgba())


def palette_rgba() -> np.ndarray:
    """Return colour_map's colour of each grey level 0..255 as 256 x 4 float32 RGBA in 0..1."""
    rgb = colour_map(np.arange(256, dtype=np.float64).reshape(1, -1), 255.0)[0] / 255.0
    return np.hstack([rgb, np.ones((256, 1))]).astype(np.float32)


def status_values(status: DiagnosticStatus) -> dict:
    """Return a diagnostic status's key/value pairs as a dict of strings."""
    return {kv.key: kv.value for kv in status.values}


# ---- calibration actions -------------------------------------------------------------------

def calibration_feedback(action_goal, session, note: str):
    """Return a calibration action's feedback after a press: counts, the last press's reading."""
    feedback = _CALIBRATIONS[action_goal].Feedback()
    feedback.presses_done = len(session.accepted)
    feedback.presses_wanted = session.wanted
    if session.accepted:
        last = session.accepted[-1]
        feedback.last_force = float(last.peak_force_n)
        shift = [float(v) if math.isfinite(v) else 0.0 for v in last.shift_m]
        feedback.last_shift_x, feedback.last_shift_y = shift
    feedback.note = note
    return feedback


_CALIBRATIONS = {a.Goal: a for a in (Calibrate, CalibrateForce, CalibrateCompliance,
                                     CalibrateGains, CalibrateDirection)}


def fill_offset_result(result, cal, outcome) -> None:
    """Fill a Calibrate result with the calibration in force (and the outcome, if any)."""
    result.x_p, result.y_p = cal.x_p_m, cal.y_p_m
    result.std_x, result.std_y = cal.std_x_m, cal.std_y_m


def fill_force_result(result, cal, outcome) -> None:
    """Fill a CalibrateForce result with the calibration in force (and the outcome, if any)."""
    curve = cal.force_curves[1] if cal.force_curves else None
    result.curve_counts = list(curve.counts) if curve else []
    result.curve_forces = list(curve.force_n) if curve else []
    result.fitted = list(outcome.fitted) if outcome else []
    result.residuals = list(outcome.residuals) if outcome else []


def fill_compliance_result(result, cal, outcome) -> None:
    """Fill a CalibrateCompliance result with the calibration in force (and outcome, if any)."""
    result.compliance = cal.compliance_m_per_n
    result.fitted = list(outcome.fitted) if outcome else []
    result.residuals = list(outcome.residuals) if outcome else []


def fill_direction_result(result, cal, outcome) -> None:
    """Fill a CalibrateDirection result with the correction in force (or the new one)."""
    learned = cal.direction
    result.applied = bool(learned is not None and learned.kept)
    result.error_before = math.radians(learned.before_deg) if learned is not None else 0.0
    result.error_after = math.radians(learned.after_deg) if learned is not None else 0.0


def fill_gains_result(result, cal, outcome) -> None:
    """Fill a CalibrateGains result with the calibration in force (and the outcome, if any)."""
    top, bottom = cal.gain_maps()
    if top is None:
        result.gain_min = result.gain_max = 1.0
    else:
        result.gain_min = float(min(top.min(), bottom.min()))
        result.gain_max = float(max(top.max(), bottom.max()))
    result.covered = outcome.covered if outcome is not None else 0.0
    result.warning = '; '.join(outcome.warnings) if outcome is not None else ''
