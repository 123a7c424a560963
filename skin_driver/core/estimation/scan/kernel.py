"""
The compiled per-scan estimation (package ``skin_kernel``, plain C) bound through ctypes.

One call per scan does what :class:`pipeline.ContactEstimator` describes in Python:
conditioning, contacts, a saturated imprint's force filled in from its rim (a calibrated
censoring curve), each contact's shift (any registered method: ``taxel_fit``, ``poc``,
``centroid``) and uncertainty, and the contact figures. The Python code stays the description
of the algorithm; the tests run both side by side (test/core/estimation/test_kernel.py).

A :class:`Kernel` copies an estimator's state once (tare, gains, force tables, settings) and owns
preallocated buffers, so a scan costs one copy of the maps into its buffer and one foreign call.
Maps of uint16, as the driver and the datasets give them, are copied as they are (any value is
a count, no check); others are checked and copied as float64.
The dead-taxel marks a touch revives are handed back to the conditioner, which owns them.
"""

from __future__ import annotations

import ctypes
from functools import lru_cache
import os
import threading
from typing import NamedTuple
import weakref

import numpy as np

from ...common.validate import check_pair

__all__ = ['METHODS', 'KernelSettings', 'Kernel', 'KernelMissing', 'load_library',
           'CONTACT_FIELDS', 'KEPT', 'DX', 'DY', 'fit_contact', 'model_numbers']

# Shift methods the kernel runs, by their registered names (skin_kernel.h: SK_CENTROID, ...).
METHODS = {'centroid': 0, 'taxel_fit': 1, 'poc': 2, 'model_fit': 3}

# skin_kernel.h's layout: bump both together.
_ABI_VERSION = 8
_INTS = 9
_REALS = 34
_NREC = 23
_NSTATUS = 3
# A record's first CONTACT_FIELDS numbers are pipeline.Contact's fields in order, the shift and
# the force vector flattened (x_m, y_m, force_n, area_m2, shift x, y, azimuth_rad, ...).
CONTACT_FIELDS = 14
KEPT, DX, DY = range(CONTACT_FIELDS, CONTACT_FIELDS + 3)
_REVIVED = 2  # sk_scan's status word SK_STATUS_REVIVED
_COUNTS = np.dtype(np.uint16)  # sk_scan_counts's maps, native byte order

_FIX = ('build it with `make setup` (or `colcon build` in the workspace) and source the '
        'workspace, e.g. `tools/with-env.sh`')


class KernelMissing(RuntimeError):
    """The compiled kernel (package skin_kernel) is not installed or does not load."""


@lru_cache(maxsize=1)
def load_library() -> ctypes.CDLL:
    """Return the loaded ``libskin_kernel.so`` found through the ament index, signatures set."""
    try:
        from ament_index_python.packages import get_package_prefix, PackageNotFoundError
    except ImportError as exc:
        raise KernelMissing(f'skin_kernel: ament_index_python is missing ({exc}); '
                            f'{_FIX}') from None
    try:
        prefix = get_package_prefix('skin_kernel')
    except PackageNotFoundError:
        raise KernelMissing('skin_kernel: the package is not in the ament index (AMENT_PREFIX_PATH'
                            f'={os.environ.get("AMENT_PREFIX_PATH", "")!r}); {_FIX}') from None
    path = os.path.join(prefix, 'lib', 'libskin_kernel.so')
    try:
        lib = ctypes.CDLL(path)
    except OSError as exc:
        raise KernelMissing(f'skin_kernel: cannot load {path} ({exc}); {_FIX}') from None
    ptr = ctypes.c_void_p
    lib.sk_abi_version.restype = ctypes.c_int
    lib.sk_abi_version.argtypes = []
    if lib.sk_abi_version() != _ABI_VERSION:
        raise KernelMissing(f'skin_kernel: {path} is another version than this skin_driver; '
                            f'{_FIX}')
    # sk_scan and sk_scan_counts (kernel, maps, every_pair, out, status) have no argtypes: their
    # checks cost 0.7 us a call, and Kernel passes the same c_void_p objects and a Python int
    # every time.
    signatures = {'sk_new': (ptr, [ptr] * 8), 'sk_free': (None, [ptr]),
                  'sk_scan': (ctypes.c_int, None), 'sk_scan_counts': (ctypes.c_int, None),
                  'sk_dead': (None, [ptr, ptr]),
                  'sk_model_fit': (ctypes.c_int, [ptr, ctypes.c_int, ctypes.c_int, ptr, ptr,
                                                  ptr, ptr, ctypes.c_int, ptr, ptr])}
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name)
        function.restype = restype
        function.argtypes = argtypes
    return lib


class KernelSettings(NamedTuple):
    """Everything a kernel copies from an estimator, as plain numbers and arrays."""

    method: str
    max_contacts: int
    remove_crosstalk: bool
    fill_dead: bool
    reals: tuple         # skin_kernel.h's SK_PITCH ... SK_TAXEL_MODEL's numbers, in order
    baseline: np.ndarray  # (2, rows, cols) each, like threshold, noise, gain (or None), dead
    threshold: np.ndarray
    noise: np.ndarray
    gain: np.ndarray
    dead: np.ndarray
    tables: np.ndarray    # (2, full_scale + 1): each layer's force at every count
    tared: bool           # conditioning.ConditionerState.tared


def _address(array: np.ndarray) -> ctypes.c_void_p:
    return ctypes.c_void_p(array.ctypes.data)


class Kernel:
    """One estimator's compiled state and buffers; scans run one at a time."""

    def __init__(self, settings: KernelSettings):
        """Copy ``settings`` into a new compiled kernel (raises KernelMissing without one)."""
        lib = load_library()
        rows, cols = settings.baseline.shape[1:]
        full_scale = settings.tables.shape[1] - 1
        ints = np.array([rows, cols, settings.max_contacts, METHODS[settings.method],
                         settings.remove_crosstalk, settings.fill_dead, full_scale,
                         settings.gain is not None, settings.tared], dtype=np.intc)
        assert ints.size == _INTS and len(settings.reals) == _REALS
        reals = np.array(settings.reals, dtype=np.float64)
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (
            settings.baseline, settings.threshold, settings.noise)]
        gain = (None if settings.gain is None
                else np.ascontiguousarray(settings.gain, dtype=np.float64))
        dead = np.ascontiguousarray(settings.dead, dtype=np.uint8)
        tables = np.ascontiguousarray(settings.tables, dtype=np.float64)
        handle = lib.sk_new(*(_address(a) for a in [ints, reals] + arrays),
                            None if gain is None else _address(gain), _address(dead),
                            _address(tables))
        if not handle:
            raise MemoryError(f'skin_kernel: no kernel for {rows} x {cols} maps')
        self._lib = lib
        self._handle = ctypes.c_void_p(handle)
        weakref.finalize(self, lib.sk_free, self._handle)
        self.shape = (rows, cols)
        # A scan's maps: float64 (sk_scan), or uint16 counts as they come (sk_scan_counts).
        self._maps = np.zeros((2, rows, cols))
        self._counts = np.zeros((2, rows, cols), dtype=np.uint16)
        self._out = np.zeros((max(min(settings.max_contacts, rows * cols), 1), _NREC))
        # A ctypes array: reading a word of it costs a tenth of reading a numpy scalar.
        self._status = (ctypes.c_int * _NSTATUS)()
        outputs = (_address(self._out), ctypes.c_void_p(ctypes.addressof(self._status)))
        # By whether the maps are uint16 counts: the function, its top and bottom buffers, and
        # its arguments for reported contacts only and for every contact (measure_shifts wants
        # the light ones too).
        self._scans = tuple((scan, maps[0], maps[1],
                             tuple((self._handle, _address(maps), every) + outputs
                                   for every in (0, 1)))
                            for scan, maps in ((lib.sk_scan, self._maps),
                                               (lib.sk_scan_counts, self._counts)))
        self._lock = threading.Lock()

    def scan(self, top, bottom, every_pair: bool = False) -> tuple:
        """
        Return (records, revived) of the raw maps: a list per contact, strongest first.

        Without ``every_pair`` a contact too light to report (record[KEPT] 0) gets no shift.
        ``revived`` is None, or the dead-taxel marks after this scan revived some. Bad maps
        raise ValueError saying what is wrong.
        """
        if not (type(top) is np.ndarray and type(bottom) is np.ndarray
                and top.shape == self.shape and bottom.shape == self.shape):
            top, bottom = check_pair(top, bottom, self.shape)
        counts = top.dtype == _COUNTS and bottom.dtype == _COUNTS
        if not (counts or top.dtype.kind in 'uif' and bottom.dtype.kind in 'uif'):
            top, bottom = check_pair(top, bottom, self.shape)
        scan, top_buffer, bottom_buffer, args = self._scans[counts]
        with self._lock:
            top_buffer[...] = top
            bottom_buffer[...] = bottom
            count = scan(*args[every_pair])
            if count < 0:
                check_pair(top, bottom, self.shape)
                raise ValueError('top or bottom holds a value that is not a count')
            revived = self.dead_masks() if self._status[_REVIVED] else None
            return self._out[:count].tolist(), revived

    def dead_masks(self) -> np.ndarray:
        """Return the kernel's dead-taxel marks, (2, rows, cols) bool."""
        out = np.zeros((2,) + self.shape, dtype=np.uint8)
        self._lib.sk_dead(self._handle, _address(out))
        return out.astype(bool)


def model_numbers(model) -> tuple:
    """Return a :class:`taxelmodel.TaxelModel` as skin_kernel.h's SK_MODEL_* numbers (0s: none)."""
    if model is None:
        return (0.0,) * 11
    return (model.pitch_m, model.fill_factor, model.cover_spread_m, model.layer_spread_m,
            model.film_scale, model.film_exponent, model.film_ceiling, model.film_activation_n,
            model.turn_on_pa, model.film_step, model.full_scale)


def fit_contact(model, counts: np.ndarray, censored: np.ndarray, u0: np.ndarray,
                iterations: int = 10, sensitivity: np.ndarray = None):
    """
    Return :func:`taxelmodel.fit_contact` of the same arguments, compiled (``sk_model_fit``).

    ``model`` is a :class:`taxelmodel.TaxelModel`; raises KernelMissing without the kernel.
    """
    from ..model.taxelmodel import PressFit
    lib = load_library()
    counts = np.ascontiguousarray(counts, dtype=np.float64)
    rows, cols = counts.shape[1:]
    numbers = np.array(model_numbers(model), dtype=np.float64)
    marks = (None if censored is None
             else np.ascontiguousarray(np.broadcast_to(censored, counts.shape), dtype=np.uint8))
    factors = (None if sensitivity is None
               else np.ascontiguousarray(np.broadcast_to(sensitivity, counts.shape),
                                         dtype=np.float64))
    start = np.ascontiguousarray(u0, dtype=np.float64)
    u = np.zeros(8)
    misfit = np.zeros(1)
    status = lib.sk_model_fit(_address(numbers), rows, cols, _address(counts),
                              None if marks is None else _address(marks),
                              None if factors is None else _address(factors), _address(start),
                              int(iterations), _address(u), _address(misfit))
    if status != 0:
        raise MemoryError(f'skin_kernel: no memory to fit a {rows} x {cols} window')
    return PressFit(u, float(misfit[0]))
