"""
The per-scan estimation (package ``skin_kernel``, plain C) bound through ctypes.

One call per scan does all of it: conditioning, contacts, a saturated imprint's force filled in
from its rim (a calibrated censoring curve), each contact's shift (any registered method:
``taxel_fit``, ``model_fit``, ``poc``, ``centroid``; or a caller's, :meth:`Kernel.scan_shifted`)
and uncertainty, and the contact figures. There is no second implementation to agree with: the
tests hold the kernel to behaviour (symmetries, invariances, hard cases) and to golden outputs.

A :class:`Kernel` copies an estimator's state once (tare, gains, force tables, settings) and owns
preallocated buffers, so a scan costs one copy of the maps into its buffer and one foreign call.
Maps of uint16, as the driver and the datasets give them, are copied as they are (any value is
a count, no check); others are checked and copied as float64.
The kernel owns the dead-taxel marks its scans revive and, for scans given their time, the
baselines that follow drift and each taxel's age under load: the estimation's mutable state,
which a kernel built to replace another takes over at the swap (:meth:`Kernel.carry_from`).
One thread owns a kernel, the one that runs its scans, and it alone enters it; it takes no
lock. Other threads read what the owner publishes after each scan (:meth:`Kernel.dead_masks`,
:attr:`Kernel.drift`), replaced whole, never changed. With the owner check on
(``SKIN_KERNEL_CHECK_OWNER=1`` or ``Kernel(spec, check_owner=True)``: the tests') a kernel
records the first thread that enters it and refuses any other (:class:`NotTheOwner`, kept in
:func:`breaches` too) until :meth:`Kernel.claim` hands it over.
:meth:`Kernel.condition` and :meth:`Kernel.force` give a scan's conditioning alone (tared
counts, clipped taxels, the crosstalk taken off, forces): what a calibration reads its presses
from.

The structs of skin_kernel.h are mirrored here field by field (:class:`Settings`,
:class:`ContactRecord`, ...); before any other call the binding compares every mirror with the
layout the library reports (``sk_layout``) and refuses a library that differs.
"""

from __future__ import annotations

from collections import namedtuple
import ctypes
from functools import lru_cache
import os
import threading
from typing import NamedTuple
import weakref

import numpy as np

from ...common.native import library_places, open_library
from ...common.validate import check_pair

__all__ = ['METHODS', 'ABI_VERSION', 'TaxelModelNumbers', 'Curve', 'Direction', 'DriftNumbers',
           'Settings', 'ContactRecord', 'Status', 'Record', 'KernelSettings', 'Conditioned',
           'Kernel', 'KernelMissing', 'KernelMismatch', 'NotTheOwner', 'breaches',
           'load_library', 'library_candidates', 'fit_contact', 'taxel_model_of', 'direction_of',
           'DIRECTION_FEATURES', 'direction_features', 'creep']

# Shift methods the kernel runs, by their registered names (skin_kernel.h: SK_CENTROID, ...).
METHODS = {'centroid': 0, 'taxel_fit': 1, 'poc': 2, 'model_fit': 3}

# skin_kernel.h's SK_ABI_VERSION, the library's SOVERSION: libskin_kernel.so.<ABI_VERSION>.
ABI_VERSION = 15
LIBRARY = f'libskin_kernel.so.{ABI_VERSION}'
# The variable that names the library file to load, before any place searched.
LIBRARY_VARIABLE = 'SKIN_KERNEL_LIBRARY'
# The variable that turns the owner check on for kernels made without check_owner (1: on).
CHECK_VARIABLE = 'SKIN_KERNEL_CHECK_OWNER'

_OK, _NOT_FINITE, _NEGATIVE, _BAD_SETTINGS, _NO_MEMORY = 0, -1, -2, -3, -4
_COUNTS = np.dtype(np.uint16)  # sk_scan_counts's maps, native byte order

_FIX = ('build it with `make setup` (or `colcon build` in the workspace), or name the library '
        f'file in {LIBRARY_VARIABLE}')

_double, _int = ctypes.c_double, ctypes.c_int
_NO_TIME = _double(float('nan'))  # a scan without a time: nothing tracked


class KernelMissing(RuntimeError):
    """The compiled kernel (package skin_kernel) is not installed or does not load."""


class KernelMismatch(KernelMissing):
    """The library found is not the one this binding was written for (layout or ABI)."""


class NotTheOwner(RuntimeError):
    """A thread entered a kernel another thread owns (raised with the owner check on)."""


# What the owner check refused, in order: a refusal on a thread nobody joins is seen here.
_BREACHES = []


def breaches() -> list:
    """Return the owner check's refusals so far (messages): a test wants none."""
    return list(_BREACHES)


class TaxelModelNumbers(ctypes.Structure):
    """skin_kernel.h's sk_taxel_model: a :class:`taxelmodel.TaxelModel` (pitch_m 0: none)."""

    _fields_ = [(name, _double) for name in (
        'pitch_m', 'fill_factor', 'cover_spread_m', 'layer_spread_m', 'film_scale',
        'film_exponent', 'film_ceiling', 'film_activation_n', 'turn_on_pa', 'film_step',
        'full_scale')]


class Curve(ctypes.Structure):
    """skin_kernel.h's sk_curve: one layer's force-curve censoring (all 0, power 2: none)."""

    _fields_ = [(name, _double) for name in (
        'censor_counts', 'rim_load_n', 'spread_taxels', 'bump_power', 'activation_n')]


# skin_kernel.h's SK_DIRECTION_FEATURES: the learned correction's features (direction.py).
DIRECTION_FEATURES = 20


class Direction(ctypes.Structure):
    """skin_kernel.h's sk_direction: the shift's learned correction (on 0: none)."""

    _fields_ = [('on', _int), ('force_ref_n', _double),
                ('weight_x', _double * DIRECTION_FEATURES),
                ('weight_y', _double * DIRECTION_FEATURES)]


class DriftNumbers(ctypes.Structure):
    """skin_kernel.h's sk_drift: baseline tracking and creep of scans with a time (0s: none)."""

    _fields_ = [(name, _double) for name in (
        'track_s', 'creep_per_decade', 'settle_s', 'recovery_s')]


class Settings(ctypes.Structure):
    """skin_kernel.h's sk_settings: everything a kernel is built with but the taxel arrays."""

    _fields_ = ([(name, _int) for name in (
        'rows', 'cols', 'max_contacts', 'method', 'remove_crosstalk', 'fill_dead', 'full_scale',
        'tared')]
        + [(name, _double) for name in (
            'pitch_m', 'compliance_m_per_n', 'min_force_n', 'min_confidence', 'min_shift_m',
            'force_scale', 'fill_factor', 'x_p_m', 'y_p_m', 'slope_x_m_per_n', 'slope_y_m_per_n',
            'zero_ref_n', 'calibration_var')]
        + [('curves', Curve * 2), ('model', TaxelModelNumbers), ('direction', Direction),
           ('drift', DriftNumbers)])


class ContactRecord(ctypes.Structure):
    """skin_kernel.h's sk_contact: one contact of a scan."""

    _fields_ = ([(name, _double) for name in (
        'x_m', 'y_m', 'force_n', 'area_m2', 'shift_x_m', 'shift_y_m', 'azimuth_rad',
        'azimuth_sigma_rad', 'alpha_rad', 'force_x_n', 'force_y_n', 'force_z_n', 'confidence',
        'dx', 'dy', 'sigma', 'top_force_n', 'bottom_force_n', 'shift_confidence')]
        + [(name, _int) for name in ('valid', 'kept', 'index', 'censored')]
        + [('held_s', _double)])


class Status(ctypes.Structure):
    """skin_kernel.h's sk_status: what a scan found besides its contacts."""

    _fields_ = [('found', _int), ('censored', _int), ('revived', _int),
                ('drift_mean', _double * 2), ('drift_max', _double * 2)]


# skin_kernel.h's sk_shift_fn: (user, window, h, w, shift out) -> 0, or anything else: none.
_SHIFT_FN = ctypes.CFUNCTYPE(_int, ctypes.c_void_p, ctypes.POINTER(_double), _int, _int,
                             ctypes.POINTER(_double))


class _Field(ctypes.Structure):
    _fields_ = [('type', ctypes.c_char_p), ('field', ctypes.c_char_p),
                ('offset', ctypes.c_ulong), ('size', ctypes.c_ulong)]


_MIRRORS = {'sk_taxel_model': TaxelModelNumbers, 'sk_curve': Curve, 'sk_direction': Direction,
            'sk_drift': DriftNumbers, 'sk_settings': Settings,
            'sk_contact': ContactRecord, 'sk_status': Status}

# One contact as Python reads it: a record's fields by name (numpy's view of the C struct).
_RECORD_DTYPE = np.dtype(ContactRecord)
Record = namedtuple('Record', _RECORD_DTYPE.names)


def _check_layout(lib: ctypes.CDLL, path: str) -> None:
    """Raise KernelMismatch unless the library's ABI and struct layouts are the mirrors'."""
    table = ctypes.POINTER(_Field)()
    abi = _int()
    count = lib.sk_layout(ctypes.byref(table), ctypes.byref(abi))
    if abi.value != ABI_VERSION:
        raise KernelMismatch(f'skin_kernel: {path} has ABI {abi.value}, this skin_driver needs '
                             f'{ABI_VERSION}; {_FIX}')
    theirs = {}
    for i in range(count):
        entry = table[i]
        field = None if entry.field is None else entry.field.decode()
        theirs[(entry.type.decode(), field)] = (entry.offset, entry.size)
    ours = {}
    for type_name, mirror in _MIRRORS.items():
        ours[(type_name, None)] = (0, ctypes.sizeof(mirror))
        for name, _ in mirror._fields_:
            described = getattr(mirror, name)
            ours[(type_name, name)] = (described.offset, described.size)
    differ = sorted(f'{t}.{f or "sizeof"}: library {theirs.get(key)}, binding {ours.get(key)}'
                    for key in set(ours) | set(theirs) if ours.get(key) != theirs.get(key)
                    for t, f in [key])
    if differ:
        raise KernelMismatch(f'skin_kernel: {path} lays its structs out otherwise than this '
                             f'binding (offset, size): {"; ".join(differ)}; {_FIX}')


def library_candidates() -> list:
    """Return the places the kernel is looked for, in order, as (where, path or None)."""
    return library_places('skin_kernel', LIBRARY, LIBRARY_VARIABLE)


@lru_cache(maxsize=1)
def load_library() -> ctypes.CDLL:
    """Return the loaded ``libskin_kernel.so.<ABI>``, its layout checked and signatures set."""
    lib, path = open_library(library_candidates(), 'skin_kernel', LIBRARY, _FIX, KernelMissing)
    _sign(lib)
    _check_layout(lib, str(path))
    return lib


def _sign(lib: ctypes.CDLL) -> None:
    """Set the argument and result types of the library's functions."""
    ptr, ulong = ctypes.c_void_p, ctypes.c_ulong
    # sk_scan and sk_scan_counts (kernel, maps, time, every_contact, out, status) have no argtypes:
    # a Kernel passes the same c_void_p objects, a c_double and a Python int every time, and a
    # scan is where their checks would cost.
    signatures = {'sk_layout': (_int, [ptr, ptr]), 'sk_abi_version': (_int, []),
                  'sk_new': (_int, [ptr, ulong] + [ptr] * 6 + [ptr, ctypes.c_char_p, ulong]),
                  'sk_free': (None, [ptr]),
                  'sk_scan': (_int, None), 'sk_scan_counts': (_int, None),
                  'sk_scan_shifted': (_int, [ptr, ptr, _int, _SHIFT_FN, ptr, ptr, ptr]),
                  'sk_dead': (None, [ptr, ptr]),
                  'sk_condition': (_int, [ptr, ptr, ptr, ptr, ptr, ptr]),
                  'sk_force': (_int, [ptr, ptr, ptr, ptr]),
                  'sk_carry': (_int, [ptr, ptr]),
                  'sk_model_fit': (_int, [ptr, _int, _int, ptr, ptr, ptr, ptr, _int, ptr, ptr]),
                  'sk_direction_features': (None, [_int] + [ptr] * 5 + [_double, ptr]),
                  'sk_creep': (None, [ptr, _int, ptr, _int, ptr]),
                  'sk_model_render': (_int, [ptr, _int, _int, ptr, _int, ptr, ptr]),
                  'sk_model_residuals': (_int, [ptr, _int, _int, ptr, ptr, ptr, ptr, _int, ptr,
                                                ptr]),
                  'sk_model_fit_free': (_int, [ptr, _int, _int, ptr, ptr, ptr, ptr, ptr, _int,
                                               ptr, ptr]),
                  'sk_model_sub': (_int, [ptr]),
                  'sk_model_start': (None, [ptr, ptr, _int, _int, ptr]),
                  'sk_model_steps': (None, [ptr, ptr, ptr])}
    for name, (restype, argtypes) in signatures.items():
        function = getattr(lib, name, None)
        if function is None:
            raise KernelMismatch(f'skin_kernel: the library has no {name}; {_FIX}')
        function.restype = restype
        if argtypes is not None:
            function.argtypes = argtypes


class KernelSettings(NamedTuple):
    """Everything a kernel copies from an estimator, as a :class:`Settings` and arrays."""

    settings: Settings    # rows, cols, full_scale, tared and the method are filled in by Kernel
    method: str
    baseline: np.ndarray  # (2, rows, cols) each, like threshold, noise, gain (or None), dead
    threshold: np.ndarray
    noise: np.ndarray
    gain: np.ndarray
    dead: np.ndarray
    tables: np.ndarray    # (2, full_scale + 1): each layer's force at every count
    tared: bool           # conditioning.ConditioningState.tared


class Conditioned(NamedTuple):
    """One scan's conditioning as the kernel does it (:meth:`Kernel.condition`)."""

    counts: np.ndarray     # (2, rows, cols) tared: crosstalk out, clipped levelled, dead filled
    force: np.ndarray      # (2, rows, cols) each taxel's force, N
    clipped: np.ndarray    # (2, rows, cols) bool: the raw count at the ADC's full scale
    crosstalk: np.ndarray  # (2, rows + cols): each line's crosstalk taken off, share of its load


def _address(array: np.ndarray) -> ctypes.c_void_p:
    return ctypes.c_void_p(array.ctypes.data)


class Kernel:
    """
    One estimator's compiled state and buffers; its owner thread runs the scans, one at a time.

    The kernel is the estimation's one piece of mutable state: the dead-taxel marks its scans
    revive, the drift followed and the time under load. The thread that runs the scans owns it
    and alone enters it (:meth:`scan`, :meth:`condition`, :meth:`carry_from`, ...); any
    thread reads the snapshots the owner publishes (:meth:`dead_masks`, :attr:`drift`,
    :attr:`timed_scans`) and :meth:`force`, which reads only what never changes.
    """

    # What only the owner enters: with the owner check on, each is wrapped by _owned.
    _ENTERED = ('scan', 'scan_shifted', 'condition', 'carry_from', '_entered')

    def __init__(self, spec: KernelSettings, check_owner: bool = None):
        """
        Copy ``spec`` into a new compiled kernel (raises KernelMissing without one).

        ``check_owner``: refuse a thread other than the owner (None: as ``CHECK_VARIABLE``
        says). The thread that makes a kernel is not its owner: the first to enter it is.
        """
        lib = load_library()
        rows, cols = spec.baseline.shape[1:]
        settings = Settings.from_buffer_copy(spec.settings)
        if spec.method not in METHODS:
            raise ValueError(f'skin_kernel: no compiled shift method {spec.method!r} '
                             f'(compiled: {", ".join(METHODS)})')
        settings.rows, settings.cols = rows, cols
        settings.full_scale = spec.tables.shape[1] - 1
        settings.method = METHODS[spec.method]
        settings.tared = bool(spec.tared)
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (
            spec.baseline, spec.threshold, spec.noise)]
        gain = (None if spec.gain is None
                else np.ascontiguousarray(spec.gain, dtype=np.float64))
        dead = np.ascontiguousarray(spec.dead, dtype=np.uint8)
        tables = np.ascontiguousarray(spec.tables, dtype=np.float64)
        handle = ctypes.c_void_p()
        message = ctypes.create_string_buffer(256)
        status = lib.sk_new(ctypes.byref(settings), ctypes.sizeof(Settings),
                            *(_address(a) for a in arrays),
                            None if gain is None else _address(gain), _address(dead),
                            _address(tables), ctypes.byref(handle), message, len(message))
        if status == _NO_MEMORY:
            raise MemoryError(f'skin_kernel: {message.value.decode()}')
        if status != _OK or not handle:
            raise ValueError(f'skin_kernel refused the settings: {message.value.decode()}')
        self._lib = lib
        self._handle = handle
        weakref.finalize(self, lib.sk_free, self._handle)
        self.shape = (rows, cols)
        # A scan's maps: float64 (sk_scan), or uint16 counts as they come (sk_scan_counts).
        self._maps = np.zeros((2, rows, cols))
        self._counts = np.zeros((2, rows, cols), dtype=np.uint16)
        self._out = np.zeros(max(min(settings.max_contacts, rows * cols), 1),
                             dtype=_RECORD_DTYPE)
        self._status = Status()
        outputs = (_address(self._out), ctypes.c_void_p(ctypes.addressof(self._status)))
        # By whether the maps are uint16 counts: the function, its top and bottom buffers, and
        # its arguments before and after the scan's time.
        self._scans = tuple((scan, maps[0], maps[1], (self._handle, _address(maps)), outputs)
                            for scan, maps in ((lib.sk_scan, self._maps),
                                               (lib.sk_scan_counts, self._counts)))
        # Published by the owner, each replaced whole (never changed): the dead marks, and the
        # last timed scan's drift (sk_status) and how many timed scans the drift state saw.
        self._dead_seen = dead.astype(bool)
        self._drift_seen = Status()
        self.timed_scans = 0
        self._owner = self._owner_name = None
        if check_owner is None:
            check_owner = os.environ.get(CHECK_VARIABLE, '') not in ('', '0')
        if check_owner:
            # Instance attributes before the class's methods: unchecked kernels pay nothing.
            for name in self._ENTERED:
                setattr(self, name, self._owned(name, getattr(self, name)))

    def _owned(self, name: str, method):
        """Return ``method`` refusing every thread but the owner (the first to enter)."""
        def entered(*args, **kwargs):
            me = threading.get_ident()
            if self._owner is None:
                self.claim()
            elif self._owner != me:
                refusal = (f'skin_kernel: thread {threading.current_thread().name!r} entered '
                           f'a kernel (Kernel.{name}) that thread {self._owner_name!r} owns')
                _BREACHES.append(refusal)
                raise NotTheOwner(refusal)
            return method(*args, **kwargs)
        return entered

    def claim(self) -> None:
        """
        Make the calling thread the owner: the hand-over of a kernel from one thread to another.

        The caller makes sure the old owner has left it (the scans' thread changes only between
        two scans).
        """
        self._owner = threading.get_ident()
        self._owner_name = threading.current_thread().name

    def _checked(self, top, bottom) -> tuple:
        """Return (whether both are uint16 counts, top, bottom), checked as a scan needs."""
        if not (type(top) is np.ndarray and type(bottom) is np.ndarray
                and top.shape == self.shape and bottom.shape == self.shape):
            top, bottom = check_pair(top, bottom, self.shape)
        counts = top.dtype == _COUNTS and bottom.dtype == _COUNTS
        if not (counts or top.dtype.kind in 'uif' and bottom.dtype.kind in 'uif'):
            top, bottom = check_pair(top, bottom, self.shape)
        return counts, top, bottom

    def scan(self, top, bottom, every_contact: bool = False, time_s: float = None) -> list:
        """
        Return the :class:`Record` of each contact in the raw maps, strongest first.

        Without ``every_contact`` a contact too light to report (``kept`` 0) gets no shift. Dead
        taxels that read a touch are revived in the kernel. ``time_s``, the scan's time in
        seconds (any origin, never going back), lets baselines follow drift and forces lose
        their creep (the settings' ``drift``); None: nothing tracked. Bad maps raise ValueError
        saying what is wrong.
        """
        counts, top, bottom = self._checked(top, bottom)
        scan, top_buffer, bottom_buffer, (handle, maps), (out, status) = self._scans[counts]
        top_buffer[...] = top
        bottom_buffer[...] = bottom
        clock = _NO_TIME if time_s is None else _double(time_s)
        count = scan(handle, maps, clock, int(every_contact), out, status)
        if count < 0:
            check_pair(top, bottom, self.shape)
            raise ValueError('top or bottom holds a value that is not a count')
        if time_s is not None:
            self._drift_seen = Status.from_buffer_copy(self._status)
            self.timed_scans += 1
        if self._status.revived:
            self._publish_dead()
        return list(map(Record._make, self._out[:count].tolist()))

    def scan_shifted(self, top, bottom, shift, every_contact: bool = False) -> list:
        """
        Return :meth:`scan`'s records with each contact's shift from ``shift``, not the kernel's.

        ``shift(window)`` takes a contact's (2, h, w) tared counts and returns (dx, dy,
        confidence) in taxels, or None for no shift: a reference estimator in the kernel's
        pipeline. What it raises is raised here.
        """
        _, top, bottom = self._checked(top, bottom)
        raised = []

        def given(_user, window, h, w, out):
            try:
                found = shift(np.ctypeslib.as_array(window, (2, h, w)).copy())
                if found is None:
                    return 1
                out[0], out[1], out[2] = (float(v) for v in found[:3])
                return 0
            except BaseException as err:  # noqa: B902 - raised again after the call
                raised.append(err)
                return 1

        self._maps[0] = top
        self._maps[1] = bottom
        count = self._lib.sk_scan_shifted(self._handle, _address(self._maps), int(every_contact),
                                          _SHIFT_FN(given), None, _address(self._out),
                                          ctypes.byref(self._status))
        if raised:
            raise raised[0]
        if count < 0:
            check_pair(top, bottom, self.shape)
            raise ValueError('top or bottom holds a value that is not a count')
        if self._status.revived:
            self._publish_dead()
        return list(map(Record._make, self._out[:count].tolist()))

    def condition(self, top, bottom) -> Conditioned:
        """
        Return the conditioning of the raw maps as a scan does it (:class:`Conditioned`).

        ``crosstalk`` holds each layer's rows, then its columns: 0 on a line that gave none, and
        everywhere on a scan whose lines were left as they were. Dead taxels that read a touch
        are revived, as by :meth:`scan`.
        """
        _, top, bottom = self._checked(top, bottom)
        layers = (2,) + self.shape
        out = Conditioned(np.zeros(layers), np.zeros(layers), np.zeros(layers, dtype=np.uint8),
                          np.zeros((2, sum(self.shape))))
        self._maps[0] = top
        self._maps[1] = bottom
        status = self._lib.sk_condition(self._handle, _address(self._maps),
                                        *(_address(a) for a in out))
        if status != _OK:
            check_pair(top, bottom, self.shape)
            raise ValueError('top or bottom holds a value that is not a count')
        self._publish_dead()
        return out._replace(clipped=out.clipped.astype(bool))

    def force(self, counts, clipped=None) -> np.ndarray:
        """
        Return each taxel's force of tared ``counts``, (2, rows, cols), as a scan reads it.

        In newtons, the gains applied. A count at or below 0 has none; a taxel ``clipped`` marks
        (bool, same shape; None: none) reads the force at the ADC's full scale. Counts that are
        not numbers raise ValueError. Any thread: it reads only what the kernel was made with.
        """
        counts = np.ascontiguousarray(counts, dtype=np.float64)
        if counts.shape != (2,) + self.shape:
            raise ValueError(f'counts have shape {counts.shape}, the kernel takes '
                             f'{(2,) + self.shape}')
        marks = None
        if clipped is not None:
            marks = np.ascontiguousarray(np.broadcast_to(clipped, counts.shape), dtype=np.uint8)
        force = np.zeros(counts.shape)
        status = self._lib.sk_force(self._handle, _address(counts),
                                    None if marks is None else _address(marks), _address(force))
        if status != _OK:
            raise ValueError('counts hold a value that is not a number')
        return force

    @property
    def drift(self) -> tuple:
        """Return the last timed scan's (mean, largest |drift|) of each layer, in counts."""
        seen = self._drift_seen  # the one read: published whole by the owner
        return (tuple(seen.drift_mean), tuple(seen.drift_max))

    def carry_from(self, other: 'Kernel') -> None:
        """
        Put ``other``'s per-scan state in force here (``sk_carry``): the owner's, at the swap.

        ``other`` is the kernel of the same skin and tare this one replaces: its dead marks,
        drift followed, time under load and count of timed scans (:attr:`timed_scans`) go on
        here, whatever this one was built with. The owner calls it between two scans (it enters
        both). Of another grid raises ValueError, nothing carried.
        """
        if self._lib.sk_carry(self._handle, other._entered()) != _OK:
            raise ValueError(f'the per-scan state of a {other.shape} kernel for a {self.shape} '
                             'one')
        self.timed_scans = other.timed_scans
        self._drift_seen = other._drift_seen
        self._publish_dead()

    def _entered(self) -> ctypes.c_void_p:
        """Return the handle, to a call that enters this kernel from another (the owner's)."""
        return self._handle

    def _publish_dead(self) -> None:
        """Publish the dead marks as they are now (the owner's, after a scan revived one)."""
        out = np.zeros((2,) + self.shape, dtype=np.uint8)
        self._lib.sk_dead(self._handle, _address(out))
        self._dead_seen = out.astype(bool)

    def dead_masks(self) -> np.ndarray:
        """Return the dead-taxel marks the owner published last, (2, rows, cols) bool (a copy)."""
        return self._dead_seen.copy()


def taxel_model_of(model) -> TaxelModelNumbers:
    """Return a :class:`taxelmodel.TaxelModel` as skin_kernel.h's sk_taxel_model (0s: none)."""
    if model is None:
        return TaxelModelNumbers()
    return TaxelModelNumbers(
        pitch_m=model.pitch_m, fill_factor=model.fill_factor,
        cover_spread_m=model.cover_spread_m, layer_spread_m=model.layer_spread_m,
        film_scale=model.film_scale, film_exponent=model.film_exponent,
        film_ceiling=model.film_ceiling, film_activation_n=model.film_activation_n,
        turn_on_pa=model.turn_on_pa, film_step=model.film_step, full_scale=model.full_scale)


def direction_of(correction) -> Direction:
    """Return a :class:`direction.DirectionCorrection` as skin_kernel.h's sk_direction."""
    if correction is None or not correction.kept:
        return Direction()
    return Direction(on=1, force_ref_n=correction.force_ref_n,
                     weight_x=(_double * DIRECTION_FEATURES)(*correction.weight_x),
                     weight_y=(_double * DIRECTION_FEATURES)(*correction.weight_y))


def fit_contact(model, counts: np.ndarray, censored: np.ndarray, u0: np.ndarray,
                iterations: int = 10, sensitivity: np.ndarray = None):
    """
    Return the forward model's least-misfit fit of one contact (``sk_model_fit``), a PressFit.

    ``counts``: the window's (2, h, w) tared counts; ``censored``: taxels whose reading is a
    lower bound (bool, same shape, or None), which count only where the model reads below
    them; ``u0``: the start (:func:`taxelmodel.start_of`); ``sensitivity``: the window's
    per-taxel load factors (:func:`taxelmodel.render_counts`) or None. A round tip first, then
    an elliptical one from four orientations (:mod:`taxelmodel`). ``model`` is a
    :class:`taxelmodel.TaxelModel`; raises KernelMissing without the kernel.
    """
    from ..model.taxelmodel import PressFit
    lib = load_library()
    counts = np.ascontiguousarray(counts, dtype=np.float64)
    rows, cols = counts.shape[1:]
    numbers = taxel_model_of(model)
    marks = (None if censored is None
             else np.ascontiguousarray(np.broadcast_to(censored, counts.shape), dtype=np.uint8))
    factors = (None if sensitivity is None
               else np.ascontiguousarray(np.broadcast_to(sensitivity, counts.shape),
                                         dtype=np.float64))
    start = np.ascontiguousarray(u0, dtype=np.float64)
    u = np.zeros(8)
    misfit = np.zeros(1)
    status = lib.sk_model_fit(ctypes.byref(numbers), rows, cols, _address(counts),
                              None if marks is None else _address(marks),
                              None if factors is None else _address(factors), _address(start),
                              int(iterations), _address(u), _address(misfit))
    if status != _OK:
        raise MemoryError(f'skin_kernel: no memory to fit a {rows} x {cols} window')
    return PressFit(u, float(misfit[0]))


def direction_features(col, row, dx, dy, force_n, force_ref_n: float) -> np.ndarray:
    """
    Return the direction correction's features of contacts, (N, DIRECTION_FEATURES).

    ``sk_direction_features``: the features a scan applies a correction's weights to. Arguments
    are arrays (or numbers, broadcast) of the contacts' places and raw shifts (taxels) and
    normal forces; ``force_ref_n`` (> 0) is what the force feature is taken relative to.
    """
    lib = load_library()
    columns = [np.ascontiguousarray(v, dtype=np.float64).ravel() for v in np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in (col, row, dx, dy, force_n)))]
    n = columns[0].size
    out = np.zeros((n, DIRECTION_FEATURES))
    lib.sk_direction_features(n, *(_address(c) for c in columns), float(force_ref_n),
                              _address(out))
    return out


def creep(drift: DriftNumbers, age_s, relative_to_1s: bool = False) -> np.ndarray:
    """
    Return the creep law's rise of readings held ``age_s`` under load (``sk_creep``).

    ``1 + creep_per_decade * log10(1 + age / settle_s)`` of ``drift`` (a :class:`DriftNumbers`)
    at each age (an array or a number; negative: 0), shaped like ``age_s``; with
    ``relative_to_1s``, over its value at 1 s: what a scan divides a loaded taxel's force by.
    """
    lib = load_library()
    ages = np.array(age_s, dtype=np.float64)  # a copy, C-ordered, 0-d for a number
    out = np.zeros(ages.shape)
    lib.sk_creep(ctypes.byref(drift), ages.size, _address(ages), int(relative_to_1s),
                 _address(out))
    return out
