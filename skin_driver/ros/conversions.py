"""
Conversions between the ROS-free core's values and ROS messages, kept in one place.

No node lives here (as in sensor_msgs_py): everything takes and returns plain values and messages,
so the nodes stay thin and the conversions can be tested without a running ROS graph.
"""

from array import array
import functools
import math
from struct import Struct
from typing import Iterable, Sequence, Tuple

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import (Point, Quaternion, Transform, TransformStamped, Vector3,
                               Wrench, WrenchStamped)
import numpy as np
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Image
from skin_driver.core.estimation.heatmap import colour_map, grey_levels
from skin_driver.core.estimation.recording import layers_of
from skin_driver.core.estimation.wrench import net_wrench, torque_about_origin
from skin_msgs.action import Calibrate, CalibrateCompliance, CalibrateForce, CalibrateGains
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
    force x, y, z; torque x, y, z; area; confidence; direction_valid. Raise ValueError for a
    non-finite value: a contact message never carries NaN or inf. Fields a contact never sets
    (location.z, shift.z) are 0; the torque is r x F about the frame origin.
    """
    fx, fy, fz = (_finite(v, 'force') for v in contact.force_xyz_n)
    sx, sy = (_finite(v, 'shift') for v in contact.shift_m)
    x, y = _finite(contact.x_m, 'x'), _finite(contact.y_m, 'y')
    normal_force = _finite(contact.force_n, 'normal force')
    area = _finite(contact.area_m2, 'area')
    confidence = min(1.0, max(0.0, _finite(contact.confidence, 'confidence')))
    direction_valid = bool(contact.direction_valid)
    if direction_valid:
        azimuth = _finite(contact.azimuth_rad, 'azimuth')
        sigma = _finite(contact.azimuth_sigma_rad, 'azimuth_sigma')
        polar = _finite(contact.alpha_rad, 'polar')
    else:
        azimuth, sigma, polar = 0.0, math.pi, 0.0
    return (x, y, 0.0, math.sqrt(fx * fx + fy * fy + fz * fz), normal_force, azimuth, sigma,
            polar, sx, sy, 0.0, fx, fy, fz, *torque_about_origin(x, y, (fx, fy, fz)), area,
            confidence, direction_valid)


def contact_to_msg(header: Header, contact, out: TactileContact = None) -> TactileContact:
    """
    Convert a core Contact (:mod:`skin_driver.core.estimation.pipeline`) into a message.

    With ``out`` the message is filled in place and returned: publish() serialises at once, so
    one message can carry scan after scan. A refused contact leaves ``out`` as it was.
    """
    return _fill_contact(header, contact_fields(contact), out)


def _fill_contact(header: Header, fields: tuple, out: TactileContact = None) -> TactileContact:
    (x, y, _, magnitude, normal_force, azimuth, sigma, polar, sx, sy, _, fx, fy, fz, tx, ty, tz,
     area, confidence, direction_valid) = fields
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
    return msg


class ContactArrayWriter:
    """
    Fill one TactileContactArray (and its contacts) scan after scan instead of building anew.

    For a publisher's hot path: publish() serialises the message at once, so the next scan may
    overwrite it. Building the messages afresh costs about three times as much in rclpy.
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
    fx, fy, fz, tx, ty, tz = _net_wrench_fields(contacts)
    return WrenchStamped(header=header, wrench=Wrench(force=Vector3(x=fx, y=fy, z=fz),
                                                      torque=Vector3(x=tx, y=ty, z=tz)))


def _net_wrench_fields(contacts: Sequence) -> tuple:
    force, torque = net_wrench(contacts)
    return (*(_finite(v, 'force') for v in force), *(_finite(v, 'torque') for v in torque))


# ---- the hot path's messages as CDR bytes ----------------------------------------------------

_CDR_LE = b'\x00\x01\x00\x00'  # encapsulation header: plain CDR, little-endian
_CONTACT_DOUBLES = 19  # TactileContact after its header: 19 float64, then direction_valid


class _Layout:
    """The struct format of CDR fields from an offset on, with the padding they need."""

    def __init__(self, offset: int):
        self.format, self.offset = '<', offset

    def add(self, code: str, size: int, count: int = 1) -> '_Layout':
        pad = -self.offset % size
        self.format += 'x' * pad + f'{count}{code}'
        self.offset += pad + size * count
        return self

    def header(self, frame_id_size: int) -> '_Layout':
        """Add std_msgs/Header: stamp sec, nanosec, then frame_id (length, bytes, NUL)."""
        return self.add('i', 4).add('I', 4).add('I', 4).add('s', 1, frame_id_size)


class SerializedMessages:
    """
    The frame, contacts, contact and wrench messages of one frame_id written as CDR bytes.

    Publisher.publish(bytes) sends them as they are: no message objects to fill and no
    conversion by rclpy (measured at about a third of a publish). ``usable`` says whether they
    equal rclpy's own serialisation of the same messages, checked once here: a middleware that
    serialises differently gets message objects from the caller instead.
    """

    def __init__(self, frame_id: str):
        self.frame_id = frame_id
        self._fid = frame_id.encode() + b'\0'
        head = _Layout(0).header(len(self._fid)).add('I', 4).add('Q', 8).add('I', 4)
        self._array_head, self._array_size = Struct(head.format), head.offset
        self._contact_at = {}
        self._frame_at = {}
        self._wrench = Struct(_Layout(0).header(len(self._fid)).add('d', 8, 6).format)
        self.usable = self._same_as_rclpy()

    def _contact(self, offset: int) -> tuple:
        """Return (Struct, size) of a TactileContact that starts at this offset."""
        key = offset % 8  # the padding depends on nothing else
        found = self._contact_at.get(key)
        if found is None:
            layout = _Layout(key).header(len(self._fid)).add('d', 8, _CONTACT_DOUBLES)
            layout.add('?', 1)
            found = self._contact_at[key] = (Struct(layout.format), layout.offset - key)
        return found

    def contacts(self, sec: int, nanosec: int, sequence: int, device_time_us: int,
                 fields: Sequence[tuple]) -> bytes:
        """Return a TactileContactArray of contacts given as :func:`contact_fields` tuples."""
        fid = self._fid
        parts = [_CDR_LE, self._array_head.pack(sec, nanosec, len(fid), fid,
                                                sequence & 0xFFFFFFFF, device_time_us,
                                                len(fields))]
        offset = self._array_size
        for values in fields:
            layout, size = self._contact(offset)
            parts.append(layout.pack(sec, nanosec, len(fid), fid, *values))
            offset += size
        return b''.join(parts)

    def contact(self, sec: int, nanosec: int, values: tuple) -> bytes:
        """Return a TactileContact of one :func:`contact_fields` tuple."""
        return _CDR_LE + self._contact(0)[0].pack(sec, nanosec, len(self._fid), self._fid,
                                                  *values)

    def frame(self, sec: int, nanosec: int, sequence: int, device_time_us: int, pitch_m: float,
              top: np.ndarray, bottom: np.ndarray) -> bytes:
        """Return the SkinFrame of one scan (two C-contiguous uint16 maps of one shape)."""
        rows, cols = top.shape
        head, gap = self._frame_layout(rows * cols)
        return b''.join((_CDR_LE, head.pack(sec, nanosec, len(self._fid), self._fid,
                                            sequence & 0xFFFFFFFF, device_time_us, rows, cols,
                                            pitch_m, rows * cols),
                         top, gap.pack(rows * cols), bottom))

    def _frame_layout(self, count: int) -> tuple:
        """Return the Structs before each layer of a SkinFrame of ``count`` taxels."""
        found = self._frame_at.get(count)
        if found is None:
            head = _Layout(0).header(len(self._fid)).add('I', 4).add('Q', 8).add('H', 2, 2)
            head.add('f', 4).add('I', 4)
            gap = _Layout(head.offset + 2 * count).add('I', 4)
            found = self._frame_at[count] = (Struct(head.format), Struct(gap.format))
        return found

    def wrench(self, sec: int, nanosec: int, contacts: Sequence) -> bytes:
        """Return the WrenchStamped of core contacts, as :func:`wrench_stamped` makes it."""
        return _CDR_LE + self._wrench.pack(sec, nanosec, len(self._fid), self._fid,
                                           *_net_wrench_fields(contacts))

    def _same_as_rclpy(self) -> bool:
        """Return whether rclpy reads these bytes back as the messages they stand for."""
        # Padding bytes are left undefined by some middlewares: compare messages, not bytes.
        header = Header(stamp=Time(sec=1_700_000_000, nanosec=123_456_789),
                        frame_id=self.frame_id)
        # location.z and shift.z (2 and 10) are 0 in every contact message.
        fields = [tuple(0.0 if i in (2, 10) else 0.5 + i + k / 7
                        for i in range(_CONTACT_DOUBLES)) + (k == 0,) for k in range(3)]
        msgs = [_fill_contact(header, values) for values in fields]
        array_msg = TactileContactArray(header=header, sequence=7, device_time_us=2 ** 40 + 3,
                                        contacts=msgs)
        wrench = WrenchStamped(header=header, wrench=Wrench(
            force=Vector3(x=1.5, y=-2.5, z=3.25), torque=Vector3(x=0.125, y=-4.0, z=8.5)))
        stamp = (header.stamp.sec, header.stamp.nanosec)
        try:
            return (deserialize_message(self.contacts(*stamp, 7, 2 ** 40 + 3, fields),
                                        TactileContactArray) == array_msg
                    and deserialize_message(self.contact(*stamp, fields[1]),
                                            TactileContact) == msgs[1]
                    and deserialize_message(_CDR_LE + self._wrench.pack(
                        *stamp, len(self._fid), self._fid, 1.5, -2.5, 3.25, 0.125, -4.0, 8.5),
                        WrenchStamped) == wrench
                    and all(self._frame_reads_back(header, shape) for shape in ((3, 5), (4, 4))))
        except Exception:  # noqa: B902 - any failure to read them back means "not usable"
            return False

    def _frame_reads_back(self, header: Header, shape: tuple) -> bool:
        """Return whether a SkinFrame of this shape (odd or even taxel count) reads back."""
        top = np.arange(np.prod(shape), dtype=np.uint16).reshape(shape)
        bottom = top[::-1].copy()
        pitch = 2.0 ** -7  # exact in the message's float32
        data = self.frame(header.stamp.sec, header.stamp.nanosec, 7, 2 ** 40 + 3, pitch, top,
                          bottom)
        return deserialize_message(data, SkinFrame) == skin_frame_to_msg(
            header, 7, 2 ** 40 + 3, pitch, top, bottom)


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


def heatmap_markers(header: Header, force_map: np.ndarray, pitch_m: float, contacts: Iterable,
                    full_scale_n: float, arrow_m_per_n: float = 0.002) -> MarkerArray:
    """
    Return rviz markers in the skin frame: the taxel grid coloured by force, and the contacts.

    Each contact gets an arrow along its force (ending at the contact, coming from where the
    push comes from) and a label with magnitude and azimuth.
    """
    markers = [Marker(header=header, ns='skin', action=Marker.DELETEALL)]
    rows, cols = force_map.shape
    grid = Marker(header=header, ns='taxels', id=0, type=Marker.CUBE_LIST, action=Marker.ADD)
    grid.pose.orientation.w = 1.0
    grid.scale = Vector3(x=pitch_m * 0.9, y=pitch_m * 0.9, z=pitch_m * 0.1)
    # Points and colours are shared, never changed, so rviz's 15 Hz costs no object per taxel.
    grid.points = list(_grid_points(rows, cols, float(pitch_m)))
    palette = _palette()
    grid.colors = [palette[level] for level in grey_levels(force_map, full_scale_n).ravel()]
    markers.append(grid)
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
    return MarkerArray(markers=markers)


@functools.lru_cache(maxsize=4)
def _grid_points(rows: int, cols: int, pitch_m: float) -> tuple:
    return tuple(Point(x=c * pitch_m, y=r * pitch_m, z=0.0)
                 for r in range(rows) for c in range(cols))


@functools.lru_cache(maxsize=1)
def _palette() -> tuple:
    """Return the ColorRGBA of each grey level 0..255 of colour_map."""
    rgb = colour_map(np.arange(256, dtype=np.float64).reshape(1, -1), 255.0)[0] / 255.0
    return tuple(ColorRGBA(r=float(r), g=float(g), b=float(b), a=1.0) for r, g, b in rgb)


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
                                     CalibrateGains)}


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
