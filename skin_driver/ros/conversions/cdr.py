"""
The hot path's messages written straight as CDR bytes, for Publisher.publish(bytes).

Each kind is checked once against rclpy's own reading of the bytes (deserialize_message): a
middleware that serialises otherwise than plain little-endian CDR gets message objects from the
caller instead (``usable`` is False).
"""

import struct
from struct import Struct
from typing import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3, Wrench, WrenchStamped
import numpy as np
from rclpy.serialization import deserialize_message, serialize_message
from skin_driver.core.estimation.data.recording import layers_of
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from .messages import (fill_contact, grid_markers, net_wrench_fields, palette_rgba,
                       skin_frame_to_msg)

_CDR_LE = b'\x00\x01\x00\x00'  # encapsulation header: plain CDR, little-endian
_CONTACT_DOUBLES = 19  # TactileContact after its header: 19 float64, then direction_valid, held


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
    conversion by rclpy (docs/benchmarks.md, stage costs). ``usable`` says whether they
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
            # direction_valid, held, then patch: one skin's contacts name no patch (empty).
            layout.add('?', 1).add('d', 8).add('I', 4).add('s', 1, 1)
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
            parts.append(layout.pack(sec, nanosec, len(fid), fid, *values, 1, b''))
            offset += size
        return b''.join(parts)

    def contact(self, sec: int, nanosec: int, values: tuple) -> bytes:
        """Return a TactileContact of one :func:`contact_fields` tuple."""
        return _CDR_LE + self._contact(0)[0].pack(sec, nanosec, len(self._fid), self._fid,
                                                  *values, 1, b'')

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
                                           *net_wrench_fields(contacts))

    def _same_as_rclpy(self) -> bool:
        """Return whether rclpy reads these bytes back as the messages they stand for."""
        # Padding bytes are left undefined by some middlewares: compare messages, not bytes.
        header = Header(stamp=Time(sec=1_700_000_000, nanosec=123_456_789),
                        frame_id=self.frame_id)
        # location.z and shift.z (2 and 10) are 0 in every contact message.
        fields = [tuple(0.0 if i in (2, 10) else 0.5 + i + k / 7
                        for i in range(_CONTACT_DOUBLES)) + (k == 0, 60.0 * k + 0.25)
                  for k in range(3)]
        msgs = [fill_contact(header, values) for values in fields]
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


# A stamp no real one equals, to find where a template's stamps lie.
_MARK = (1_234_567_891, 987_654_321)
_STAMP = Struct('<iI')


class GridMarkers:
    """
    The taxel grid of :func:`heatmap_markers` (clearing marker, coloured grid) as CDR bytes.

    rclpy converts a grid's points and colours from Python objects at every publish, holding
    the GIL throughout, in one call; here a MarkerArray serialised once by rclpy is copied
    and only its two stamps and its block of colours are written per publish.
    """

    def __init__(self, frame_id: str, shape: tuple, pitch_m: float):
        self.key = (frame_id, tuple(shape), float(pitch_m))
        levels = np.arange(shape[0] * shape[1], dtype=np.uint8).reshape(shape)  # wraps at 256
        self._palette = palette_rgba()
        header = Header(stamp=Time(sec=_MARK[0], nanosec=_MARK[1]), frame_id=frame_id)
        template = serialize_message(MarkerArray(
            markers=grid_markers(header, levels, pitch_m, 255.0)))
        block = self._palette[levels.ravel()].tobytes()
        stamp = _STAMP.pack(*_MARK)
        self._stamps = []
        at = template.find(stamp)
        while at >= 0:
            self._stamps.append(at)
            at = template.find(stamp, at + 1)
        self._colours = template.find(block)
        self._size = len(block)
        self._template = template
        self.usable = (len(self._stamps) == 2 and self._colours >= 0
                       and template.rfind(block) == self._colours
                       and self._reads_back(levels))

    def serialize(self, sec: int, nanosec: int, levels: np.ndarray) -> bytes:
        """Return the grid markers of uint8 colour levels (:func:`grey_levels`) at a stamp."""
        data = bytearray(self._template)
        for at in self._stamps:
            _STAMP.pack_into(data, at, sec, nanosec)
        data[self._colours:self._colours + self._size] = self._palette[levels.ravel()].tobytes()
        return bytes(data)

    def _reads_back(self, levels: np.ndarray) -> bool:
        frame_id, _, pitch_m = self.key
        header = Header(stamp=Time(sec=5, nanosec=6), frame_id=frame_id)
        shuffled = levels[::-1].copy()
        try:
            return deserialize_message(self.serialize(5, 6, shuffled), MarkerArray) == MarkerArray(
                markers=grid_markers(header, shuffled, pitch_m, 255.0))
        except Exception:  # noqa: B902 - any failure to read them back means "not usable"
            return False


class _Cursor:
    """Read CDR fields in order from bytes, aligned as the writer aligned them."""

    def __init__(self, data: bytes):
        self.data, self.offset = data, len(_CDR_LE)

    def take(self, fmt: str, align: int) -> tuple:
        self.offset += -(self.offset - len(_CDR_LE)) % align
        values = struct.unpack_from('<' + fmt, self.data, self.offset)
        self.offset += struct.calcsize('<' + fmt)
        return values

    def text(self) -> str:
        (length,) = self.take('I', 4)  # with its NUL
        start, self.offset = self.offset, self.offset + length
        return self.data[start:self.offset - 1].decode()

    def counts(self) -> np.ndarray:
        (count,) = self.take('I', 4)
        layer = np.frombuffer(self.data, '<u2', count, self.offset)
        self.offset += 2 * count
        return layer


def read_contacts_head(data: bytes) -> tuple:
    """
    Return (stamp sec, nanosec, sequence, device time, contacts) of TactileContactArray bytes.

    The contacts are counted, not read (a counting subscriber). Raise ValueError for bytes too
    short to hold those fields.
    """
    cursor = _Cursor(data)
    try:
        sec, nanosec, length = cursor.take('iIi', 4)
        cursor.offset += length  # the frame_id, NUL included
        (sequence,) = cursor.take('I', 4)
        (device_time_us,) = cursor.take('Q', 8)
        (count,) = cursor.take('I', 4)
    except struct.error as err:
        raise ValueError(f'not a TactileContactArray: {err}') from None
    return sec, nanosec, sequence, device_time_us, count


def read_skin_frame(data: bytes) -> tuple:
    """
    Return (header, sequence, device time, pitch, top, bottom) of a SkinFrame's CDR bytes.

    The layers are read-only (rows, cols) views of ``data``. Raise ValueError for bytes that are
    not a whole SkinFrame or whose layers do not match its grid, as skin_frame_layers does.
    """
    cursor = _Cursor(data)
    try:
        sec, nanosec = cursor.take('iI', 4)
        frame_id = cursor.text()
        (sequence,) = cursor.take('I', 4)
        (device_time_us,) = cursor.take('Q', 8)
        rows, cols = cursor.take('HH', 2)
        (pitch,) = cursor.take('f', 4)
        top, bottom = cursor.counts(), cursor.counts()
    except (struct.error, ValueError) as err:  # UnicodeDecodeError is a ValueError
        raise ValueError(f'not a whole SkinFrame: {err}') from None
    header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)
    return (header, sequence, device_time_us, pitch) + layers_of(rows, cols, top, bottom)


def skin_frames_read_back() -> bool:
    """Return whether :func:`read_skin_frame` reads rclpy's own SkinFrame bytes right."""
    top = np.arange(15, dtype=np.uint16).reshape(3, 5)
    bottom = top[::-1].copy()
    pitch = 2.0 ** -7  # exact in the message's float32
    header = Header(stamp=Time(sec=3, nanosec=4), frame_id='abc')
    try:
        got = read_skin_frame(serialize_message(
            skin_frame_to_msg(header, 7, 2 ** 40 + 3, pitch, top, bottom)))
    except ValueError:
        return False
    return (got[:4] == (header, 7, 2 ** 40 + 3, pitch) and np.array_equal(got[4], top)
            and np.array_equal(got[5], bottom))
