"""
Calibration actions for any node that estimates contacts: the ROS side of core session.py.

``CalibrationServices(node, get_estimator, put_calibration)`` declares the calibration
parameters on ``node``, loads the calibration file into the estimator, and offers

* ``~/calibrate`` (skin_msgs/action/Calibrate): (x_p, y_p) from normal presses;
* ``~/calibrate_force`` (skin_msgs/action/CalibrateForce): the counts-to-force curves from
  presses of known normal force;
* ``~/calibrate_compliance`` (skin_msgs/action/CalibrateCompliance): the compliance from presses
  of known tilted load, given in the goal or read from the WrenchStamped topic named by
  ``calibration.wrench_topic``;
* ``~/calibrate_gains`` (skin_msgs/action/CalibrateGains): per-taxel gains from a plate over the
  skin or many presses spread over it;
* ``~/calibrate_direction`` (skin_msgs/action/CalibrateDirection): a correction of the direction
  from tilted presses of known azimuth (goal or wrench topic), kept only when it gains on
  held-out presses;
* ``~/reset_calibration`` (std_srvs/Trigger): the defaults, in force and in the file.

A calibration takes seconds to minutes of presses, so each is an action: feedback after every
press, cancel (Ctrl-C on ``ros2 action send_goal``) ends it. One runs at a time: a goal that
arrives while one runs is rejected at once (the reason is logged). A goal is checked before any
press is awaited: one no presses could satisfy ends at once, aborted with the reason. The node
calls :meth:`feed` with every scan and its contacts (on the scans' thread), and
:meth:`check_skin` (off it) before it estimates the scans of a skin's grid and pitch. The scans'
thread only hands a running calibration its scans (a bounded queue: a scan that finds it full is
dropped and counted, in the diagnostics and the log); a worker thread of the calibration's own
gives them to the session, which conditions each press on a kernel of its own and, for a
direction calibration, scans again without the correction in force: no calibration work, and no
kernel of the calibration's, on the scans' thread. The
calibration lives in the estimator alone, which the node owns: ``get_estimator()`` returns the
one in force and ``put_calibration(calibration)`` asks the node to put a new one in force. A new
calibration is written to the file first and put in force only once written; a refusal, a
timeout, a cancel or a failed write leaves the calibration in force (and is logged).

A calibration file belongs to one skin (grid, pitch, ``calibration.skin_id``) and, when made
while the board said who it is, to that board (its unique ID): one made for another skin or
board is refused when the frames show the skin or the board says who it is (:meth:`set_board`),
with a WARN in the log and in the diagnostics, and the defaults are put in force. A refused file
(another skin's or board's, or unreadable) is never written: a calibration or a reset is then
refused, naming the file and the way out (core calfile.py). A file set at run time that is
refused (another skin's or board's, unreadable, or absent) is refused by the parameter set
itself, with the reason, and the calibration in force stays. Every write keeps the file it
replaces as ``<file>.bak``. A file bound to no board loads with a note; a file bound to a board
loads with a WARN on a board that does not say who it is (a version-1 stream).
"""

from dataclasses import replace
import math
import os
import queue
import threading
import time

from geometry_msgs.msg import WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import CancelResponse, GoalResponse
from rclpy.task import Future
from skin_driver.core.estimation.calibration.calfile import (backup_of, CalibrationFile,
                                                             refusal)
from skin_driver.core.estimation.calibration.calibration import (Calibration, CalibrationMismatch,
                                                                 PARTS, SkinIdentity)
from skin_driver.core.estimation.calibration.session import CalibrationRefused, CalibrationSession
from skin_driver.ros import conversions, qos
from skin_driver.ros.lifetime import ActionOwner
from skin_driver.ros.params import declare
from skin_driver.ros.paths import ros_home
from skin_msgs.action import (Calibrate, CalibrateCompliance, CalibrateDirection, CalibrateForce,
                              CalibrateGains)
from std_srvs.srv import Trigger

MAX_CALIBRATION_PRESSES = 1000
MAX_CALIBRATION_S = 3600.0
# A reference wrench older than this when a scan arrives is not taken as that scan's load.
MAX_WRENCH_AGE_S = 0.5
# How often a running calibration looks for a cancel or its timeout.
POLL_S = 0.1
# Scans a running calibration's worker may be behind by (1 s at 2 kHz) before one is dropped.
MAX_WAITING_SCANS = 2000
KEEP = '; the previous calibration stays in force'
# A board says who it is once a second (docs/protocol.md); a driver that opens the port while
# the board runs hears it up to a second after the first frame. Until this long after the
# first frame a silent board is not yet taken for a version-1 board.
BOARD_SILENCE_S = 2.0


def default_calibration_file(fully_qualified_name: str) -> str:
    """Return the calibration file of the node with this name: two skins never share one."""
    return os.path.join(ros_home(), 'skin_driver', 'calibration',
                        fully_qualified_name.strip('/') + '.yaml')


def declare_calibration_parameters(node) -> None:
    """Declare the calibration parameters on ``node``."""
    declare(node, 'calibration_file', '',
            'YAML file of the calibration, loaded at start-up and written by the calibration '
            'actions; empty: ~/.ros/skin_driver/calibration/<node namespace and name>.yaml. Set '
            "at run time, it must name an existing file of this skin's. A refused file is never "
            'written.')
    declare(node, 'calibration.skin_id', '',
            'Name of this skin, stored with its calibration: a file made under another name is '
            'refused. Empty: grid and pitch only (and the board uid, when the board says who '
            'it is: docs/protocol.md).')
    declare(node, 'calibration.presses', 8,
            'Normal presses ~/calibrate records when the goal asks for 0.',
            low=1, high=MAX_CALIBRATION_PRESSES)
    declare(node, 'calibration.timeout', 60.0,
            'Seconds a calibration waits for its presses when the goal asks for 0.',
            low=0.1, high=MAX_CALIBRATION_S)
    declare(node, 'calibration.max_std', 0.0005,
            "Largest spread (metres, standard deviation) of the presses' shifts accepted.",
            low=1.0e-6, high=0.1)
    declare(node, 'calibration.normal_tolerance', 0.0005,
            "How far a press's shift may grow with its force (metres) and look normal.",
            low=1.0e-6, high=0.1)
    declare(node, 'calibration.wrench_topic', '',
            'geometry_msgs/WrenchStamped topic (best effort: any publisher) of a force/torque '
            'sensor in the skin frame that ~/calibrate_compliance and ~/calibrate_direction read '
            'the load from; empty: loads come in the goal.')


def request_problem(presses: int, timeout: float, forces=()) -> str:
    """Return why a goal's counts or timeout cannot be served, or ''."""
    if presses > MAX_CALIBRATION_PRESSES or len(forces) > MAX_CALIBRATION_PRESSES:
        return (f'presses {max(presses, len(forces))} is more than {MAX_CALIBRATION_PRESSES}; '
                'ask for 0 (the default) or a number up to that')
    if not (math.isfinite(timeout) and 0.0 <= timeout <= MAX_CALIBRATION_S):
        return (f'timeout {timeout} s is not in (0, {MAX_CALIBRATION_S:.0f}]; ask for '
                '0 (the default) or a number of seconds in that range')
    return ''


class RunningCalibration:
    """
    The calibration running: its session and goal together, put in force by one assignment.

    The scans' thread hands it scans (:meth:`offer`) until the executor closes it; a worker
    thread of its own gives them to the session, in order, and says what a press made of them
    (``on_note(running, note)``). Closing waits for the worker to end, so no scan reaches a
    session that is being finished.
    """

    __slots__ = ('session', 'goal', 'dropped', '_scans', '_open', '_worker')

    def __init__(self, session: CalibrationSession, goal_handle, on_note):
        self.session = session
        self.goal = goal_handle
        self.dropped = 0  # scans that found the queue full (the scans' thread's count)
        self._scans = queue.SimpleQueue()
        self._open = True
        self._worker = threading.Thread(target=self._work, args=(on_note,), daemon=True,
                                        name='skin-calibration')
        self._worker.start()

    def offer(self, top, bottom, contacts, wrench) -> None:
        """Hand the worker one scan (never blocks); one the queue has no room for is counted."""
        if not self._open:
            return
        # The scans' thread alone puts: the queue only shrinks between the check and the put.
        if self._scans.qsize() >= MAX_WAITING_SCANS:
            self.dropped += 1
            return
        self._scans.put((top, bottom, contacts, wrench))

    def _work(self, on_note) -> None:
        while True:
            scan = self._scans.get()
            if scan is None:
                return
            if not self._open:
                continue  # closed: what is left waits for nothing
            try:
                note = self.session.add_scan(*scan)
            except Exception as err:  # noqa: B902 - said, and the next scan is given still
                note = f'a scan not taken: {err!r}'
            if note:
                on_note(self, note)

    def close(self) -> None:
        """Take no more scans; return once the worker has ended (after the scan it gives)."""
        self._open = False
        self._scans.put(None)
        self._worker.join()


async def goal_outcome(node, goal_handle, done, timeout_s: float) -> str:
    """
    Return what ended a goal that waits for ``done()``: 'done', 'cancel' or 'timeout'.

    Polled every POLL_S by a timer on the executor, whose future it is alone: the scans' thread
    only makes ``done()`` true.
    """
    deadline = time.monotonic() + timeout_s
    future = Future()

    def watch():
        if future.done():
            return
        if goal_handle.is_cancel_requested:
            future.set_result('cancel')
        elif done():
            future.set_result('done')
        elif time.monotonic() > deadline:
            future.set_result('timeout')
    timer = node.create_timer(POLL_S, watch)
    try:
        return await future
    finally:
        node.destroy_timer(timer)


class CalibrationServices(ActionOwner):
    """Offer the calibration actions on a node whose estimator ``get_estimator()`` returns."""

    def __init__(self, node, get_estimator, put_calibration):
        """Declare the parameters, load the calibration file and create the actions."""
        self._node = node
        self._get_estimator = get_estimator
        self._put_calibration = put_calibration
        self._running_now = None  # a RunningCalibration while one runs, read once per scan
        self._dropped = 0  # scans the calibrations that ended had no room for
        self._running = threading.Lock()  # held from a goal's acceptance to its end
        self._wrench = None
        self._wrench_sub = None
        self._skin = None
        self._board = None  # the BoardInfo the board last gave, None while it said nothing
        declare_calibration_parameters(node)
        self.note = ''
        self.warning = ''
        self.binding = ''  # how the calibration in force is bound to this skin's board
        self._binding_warning = ''
        self._first_frame_s = 0.0  # time.monotonic() of the first frame's check
        self._board_awaited = False  # a bound calibration waits for a silent board to speak
        self._file = CalibrationFile('')
        self.load()
        self._follow_wrench_topic()
        for action, name, kind, goal_args, answer in (
                (Calibrate, '~/calibrate', 'offset', self._offset_args,
                 conversions.fill_offset_result),
                (CalibrateForce, '~/calibrate_force', 'force', self._force_args,
                 conversions.fill_force_result),
                (CalibrateCompliance, '~/calibrate_compliance', 'compliance',
                 self._compliance_args, conversions.fill_compliance_result),
                (CalibrateGains, '~/calibrate_gains', 'gains', self._gains_args,
                 conversions.fill_gains_result),
                (CalibrateDirection, '~/calibrate_direction', 'direction', self._direction_args,
                 conversions.fill_direction_result)):
            self.serve(node, action, name, self._executor(action, kind, goal_args, answer),
                       self._on_goal(kind), self._on_cancel)
        node.create_service(Trigger, '~/reset_calibration', self._on_reset)
        node.add_on_set_parameters_callback(self._check_parameters)
        node.add_post_set_parameters_callback(self._on_parameters)

    # ---- file --------------------------------------------------------------------------------
    @property
    def path(self) -> str:
        """Return the calibration file the parameter names."""
        return self._path_of(self._node.get_parameter('calibration_file').value)

    @property
    def loaded_from(self) -> str:
        """Return the calibration file in force: the one read, and the only one written."""
        return self._file.path

    def _path_of(self, given) -> str:
        if not str(given).strip():
            return default_calibration_file(self._node.get_fully_qualified_name())
        return os.path.expanduser(given)

    def load(self) -> None:
        """Load the calibration file (the defaults if there is none, or it is another skin's)."""
        path = self.path
        cal = Calibration()
        self.warning = ''
        refused = ''
        if not os.path.exists(path):
            self.note = f'no calibration file at {path} yet: uncalibrated'
            if str(self._node.get_parameter('calibration_file').value).strip():
                self.warning = f'calibration_file {path} does not exist: uncalibrated'
                self._node.get_logger().warning(self.warning)
        else:
            try:
                cal = Calibration.load_yaml(path, self._skin)
                self.note = f'calibration from {path}: {cal.describe()}'
            except CalibrationMismatch as err:
                # Another skin's or board's file: the calibration in force stays, and that
                # file is never written.
                self.warning = f'calibration file refused: {err}{KEEP}'
                self.note = self.warning
                self._node.get_logger().warning(self.warning)
                self._file = CalibrationFile(path, str(err))
                return
            except (OSError, ValueError) as err:
                self._node.get_logger().error(f'ignoring calibration file {path}: {err}; it is '
                                              'never written')
                self.warning = f'calibration file {path} unreadable: uncalibrated'
                self.note = self.warning
                refused = str(err)
        self._file = CalibrationFile(path, refused)
        self._put_calibration(cal)
        self._bind(cal)

    def _refuse(self, problem: str) -> None:
        self.warning = f'calibration refused, running uncalibrated: {problem}'
        self.note = self.warning
        self._node.get_logger().warning(self.warning)

    def check_skin(self, rows: int, cols: int, pitch_m: float) -> None:
        """
        Refuse the calibration in force if it belongs to another skin than the frames'.

        Called off the hot path (the executor, or the driver's configure), before the skin's
        scans are estimated.
        """
        board = self._board
        skin = SkinIdentity(rows, cols, conversions.frame_pitch(pitch_m),
                            self._param('calibration.skin_id'), board.uid if board else '',
                            board.board if board else '')
        if skin == self._skin:
            return
        if self._skin is None:
            self._first_frame_s = time.monotonic()
        self._check(skin)

    @property
    def board(self):
        """Return the BoardInfo the board last gave (None while it said nothing)."""
        return self._board

    def set_board(self, info) -> None:
        """
        Take who the board says it is (a core.protocol.wire.BoardInfo) as this skin's board.

        Once the frames have shown the skin, the calibration in force is checked against the
        board at once: one made on another board is refused and the defaults are put in force.
        """
        same_board = self._board is not None and info.identity == self._board.identity
        self._board = info  # its health too, for skin_info
        if same_board:
            return
        if self._skin is not None:
            self._check(replace(self._skin, board_uid=info.uid, board_name=info.board))

    def _check(self, skin: SkinIdentity) -> None:
        self._skin = skin
        running = self._running_now
        if running is not None:
            # A session begun before the board spoke is stamped for the skin known at its end.
            running.session.skin = skin
        cal = self._get_estimator().calibration
        problem = cal.check_skin(skin)
        if problem:
            self._file = CalibrationFile(self._file.path, problem)
            self._refuse(self._file.problem())
            cal = Calibration()
            self._put_calibration(cal)
        self._bind(cal)

    def _bind(self, cal: Calibration) -> None:
        """Say how ``cal``, now in force, is bound to the board; a warning when unchecked."""
        if self._skin is None:
            return
        warning, note = cal.board_binding(self._skin)
        if self.warning and self.warning == self._binding_warning:
            self.warning = ''  # said of the calibration before, or of the board before
        self._binding_warning = ''
        self._board_awaited = False
        if warning and time.monotonic() - self._first_frame_s < BOARD_SILENCE_S:
            # diagnostic_values() says it once the board has had its time to speak.
            self._board_awaited = True
            self.binding = 'waiting for the board to say who it is'
            return
        if cal.skin is None and not cal.made_utc:
            note = ''  # nothing calibrated: nothing to bind
        self._binding_warning = f'{self.loaded_from}: {warning}' if warning else ''
        if warning and not self.warning:
            self.warning = self._binding_warning
            self._node.get_logger().warning(self.warning)
        elif note:
            self._node.get_logger().info(note)
        self.binding = warning or note or (f'bound to {cal.skin.board()}' if (
            cal.skin is not None and cal.skin.board_uid) else 'bound to no board')

    def _check_parameters(self, params) -> SetParametersResult:
        """Refuse a file (or skin name) under which the file would not be this skin's."""
        given = {p.name: p.value for p in params}
        if not {'calibration_file', 'calibration.skin_id'} & set(given):
            return SetParametersResult(successful=True)
        path = self._path_of(given.get('calibration_file', self._param('calibration_file')))
        skin = self._skin
        if skin is not None and 'calibration.skin_id' in given:
            skin = replace(skin, board_id=str(given['calibration.skin_id']))
        if str(given.get('calibration_file', '')).strip() and not os.path.isfile(path):
            reason = (f'no calibration file at {path}; name an existing file (or empty for the '
                      'default)')
        else:
            reason = refusal(path, skin)
            if 'calibration_file' not in given and refusal(path, self._skin):
                reason = ''  # refused already under the old name: the name is not the cause
            reason = f'calibration file refused: {reason}' if reason else ''
        if not reason:
            return SetParametersResult(successful=True)
        reason += '; the calibration in force stays'
        name = 'calibration_file' if 'calibration_file' in given else 'calibration.skin_id'
        self._node.get_logger().warning(f'{name} refused: {reason}')
        return SetParametersResult(successful=False, reason=reason)

    def _on_parameters(self, params) -> None:
        names = {p.name for p in params}
        if 'calibration.skin_id' in names and self._skin is not None:
            # The scans' skin is known: the file is checked at once under the new name.
            self._skin = replace(self._skin, board_id=str(self._param('calibration.skin_id')))
        if names & {'calibration_file', 'calibration.skin_id'}:
            self.load()
        if 'calibration.wrench_topic' in names:
            self._follow_wrench_topic()

    def diagnostic_values(self) -> dict:
        """Return what is calibrated, for which skin, where it came from and when made."""
        if self._board_awaited and time.monotonic() - self._first_frame_s >= BOARD_SILENCE_S:
            # Called once a diagnostics period: a board silent so long is a version-1 board.
            self._bind(self._get_estimator().calibration)
        cal = self._get_estimator().calibration
        running = self._running_now
        session = running.session if running is not None else None
        return {'calibration file': self.loaded_from, 'calibration made': cal.made_utc or '-',
                **{f'{part} made': cal.made(part) or '-' for part in PARTS},
                'calibration skin': cal.skin.describe() if cal.skin else '-',
                'calibration board': self.binding or '-',
                'calibration warning': self.warning or '-',
                'x_p [m]': cal.x_p_m, 'y_p [m]': cal.y_p_m,
                'compliance [m/N]': cal.compliance_m_per_n or '- (parameter compliance)',
                'force curve': (f'{cal.force_presses} presses' if cal.force_curves
                                else '- (assumed FSR model)'),
                'calibrating': (f'{session.kind}: {len(session.accepted)} of {session.wanted} '
                                'presses' if session else 'no'),
                'calibration scans dropped': self._dropped + (running.dropped if running else 0)}

    # ---- data --------------------------------------------------------------------------------
    def _follow_wrench_topic(self) -> None:
        if self._wrench_sub is not None:
            self._node.destroy_subscription(self._wrench_sub)
            self._wrench_sub = None
        topic = self._node.get_parameter('calibration.wrench_topic').value
        if topic:
            # Best effort takes a sensor's samples from a reliable or a best-effort publisher.
            self._wrench_sub = self._node.create_subscription(
                WrenchStamped, topic, self._on_wrench, qos.stream(), **qos.overridable())

    def _on_wrench(self, msg: WrenchStamped) -> None:
        f = msg.wrench.force
        self._wrench = ((f.x, f.y, f.z), time.monotonic())

    def feed(self, top, bottom, contacts) -> None:
        """Give the running session, if any, one scan and its contacts (strongest first)."""
        running = self._running_now  # the one read: session and goal belong together
        if running is None:
            return
        wrench = None
        known = self._wrench
        if known is not None and time.monotonic() - known[1] <= MAX_WRENCH_AGE_S:
            wrench = known[0]
        running.offer(top, bottom, contacts, wrench)

    def _on_note(self, running: RunningCalibration, note: str) -> None:
        """Say what a press made of the scans (the calibration's worker thread)."""
        session, goal = running.session, running.goal
        self._node.get_logger().info(f'calibration ({session.kind}): {note}')
        goal.publish_feedback(conversions.calibration_feedback(type(goal.request), session, note))

    # ---- actions -----------------------------------------------------------------------------
    def _param(self, name: str):
        return self._node.get_parameter(name).value

    def _on_goal(self, kind: str):
        def accept(request):
            if not self._running.acquire(blocking=False):
                now = self._running_now
                running = now.session.kind if now is not None else 'another'
                self._node.get_logger().warning(
                    f'{kind} calibration goal rejected: a {running} calibration is already '
                    'running; wait for it to end or cancel it')
                return GoalResponse.REJECT
            return GoalResponse.ACCEPT
        return accept

    def _on_cancel(self, goal_handle) -> CancelResponse:
        self._node.get_logger().info('calibration: cancel requested; the calibration in force '
                                     'stays')
        return CancelResponse.ACCEPT

    def _offset_args(self, goal) -> tuple:
        return (request_problem(goal.presses, goal.timeout),
                {'presses': goal.presses or self._param('calibration.presses'),
                 'max_std_m': self._param('calibration.max_std')})

    def _force_args(self, goal) -> tuple:
        forces = list(goal.forces)
        return request_problem(0, goal.timeout, forces), {'forces_n': forces}

    def _compliance_args(self, goal) -> tuple:
        forces, alphas = list(goal.forces), list(goal.alphas)
        problem = request_problem(goal.presses, goal.timeout, forces)
        if not problem and not forces and self._wrench_sub is None:
            problem = ('no forces in the goal and no calibration.wrench_topic to read them '
                       'from; give forces and alphas, or name the force sensor topic')
        return problem, {'forces_n': forces, 'alphas_rad': alphas,
                         'presses': 0 if forces else (goal.presses
                                                      or self._param('calibration.presses'))}

    def _direction_args(self, goal) -> tuple:
        azimuths = list(goal.azimuths)
        problem = request_problem(goal.presses, goal.timeout, azimuths)
        if not problem and not azimuths and self._wrench_sub is None:
            problem = ('no azimuths in the goal and no calibration.wrench_topic to read them '
                       'from; give azimuths, or name the force sensor topic')
        return problem, {'azimuths_rad': azimuths,
                         'presses': 0 if azimuths else (goal.presses
                                                        or self._param('calibration.presses'))}

    async def _polled(self, future: Future, watch):
        """Return ``future``'s result, calling ``watch`` (which may set it) every POLL_S."""
        timer = self._node.create_timer(POLL_S, watch)
        try:
            return await future
        finally:
            self._node.destroy_timer(timer)

    async def _off_the_executor(self, work):
        """
        Return ``work()`` run on a thread of its own, raising what it raises.

        A fit may take seconds (a force calibration that learns the taxel model): the executor
        goes on with scans, diagnostics and cancel requests meanwhile, polling for the end.
        """
        box = {}
        finished = threading.Event()

        def run():
            try:
                box['result'] = work()
            except Exception as err:  # noqa: B902 - handed to the awaiting action as it is
                box['error'] = err
            finally:
                finished.set()

        threading.Thread(target=run, name='calibration fit', daemon=True).start()
        future = Future()

        def watch():
            if finished.is_set() and not future.done():
                future.set_result(True)
        await self._polled(future, watch)
        if 'error' in box:
            raise box['error']
        return box['result']

    def _gains_args(self, goal) -> tuple:
        return request_problem(goal.presses, goal.timeout), {'presses': goal.presses or 1}

    def _executor(self, action, kind: str, goal_args, answer):
        async def execute(goal_handle):
            try:
                return await self._run(goal_handle, action.Result(), kind, goal_args, answer)
            finally:
                self._running.release()
        return execute

    async def _run(self, goal_handle, result, kind: str, goal_args, answer):
        """Run one session; every way but success leaves the calibration in force."""
        answer(result, self._get_estimator().calibration, None)
        result.success = False
        try:
            problem, args = goal_args(goal_handle.request)
            # A file that would not be written: said before any press is awaited.
            problem = problem or self._file.problem()
            if problem:
                raise CalibrationRefused(problem)
            session = CalibrationSession(
                self._get_estimator(), kind, skin=self._skin,
                normal_tolerance_m=self._param('calibration.normal_tolerance'), **args)
        except CalibrationRefused as err:
            result.message = f'{err}{KEEP}'
            self._node.get_logger().warning(f'{kind} calibration goal aborted: {result.message}')
            goal_handle.abort()
            return result
        timeout = goal_handle.request.timeout or self._param('calibration.timeout')
        running = RunningCalibration(session, goal_handle, self._on_note)
        self._running_now = running
        self._node.get_logger().info(
            f'calibration ({kind}): make {session.wanted} presses within {timeout:.0f} s')
        try:
            outcome = await goal_outcome(self._node, goal_handle, lambda: session.done, timeout)
        finally:
            self._running_now = None
            running.close()
            self._dropped += running.dropped
        if running.dropped:
            self._node.get_logger().warning(
                f'calibration ({kind}): {running.dropped} scans dropped, its worker being '
                f'{MAX_WAITING_SCANS} scans behind; its presses are read from the others')
        result.presses_used = len(session.accepted)
        made = f'{len(session.accepted)} of {session.wanted} presses'
        if outcome == 'cancel':
            result.message = f'cancelled with {made}{KEEP}'
            self._node.get_logger().info(f'calibration ({kind}): {result.message}')
            goal_handle.canceled()
            return result
        if outcome == 'timeout':
            ignored = (f'; {session.ignored} ignored, the last one because {session.last_ignored}'
                       if session.ignored else '')
            result.message = f'timed out after {timeout:.0f} s with {made}{ignored}{KEEP}'
            self._node.get_logger().warning(f'calibration ({kind}): {result.message}')
            goal_handle.abort()
            return result
        try:
            outcome = await self._off_the_executor(session.finish)
            path = self._file.save(outcome.calibration)
        except (CalibrationRefused, OSError, ValueError) as err:
            result.message = f'{err}{KEEP}'
            self._node.get_logger().warning(f'calibration ({kind}): {result.message}')
            goal_handle.abort()
            return result
        self._put_calibration(outcome.calibration)
        self.warning = ''
        self._bind(outcome.calibration)
        self.note = f'calibration from {path}: {outcome.calibration.describe()}'
        answer(result, outcome.calibration, outcome)
        result.success = True
        result.presses_used = outcome.presses_used
        result.message = f'{outcome.message}; written to {path}'
        logger = self._node.get_logger()
        logger.info(f'calibration ({kind}): {result.message}')
        for warning in outcome.warnings:
            logger.warning(f'calibration ({kind}): {warning}')
        goal_handle.succeed()
        return result

    def file_problem(self) -> str:
        """Return why no calibration may be written to the file in force ('' when it may)."""
        return self._file.problem()

    def write_and_put(self, calibration) -> str:
        """
        Write ``calibration`` to the file, then put it in force; return the file's path.

        For a part another action makes (the mount, the creep): raises OSError or ValueError
        (FileRefused for a refused file) when the file cannot be written, and then nothing
        changes.
        """
        path = self._file.save(calibration)
        self._put_calibration(calibration)
        self.note = f'calibration from {path}: {calibration.describe()}'
        return path

    # ---- reset -------------------------------------------------------------------------------
    def _on_reset(self, request, response):
        running = self._running_now
        if running is not None:
            response.success = False
            response.message = (f'reset refused: a {running.session.kind} calibration is '
                                'running; cancel it first' + KEEP)
            self._node.get_logger().warning(response.message)
            return response
        defaults = Calibration(skin=self._skin)
        kept = os.path.isfile(self._file.path)
        try:
            path = self._file.save(defaults)
        except (OSError, ValueError) as err:
            response.success = False
            response.message = f'reset refused: {err}{KEEP}'
            self._node.get_logger().warning(response.message)
            return response
        self._put_calibration(defaults)
        self.warning = ''
        self._bind(defaults)
        self.note = f'calibration reset to the defaults in {path}'
        response.success = True
        response.message = self.note + (f' (the previous one is kept as {backup_of(path)})'
                                        if kept else '')
        self._node.get_logger().info(self.note)
        return response
