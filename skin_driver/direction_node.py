"""
Direction node: turns SkinFrame scans into contacts with location, force and direction.

Subscribes to frame (skin_msgs/SkinFrame). Publishes contacts (TactileContactArray, every scan,
empty when nothing touches), contact (the strongest TactileContact, when there is one) and wrench
(its force as geometry_msgs/WrenchStamped; zero when nothing touches, so a controller sees the
release). For rviz, at most viz_rate times a second: top/heatmap and bottom/heatmap (rgb8) and
markers (visualization_msgs/MarkerArray). Services: ~/tare (std_srvs/srv/Trigger) and the
calibration services of calibration_services.py. Diagnostics on /diagnostics.
"""

import collections
import math
import time

from geometry_msgs.msg import WrenchStamped
import numpy as np
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image
from skin_driver import conversions, diagnostics
from skin_driver.calibration_services import CalibrationServices
from skin_driver.core.estimation.heatmap import colour_map
from skin_driver.core.estimation.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift import DEFAULT_METHOD, method_names
from skin_driver.estimator_params import estimator_config, ESTIMATOR_PARAMETERS
from skin_driver.params import check, declare, ParameterError
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray


class DirectionNode(Node):
    """Estimate contacts from raw scans; calibrate and tare on request."""

    def __init__(self, **kwargs):
        super().__init__('skin_direction', **kwargs)
        self._declare_parameters()
        self._estimator = self._build_estimator(EstimatorConfig().pitch_m)
        self._calibrator = CalibrationServices(self, lambda: self._estimator)
        self._recent = collections.deque(maxlen=self._p('tare.frames'))
        self._stats = collections.Counter()
        self._cost = []
        self._last_viz = 0.0
        self._rate = diagnostics.RateMeter(time.monotonic())

        # Every QoS event handler is one more entity the Python executor walks on each wake,
        # at up to 2 kHz; readers of these topics still get rclpy's incompatible-QoS warnings.
        quiet = {'event_callbacks': PublisherEventCallbacks(use_default_callbacks=False)}
        stream = qos_profile_sensor_data
        self._pub_contacts = self.create_publisher(TactileContactArray, 'contacts', stream,
                                                   **quiet)
        self._pub_contact = self.create_publisher(TactileContact, 'contact', stream, **quiet)
        self._pub_wrench = self.create_publisher(WrenchStamped, 'wrench', stream, **quiet)
        self._pub_heat = {layer: self.create_publisher(Image, f'{layer}/heatmap', 5, **quiet)
                          for layer in ('top', 'bottom')}
        self._pub_markers = self.create_publisher(MarkerArray, 'markers', 5, **quiet)
        self.create_subscription(SkinFrame, 'frame', self._on_frame, qos_profile_sensor_data)
        self.create_service(Trigger, '~/tare', self._on_tare)
        self._diag = diagnostics.DiagnosticPublisher(self)
        self.create_timer(self._p('diagnostics_period'), self._report)
        self.add_on_set_parameters_callback(self._check_new_parameters)
        self.add_post_set_parameters_callback(self._apply_new_parameters)
        self.get_logger().info(
            f"estimating with '{self._p('method')}'; {self._calibrator.note}")

    # ---- parameters -------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        declare(self, 'method', DEFAULT_METHOD,
                "Shift estimator between the layers; seed is the paper's phase correlation.",
                choices=method_names())
        # The core's defaults are the node's: the evaluator and the node measure the same thing.
        core = EstimatorConfig()
        declare(self, 'threshold', core.threshold_counts,
                'ADC counts above the baseline below which a taxel counts as untouched.',
                low=0.0, high=4095.0)
        declare(self, 'min_force', 0.2, 'Contacts weaker than this (newtons) are ignored.',
                low=0.0, high=1000.0)
        declare(self, 'min_confidence', core.min_confidence,
                'Directions less trusted than this are reported with direction_valid false.',
                low=0.0, high=1.0)
        declare(self, 'min_shift', core.min_shift_m,
                'Layer shift (metres, after calibration) below which no direction is reported.',
                low=0.0, high=0.1)
        declare(self, 'compliance', core.compliance_m_per_n,
                'Layer shift per newton of tangential force (m/N); gives the polar angle alpha.',
                low=1.0e-7, high=1.0)
        declare(self, 'force_scale', core.force_scale,
                'Factor on the normal force: a force calibration against a reference sensor.',
                low=0.01, high=100.0)
        declare(self, 'skin.fill_factor', core.fill_factor,
                'Sensitive fraction of the pitch along each axis of a taxel.', low=0.1, high=1.0)
        declare(self, 'tare.frames', 20, 'Scans averaged into the unloaded baseline by ~/tare.',
                low=1, high=10000)
        declare(self, 'viz_rate', 15.0,
                'Heatmap images and markers per second (0 turns them off).', low=0.0, high=1000.0)
        declare(self, 'viz_full_scale', 10.0,
                'Force per taxel (newtons) drawn at the top of the colour scale.',
                low=0.001, high=1000.0)
        declare(self, 'diagnostics_period', 1.0, 'Seconds between two /diagnostics reports.',
                low=0.1, high=60.0)

    def _p(self, name):
        return self.get_parameter(name).value

    def _check_new_parameters(self, params) -> SetParametersResult:
        """Refuse at run time what start-up would refuse (rclpy checks the ranges)."""
        for param in params:
            try:
                if param.name == 'method':
                    check('method', param.value, 'a shift estimator', choices=method_names())
            except ParameterError as err:
                return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    def _apply_new_parameters(self, params) -> None:
        names = {param.name for param in params}
        if names & set(ESTIMATOR_PARAMETERS):
            self._estimator = self._build_estimator(self._estimator.config.pitch_m,
                                                    self._estimator.conditioner)
            self.get_logger().info(f"estimator rebuilt for {', '.join(sorted(names))}")
        if 'tare.frames' in names:
            self._recent = collections.deque(self._recent, maxlen=self._p('tare.frames'))

    def _build_estimator(self, pitch_m: float, conditioner=None) -> ContactEstimator:
        """Return an estimator for the current parameters; a conditioner carries the tare over."""
        config = estimator_config({n: self._p(n) for n in ESTIMATOR_PARAMETERS}, pitch_m)
        # The estimator holds the calibration: a new one takes over the one in force.
        previous = getattr(self, '_estimator', None)
        calibration = previous.calibration if previous is not None else None
        return ContactEstimator(config, calibration, conditioner=conditioner)

    def _follow_pitch(self, pitch_m: float) -> None:
        """Take the taxel pitch from the frames, keeping the tare and the calibration."""
        # SkinFrame carries the pitch as float32: 0.005 arrives as 0.004999999888; only a real
        # change rebuilds the estimator.
        if not math.isclose(pitch_m, self._estimator.config.pitch_m, rel_tol=1e-5):
            self._estimator = self._build_estimator(pitch_m, self._estimator.conditioner)

    # ---- data path --------------------------------------------------------------------------
    def _on_frame(self, msg: SkinFrame) -> None:
        try:
            top, bottom = conversions.skin_frame_layers(msg)
            if not (math.isfinite(msg.pitch) and msg.pitch > 0):
                raise ValueError(f'pitch {msg.pitch} is not a positive length')
            self._follow_pitch(float(msg.pitch))
            start = time.perf_counter()
            contacts = self._estimator.process(top, bottom)
            self._cost.append(time.perf_counter() - start)
            # Converting here means a non-finite value never reaches a publisher.
            array = conversions.contacts_to_array(msg.header, contacts)
        except ValueError as err:
            self._stats['bad frames'] += 1
            self.get_logger().warning(f'dropping frame {msg.sequence}: {err}',
                                      throttle_duration_sec=5.0)
            return
        self._stats['frames'] += 1
        self._rate.add()
        self._recent.append((top, bottom, len(contacts)))
        header = msg.header
        self._pub_contacts.publish(array)
        if contacts:
            strongest = contacts[0]
            self._stats['contacts'] += len(contacts)
            # The array already holds the strongest contact's message: no second conversion.
            self._pub_contact.publish(array.contacts[0])
            self._pub_wrench.publish(conversions.wrench_stamped(
                header, strongest.force_xyz_n, (strongest.x_m, strongest.y_m)))
        else:
            self._pub_wrench.publish(conversions.wrench_stamped(header, (0.0, 0.0, 0.0)))
        self._calibrator.feed(top, bottom, contacts)
        self._visualise(header, msg.pitch, top, bottom, contacts)

    def _visualise(self, header, pitch, top, bottom, contacts) -> None:
        rate = self._p('viz_rate')
        now = time.monotonic()
        if rate <= 0 or now - self._last_viz < 1.0 / rate:
            return
        self._last_viz = now
        full = self._p('viz_full_scale')
        top_force, bottom_force = self._estimator.conditioner.condition(top, bottom)
        self._pub_heat['top'].publish(
            conversions.rgb_to_image(header, colour_map(top_force, full)))
        self._pub_heat['bottom'].publish(
            conversions.rgb_to_image(header, colour_map(bottom_force, full)))
        self._pub_markers.publish(conversions.heatmap_markers(
            header, top_force, float(pitch), contacts, full))

    # ---- tare -------------------------------------------------------------------------------
    def _on_tare(self, request, response):
        wanted = self._p('tare.frames')
        frames = list(self._recent)
        if len(frames) < wanted:
            response.success = False
            response.message = (f'only {len(frames)} of {wanted} scans received so far; '
                                'is the driver running?')
            return response
        loaded = sum(1 for _, _, n in frames if n)
        if loaded:
            response.success = False
            response.message = (f'the skin is loaded ({loaded} of the last {wanted} scans have a '
                                'contact); lift everything off it and call again')
            return response
        tops = np.stack([f[0] for f in frames])
        bottoms = np.stack([f[1] for f in frames])
        try:
            self._estimator.tare(tops, bottoms)
        except ValueError as err:
            response.success = False
            response.message = f'tare failed: {err}'
            return response
        response.success = True
        response.message = f'baseline recorded from {wanted} unloaded scans'
        self.get_logger().info(response.message)
        return response

    # ---- diagnostics --------------------------------------------------------------------------
    def _report(self) -> None:
        rate, _ = self._rate.take(time.monotonic())
        cost, self._cost = self._cost, []
        values = {
            'method': self._p('method'), 'frame rate [Hz]': rate,
            'frames': self._stats['frames'], 'bad frames': self._stats['bad frames'],
            'contacts': self._stats['contacts'],
            'mean cost [us]': 1e6 * sum(cost) / len(cost) if cost else 0.0,
            'max cost [us]': 1e6 * max(cost) if cost else 0.0,
            **self._calibrator.diagnostic_values(),
        }
        level, message = diagnostics.OK, self._calibrator.note
        if self._stats['frames'] == 0:
            level, message = diagnostics.WARN, 'no frame received yet'
        elif rate == 0.0:
            level, message = diagnostics.WARN, 'no frame in the last period'
        self._diag.publish([diagnostics.make_status(
            f'{self.get_fully_qualified_name()}: contact estimation', 'skin', level, message,
            values)])


def main(args=None):
    """Run the direction node until shut down."""
    rclpy.init(args=args)
    try:
        node = DirectionNode()
    except ParameterError as err:
        rclpy.logging.get_logger('skin_direction').fatal(str(err))
        rclpy.try_shutdown()
        raise SystemExit(1)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # noqa: B902 - judged by the context, re-raised unless shutting down
        # Ctrl-C shuts the context down under a callback already running: its publish fails,
        # and that is the shutdown, not a crash.
        if node.context.ok():
            raise
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
