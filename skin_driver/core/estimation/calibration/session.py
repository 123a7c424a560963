"""
A calibration session: presses in, a new calibration (or a clear refusal) out. ROS-free.

A front end (the direction node's services, the evaluator, a script) makes a session for one
kind of calibration, feeds it every scan with the contacts the estimator found (or whole presses
with :meth:`CalibrationSession.add_press`), and calls :meth:`finish` when :attr:`done`:

* ``offset``: presses straight down give ``(x_p, y_p)``; presses whose shift grows with their
  force are tilted and are ignored.
* ``force``: presses of known normal force (``forces_n``, one per press, in order) give each
  layer's counts-to-force curve (:mod:`forcecurve`).
* ``compliance``: presses of known force and polar angle (``forces_n`` and ``alphas_rad``, or a
  reference wrench fed with each scan) give the layer shift per tangential newton.
* ``gains``: a uniform load, or many presses spread over the skin, give the per-taxel gains
  (:mod:`gains` says what the user does).
* ``direction``: tilted presses of known azimuth (``azimuths_rad``, or a reference wrench fed
  with each scan), spread over the skin, give a correction of the shift that is kept only when
  it lowers the azimuth error on presses it did not learn from (:mod:`direction`).

:meth:`finish` returns the calibration in force with that part replaced; it never changes the
estimator. Putting the result in force, and storing it, is the front end's business, so a
refusal (:class:`CalibrationRefused`) leaves everything as it was.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Optional, Sequence

import numpy as np

from .calibration import calibrate_zero, Calibration, compliance_from_presses, SkinIdentity
from .direction import KnownPress, learn_direction, MIN_DIRECTION_PRESSES
from .forcefit import check_known_forces, fit_force_curve
from .gains import gains_from_force_sums, limits_note, without_crosstalk
from .presses import PressSegmenter
from .rendered import render_known_presses
from .taxellearn import film_start, learn_taxel_model, LearningPress
from ..shift.methods import get_method

__all__ = ['KINDS', 'PressRecord', 'Outcome', 'CalibrationRefused', 'CalibrationSession',
           'crosstalk_share_of']

KINDS = ('offset', 'force', 'compliance', 'gains', 'direction')
MIN_COMPLIANCE_PRESSES = 3
# The direction's presses the taxel model is learned from, to render more (.rendered): the
# learning's cost grows with each, and a few dozen at several tips pin the skin's numbers.
MODEL_PRESSES = 32


class CalibrationRefused(ValueError):
    """The presses do not make a calibration; the message says why (SI units)."""


@dataclass(frozen=True)
class PressRecord:
    """
    What one press showed at full load.

    ``shift_m`` is the raw layer shift (before the offset is removed), ``counts`` both layers'
    counts above baseline (2 x rows x cols, 0 where untouched), ``wrench_n`` the reference
    sensor's mean force (x, y, z) in the skin frame when one was fed, ``clipped`` where the
    raw counts read the ADC's full scale (2 x rows x cols, None where no taxel did): those
    readings are clipped, and a force fit censors them. ``crosstalk_share`` is the crosstalk the
    press showed as a share of a line's load (:func:`crosstalk_share_of`; NaN where none did).
    ``place_m`` is where its contact was (x, y), when one was found.
    """

    peak_force_n: float
    shift_m: tuple
    counts: np.ndarray
    looks_normal: bool = True
    shift_growth_m: float = 0.0
    wrench_n: Optional[tuple] = None
    clipped: Optional[np.ndarray] = None
    crosstalk_share: float = math.nan
    place_m: Optional[tuple] = None


@dataclass(frozen=True)
class Outcome:
    """
    A successful session: the new calibration and how well it fits each press.

    ``fitted`` and ``residuals`` are per press, in newtons (force: the force the new curve gives
    back) or metres (offset: shift from the mean; compliance: shift minus compliance times
    tangential force); for gains ``fitted`` is (smallest, largest) gain and ``covered`` the share
    of the taxels the presses reached. ``warnings`` are what a front end should warn of (the
    calibration is made, but something in it needs a look); the message says them too.
    """

    calibration: Calibration
    presses_used: int
    fitted: tuple
    residuals: tuple
    message: str
    covered: float = 1.0
    warnings: tuple = ()


class CalibrationSession:
    """Collect presses of one kind from a stream of scans and fit that part of the calibration."""

    def __init__(self, estimator, kind: str, presses: int = 0,
                 forces_n: Sequence[float] = (), alphas_rad: Sequence[float] = (),
                 azimuths_rad: Sequence[float] = (), max_std_m: float = 0.0005,
                 normal_tolerance_m: float = 0.0005,
                 start_force_n: float = 0.5, release_scans: int = 5,
                 skin: SkinIdentity = None):
        """
        Start a session on ``estimator`` (a pipeline.ContactEstimator, read, never changed).

        ``presses`` is how many to collect; for force and compliance with known loads it is
        the number of known forces. A press ends after ``release_scans`` scans without touch:
        more than a lost scan or two, so that a press is never counted twice. ``skin`` is the
        skin the result is stamped for (default: the grid pressed, the estimator's pitch and
        the board of the calibration in force). Raises CalibrationRefused on inconsistent
        arguments.
        """
        if kind not in KINDS:
            raise CalibrationRefused(f'calibration kind {kind!r} is not one of {KINDS}')
        forces = np.asarray(forces_n, dtype=np.float64).ravel()
        alphas = np.asarray(alphas_rad, dtype=np.float64).ravel()
        azimuths = np.asarray(azimuths_rad, dtype=np.float64).ravel()
        if not np.isfinite(azimuths).all():
            raise CalibrationRefused('every azimuth must be a finite number of radians')
        if azimuths.size and kind != 'direction':
            raise CalibrationRefused(f'a {kind} calibration takes no azimuths')
        if kind == 'direction' and (forces.size or alphas.size):
            raise CalibrationRefused('a direction calibration takes azimuths, not forces or '
                                     'alphas')
        if kind == 'direction' and 0 < max(azimuths.size, int(presses)) < MIN_DIRECTION_PRESSES:
            raise CalibrationRefused(f'{max(azimuths.size, int(presses))} presses asked for; '
                                     f'learning the direction needs at least '
                                     f'{MIN_DIRECTION_PRESSES}')
        if not (np.isfinite(forces).all() and (forces > 0).all()):
            raise CalibrationRefused('every known force must be a positive number of newtons')
        if not (np.isfinite(alphas).all() and ((alphas >= 0) & (alphas < math.pi / 2)).all()):
            raise CalibrationRefused('every alpha must be in [0, pi/2) radians')
        if kind == 'force' and forces.size == 0:
            raise CalibrationRefused('a force calibration needs the known force of each press')
        # What a fit would refuse after every press was made is refused before the first.
        if kind == 'force':
            try:
                check_known_forces(forces)
            except ValueError as err:
                raise CalibrationRefused(str(err)) from None
        if kind == 'compliance' and 0 < max(forces.size, int(presses)) < MIN_COMPLIANCE_PRESSES:
            n = max(forces.size, int(presses))
            raise CalibrationRefused(f'{n} tilted press{"es" if n != 1 else ""} asked for; the '
                                     f'compliance needs at least {MIN_COMPLIANCE_PRESSES}')
        if kind == 'compliance' and alphas.size != forces.size:
            raise CalibrationRefused(f'{forces.size} forces but {alphas.size} alphas; give one '
                                     'alpha per force (or neither, with a reference wrench)')
        if kind in ('offset', 'gains') and forces.size:
            raise CalibrationRefused(f'a {kind} calibration takes no known forces')
        wanted = int(forces.size or azimuths.size or presses)
        if wanted < 1:
            raise CalibrationRefused('ask for at least one press')
        self.estimator = estimator
        self.kind = kind
        self.wanted = wanted
        self.forces_n = forces
        self.alphas_rad = alphas
        self.azimuths_rad = azimuths
        # With known azimuths every press made takes the next one, counted or not: a press
        # left out does not hand its azimuth to the next.
        self.made = 0
        self._azimuth_of = []
        # The direction is learned from the shift without a correction: one in force is set
        # aside in a private estimator that the scans are measured with again.
        self._plain = None
        if kind == 'direction' and estimator.calibration.direction is not None:
            self._plain = estimator.with_calibration(replace(estimator.calibration,
                                                             direction=None))
        self.max_std_m = max_std_m
        self.skin = skin
        self.accepted = []
        self.ignored = 0
        self.last_ignored = ''
        self._segmenter = PressSegmenter(start_force_n=start_force_n,
                                         release_scans=release_scans,
                                         normal_tolerance_m=normal_tolerance_m)

    @property
    def done(self) -> bool:
        """Return True once the wanted presses are in (made, with known azimuths)."""
        if self.azimuths_rad.size:
            return self.made >= self.wanted
        return len(self.accepted) >= self.wanted

    def add_scan(self, top_counts, bottom_counts, contacts, wrench_n=None) -> str:
        """
        Feed one scan and the contacts found in it (strongest first); '' or a note on a press.

        ``wrench_n`` is a reference sensor's force (x, y, z) in the skin frame at this scan.
        """
        if self.done:
            return ''
        cal = self.estimator.calibration
        contacts = self._uncorrected(top_counts, bottom_counts, contacts)
        if contacts:
            c = contacts[0]
            payload = (top_counts, bottom_counts, wrench_n, (c.x_m, c.y_m))
            zero = cal.zero_m(c.force_n)
            press = self._segmenter.add(c.force_n, (c.shift_m[0] + zero[0],
                                                    c.shift_m[1] + zero[1]), payload)
        else:
            press = self._segmenter.add(0.0, None)
        if press is None:
            return ''
        scans = self._conditioned([(t, b) for t, b, _, _ in press.plateau])
        counts = np.mean([c.counts for c in scans], axis=0)
        clipped = [c.clipped for c in scans if c.clipped.any()]
        wrenches = [w for _, _, w, _ in press.plateau if w is not None]
        wrench = tuple(np.mean(wrenches, axis=0)) if wrenches else None
        shares = [crosstalk_share_of(c.crosstalk) for c in scans]
        place = tuple(np.mean([p for _, _, _, p in press.plateau], axis=0))
        return self.add_press(PressRecord(
            peak_force_n=press.peak_force_n, shift_m=press.plateau_shift_m, counts=counts,
            looks_normal=press.looks_normal, shift_growth_m=press.shift_growth_m,
            wrench_n=wrench, clipped=np.any(clipped, axis=0) if clipped else None,
            crosstalk_share=_median_of_finite(shares), place_m=place))

    def _uncorrected(self, top_counts, bottom_counts, contacts) -> list:
        """Return the scan's contacts as measured without a direction correction."""
        if self._plain is None:
            return contacts
        return self._plain.process(top_counts, bottom_counts)

    def record(self, top_counts, bottom_counts, contacts, wrench_n=None) -> PressRecord:
        """Return the record of a press seen in one scan at full load (no stream needed)."""
        cal = self.estimator.calibration
        contacts = self._uncorrected(top_counts, bottom_counts, contacts)
        scan, = self._conditioned([(top_counts, bottom_counts)])
        counts = scan.counts
        clipped = scan.clipped if scan.clipped.any() else None
        crosstalk = crosstalk_share_of(scan.crosstalk)
        if not contacts:
            return PressRecord(0.0, (math.nan, math.nan), counts, wrench_n=wrench_n,
                               clipped=clipped, crosstalk_share=crosstalk)
        c = contacts[0]
        zero = cal.zero_m(c.force_n)
        return PressRecord(c.force_n, (c.shift_m[0] + zero[0], c.shift_m[1] + zero[1]),
                           counts, wrench_n=wrench_n, clipped=clipped, crosstalk_share=crosstalk,
                           place_m=(c.x_m, c.y_m))

    def _conditioned(self, scans: list) -> list:
        """
        Return the kernel's conditioning (kernel.Conditioned) of raw (top, bottom) ``scans``.

        On a kernel of the estimator's own, made for them from its state now (one snapshot):
        the press is read as the scans read it, and the dead marks its taxels revive are
        revived there alone.
        """
        kernel = self.estimator.conditioning_kernel(*np.shape(scans[0][0]))
        return [kernel.condition(t, b) for t, b in scans]

    def add_press(self, record: PressRecord) -> str:
        """Add one press; return a note saying whether it counts (for a person)."""
        if self.done:
            return ''
        self.made += 1
        if self.kind == 'offset' and not record.looks_normal:
            return self._ignore('press ignored: it did not look normal (its shift grew by '
                                f'{record.shift_growth_m:.6f} m with its force); press straight '
                                'down')
        if self.kind == 'compliance' and not self.forces_n.size and record.wrench_n is None:
            return self._ignore('press ignored: no reference wrench arrived during it')
        if self.kind == 'direction' and not self.azimuths_rad.size and (
                record.wrench_n is None or math.hypot(*record.wrench_n[:2]) <= 0):
            return self._ignore('press ignored: no tangential reference wrench arrived during '
                                'it, so its azimuth is not known')
        if not all(math.isfinite(v) for v in record.shift_m) and self.kind in (
                'offset', 'compliance', 'direction'):
            return self._ignore('press ignored: no layer shift could be measured')
        self.accepted.append(record)
        if self.azimuths_rad.size:
            self._azimuth_of.append(float(self.azimuths_rad[self.made - 1]))
        n = len(self.accepted)
        known = f' of known force {self.forces_n[n - 1]:.2f} N' if self.forces_n.size else ''
        if self.azimuths_rad.size:
            known = f' of known azimuth {self._azimuth_of[-1]:.3f} rad'
        return f'press {n}/{self.wanted}{known} recorded ({record.peak_force_n:.2f} N as read)'

    def _ignore(self, note: str) -> str:
        self.ignored += 1
        self.last_ignored = note
        return note

    def finish(self) -> Outcome:
        """Fit the presses; raise CalibrationRefused with the reason when they do not do."""
        if not self.accepted:
            raise CalibrationRefused(f'no usable press of the {self.wanted} asked for '
                                     f'({self.ignored} ignored; {self.last_ignored})')
        try:
            return getattr(self, f'_fit_{self.kind}')()
        except CalibrationRefused:
            raise
        except ValueError as err:
            raise CalibrationRefused(str(err)) from None

    def _updated(self, **changes) -> Calibration:
        """Return the calibration in force with ``changes``, stamped now and for this skin."""
        previous = self.estimator.calibration
        skin = self.skin
        if skin is None:
            rows, cols = self.accepted[0].counts.shape[1:]
            board = previous.skin.board_id if previous.skin else ''
            skin = SkinIdentity(rows, cols, self.estimator.config.pitch_m, board)
        return previous.updated(skin=skin, **changes)

    # ---- one fit per kind --------------------------------------------------------------------
    def _fit_offset(self) -> Outcome:
        shifts = np.array([r.shift_m for r in self.accepted])
        forces = np.array([r.peak_force_n for r in self.accepted])
        fit = calibrate_zero(shifts, forces, max_std_m=self.max_std_m,
                             prior_slope_m_per_n=self.estimator.calibration.zero_slope_m_per_n)
        new = self._updated(x_p_m=fit.x_p_m, y_p_m=fit.y_p_m, std_x_m=fit.std_x_m,
                            std_y_m=fit.std_y_m, presses=fit.presses,
                            zero_slope_m_per_n=fit.zero_slope_m_per_n, zero_ref_n=fit.zero_ref_n)
        residuals = tuple(float(math.hypot(x - zx, y - zy)) for (x, y), (zx, zy) in
                          zip(shifts, (fit.zero_m(f) for f in forces)))
        return Outcome(new, fit.presses, tuple(map(tuple, shifts.tolist())), residuals,
                       f'offset from {fit.presses} normal presses: x_p = {fit.x_p_m:.6f} m, '
                       f'y_p = {fit.y_p_m:.6f} m (std {fit.std_x_m:.6f}, {fit.std_y_m:.6f} m)')

    def _fit_force(self) -> Outcome:
        n = len(self.accepted)
        if n < self.wanted:
            raise CalibrationRefused(f'only {n} of the {self.wanted} presses of known force '
                                     'were made')
        known = self.forces_n[:n]
        fill = self.estimator.config.fill_factor
        conditioning = self.estimator.conditioning
        gains = conditioning.gain_maps()
        full_scale = conditioning.config.fsr.full_scale
        # A reading the ADC clipped is a lower bound whatever its tared counts: the fit is told so
        # by its count at full scale, at or past the ceiling of every curve (forcefit).
        marked = [r.counts if r.clipped is None
                  else np.where(r.clipped & (r.counts > 0), float(full_scale), r.counts)
                  for r in self.accepted]
        fits = {}
        notes = ''
        # The normal force is the bottom layer's sum: its curve must fit. The top layer (the
        # same film) may borrow it when its own presses do not make a curve. A press's known
        # force is right or wrong for both layers, so the bottom's fit alone says which presses
        # are left out: a top curve that fits only by leaving out others would be bent at the
        # ends its own imprints do not pin, and the bottom's is the better guess.
        for layer, name in ((1, 'bottom'), (0, 'top')):
            counts = [m[layer] for m in marked]
            judged = ({} if name == 'bottom' else
                      {'left_out': fits['bottom'].left_out, 'may_leave_out': False})
            try:
                fits[name] = fit_force_curve(counts, [gains[layer]] * n, known * fill * fill,
                                             known, conditioning.config.fsr, **judged)
            except ValueError as err:
                if name == 'bottom':
                    raise CalibrationRefused(f'{name} layer: {err}{self._clipping()}') from None
                fits[name] = fits['bottom']
                notes += f'; the top layer takes the bottom curve ({err})'
        model, model_note = self._learn_taxel_model(known, fits['bottom'].left_out)
        # The matrix's crosstalk: what the presses' lines showed (0 where they showed none).
        crosstalk = _median_of_finite([r.crosstalk_share for r in self.accepted])
        new = self._updated(
            force_curves=(fits['top'].curve, fits['bottom'].curve), force_presses=n,
            taxel_model=model,
            crosstalk_share=crosstalk if math.isfinite(crosstalk) else 0.0)
        # The pipeline's normal force is the bottom layer's sum: report that layer's fit.
        bottom = fits['bottom']
        agreed = [r for k, r in enumerate(bottom.residuals_n) if k not in bottom.left_out]
        rms = math.sqrt(float(np.mean(np.square(agreed))))
        saturated = ''.join(f'; the {name} layer saturated in {fit.censored} presses '
                            f'(from {fit.curve.censor_counts:.0f} counts on), filled in from '
                            'their rims' for name, fit in fits.items() if fit.censored)
        kept = n - len(bottom.left_out)
        left = ''.join(f'; left out press {k + 1} ({known[k]:.2f} N, fitted as '
                       f'{bottom.fitted_n[k]:.2f} N): it disagrees with the curve of the other '
                       f'{kept}' for k in bottom.left_out)
        return Outcome(new, kept, bottom.fitted_n, bottom.residuals_n,
                       f'force curves from {kept} presses over {known.min():.2f} to '
                       f'{known.max():.2f} N; residual rms {rms:.3f} N{saturated}{notes}'
                       f'{left}{model_note}')

    def _learn_taxel_model(self, known: np.ndarray, left_out=()) -> tuple:
        """
        Return (the skin's taxel model or None, a note): learned when the method in use fits one.

        Presses the force curve left out (``left_out``, indices) are left out here too.

        A model learned for another method would be stale the day the method changes, so a
        force calibration for a method without one clears it.
        """
        estimator = self.estimator
        if not get_method(estimator.config.method).modelled:
            return None, ''
        pitch = estimator.config.pitch_m
        conditioning = estimator.conditioning  # one snapshot
        fsr = conditioning.config.fsr
        sensitivity = conditioning.sensitivity_maps()
        presses = [LearningPress(r.counts, r.clipped, float(f),
                                 (r.shift_m[0] / pitch, r.shift_m[1] / pitch)
                                 if all(math.isfinite(v) for v in r.shift_m) else (0.0, 0.0),
                                 sensitivity)
                   for k, (r, f) in enumerate(zip(self.accepted, known)) if k not in left_out]
        try:
            model = learn_taxel_model(presses, pitch, film_start(fsr), fsr.full_scale)
        except ValueError as err:
            return None, f'; no taxel model ({err})'
        return model, (f'; taxel model from {model.presses} presses (misfit '
                       f'{model.misfit_counts:.1f} counts rms)')

    def _clipping(self) -> str:
        """Return a note naming the presses whose taxels read the ADC's full scale ('' if none)."""
        clipped = [k + 1 for k, r in enumerate(self.accepted)
                   if r.clipped is not None and r.clipped.any()]
        if not clipped:
            return ''
        return (f'; press{"es" if len(clipped) > 1 else ""} {", ".join(map(str, clipped))} '
                "drove taxels to the ADC's full scale, where readings are clipped (crosstalk or "
                'an overloaded film): press more lightly')

    def _known_loads(self) -> tuple:
        """Return (tangential, normal) known force per accepted press, newtons."""
        n = len(self.accepted)
        if self.forces_n.size:
            f, a = self.forces_n[:n], self.alphas_rad[:n]
            return f * np.sin(a), f * np.cos(a)
        w = np.array([r.wrench_n for r in self.accepted], dtype=np.float64)
        return np.hypot(w[:, 0], w[:, 1]), np.abs(w[:, 2])

    def _fit_compliance(self) -> Outcome:
        n = len(self.accepted)
        if n < MIN_COMPLIANCE_PRESSES:
            raise CalibrationRefused(f'{n} tilted press{"es" if n != 1 else ""}; the compliance '
                                     f'needs at least {MIN_COMPLIANCE_PRESSES}')
        tangential, _ = self._known_loads()
        previous = self.estimator.calibration
        # Each press's shift from the zero at its own normal force.
        shifts = np.array([np.subtract(r.shift_m, previous.zero_m(r.peak_force_n))
                           for r in self.accepted])
        compliance = compliance_from_presses(shifts, tangential)
        if not (math.isfinite(compliance) and compliance > 0):
            raise CalibrationRefused('the layer shift does not grow with the tangential force; '
                                     'press at alpha > 0 with a known load')
        magnitude = np.hypot(shifts[:, 0], shifts[:, 1])
        residuals = magnitude - compliance * tangential
        new = self._updated(compliance_m_per_n=compliance, compliance_presses=n)
        return Outcome(new, n, tuple(float(v) for v in compliance * tangential),
                       tuple(float(v) for v in residuals),
                       f'compliance {compliance:.4e} m/N from {n} presses with '
                       f'{tangential.min():.2f} to {tangential.max():.2f} N tangential; '
                       f'residual rms {math.sqrt(float(np.mean(residuals ** 2))):.6f} m')

    def _fit_direction(self) -> Outcome:
        pitch = self.estimator.config.pitch_m
        cal = self.estimator.calibration
        if self.azimuths_rad.size:
            azimuths = self._azimuth_of
        else:
            azimuths = [math.atan2(r.wrench_n[1], r.wrench_n[0]) for r in self.accepted]
        presses = []
        for r, azimuth in zip(self.accepted, azimuths):
            if r.place_m is None:
                continue
            zero = cal.zero_m(r.peak_force_n)
            presses.append(KnownPress(r.place_m[0] / pitch, r.place_m[1] / pitch,
                                      ((r.shift_m[0] - zero[0]) / pitch,
                                       (r.shift_m[1] - zero[1]) / pitch),
                                      r.peak_force_n, float(azimuth),
                                      (r.shift_m[0] / pitch, r.shift_m[1] / pitch)))
        rendered, note = self._rendered(presses)
        correction = learn_direction(presses, rendered=rendered)
        new = self._updated(direction=correction)
        return Outcome(new, correction.presses, (correction.before_deg, correction.after_deg),
                       (), correction.describe() + note,
                       warnings=() if correction.kept else (correction.describe(),))

    def _rendered(self, presses: list) -> tuple:
        """
        Return (presses rendered from the skin's taxel model, a note when there are none).

        The model is learned from an even sample of the recorded presses (at most
        MODEL_PRESSES: the learning's cost grows with each), each at the force it was read.
        """
        estimator = self.estimator
        pitch = estimator.config.pitch_m
        conditioning = estimator.conditioning  # one snapshot
        if conditioning.shape is None:
            return [], '; no presses rendered (the estimator has no tare)'
        fsr = conditioning.config.fsr
        sensitivity = conditioning.sensitivity_maps()
        # (add_press took only presses whose shift was measured)
        records = [r for r in self.accepted if r.place_m is not None]
        step = max(1, math.ceil(len(records) / MODEL_PRESSES))
        learning = [LearningPress(r.counts, r.clipped, r.peak_force_n,
                                  (r.shift_m[0] / pitch, r.shift_m[1] / pitch), sensitivity)
                    for r in records[::step]]
        radii = []
        try:
            model = learn_taxel_model(learning, pitch, film_start(fsr), fsr.full_scale,
                                      radii_out=radii)
        except ValueError as err:
            return [], f'; no presses rendered ({err})'
        return render_known_presses(estimator, model, presses, radii), ''

    def _fit_gains(self) -> Outcome:
        n = len(self.accepted)
        estimator = self.estimator
        # What each taxel sensed, without the gains in force: those are being replaced. A plate
        # loads whole lines, which the per-scan clean-up leaves alone (its record shows no
        # crosstalk): the crosstalk the force calibration's presses showed comes off here. A spread
        # press's lines were cleaned with its scan. Counts to force as a scan reads them.
        crosstalk = estimator.calibration.crosstalk_share
        kernel = estimator.conditioning_kernel(*self.accepted[0].counts.shape[1:])
        sums = sum(kernel.force(without_crosstalk(r.counts, crosstalk)
                                if math.isnan(r.crosstalk_share) else r.counts)
                   for r in self.accepted) / estimator.conditioning.gain_maps()
        gains, covered = gains_from_force_sums(sums, n)
        new = self._updated(gains=(gains[0], gains[1]))
        share = float(covered.mean())
        warning = limits_note(gains, covered)
        return Outcome(new, n, (float(gains.min()), float(gains.max())), (),
                       f'taxel gains from {n} press{"es" if n != 1 else ""} covering '
                       f'{100 * share:.0f} % of the taxels: {gains.min():.2f} to '
                       f'{gains.max():.2f}' + (f'; {warning}' if warning else ''),
                       covered=share, warnings=(warning,) if warning else ())


def crosstalk_share_of(line_shares: np.ndarray) -> float:
    """
    Return the crosstalk one scan of a press showed, as a share of a line's load (NaN: none).

    The median over the lines the kernel took crosstalk off (kernel.Conditioned.crosstalk). A
    press's crosstalk lies along its own rows and columns only, on taxels that carry no load of
    their own, so its lines tell the matrix's crosstalk apart from the load: what a plate over
    the whole skin cannot (:func:`gains.without_crosstalk`).
    """
    shares = np.asarray(line_shares)
    shown = shares[shares > 0]
    return float(np.median(shown)) if shown.size else math.nan


def _median_of_finite(values) -> float:
    """Return the median of the finite ``values`` (NaN when there is none)."""
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan
