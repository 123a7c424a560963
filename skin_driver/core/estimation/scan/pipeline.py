"""
The contact estimation pipeline used by the ROS nodes, the evaluator and the benchmark.

raw counts (top, bottom) -> conditioning (tare, threshold, FSR model -> force per taxel)
-> contacts (each top imprint paired with its share of the bottom load)
-> shift between the layers in each contact's window (a method named in :mod:`..shift.methods`)
-> calibrated shift ``s = raw - (x_p, y_p)`` -> azimuth ``atan2(s_y, s_x)``
-> tangential force ``|s| / compliance`` -> polar angle and 3-D force.

Geometry and force: contacts, their windows and the shift are measured on the tared counts (the
sensor's own readings, whatever its FSR curve); the force maps only give the contacts' forces.

Uncertainty, from the contact's own data (the kernel's uncertainty.c): ``sigma`` (taxels, one
axis of the shift) gives ``azimuth_sigma = atan2(sigma, |s|)``; a shift shorter than
``MIN_SNR`` sigmas is within the noise and carries no direction.

All of the above runs in the compiled kernel (package ``skin_kernel``, :mod:`kernel`), one call
per scan, for every registered method; a reference shift (``shift=``, the benchmark's) replaces
only the shift of each contact inside the kernel's pipeline.

Normal force: the taxels sense only ``fill_factor**2`` of the skin area, so the summed taxel
forces of a contact are divided by it. The bottom layer's sum is used because the elastic layer
spreads the pressure over several taxels, which makes the sensed share independent of where the
contact sits (within 1 % in simulation); the top layer's share varies by +-5 % with the sub-taxel
position of a small indenter. At the map edge, where the wider bottom imprint is cut first, the
larger of the two sums is used when the bottom imprint's strongest line is the edge line (its
centre on or past the edge: a real part of it is cut off); an imprint that reaches the edge only
with its rim keeps the bottom sum, since the top sum's wider press-to-press scatter would
otherwise win the larger of the two there and read high (on a film that turns on at a
pressure, docs/estimation.md).

Skin frame: x along columns, y along rows, z out of the skin. Pressing into the skin is a force
along -z, so ``force_xyz_n[2] = -force_n`` (``force_n`` is the normal magnitude, >= 0). The
tangential components point along the azimuth, the direction in which the top layer is pushed.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
import threading

import numpy as np

from . import kernel as compiled_kernel
from .conditioning import Conditioning
from ..calibration.calibration import Calibration
from ..model.fsr import FsrModel
from ..shift.methods import DEFAULT_METHOD, get_method, Method
from ...common.validate import check_int, check_number, check_pair

__all__ = ['EstimatorConfig', 'Contact', 'ContactEstimator']


@dataclass(frozen=True)
class EstimatorConfig:
    """
    Parameters of the pipeline (SI units).

    ``min_confidence``: estimates below it get ``direction_valid = False``.
    ``min_shift_m``: a calibrated shift shorter than this is no shear (alpha = 0, no direction).
    ``compliance_m_per_n``: layer shift per tangential newton, used when the calibration has none.
    ``force_scale``: extra factor on the normal force (a user's force calibration; 1 = none).
    ``fill_factor``: sensitive fraction of the pitch on each axis; normal force = summed taxel
    forces / fill_factor**2.
    The conditioning of each scan (:mod:`.conditioning`): ``threshold_counts``, the least
    reading above baseline that counts as touch, raised by a tare to ``noise_sigmas`` times a
    taxel's measured noise where that is larger; ``fsr``, the force curve assumed until a force
    calibration fits one; ``fill_dead`` fills dead taxels from their live neighbours (else they
    read 0); ``remove_crosstalk`` takes the load that leaks along the rows and columns of a
    passive matrix out of every scan (the kernel's crosstalk.c).
    Scans given their time (:meth:`ContactEstimator.process`'s ``time_s``): ``track_s``, the time
    constant with which untouched taxels' baselines follow their drift (0: none); the creep
    model a loaded taxel's force is corrected by, ``creep_per_decade`` (0: none),
    ``creep_settle_s``, ``creep_recovery_s`` (defaults: the simulated family's middle; a
    calibration's creep, :mod:`..calibration.creep`, replaces them).
    """

    method: str = DEFAULT_METHOD
    pitch_m: float = 0.005
    compliance_m_per_n: float = 7.0e-4
    threshold_counts: float = 40.0
    noise_sigmas: float = 5.0
    min_contact_force_n: float = 0.2
    min_confidence: float = 0.3
    min_shift_m: float = 2.5e-4
    max_contacts: int = 32
    force_scale: float = 1.0
    fsr: FsrModel = field(default_factory=FsrModel)
    fill_factor: float = 0.9
    fill_dead: bool = True
    remove_crosstalk: bool = True
    track_s: float = 60.0
    creep_per_decade: float = 0.025
    creep_settle_s: float = 1.0
    creep_recovery_s: float = 60.0

    def __post_init__(self):
        """Validate every field and the method name."""
        get_method(self.method)
        check_number(self.pitch_m, 'pitch_m', positive=True)
        check_number(self.compliance_m_per_n, 'compliance_m_per_n', positive=True)
        check_number(self.threshold_counts, 'threshold_counts', non_negative=True)
        check_number(self.noise_sigmas, 'noise_sigmas', non_negative=True)
        check_number(self.min_contact_force_n, 'min_contact_force_n', non_negative=True)
        check_number(self.min_confidence, 'min_confidence', low=0.0, high=1.0)
        check_number(self.min_shift_m, 'min_shift_m', non_negative=True)
        check_number(self.force_scale, 'force_scale', positive=True)
        check_number(self.fill_factor, 'fill_factor', low=0.05, high=1.0)
        check_int(self.max_contacts, 'max_contacts', low=0)
        check_number(self.track_s, 'track_s', non_negative=True)
        check_number(self.creep_per_decade, 'creep_per_decade', non_negative=True)
        check_number(self.creep_settle_s, 'creep_settle_s', positive=True)
        check_number(self.creep_recovery_s, 'creep_recovery_s', positive=True)


@dataclass(frozen=True)
class Contact:
    """
    One contact in the skin frame (SI units); never holds NaN or inf.

    ``shift_m`` is the calibrated layer shift; ``azimuth_rad`` (in (-pi, pi]) and the tangential
    part of ``force_xyz_n`` are meaningful only when ``direction_valid``; otherwise they are 0 and
    ``alpha_rad`` is 0. ``azimuth_sigma_rad`` is the 1-sigma uncertainty of the azimuth (pi when
    there is no direction). ``held_s`` is how long its taxels have been under load (scans
    given their time; 0 otherwise).
    """

    x_m: float
    y_m: float
    force_n: float
    area_m2: float
    shift_m: tuple
    azimuth_rad: float
    azimuth_sigma_rad: float
    alpha_rad: float
    force_xyz_n: tuple
    confidence: float
    direction_valid: bool
    held_s: float = 0.0


class ContactEstimator:
    """
    Estimate contacts (location, force, direction) from raw top and bottom count maps.

    Every scan is one call of the compiled kernel (:mod:`kernel`).

    An estimator does not change once made: its config, calibration and tare are fixed, and a
    change (``with_*``) makes a new one, which a live host swaps in whole. The mutable state is
    the kernel's alone: the dead-taxel marks that its scans revive and, for scans given their
    time, the drift followed and the time under load; the swap carries it into the new
    estimator's kernel (:meth:`carry_from`). It belongs to the thread that runs the scans
    (:meth:`process`, :meth:`measure_shifts`, :meth:`carry_from`), which alone enters the
    kernel and takes no lock; other threads read the snapshots it publishes after each scan
    (:meth:`dead_masks`, :meth:`drift`, :attr:`conditioning`, :attr:`timed_scans`) or
    condition maps on a kernel of their own (:meth:`maps_of`, :meth:`conditioning_kernel`). A
    kernel is built when the estimator is made if the maps' shape is known then (a tare or
    gains fix it), else by :meth:`ready_for` or the first scan of each new shape: readers find
    it in a dict that is replaced, never changed, so a scan takes no lock to look it up.
    """

    def __init__(self, config: EstimatorConfig = None, calibration: Calibration = None,
                 conditioning: Conditioning = None, shift: Method = None):
        """
        Create the pipeline; ``conditioning`` may carry a tare (it is copied, never shared).

        ``shift`` replaces the configured shift method by one that is not registered (the
        benchmark's references): it runs on each contact's counts window, or once on the whole
        maps (``whole_map``), inside the kernel's pipeline. A missing kernel raises
        :class:`kernel.KernelMissing`.
        """
        self.config = config or EstimatorConfig()
        conditioning = (Conditioning(self.config) if conditioning is None
                        else conditioning.copy(self.config))
        self._calibration = calibration or Calibration()
        conditioning.set_force_curves(*(self._calibration.force_curves or (None, None)))
        top, bottom = self._calibration.gain_maps()
        if top is not None or conditioning.shape is not None:
            conditioning.set_gain(top, bottom)
        # Never changed after this: snapshots and kernels are made from it.
        self._conditioning = conditioning
        self._shift = shift
        self._method = shift or get_method(self.config.method)
        if shift is not None and (shift.linear or shift.modelled or shift.function is None):
            raise ValueError(f'a reference shift takes the counts window alone: {shift.name} '
                             'wants force maps or a taxel model')
        self._kernels = {}
        self._build_lock = threading.Lock()
        # A missing kernel stops the estimator's maker (a node at start-up), not a scan.
        compiled_kernel.load_library()
        if conditioning.shape is not None:
            self._kernels = {conditioning.shape: self._new_kernel(conditioning.shape)}
        self._viewer = None
        self._viewer_lock = threading.Lock()
        # Which tare this estimator's baselines and dead marks come from: a tare starts them
        # afresh, any other change carries them (carry_from).
        self._tare_epoch = object()

    def _same_tare(self, made: 'ContactEstimator') -> 'ContactEstimator':
        """Return ``made`` (from this estimator, its tare kept) marked as of this tare."""
        made._tare_epoch = self._tare_epoch
        return made

    @property
    def calibration(self) -> Calibration:
        """Return the calibration in force."""
        return self._calibration

    @property
    def conditioning(self) -> Conditioning:
        """
        Return a snapshot of the conditioning: tare, gains, curves, the dead marks in force now.

        A copy: changing it changes nothing here. Read it once for a consistent view. Its dead
        marks are those the kernel published last; a new estimator built from it starts from
        them, and takes the kernel's own over when it is swapped in (:meth:`carry_from`).
        """
        snapshot = self._conditioning.copy()
        top, bottom = self.dead_masks()
        if top is not None:
            snapshot.set_dead(top, bottom)
        return snapshot

    def dead_masks(self) -> tuple:
        """
        Return the (top, bottom) dead-taxel marks in force now (None, None: no kernel yet).

        The kernel's, as its owner published them after its last scan: the one copy that lives.
        """
        shape = self._conditioning.shape
        kernels = self._kernels
        kernel = kernels.get(shape) if shape is not None else (
            next(iter(kernels.values())) if len(kernels) == 1 else None)
        if kernel is None:
            return None, None
        dead = kernel.dead_masks()
        return dead[0], dead[1]

    def with_calibration(self, calibration: Calibration) -> 'ContactEstimator':
        """Return this estimator with ``calibration`` (force curves and gains too) in force."""
        return self._same_tare(ContactEstimator(self.config, calibration, self.conditioning,
                                                self._shift))

    def for_grid(self, rows: int, cols: int) -> 'ContactEstimator':
        """
        Return this estimator for scans of ``rows`` x ``cols`` taxels.

        Itself when its tare and gains are of that grid or of none; else one without them (a
        tare or gains of another grid say nothing of this one), its settings and the rest of
        its calibration kept, so the skin it has is estimated rather than every scan refused.
        """
        shape = self._conditioning.shape
        if shape is None or shape == (rows, cols):
            return self
        calibration = self._calibration
        gains = calibration.gain_maps()[0]
        if gains is not None and gains.shape != (rows, cols):
            calibration = replace(calibration, gains=None)
        return ContactEstimator(self.config, calibration, None, self._shift)

    def with_config(self, config: EstimatorConfig) -> 'ContactEstimator':
        """Return an estimator with other settings, keeping the tare and the calibration."""
        return self._same_tare(ContactEstimator(config, self._calibration, self.conditioning,
                                                self._shift))

    def with_tare(self, top_frames, bottom_frames) -> 'ContactEstimator':
        """Return this estimator tared from no-touch frames (N x rows x cols each)."""
        tared = self.conditioning
        tared.tare(top_frames, bottom_frames)
        return ContactEstimator(self.config, self._calibration, tared, self._shift)

    def maps_of(self, top_counts, bottom_counts) -> tuple:
        """
        Return the (top, bottom) force maps (N per taxel) of one scan, as the scans condition it.

        For the heatmaps of a thread that does not run the scans: it conditions on a kernel of
        its own (the dead marks the scanning one published when it was made), never on the
        scanning one. That kernel belongs to whichever thread holds its lock.
        """
        t, b = check_pair(top_counts, bottom_counts)
        with self._viewer_lock:
            viewer = self._viewer
            if viewer is None or viewer.shape != t.shape:
                # Untared, there are no marks, and no grid to hold the snapshot to.
                published = self.conditioning if self._conditioning.shape is not None else None
                viewer = self._viewer = self._new_kernel(t.shape, published)
            viewer.claim()
            force = viewer.condition(t, b).force
        return force[0], force[1]

    def conditioning_kernel(self, rows: int, cols: int) -> compiled_kernel.Kernel:
        """
        Return a new kernel of this estimator for ``rows`` x ``cols`` maps, its own to keep.

        For a thread that conditions scans apart from the scanning one (a calibration reads its
        presses' tared counts, clipped taxels, crosstalk and forces from it: the scans' own
        conditioning). Its dead marks are those in force now; the scanning kernel's are never
        touched.
        """
        return self._new_kernel((int(rows), int(cols)), self.conditioning)

    @property
    def every_scan(self) -> bool:
        """
        Return whether this estimator keeps up with a live skin's every scan.

        A method that is not (``Method.every_scan``) keeps up all the same while it has nothing
        to fit with (``model_fit`` without the calibration's taxel model is ``taxel_fit``).
        """
        return self._method.every_scan or (self._method.modelled
                                           and self._calibration.taxel_model is None)

    @property
    def compliance_m_per_n(self) -> float:
        """Return the compliance in use: the calibrated one, else the configured one."""
        return self.calibration.compliance_m_per_n or self.config.compliance_m_per_n

    def _calibration_variance(self) -> float:
        """
        Return the calibration's share of sigma**2 (taxels**2): the zero a new press meets.

        The normal presses' spread about the zero (``std_x_m``, ``std_y_m``) is what the zero is
        off by at another spot and force (sampling bias that follows the imprint's place and
        size), so a new press meets that spread as well as the zero's standard error.
        """
        cal = self.calibration
        if cal.presses <= 0:
            return 0.0
        pitch = self.config.pitch_m
        return ((cal.std_x_m ** 2 + cal.std_y_m ** 2) * (1.0 + 1.0 / cal.presses)
                / (2.0 * pitch * pitch))

    def measure_shifts(self, top_counts, bottom_counts) -> list:
        """
        Return the uncalibrated layer shifts (x, y) in metres of the contacts, strongest first.

        Use it on normal presses to feed :func:`calibration.calibrate_from_shifts`.
        """
        p = self.config.pitch_m
        return [(r.dx * p, r.dy * p)
                for r in self._scan(top_counts, bottom_counts, every_contact=True)]

    def process(self, top_counts, bottom_counts, time_s: float = None) -> list:
        """
        Return the contacts in the two raw count maps, strongest (normal force) first.

        ``time_s``: the scan's time (seconds, never going back), with which the baselines of
        untouched taxels follow their drift and loaded taxels lose their creep; None: neither.
        """
        return [_contact(r) for r in self._scan(top_counts, bottom_counts, time_s=time_s)
                if r.kept]

    def drift(self) -> tuple:
        """Return the last timed scan's (mean, largest |drift|) of each layer since the tare."""
        kernels = self._kernels
        shape = self._conditioning.shape
        kernel = kernels.get(shape) if shape is not None else (
            next(iter(kernels.values())) if len(kernels) == 1 else None)
        return kernel.drift if kernel is not None else ((0.0, 0.0), (0.0, 0.0))

    def creep_factor(self, held_s: float) -> float:
        """Return what the creep in force divides a taxel's force by after ``held_s`` loaded."""
        d = self._drift_numbers()
        if not d.creep_per_decade > 0:
            return 1.0
        return float(compiled_kernel.creep(d, held_s, relative_to_1s=True))

    def carry_from(self, other: 'ContactEstimator') -> 'ContactEstimator':
        """
        Return this estimator with ``other``'s per-scan state in force (the kernel's, whole).

        For a change of parameters or calibration of the same skin and tare, made off the hot
        path and put in force by the thread that runs the scans, which calls this between two
        scans (it enters both kernels): the dead marks as ``other``'s scans left them (a taxel
        revived after this estimator was built stays revived), how far the skin drifted and how
        long it has been loaded stay true, and no scan is lost from them. Of another grid or
        tare there is nothing to carry (a tare measures its dead marks and starts the time
        afresh).
        """
        if other is None or other is self or other._tare_epoch is not self._tare_epoch:
            return self
        # Each grid's kernel, tared or not (an untared estimator's is made for the scans' grid).
        theirs = other._kernels
        for shape, mine in self._kernels.items():
            if shape in theirs:
                mine.carry_from(theirs[shape])
        return self

    @property
    def timed_scans(self) -> int:
        """Return how many timed scans its drift state has seen since the tare (carried on)."""
        return sum(kernel.timed_scans for kernel in self._kernels.values())

    def claim(self) -> 'ContactEstimator':
        """
        Return this estimator, its kernels now the calling thread's (:meth:`kernel.Kernel.claim`).

        For a host whose scans move to another thread (a slow estimator's own, and back): the
        new thread claims them between two scans, once the old one has left them.
        """
        for kernel in self._kernels.values():
            kernel.claim()
        return self

    def _scan(self, top_counts, bottom_counts, every_contact: bool = False,
              time_s: float = None) -> list:
        """Return the compiled kernel's records of the contacts (kernel.Kernel.scan)."""
        kernel = self._kernels.get(np.shape(top_counts))
        if kernel is None:
            kernel = self._kernel_for(top_counts, bottom_counts)
        if self._shift is None:
            return kernel.scan(top_counts, bottom_counts, every_contact, time_s)
        return kernel.scan_shifted(top_counts, bottom_counts,
                                   self._reference(top_counts, bottom_counts), every_contact)

    def _reference(self, top_counts, bottom_counts):
        """Return the reference shift's function of a contact's counts window for one scan."""
        method = self._shift
        if method.whole_map:
            whole = method.function(np.stack(check_pair(top_counts, bottom_counts))
                                    .astype(np.float64))
            return lambda window: whole
        return method.function

    def ready_for(self, rows: int, cols: int) -> 'ContactEstimator':
        """
        Return this estimator with its kernel for ``rows`` x ``cols`` maps built now.

        A live host calls it where it makes the estimator, off the hot path, so that the first
        scan after a change builds nothing on the thread that reads the scans.
        """
        shape = (int(rows), int(cols))
        if shape not in self._kernels:
            with self._build_lock:
                if shape not in self._kernels:
                    self._kernels = {**self._kernels, shape: self._new_kernel(shape)}
        return self

    def _kernel_for(self, top_counts, bottom_counts) -> compiled_kernel.Kernel:
        """Return the kernel of the maps' shape, built by the first scan of that shape."""
        t, _ = check_pair(top_counts, bottom_counts)
        with self._build_lock:
            kernel = self._kernels.get(t.shape)
            if kernel is None:
                kernel = self._new_kernel(t.shape)
                # Replaced, never changed: a reader holds the old dict or the new one, whole.
                self._kernels = {**self._kernels, t.shape: kernel}
        return kernel

    def _new_kernel(self, shape: tuple,
                    conditioning: Conditioning = None) -> compiled_kernel.Kernel:
        """Return a new kernel for ``shape`` maps from ``conditioning`` (default: as made)."""
        conditioning = conditioning or self._conditioning
        if conditioning.shape is None:
            conditioning = conditioning.copy()  # state() fixes the shape: not on the original
        state = conditioning.state(shape)
        return compiled_kernel.Kernel(compiled_kernel.KernelSettings(
            self._kernel_settings(), self.config.method, *state))

    def _kernel_settings(self) -> compiled_kernel.Settings:
        """Return the kernel's settings of this estimator (the maps' shape filled in later)."""
        cfg, cal = self.config, self.calibration
        curves = [compiled_kernel.Curve(bump_power=2.0) if c is None else compiled_kernel.Curve(
            censor_counts=c.censor_counts, rim_load_n=c.rim_load_n,
            spread_taxels=c.spread_taxels, bump_power=c.bump_power,
            activation_n=c.activation_n) for c in (cal.force_curves or (None, None))]
        slope_x, slope_y = cal.zero_slope_m_per_n
        return compiled_kernel.Settings(
            max_contacts=cfg.max_contacts, remove_crosstalk=cfg.remove_crosstalk,
            fill_dead=cfg.fill_dead, pitch_m=cfg.pitch_m,
            compliance_m_per_n=self.compliance_m_per_n, min_force_n=cfg.min_contact_force_n,
            min_confidence=cfg.min_confidence, min_shift_m=cfg.min_shift_m,
            force_scale=cfg.force_scale, fill_factor=cfg.fill_factor, x_p_m=cal.x_p_m,
            y_p_m=cal.y_p_m, slope_x_m_per_n=slope_x, slope_y_m_per_n=slope_y,
            zero_ref_n=cal.zero_ref_n, calibration_var=self._calibration_variance(),
            curves=(compiled_kernel.Curve * 2)(*curves),
            model=compiled_kernel.taxel_model_of(cal.taxel_model),
            direction=compiled_kernel.direction_of(cal.direction),
            drift=self._drift_numbers())

    def _drift_numbers(self) -> compiled_kernel.DriftNumbers:
        """Return the kernel's tracking and creep: the calibration's creep, else the config's."""
        cfg = self.config
        creep = getattr(self.calibration, 'creep', None)
        rate, settle, recovery = ((creep.per_decade, creep.settle_s, creep.recovery_s)
                                  if creep is not None else
                                  (cfg.creep_per_decade, cfg.creep_settle_s,
                                   cfg.creep_recovery_s))
        return compiled_kernel.DriftNumbers(track_s=cfg.track_s, creep_per_decade=rate,
                                            settle_s=settle, recovery_s=recovery)


def _contact(r: compiled_kernel.Record) -> Contact:
    """Return the Contact of a compiled record."""
    # The frozen dataclass's __init__ sets each field through object.__setattr__; its __dict__
    # made at once is the same Contact for less than half the cost (a scan's Python share).
    contact = object.__new__(Contact)
    object.__setattr__(contact, '__dict__', {
        'x_m': r.x_m, 'y_m': r.y_m, 'force_n': r.force_n, 'area_m2': r.area_m2,
        'shift_m': (r.shift_x_m, r.shift_y_m), 'azimuth_rad': r.azimuth_rad,
        'azimuth_sigma_rad': r.azimuth_sigma_rad, 'alpha_rad': r.alpha_rad,
        'force_xyz_n': (r.force_x_n, r.force_y_n, r.force_z_n), 'confidence': r.confidence,
        'direction_valid': r.valid > 0, 'held_s': r.held_s})
    return contact
