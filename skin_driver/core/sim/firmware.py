"""
The firmware core built for the host (package skin_fw_host, firmware/host), through ctypes.

The simulated board frames every data frame and information frame with the firmware's own code
and sends its information frames on the firmware's schedule, so that the two boards cannot drift
apart: a change to the firmware's framing is the simulator's at the next build.
"""

from __future__ import annotations

import ctypes
from functools import lru_cache

import numpy as np

from ..common.native import library_places, open_library

# sim_board.h's SKIN_SIM_ABI_VERSION, the library's SOVERSION.
ABI_VERSION = 1
LIBRARY = f'libskin_fw_host.so.{ABI_VERSION}'
LIBRARY_VARIABLE = 'SKIN_FW_HOST_LIBRARY'
INFO_MAX_SIZE = 206  # SKIN_INFO_MAX_SIZE
_FIX = ('build it with `make setup` (or `colcon build` in the workspace), or name the library '
        f'file in {LIBRARY_VARIABLE}')
_u8, _u16, _u32, _u64 = ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32, ctypes.c_uint64
_ptr = ctypes.c_void_p


class FirmwareMissing(RuntimeError):
    """The firmware core built for the host is not installed, does not load or is another ABI."""


class _Schedule(ctypes.Structure):
    """skin_info_schedule_t (firmware/core/include/skin_fw/info.h)."""

    _fields_ = [('due_us', _u64), ('period_us', _u64), ('started', _u8)]


@lru_cache(maxsize=1)
def library() -> ctypes.CDLL:
    """Return the loaded library, its ABI and schedule layout checked and signatures set."""
    places = library_places('skin_fw_host', LIBRARY, LIBRARY_VARIABLE)
    lib, path = open_library(places, 'skin_fw_host', LIBRARY, _FIX, FirmwareMissing)
    if not hasattr(lib, 'skin_sim_abi_version'):
        raise FirmwareMissing(f'skin_fw_host: {path} is not skin_fw_host (no '
                              f'skin_sim_abi_version); {_FIX}')
    if lib.skin_sim_abi_version() != ABI_VERSION:
        raise FirmwareMissing(f'skin_fw_host: {path} has ABI {lib.skin_sim_abi_version()}, '
                              f'this skin_driver needs {ABI_VERSION}; {_FIX}')
    lib.skin_sim_schedule_size.restype = _u32
    if lib.skin_sim_schedule_size() != ctypes.sizeof(_Schedule):
        raise FirmwareMissing(f'skin_fw_host: {path} lays out skin_info_schedule_t in '
                              f'{lib.skin_sim_schedule_size()} bytes, this binding in '
                              f'{ctypes.sizeof(_Schedule)}; {_FIX}')
    _sign(lib)
    return lib


def _sign(lib: ctypes.CDLL) -> None:
    lib.skin_sim_buffer_size.argtypes = [_u8, _u8]
    lib.skin_sim_buffer_size.restype = _u32
    lib.skin_sim_frame.argtypes = [_ptr, _u32, _u8, _u32, _u64, _u8, _u8, _ptr, _u16, _ptr]
    lib.skin_sim_frame.restype = _u32
    lib.skin_sim_info.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p,
                                  ctypes.c_char_p, _u8, _u8, _u32, _u32, ctypes.c_char_p]
    lib.skin_sim_info.restype = _u32
    lib.skin_info_schedule_init.argtypes = [ctypes.POINTER(_Schedule), _u64]
    lib.skin_info_due.argtypes = [ctypes.POINTER(_Schedule), _u64]
    lib.skin_info_due.restype = ctypes.c_bool
    lib.skin_info_sent.argtypes = [ctypes.POINTER(_Schedule), _u64]


class Framer:
    """The firmware's data frames of one grid, built in one reused buffer."""

    def __init__(self, rows: int, cols: int, version: int):
        """Prepare a frame buffer for a rows x cols grid of protocol ``version``."""
        self._lib = library()
        self.rows, self.cols, self.version = rows, cols, version
        words = self._lib.skin_sim_buffer_size(rows, cols) // 4
        self._buf = np.zeros(words, dtype=np.uint32)  # numpy's data is aligned to words
        self._at = self._buf.ctypes.data
        self._size = 4 * self._buf.size
        self._bytes = self._buf.view(np.uint8)

    def frame(self, seq: int, device_time_us: int, counts: np.ndarray, faults: int = 0,
              row_map: bytes | None = None) -> bytes:
        """
        Return the frame of counts ((2, rows, cols) C-contiguous uint16: top, bottom).

        row_map: 2 * ceil(rows / 8) bytes, bit r % 8 of byte r // 8 set for each row sampled
        (top, then bottom); None: every row.
        """
        if counts.dtype != np.uint16 or counts.shape != (2, self.rows, self.cols) or not (
                counts.flags.c_contiguous):
            raise ValueError(f'counts must be C-contiguous uint16 of shape (2, {self.rows}, '
                             f'{self.cols}), got {counts.dtype} {counts.shape}')
        # The array interface's address: a tenth of the cost of ndarray.ctypes, once a frame.
        size = self._lib.skin_sim_frame(self._at, self._size, self.version, seq,
                                        device_time_us, self.rows, self.cols,
                                        counts.__array_interface__['data'][0], faults, row_map)
        if not size:
            raise ValueError(f'skin_fw_host refused a frame of version {self.version}')
        return self._bytes[:size].tobytes()


def row_map(row_valid: np.ndarray) -> bytes:
    """Return the row map of (2, rows) booleans as frame.h's skin_frame_meta_t takes it."""
    return np.packbits(np.asarray(row_valid, dtype=bool), axis=1, bitorder='little').tobytes()


def info_frame(info) -> bytes:
    """Return the board information frame of a BoardInfo, built by the firmware's code."""
    extra = ''.join(f';{k}={v}' for k, v in info.extra)
    out = ctypes.create_string_buffer(INFO_MAX_SIZE)
    size = library().skin_sim_info(out, info.board.encode('ascii'), bytes.fromhex(info.uid),
                                   info.fw.encode('ascii'), info.rows, info.cols, info.pitch_um,
                                   info.rate_hz, extra.encode('ascii'))
    if not size:
        raise ValueError(f'the information frame of {info.text!r} does not fit')
    return out.raw[:size]


class InfoSchedule:
    """The firmware's schedule of the information frame (skin_fw/info.h), for one board."""

    def __init__(self, period_us: int):
        """Start with the first information frame due at the first scan."""
        self._lib = library()
        self._state = _Schedule()
        self._ref = ctypes.byref(self._state)
        self._lib.skin_info_schedule_init(self._ref, period_us)

    def due(self, device_time_us: int) -> bool:
        """Return whether an information frame goes ahead of the scan of this device time."""
        return self._lib.skin_info_due(self._ref, device_time_us)

    def sent(self, device_time_us: int) -> None:
        """Note that one went ahead of the scan of this device time."""
        self._lib.skin_info_sent(self._ref, device_time_us)
