"""
Calibration services for any node that estimates contacts: the ROS side of core session.py.

``CalibrationServices(node, get_estimator, put_calibration)`` declares the calibration
parameters on ``node``, loads the calibration file into the estimator, and offers

* ``~/calibrate`` (skin_msgs/srv/Calibrate): (x_p, y_p) from normal presses;
* ``~/calibrate_force`` (skin_msgs/srv/CalibrateForce): the counts-to-force curves from presses
  of known normal force;
* ``~/calibrate_compliance`` (skin_msgs/srv/CalibrateCompliance): the compliance from presses of
  known tilted load, given in the request or read from the WrenchStamped topic named by
  ``calibration.wrench_topic``;
* ``~/calibrate_gains`` (skin_msgs/srv/CalibrateGains): per-taxel gains from a plate over the
  skin or many presses spread over it.

The node calls :meth:`feed` with every scan and its contacts. The calibration lives in the
estimator alone, which the node owns: ``get_estimator()`` returns the one in force and
``put_calibration(calibration)`` asks the node to put a new one in force. A new calibration is
written to the file first and put in force only once written; a refusal, a timeout or a failed
write answers with the calibration still in force.
"""

import math
import os
import time

from geometry_msgs.msg import WrenchStamped
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.task import Future
from skin_driver.core.estimation.calibration import Calibration
from skin_driver.core.estimation.session import CalibrationRefused, CalibrationSession
from skin_driver.ros.params import declare
from skin_driver.ros.paths import ros_home
from skin_msgs.srv import Calibrate, CalibrateCompliance, CalibrateForce, CalibrateGains

MAX_CALIBRATION_PRESSES = 1000
MAX_CALIBRATION_S = 3600.0
# A reference wrench older than this when a scan arrives is not taken as that scan's load.
MAX_WRENCH_AGE_S = 0.5
KEEP = '; the previous calibration stays in force'


def default_calibration_file(fully_qualified_name: str) -> str:
    """Return the calibration file of the node with this name: two skins never share one."""
    return os.path.join(ros_home(), 'skin_driver', 'calibration',
                        fully_qualified_name.strip('/') + '.yaml')


def declare_calibration_parameters(node) -> None:
    """Declare the calibration parameters on ``node``."""
    declare(node, 'calibration_file', '',
            'YAML file of the calibration, loaded at start-up and written by the calibration '
            'services; empty: ~/.ros/skin_driver/calibration/<node namespace and name>.yaml.')
    declare(node, 'calibration.presses', 8,
            'Normal presses ~/calibrate records when the request asks for 0.',
            low=1, high=MAX_CALIBRATION_PRESSES)
    declare(node, 'calibration.timeout', 60.0,
            'Seconds a calibration service waits when the request asks for 0.',
            low=0.1, high=MAX_CALIBRATION_S)
    declare(node, 'calibration.max_std', 0.0005,
            "Largest spread (metres, standard deviation) of the presses' shifts accepted.",
            low=1.0e-6, high=0.1)
    declare(node, 'calibration.normal_tolerance', 0.0005,
            "How far a press's shift may grow with its force (metres) and look normal.",
            low=1.0e-6, high=0.1)
    declare(node, 'calibration.wrench_topic', '',
            'geometry_msgs/WrenchStamped topic of a force/torque sensor in the skin frame that '
            '~/calibrate_compliance reads the load from; empty: loads come in the request.')


def request_problem(presses: int, timeout: float, forces=()) -> str:
    """Return why a request's counts or timeout cannot be served, or ''."""
    if presses > MAX_CALIBRATION_PRESSES or len(forces) > MAX_CALIBRATION_PRESSES:
        return (f'presses {max(presses, len(forces))} is more than {MAX_CALIBRATION_PRESSES}; '
                'ask for 0 (the default) or a number up to that')
    if not (math.isfinite(timeout) and 0.0 <= timeout <= MAX_CALIBRATION_S):
        return (f'timeout {timeout} s is not in (0, {MAX_CALIBRATION_S:.0f}]; ask for '
                '0 (the default) or a number of seconds in that range')
    return ''


class CalibrationServices:
    """Offer the calibration services on a node whose estimator ``get_estimator()`` returns."""

    def __init__(self, node, get_estimator, put_calibration):
        """Declare the parameters, load the calibration file and create the services."""
        self._node = node
        self._get_estimator = get_estimator
        self._put_calibration = put_calibration
        self._session = None
        self._future = None
        self._wrench = None
        self._wrench_sub = None
        declare_calibration_parameters(node)
        self.note = ''
        self.loaded_from = ''
        self.load()
        self._follow_wrench_topic()
        for srv, name, handler in ((Calibrate, '~/calibrate', self._on_calibrate),
                                   (CalibrateForce, '~/calibrate_force', self._on_force),
                                   (CalibrateCompliance, '~/calibrate_compliance',
                                    self._on_compliance),
                                   (CalibrateGains, '~/calibrate_gains', self._on_gains)):
            # A call waits for presses: in a group of its own it cannot hold up the frames it
            # waits for, which run in the node's default group.
            node.create_service(srv, name, handler,
                                callback_group=MutuallyExclusiveCallbackGroup())
        node.add_post_set_parameters_callback(self._on_parameters)

    # ---- file --------------------------------------------------------------------------------
    @property
    def path(self) -> str:
        """Return the calibration file in use."""
        given = self._node.get_parameter('calibration_file').value
        if not str(given).strip():
            return default_calibration_file(self._node.get_fully_qualified_name())
        return os.path.expanduser(given)

    def load(self) -> None:
        """Load the calibration file into the estimator (the default one if there is none)."""
        path = self.path
        cal = Calibration()
        if not os.path.exists(path):
            self.note = f'no calibration file at {path} yet: uncalibrated'
        else:
            try:
                cal = Calibration.load_yaml(path)
                self.note = f'calibration from {path}: {cal.describe()}'
            except (OSError, ValueError) as err:
                self._node.get_logger().error(f'ignoring calibration file {path}: {err}')
                self.note = f'calibration file {path} unreadable: uncalibrated'
        self.loaded_from = path
        self._put_calibration(cal)

    def _on_parameters(self, params) -> None:
        names = {p.name for p in params}
        if 'calibration_file' in names:
            self.load()
        if 'calibration.wrench_topic' in names:
            self._follow_wrench_topic()

    def diagnostic_values(self) -> dict:
        """Return what is calibrated, where it came from and when it was made."""
        cal = self._get_estimator().calibration
        return {'calibration file': self.loaded_from, 'calibration made': cal.made_utc or '-',
                'x_p [m]': cal.x_p_m, 'y_p [m]': cal.y_p_m,
                'compliance [m/N]': cal.compliance_m_per_n or '- (parameter compliance)',
                'force curve': (f'{cal.force_presses} presses' if cal.force_curves
                                else '- (assumed FSR model)'),
                'calibrating': self._session.kind if self._session else 'no'}

    # ---- data --------------------------------------------------------------------------------
    def _follow_wrench_topic(self) -> None:
        if self._wrench_sub is not None:
            self._node.destroy_subscription(self._wrench_sub)
            self._wrench_sub = None
        topic = self._node.get_parameter('calibration.wrench_topic').value
        if topic:
            self._wrench_sub = self._node.create_subscription(
                WrenchStamped, topic, self._on_wrench, 10)

    def _on_wrench(self, msg: WrenchStamped) -> None:
        f = msg.wrench.force
        self._wrench = ((f.x, f.y, f.z), time.monotonic())

    def feed(self, top, bottom, contacts) -> None:
        """Give the running session, if any, one scan and its contacts (strongest first)."""
        session = self._session
        if session is None:
            return
        wrench = None
        if self._wrench is not None and time.monotonic() - self._wrench[1] <= MAX_WRENCH_AGE_S:
            wrench = self._wrench[0]
        note = session.add_scan(top, bottom, contacts, wrench)
        if note:
            self._node.get_logger().info(f'calibration ({session.kind}): {note}')
        if session.done and not self._future.done():
            self._future.set_result('done')

    # ---- services ----------------------------------------------------------------------------
    def _param(self, name: str):
        return self._node.get_parameter(name).value

    async def _on_calibrate(self, request, response):
        problem = request_problem(request.presses, request.timeout)
        args = {'presses': request.presses or self._param('calibration.presses'),
                'max_std_m': self._param('calibration.max_std')}
        return await self._run(response, problem, 'offset', request.timeout, args,
                               _answer_offset)

    async def _on_force(self, request, response):
        forces = list(request.forces)
        problem = request_problem(0, request.timeout, forces)
        return await self._run(response, problem, 'force', request.timeout,
                               {'forces_n': forces}, _answer_force)

    async def _on_compliance(self, request, response):
        forces, alphas = list(request.forces), list(request.alphas)
        problem = request_problem(request.presses, request.timeout, forces)
        if not problem and not forces and self._wrench_sub is None:
            problem = ('no forces in the request and no calibration.wrench_topic to read them '
                       'from; give forces and alphas, or name the force sensor topic')
        args = {'forces_n': forces, 'alphas_rad': alphas,
                'presses': request.presses or self._param('calibration.presses')}
        return await self._run(response, problem, 'compliance', request.timeout, args,
                               _answer_compliance)

    async def _on_gains(self, request, response):
        problem = request_problem(request.presses, request.timeout)
        return await self._run(response, problem, 'gains', request.timeout,
                               {'presses': request.presses or 1}, _answer_gains)

    async def _run(self, response, problem: str, kind: str, timeout: float, args: dict,
                   answer):
        """Run one session and answer; every failure answers with the calibration in force."""
        answer(response, self._get_estimator().calibration, None)
        response.success = False
        if self._session is not None:
            response.message = (f'a {self._session.kind} calibration is already running; wait '
                                'for it to finish')
            return response
        try:
            if problem:
                raise CalibrationRefused(problem)
            session = CalibrationSession(
                self._get_estimator(), kind,
                normal_tolerance_m=self._param('calibration.normal_tolerance'), **args)
        except CalibrationRefused as err:
            response.message = f'{err}{KEEP}'
            return response
        timeout = timeout or self._param('calibration.timeout')
        future = Future()
        self._session, self._future = session, future
        timer = self._node.create_timer(
            timeout, lambda: future.done() or future.set_result('timeout'))
        self._node.get_logger().info(
            f'calibration ({kind}): make {session.wanted} presses within {timeout:.0f} s')
        try:
            outcome = await future
        finally:
            self._node.destroy_timer(timer)
            self._session = self._future = None
        response.presses_used = len(session.accepted)
        if outcome == 'timeout':
            ignored = (f'; {session.ignored} ignored, the last one because {session.last_ignored}'
                       if session.ignored else '')
            response.message = (f'timed out after {timeout:.0f} s with {len(session.accepted)} '
                                f'of {session.wanted} presses{ignored}{KEEP}')
            return response
        path = self.path
        try:
            result = session.finish()
            result.calibration.save_yaml(path)
        except (CalibrationRefused, OSError, ValueError) as err:
            response.message = f'{err}{KEEP}'
            return response
        self._put_calibration(result.calibration)
        self.loaded_from = path
        self.note = f'calibration from {path}: {result.calibration.describe()}'
        answer(response, result.calibration, result)
        response.success = True
        response.presses_used = result.presses_used
        response.message = f'{result.message}; written to {path}'
        self._node.get_logger().info(f'calibration ({kind}): {response.message}')
        return response


def _answer_offset(response, cal: Calibration, outcome) -> None:
    response.x_p, response.y_p = cal.x_p_m, cal.y_p_m
    response.std_x, response.std_y = cal.std_x_m, cal.std_y_m


def _answer_force(response, cal: Calibration, outcome) -> None:
    curve = cal.force_curves[1] if cal.force_curves else None
    response.curve_counts = list(curve.counts) if curve else []
    response.curve_forces = list(curve.force_n) if curve else []
    response.fitted = list(outcome.fitted) if outcome else []
    response.residuals = list(outcome.residuals) if outcome else []


def _answer_compliance(response, cal: Calibration, outcome) -> None:
    response.compliance = cal.compliance_m_per_n
    response.fitted = list(outcome.fitted) if outcome else []
    response.residuals = list(outcome.residuals) if outcome else []


def _answer_gains(response, cal: Calibration, outcome) -> None:
    top, bottom = cal.gain_maps()
    if top is None:
        response.gain_min = response.gain_max = 1.0
    else:
        response.gain_min = float(min(top.min(), bottom.min()))
        response.gain_max = float(max(top.max(), bottom.max()))
    response.covered = 0.0
    if outcome is not None:
        response.covered = outcome.covered
