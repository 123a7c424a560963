"""
The ROS side of contact estimation, shared by the direction node and the driver's fused mode.

An EstimationHost lives on a node named skin_direction and gives it everything but the source of
its scans: the estimation parameters (declared, checked, applied at run time), the publishers
(contacts, contact, wrench; heatmaps and markers for rviz), ~/tare, the calibration actions and
file (skin_driver.ros.calibration_services) and the diagnostics. Scans come in through
:meth:`EstimationHost.process`, either from the direction node's subscription to frame or, fused,
straight from the driver's serial reader thread: parameters, services and diagnostics are then
the same whichever way the scans arrive.

Threads: process() is the hot path and may run on any one thread; everything else runs on the
executor (parameter changes on a thread of their own). An estimator slower than the scans
(``model_fit`` with a learned taxel model) takes the newest scan on a thread of its own instead, so
that the hot path is never held up. The thread that estimates owns the live estimator and its
kernels (dead marks, drift tracked, time under load), and it alone enters them; it takes no lock.
Every change (tare, calibration, parameters, a new skin or taxel pitch) builds a new estimator
from the newest one off the hot path, with its kernel, serialised by a lock only changes take,
and hands it over (core scan/handover.py, one immutable :class:`Live`: the estimator, the skin it
was checked for, its generation); the estimating thread puts the changes in force in order
before its next scan and carries the kernels' per-scan state (dead marks, drift state) into the
new estimator then, so no scan is lost from it. Other threads read what the owner publishes
(the drift and dead marks each kernel publishes after a scan) or work on kernels of their own
(heatmaps: ``maps_of``; a calibration's presses, on the calibration's worker thread:
calibration_services). The scans' thread changes only between two scans (to a slow estimator's
thread and back); the new one claims the kernels.
A scan of a skin the estimator was not checked for asks the executor to check it (the
calibration's skin, the pitch) and is counted, not estimated, until then.
Each diagnostic count is written by one thread only: the hot path raises totals, the report takes
differences. Work a lower rate does as well (heatmaps, markers, diagnostics) runs on timers, on the
latest scan only, and heatmaps and markers only while someone subscribes to them. Contacts, contact
and wrench leave as CDR bytes written directly (conversions.SerializedMessages), to topics that
have subscribers.
"""

from dataclasses import replace
import math
import threading
import time
from typing import NamedTuple, Optional, Tuple

import cv2
from geometry_msgs.msg import Pose, Quaternion, WrenchStamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.event_handler import PublisherEventCallbacks
from sensor_msgs.msg import Image
from skin_driver.core.common.boardhealth import BoardHealth
from skin_driver.core.estimation.calibration.calibration import SkinMount
from skin_driver.core.estimation.calibration.tare import RecentScans
from skin_driver.core.estimation.scan.drift import drift_status
from skin_driver.core.estimation.scan.handover import Handover
from skin_driver.core.estimation.scan.heatmap import (colour_map, display_scale, grey_levels,
                                                      top_down)
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD, get_method, method_names
from skin_driver.core.protocol.realtime import StageCpu
from skin_driver.ros import conversions, diagnostics, qos
from skin_driver.ros.calibration_services import CalibrationServices
from skin_driver.ros.creep_calibration import CreepCalibration
from skin_driver.ros.estimator_params import estimator_config, ESTIMATOR_PARAMETERS
from skin_driver.ros.frames import default_frame_id
from skin_driver.ros.hot_path import LatestOnly, Listened
from skin_driver.ros.mount_calibration import MountCalibration
from skin_driver.ros.params import accept_whole_numbers, check, declare, ParameterError
from skin_msgs.msg import SkinInfo, TactileContact, TactileContactArray
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

STAGES = ('estimate', 'publish', 'bookkeeping')


class Live(NamedTuple):
    """What the hot path reads once per scan; a change puts a new one in force, whole."""

    estimator: ContactEstimator
    # (rows, cols, frame_pitch) the estimator and its calibration were checked for; None until
    # a skin is known.
    skin: Optional[Tuple[int, int, float]]
    generation: int  # one more with every change: names the estimator a scan met


class Tally(NamedTuple):
    """What became of the scans the host was given (counts since it started)."""

    estimated: int  # estimated and published
    refused: int  # not estimable: an unreadable frame, a pitch that is no length, ...
    left_for_newer: int  # replaced by a newer scan before a slow estimator took them up
    before_skin_checked: int  # came before the estimator was checked for their skin
    contacts: int  # contacts published


class EstimationHost:
    """Estimation parameters, publishers, services and diagnostics of one node."""

    def __init__(self, node):
        self.node = node
        # OpenCV's worker pool spins between calls, which on maps of a few hundred taxels costs
        # more CPU than the pool saves: one thread for the process.
        cv2.setNumThreads(1)
        self._declare_parameters()
        accept_whole_numbers(node)
        # What is in force, the estimating thread's; changes are handed over to it (_swap).
        self._handover = Handover(
            Live(ContactEstimator(self._config(EstimatorConfig().pitch_m)), None, 0),
            lambda new, old: new.estimator.carry_from(old.estimator))
        self._estimating = None  # the thread that estimated last (threading.get_ident())
        # The estimator holds the calibration; the services put every new one in force here.
        self.mount = None  # until made: the file's calibration is put in force first
        self._skin = default_frame_id(node.get_namespace())
        self.calibration = CalibrationServices(node, lambda: self.estimator,
                                               self.put_calibration)
        self.mount = MountCalibration(node, lambda: self._skin, self._skin_grid, self._put_mount,
                                      self.calibration.file_problem)
        # The file's mount goes on /tf_static at every start, before any scan.
        self._show_mount()
        self.creep = CreepCalibration(node, lambda: self.estimator, self._put_creep,
                                      self.calibration.file_problem)
        # The scans a tare averages: filled and resized by the estimating thread alone.
        self._recent = RecentScans(self._p('tare.frames'))
        self._recent_size = self._recent_wanted = self._p('tare.frames')
        # Counts, each written by one thread: frames unreadable by the thread that calls
        # process(), the rest by the thread that estimates (the same one unless the estimator
        # is slow). The report keeps what it saw last and takes differences.
        self._unreadable = 0
        self._frames = self._bad_frames = self._contacts = self._unchecked = 0
        self._cost_sum, self._cost_count = 0.0, 0
        self._cost_seen = (0.0, 0)
        self._cost_max = diagnostics.PeriodMax()
        self._cpu = StageCpu(STAGES)
        self._cpu_reading = diagnostics.TakenByOwner(self._cpu.take, dict.fromkeys(STAGES, 0.0))
        self._rate = diagnostics.RateMeter(time.monotonic())
        # A slow estimator's thread, made on the first scan it cannot keep up with.
        self._newest = None
        # (header, pitch, top, bottom, contacts, estimator) of the latest scan, the hot path's;
        # the one the viz timer drew last, the timer's.
        self._latest = self._drawn = None
        # The skin the scans show that the estimator was not checked for (the hot path's), and
        # the executor's work that checks it.
        self._asked_skin = None
        self._pitch_seen = (None, None)  # (a scan's pitch, its frame_pitch), the hot path's
        self._skin_check = node.create_guard_condition(self._check_skin)
        # The skin it estimates, for /diagnostics and the mount: the frame its scans carry
        # (until the first scan, the frame its namespace gives; set above).
        self._writer = conversions.ContactArrayWriter()
        self._serialized = None
        self._rebuilders = []

        # Every QoS event handler is one more entity the Python executor walks on each wake,
        # at up to 2 kHz; readers of these topics still get rclpy's incompatible-QoS warnings.
        quiet = {'event_callbacks': PublisherEventCallbacks(use_default_callbacks=False),
                 **qos.overridable()}
        self._pub_contacts = node.create_publisher(TactileContactArray, 'contacts', qos.stream(),
                                                   **quiet)
        self._pub_contact = node.create_publisher(TactileContact, 'contact', qos.stream(), **quiet)
        self._pub_wrench = node.create_publisher(WrenchStamped, 'wrench', qos.stream(), **quiet)
        # What the skin is, latched: a tool that finds the topic later still learns it.
        self._pub_info = node.create_publisher(SkinInfo, 'skin_info', qos.latched())
        self._described = None
        # The protocol version of the frames fed (fused: set by the driver's reader); 0: unknown.
        self.protocol_version = 0
        # The viz timer runs only while rviz's topics have subscribers: told by their matched
        # events (three entities) rather than woken at viz_rate to ask.
        self._viz_watchers = {}
        self._pub_heat = {layer: node.create_publisher(Image, f'{layer}/heatmap', qos.VIZ_DEPTH,
                                                       **self._viz_events(layer))
                          for layer in ('top', 'bottom')}
        self._pub_markers = node.create_publisher(MarkerArray, 'markers', qos.VIZ_DEPTH,
                                                  **self._viz_events('markers'))
        self._listened = Listened({'contacts': self._pub_contacts, 'contact': self._pub_contact,
                                   'wrench': self._pub_wrench, 'markers': self._pub_markers,
                                   **self._pub_heat})
        node.create_service(Trigger, '~/tare', self._on_tare)
        self._diag = diagnostics.DiagnosticPublisher(node)
        node.create_timer(self._p('diagnostics_period'), self._report)
        self._viz_timer = None
        self._grid = None  # conversions.GridMarkers of the latest skin seen
        self._start_viz_timer()
        node.add_on_set_parameters_callback(self._check_new_parameters)
        node.add_post_set_parameters_callback(self._apply_new_parameters)
        node.get_logger().info(
            f"estimating with '{self._p('method')}'; {self.calibration.note}")
        self._caution()

    def _caution(self) -> None:
        """Warn of what the method in use asks of a live driver (its own words)."""
        caution = get_method(self._p('method')).caution
        if caution:
            self.node.get_logger().warning(caution)

    # ---- parameters -------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        node = self.node
        declare(node, 'method', DEFAULT_METHOD,
                "Shift estimator between the layers (the paper's phase correlation is a "
                'reference of the evaluator, not a choice).',
                choices=method_names())
        # The core's defaults are the node's: the evaluator and the node measure the same thing.
        core = EstimatorConfig()
        declare(node, 'threshold', core.threshold_counts,
                'ADC counts above the baseline below which a taxel counts as untouched.',
                low=0.0, high=4095.0)
        declare(node, 'min_force', core.min_contact_force_n,
                'Contacts weaker than this (newtons) are ignored.',
                low=0.0, high=1000.0)
        declare(node, 'min_confidence', core.min_confidence,
                'Directions less trusted than this are reported with direction_valid false.',
                low=0.0, high=1.0)
        declare(node, 'min_shift', core.min_shift_m,
                'Layer shift (metres, after calibration) below which no direction is reported.',
                low=0.0, high=0.1)
        declare(node, 'compliance', core.compliance_m_per_n,
                'Layer shift per newton of tangential force (m/N); gives the polar angle alpha.',
                low=1.0e-7, high=1.0)
        declare(node, 'force_scale', core.force_scale,
                'Factor on the normal force: a force calibration against a reference sensor.',
                low=0.01, high=100.0)
        declare(node, 'skin.fill_factor', core.fill_factor,
                'Sensitive fraction of the pitch along each axis of a taxel.', low=0.1, high=1.0)
        declare(node, 'tare.frames', 20, 'Scans averaged into the unloaded baseline by ~/tare.',
                low=1, high=10000)
        declare(node, 'viz_rate', 15.0,
                'Heatmap images and markers per second (0 turns them off).', low=0.0, high=1000.0)
        # The colour scale's least top: on the seed's 5 mm skin the strongest taxel of a press
        # carries about a fifth of it, so a 2 N press fills the scale and a 1 N one half; an
        # idle skin's taxels read nothing above the touch threshold and stay dark.
        declare(node, 'viz_full_scale', 0.4,
                'Least force per taxel (newtons) at the top of the colour scale of heatmaps and '
                'markers: the scale reaches the strongest taxel of the scan, never less than '
                'this, so a light touch fills it and an idle skin stays dark.',
                low=0.001, high=1000.0)
        declare(node, 'diagnostics_period', 1.0, 'Seconds between two /diagnostics reports.',
                low=0.1, high=60.0)
        declare(node, 'layer_gap', 0.0,
                'Thickness of the elastic layer between the two FSR layers (metres), for '
                'skin_info; 0: not given.', low=0.0, high=0.1)

    def _p(self, name):
        return self.node.get_parameter(name).value

    def _check_new_parameters(self, params) -> SetParametersResult:
        """Refuse at run time what start-up would refuse (rclpy checks the ranges)."""
        for param in params:
            try:
                if param.name == 'method':
                    check('method', param.value, 'a shift estimator', choices=method_names())
            except ParameterError as err:
                self.node.get_logger().warning(f'parameter refused: {err}')
                return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    def _apply_new_parameters(self, params) -> None:
        names = {param.name for param in params}
        if names & set(ESTIMATOR_PARAMETERS):
            # Off the executor: a change of method may load the compiled kernel, and the
            # executor serves the actions and services meanwhile.
            worker = threading.Thread(target=self._rebuild, args=(sorted(names),), daemon=True,
                                      name='skin-estimator-rebuild')
            self._rebuilders = [t for t in self._rebuilders if t.is_alive()] + [worker]
            worker.start()
        if 'tare.frames' in names:
            self._recent_wanted = self._p('tare.frames')  # resized by the estimating thread
        if 'viz_rate' in names:
            self._start_viz_timer()

    def _rebuild(self, names) -> None:
        self._swap(lambda old: old.with_config(self._config(old.config.pitch_m)))
        self.node.get_logger().info(f"estimator rebuilt for {', '.join(names)}")
        if 'method' in names:
            self._caution()

    @property
    def rebuilding(self) -> bool:
        """Return whether a parameter change is still being applied to the estimator."""
        return any(worker.is_alive() for worker in self._rebuilders)

    def _config(self, pitch_m: float) -> EstimatorConfig:
        """Return the estimator settings of the current parameters."""
        return estimator_config({n: self._p(n) for n in ESTIMATOR_PARAMETERS}, pitch_m)

    # ---- the live estimator -----------------------------------------------------------------
    @property
    def estimator(self) -> ContactEstimator:
        """Return the newest estimator: immutable, in force from the next scan at the latest."""
        return self._handover.newest.estimator

    @property
    def live(self) -> Live:
        """Return the newest estimator, the skin it was checked for and its generation."""
        return self._handover.newest

    @property
    def in_force(self) -> Live:
        """Return what the last scan met (a snapshot: the estimating thread's)."""
        return self._handover.in_force

    def _swap(self, change, skin=None) -> None:
        """
        Hand ``change(newest estimator)`` over to the scans; nothing changes if it raises.

        Built here, off the hot path, with its kernel; the estimating thread puts it in force
        before its next scan and carries the drift tracked and the time under load into it
        then (across a change of parameters or calibration; a tare, another baseline, starts
        afresh). ``skin`` (rows, cols, frame_pitch): the new estimator was checked for it;
        without, it serves the skin the current one served.
        """
        def made(live: Live) -> Live:
            checked = skin or live.skin
            estimator = change(live.estimator)
            if checked is not None:
                # Its kernel now, not by the first scan on the thread that reads them.
                estimator.ready_for(checked[0], checked[1])
            return Live(estimator, checked, live.generation + 1)
        self._handover.put(made)

    def _skin_grid(self) -> tuple:
        """Return (rows, cols, pitch) of the skin the scans show (touches come with scans)."""
        live = self.live
        return live.skin or (0, 0, live.estimator.config.pitch_m)

    def _put_mount(self, parent: str, fit) -> str:
        """Store a mount found from touches with the calibration; return where it was written."""
        return self._put_part(mount=SkinMount(parent, fit.translation_m, fit.rpy_rad,
                                              fit.rms_residual_m, len(fit.residuals_m)))

    def _put_creep(self, fit) -> str:
        """Store a creep fitted from a held load with the calibration; return where."""
        return self._put_part(creep=fit)

    def _put_part(self, **part) -> str:
        """Store one part, stamped now (in the made map and its own time alike); say where."""
        calibration = self.estimator.calibration.updated(**part)
        name, value = next(iter(part.items()))
        path = self.calibration.write_and_put(replace(calibration, **{
            name: replace(value, made_utc=calibration.made(name))}))
        return f'; written to {path}'

    def put_calibration(self, calibration) -> None:
        """Put ``calibration`` in force (with its force curves, gains and mount)."""
        self._swap(lambda estimator: estimator.with_calibration(calibration))
        self._show_mount()

    def _show_mount(self) -> None:
        if self.mount is not None:
            self.mount.show(self.estimator.calibration, self.calibration.loaded_from)

    def prepare(self, rows: int, cols: int, pitch_m: float) -> None:
        """
        Check the calibration and the pitch for a skin, off the hot path, before its scans.

        The fused driver calls this at configure, so its first scan is estimated; a direction
        node's first scans ask the executor for it (and are counted until it is done).
        """
        skin = (int(rows), int(cols), conversions.frame_pitch(pitch_m))
        # A calibration made for another skin is refused before it is used.
        self.calibration.check_skin(rows, cols, pitch_m)

        def for_skin(old):
            # A tare or gains of another grid would refuse every scan of this one.
            old = old.for_grid(skin[0], skin[1])
            if conversions.frame_pitch(old.config.pitch_m) == skin[2]:
                return old
            return old.with_config(replace(old.config, pitch_m=skin[2]))
        self._swap(for_skin, skin)

    def _check_skin(self) -> None:
        """Check the estimator for the skin the scans show (the executor's, asked by them)."""
        asked = self._asked_skin
        if asked is None or asked == self.live.skin:
            return
        rows, cols, pitch_m = asked
        try:
            self.prepare(rows, cols, pitch_m)
        except ValueError as err:  # a grid no skin has: its scans stay counted, not estimated
            self.node.get_logger().error(
                f'frames of {rows} x {cols} taxels at pitch {pitch_m} m are not estimated: {err}')
            return
        self.node.get_logger().info(
            f'estimating a skin of {rows} x {cols} taxels at {1000 * pitch_m:.3f} mm pitch')

    # ---- hot path ---------------------------------------------------------------------------
    def process(self, header, sequence: int, device_time_us: int, pitch_m: float,
                top: np.ndarray, bottom: np.ndarray) -> None:
        """
        Estimate the contacts of one scan and publish them; count a bad scan and go on.

        An estimator slower than the scans (``ContactEstimator.every_scan`` false) estimates on a
        thread of its own, each time the newest scan: the scans in between are left, and the
        caller (the serial reader, fused) is never held up. A switch of method lets the scan in
        flight there finish, and scans go there until it has: one thread estimates at a time,
        the one owner of the live estimator and its kernels, and of the estimation's counts,
        caches and reused messages. It puts the changes handed over in force before the scan.
        """
        scan = (header, sequence, device_time_us, pitch_m, top, bottom)
        newest = self._newest
        if self.estimator.every_scan and (newest is None or not newest.busy):
            self._estimate(scan)
            return
        if newest is None:
            newest = self._newest = LatestOnly(self._estimate, 'skin-estimate',
                                               self._estimate_failed)
        newest.offer(scan)

    def close(self) -> None:
        """Stop the thread of a slow estimator, if one ran, and destroy the actions."""
        if self._newest is not None:
            self._newest.stop()
        self.calibration.close()
        self.mount.close()
        self.creep.close()

    def _estimate_failed(self, err: Exception) -> None:
        self._bad_frames += 1
        self.node.get_logger().error(f'scan not estimated: {err!r}', throttle_duration_sec=5.0)

    def _estimate(self, scan) -> None:
        header, sequence, device_time_us, pitch_m, top, bottom = scan
        cpu = self._cpu
        cpu.begin()
        if threading.get_ident() != self._estimating:
            # The scans moved to this thread (a slow estimator's, or back): it owns the kernels.
            self._estimating = threading.get_ident()
            self._handover.in_force.estimator.claim()
        # The changes handed over, in force from this scan on: the one read for the whole scan.
        live = self._handover.take()
        try:
            if not (math.isfinite(pitch_m) and pitch_m > 0):
                raise ValueError(f'pitch {pitch_m} is not a positive length')
            if pitch_m != self._pitch_seen[0]:  # the rule's formatting, once per pitch seen
                self._pitch_seen = (pitch_m, conversions.frame_pitch(pitch_m))
            skin = (top.shape[0], top.shape[1], self._pitch_seen[1])
            if skin != live.skin:
                self._unchecked += 1
                self._ask_for_skin(skin)
                return
            start = time.perf_counter()
            scan_s = device_time_us * 1e-6
            contacts = live.estimator.process(top, bottom, scan_s)
            cost = time.perf_counter() - start
            cpu.mark('estimate')
            # Converting here means a non-finite value never reaches a publisher.
            fields = [conversions.contact_fields(c) for c in contacts]
        except ValueError as err:
            self._bad_frames += 1
            self._refused(sequence, err)
            return
        now = time.monotonic()
        self._publish(header, sequence, device_time_us, contacts, fields, self._listened(now))
        cpu.mark('publish')
        cpu.frames(1)
        self._frames += 1
        self._contacts += len(contacts)
        self._cost_sum += cost
        self._cost_count += 1
        self._cost_max.see(cost)
        self._rate.add()
        if self._recent_size != self._recent_wanted:
            self._recent_size = self._recent_wanted
            self._recent.resize(self._recent_size)
        self._recent.add(top, bottom, len(contacts), now)
        self._latest = (header, pitch_m, top, bottom, contacts, live.estimator)
        self._skin = header.frame_id
        self.calibration.feed(top, bottom, contacts)
        self.mount.feed(contacts)
        self.creep.feed(scan_s, contacts)
        cpu.mark('bookkeeping')
        self._cpu_reading.serve()

    def _ask_for_skin(self, skin) -> None:
        """Ask the executor to check the estimator for ``skin``, once per skin shown."""
        if skin != self._asked_skin:
            self._asked_skin = skin
            self._skin_check.trigger()

    def _publish(self, header, sequence, device_time_us, contacts, fields, listened) -> None:
        """Publish contacts, contact and wrench to those of them that have subscribers."""
        # A topic nobody listens to costs a message and a publish for nothing: skipped, as
        # image_transport skips its unwatched topics. A late subscriber is served within
        # hot_path.REFRESH_S.
        serialized = self._serialized_for(header.frame_id)
        if serialized is not None:
            sec, nanosec = header.stamp.sec, header.stamp.nanosec
            contacts_msg = (lambda: serialized.contacts(sec, nanosec, sequence, device_time_us,
                                                        fields))
            contact_msg = (lambda: serialized.contact(sec, nanosec, fields[0]))
            wrench_msg = (lambda: serialized.wrench(sec, nanosec, contacts))
        else:  # a middleware that serialises otherwise than plain CDR: message objects
            array = self._writer.fill(header, contacts, sequence, device_time_us)
            contacts_msg = (lambda: array)
            contact_msg = (lambda: array.contacts[0])
            wrench_msg = (lambda: conversions.wrench_stamped(header, contacts))
        if listened['contacts']:
            self._pub_contacts.publish(contacts_msg())
        if contacts and listened['contact']:
            self._pub_contact.publish(contact_msg())
        if listened['wrench']:
            self._pub_wrench.publish(wrench_msg())

    def _serialized_for(self, frame_id: str):
        """Return the SerializedMessages of frame_id, or None if the middleware differs."""
        known = self._serialized
        if known is None or known.frame_id != frame_id:
            known = self._serialized = conversions.SerializedMessages(frame_id)
        return known if known.usable else None

    def reject(self, sequence, err: Exception) -> None:
        """Count a frame that cannot be read (on the thread that calls process) and say why."""
        self._unreadable += 1
        self._refused(sequence, err)

    def _refused(self, sequence, err: Exception) -> None:
        """Say why a scan is dropped (at most every 5 s)."""
        which = 'a frame' if sequence is None else f'frame {sequence}'
        self.node.get_logger().warning(f'dropping {which}: {err}', throttle_duration_sec=5.0)

    def tally(self) -> Tally:
        """Return what became of the scans given so far, each counted once."""
        newest = self._newest
        return Tally(self._frames, self._bad_frames + self._unreadable,
                     0 if newest is None else newest.dropped, self._unchecked, self._contacts)

    # ---- rviz -------------------------------------------------------------------------------
    def _viz_events(self, name: str) -> dict:
        def matched(info) -> None:
            self._viz_watchers[name] = info.current_count
            self._start_viz_timer()
        return {'event_callbacks': PublisherEventCallbacks(matched=matched,
                                                           use_default_callbacks=False),
                **qos.overridable()}

    def _start_viz_timer(self) -> None:
        if self._viz_timer is not None:
            self.node.destroy_timer(self._viz_timer)
            self._viz_timer = None
        rate = self._p('viz_rate')
        if rate > 0 and any(self._viz_watchers.values()):
            self._viz_timer = self.node.create_timer(1.0 / rate, self._visualise)

    def _visualise(self) -> None:
        latest = self._latest
        listened = self._listened(time.monotonic())
        wanted = [name for name in ('top', 'bottom', 'markers') if listened[name]]
        if latest is None or latest is self._drawn or not wanted:
            return
        self._drawn = latest
        header, pitch, top, bottom, contacts, estimator = latest
        forces = dict(zip(('top', 'bottom'), estimator.maps_of(top, bottom)))
        full = display_scale(self._p('viz_full_scale'), *forces.values())
        for layer in ('top', 'bottom'):
            if layer in wanted:
                self._pub_heat[layer].publish(conversions.rgb_to_image(
                    header, colour_map(top_down(forces[layer]), full)))
        if 'markers' in wanted:
            self._publish_markers(header, forces['top'], float(pitch), contacts, full)

    def _publish_markers(self, header, force_map, pitch_m, contacts, full_scale_n) -> None:
        """Publish the grid (as CDR bytes where they are rmw's), then the contacts' markers."""
        grid = self._grid
        if grid is None or grid.key != (header.frame_id, force_map.shape, pitch_m):
            grid = self._grid = conversions.GridMarkers(header.frame_id, force_map.shape,
                                                        pitch_m)
        if grid.usable:
            self._pub_markers.publish(grid.serialize(header.stamp.sec, header.stamp.nanosec,
                                                     grey_levels(force_map, full_scale_n)))
        else:
            self._pub_markers.publish(MarkerArray(markers=conversions.grid_markers(
                header, force_map, pitch_m, full_scale_n)))
        if contacts:  # after the grid's message, whose first marker clears the old ones
            self._pub_markers.publish(MarkerArray(
                markers=conversions.contact_markers(header, contacts, pitch_m)))

    # ---- tare -------------------------------------------------------------------------------
    def _on_tare(self, request, response):
        try:
            tops, bottoms = self._recent.unloaded(self._p('tare.frames'), time.monotonic())
            self._swap(lambda estimator: estimator.with_tare(tops, bottoms))
        except ValueError as err:  # TareRefused, or frames the conditioning cannot take
            response.success = False
            response.message = f'tare refused: {err}'
            self.node.get_logger().warning(response.message)
            return response
        response.success = True
        response.message = f'baseline recorded from {len(tops)} unloaded scans'
        self.node.get_logger().info(response.message)
        return response

    # ---- diagnostics ------------------------------------------------------------------------
    def _describe_skin(self) -> None:
        """Publish what the skin is on skin_info (latched) when any of it changed."""
        self._show_mount()  # the scans' frame, once known
        live = self.live
        if live.skin is None:
            return
        info = skin_info(self._skin, live.skin, live.estimator, self.calibration.board,
                         self._p('layer_gap'), self.mount.in_force, self.protocol_version)
        if info != self._described:
            self._described = info
            self._pub_info.publish(info)

    def _report(self) -> None:
        rate, _ = self._rate.take(time.monotonic())
        tally = self.tally()
        total, count = self._cost_sum, self._cost_count
        seen_total, seen_count = self._cost_seen
        self._cost_seen = (total, count)
        total, count = total - seen_total, count - seen_count
        worst = self._cost_max.take()
        values = {
            'method': self._p('method'), 'frame rate [Hz]': rate,
            'frames': tally.estimated, 'bad frames': tally.refused,
            'frames left for newer ones (estimator slower than the scans)':
                tally.left_for_newer,
            'frames before the estimator was checked for their skin': tally.before_skin_checked,
            'contacts': tally.contacts,
            'estimator generation': self.in_force.generation,
            'mean cost [us]': 1e6 * total / count if count else 0.0,
            'max cost [us]': 1e6 * worst,
            **{f'CPU per scan, {stage} [us]': round(us, 1)
               for stage, us in self._cpu_reading.ask().items()},
            **self.calibration.diagnostic_values(),
        }
        drifted, drift_warning = drift_status(self.in_force.estimator)
        values.update(drifted)
        level, message = diagnostics.OK, self.calibration.note
        if drift_warning:
            level, message = diagnostics.WARN, drift_warning
        if self.calibration.warning:
            level, message = diagnostics.WARN, self.calibration.warning
        if tally.estimated == 0:
            level, message = diagnostics.WARN, 'no frame received yet'
        elif rate == 0.0:
            level, message = diagnostics.WARN, 'no frame in the last period'
        self._describe_skin()
        self._diag.publish([diagnostics.make_status(
            f'{self.node.get_fully_qualified_name()}: contact estimation', self._skin, level,
            message, values)])


def skin_info(frame_id: str, skin: tuple, estimator: ContactEstimator, board,
              layer_gap_m: float, mount=None, protocol_version: int = 0) -> SkinInfo:
    """Return what a tool needs to know of the skin ``estimator`` serves, as a SkinInfo."""
    rows, cols, pitch_m = skin
    cal = estimator.calibration
    parts = cal.parts_in_force()
    health = BoardHealth.of(board)
    return SkinInfo(
        header=Header(frame_id=frame_id), rows=int(rows), cols=int(cols), pitch=float(pitch_m),
        layer_gap=float(layer_gap_m),
        min_contact_force=float(estimator.config.min_contact_force_n),
        scan_rate=float(board.rate_hz) if board is not None and board.rate_hz else 0.0,
        board_name=board.board if board is not None else '',
        board_uid=board.uid if board is not None else '',
        firmware_version=board.fw if board is not None else '',
        board_reset_cause=health.values()['board reset cause'] if health is not None else '',
        board_faults=health.named() if health is not None else [],
        protocol_version=int(protocol_version),
        calibration_made=cal.made_utc, calibration_parts=[part for part, _ in parts],
        calibration_parts_made=[made for _, made in parts],
        parent_frame=mount.parent_frame if mount else '',
        mount_pose=conversions.mount_pose(mount.xyz_m, mount.rpy_rad) if mount else Pose(
            orientation=Quaternion(w=1.0)),
        mount_source=mount.source if mount else '')
