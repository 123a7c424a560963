"""
The creep action: how the skin's reading rises under a held load, the ROS side of core creep.py.

``CreepCalibration(node, get_estimator, put_creep)`` offers ``~/calibrate_creep``
(skin_msgs/action/CalibrateCreep). One known load is put on the skin and held still; the node
calls :meth:`feed` with every scan's time and contacts (on the scans' thread). Each contact's
force is read with the creep correction in force undone (the estimator's own factor at the
contact's time under load), so a calibration fits the film as it is, whatever was in force. On
success the fit goes to ``put_creep`` (stored with the calibration, then in force) and is
returned. A load that never comes, comes off, moves or changes ends the goal with the reason; a
refused, failed or cancelled calibration changes nothing; each is logged, as is a rejected goal.
"""

import math
import threading

from rclpy.action import CancelResponse, GoalResponse
from skin_driver.core.estimation.calibration.creep import CreepError, CreepSession, MIN_HOLD_S
from skin_driver.ros.calibration_services import goal_outcome
from skin_driver.ros.lifetime import ActionOwner
from skin_msgs.action import CalibrateCreep

DEFAULT_HOLD_S = 180.0
MAX_HOLD_S = 3600.0
# Seconds between two feedbacks (the scans come hundreds a second).
FEEDBACK_S = 0.5
NOTHING = '; the previous calibration stays in force'
# What a calibration with a rest asks for next, by the session's phase.
_DUE = {'release': 'held long enough: take the load off now',
        'rest': 'load off: put it back in a moment, where it was',
        'repress': 'load back: hold it two seconds'}


class _Running:
    """One running calibration: read whole by the scans' thread, set whole by the executor."""

    def __init__(self, session: CreepSession, goal, estimator):
        self.session = session
        self.goal = goal
        self.estimator = estimator
        self.error = ''
        self.force = 0.0
        self.fed_s = -math.inf
        self.phase = session.phase


class CreepCalibration(ActionOwner):
    """Offer ~/calibrate_creep on ``node``."""

    def __init__(self, node, get_estimator, put_creep, file_problem=lambda: ''):
        """
        Create the action; put_creep(fit) stores a fit and returns where it was written.

        file_problem() says why nothing may be written (a refused file): the goal then ends at
        once, before the load is awaited.
        """
        self._node = node
        self._file_problem = file_problem
        self._get_estimator = get_estimator
        self._put_creep = put_creep
        self._running = None
        self._busy = threading.Lock()
        self.serve(node, CalibrateCreep, '~/calibrate_creep', self._execute, self._on_goal,
                   self._on_cancel)

    # ---- per scan ----------------------------------------------------------------------------
    def feed(self, time_s: float, contacts) -> None:
        """Give the running calibration, if any, one scan's time and contacts."""
        running = self._running
        if running is None or running.error or running.session.done:
            return
        est = running.estimator
        # The film's own reading: the correction in force taken off again.
        read = [_Read(c.x_m, c.y_m, c.force_n * est.creep_factor(c.held_s)) for c in contacts]
        try:
            running.session.add(time_s, read)
        except CreepError as err:
            running.error = str(err)
            return
        if read:
            running.force = read[0].force_n
        session = running.session
        held, phase = session.held_s, session.phase
        note = _DUE.get(phase, '')
        if phase != running.phase and note:
            running.phase = phase
            self._node.get_logger().info(f'creep calibration: {note}')
        elif phase == 'hold' and read and held - running.fed_s >= FEEDBACK_S:
            running.fed_s = held
            note = f'held {held:.1f} of {session.hold_s:.0f} s'
        else:
            return
        running.goal.publish_feedback(CalibrateCreep.Feedback(
            held=held, hold=session.hold_s, force=running.force, note=note))

    # ---- action ------------------------------------------------------------------------------
    def _on_goal(self, request) -> GoalResponse:
        if not self._busy.acquire(blocking=False):
            self._node.get_logger().warning(
                'creep calibration goal rejected: one is already running; wait for it to end '
                'or cancel it')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle) -> CancelResponse:
        self._node.get_logger().info('creep calibration: cancel requested' + NOTHING)
        return CancelResponse.ACCEPT

    @staticmethod
    def _problem(goal) -> str:
        """Return why the goal cannot be served, or ''."""
        for name in ('load', 'hold', 'rest', 'timeout'):
            value = getattr(goal, name)
            if not (math.isfinite(value) and value >= 0.0):
                return f'{name} {value} is not a number >= 0'
        if goal.hold and not MIN_HOLD_S <= goal.hold <= MAX_HOLD_S:
            return (f'hold {goal.hold:g} s is not in [{MIN_HOLD_S:g}, {MAX_HOLD_S:g}] s; a few '
                    'minutes (0: the default) see the creep best')
        hold = goal.hold or DEFAULT_HOLD_S
        if goal.rest > MAX_HOLD_S:
            return f'rest {goal.rest:g} s is over {MAX_HOLD_S:g} s'
        if goal.timeout and goal.timeout < hold + goal.rest:
            return (f'timeout {goal.timeout:g} s is shorter than the hold and the rest '
                    f'({hold + goal.rest:g} s)')
        return ''

    async def _execute(self, goal_handle):
        """Serve one goal; whatever ends it, the next goal is taken."""
        result = CalibrateCreep.Result()
        try:
            message, finish = await self._serve(goal_handle, result)
        finally:
            self._running = None
            self._busy.release()
        result.message = message
        log = self._node.get_logger()
        (log.info if result.success else log.warning)(f'creep calibration: {message}')
        (goal_handle.succeed if result.success else finish)()
        return result

    async def _serve(self, goal_handle, result) -> tuple:
        """Run the goal into ``result``; return (its message, how a failure ends it)."""
        goal = goal_handle.request
        problem = self._problem(goal) or self._file_problem()
        if problem:
            return f'refused: {problem}{NOTHING}', goal_handle.abort
        estimator = self._get_estimator()
        hold = goal.hold or DEFAULT_HOLD_S
        timeout = goal.timeout or hold + 2.0 * goal.rest + 60.0
        session = CreepSession(hold, estimator.config.pitch_m,
                               estimator.config.creep_recovery_s, goal.rest)
        running = self._running = _Running(session, goal_handle, estimator)
        self._node.get_logger().info(
            f'creep calibration: put one load on the skin and hold it still for {hold:.0f} s '
            f'(within {timeout:.0f} s)')
        try:
            outcome = await goal_outcome(self._node, goal_handle,
                                         lambda: bool(running.error) or session.done, timeout)
        finally:
            self._running = None
        result.held = session.held_s
        if outcome == 'cancel':
            return f'cancelled after {session.held_s:.0f} s held{NOTHING}', goal_handle.canceled
        if running.error:
            return f'{running.error}{NOTHING}', goal_handle.abort
        if outcome == 'timeout':
            why = ('no load arrived' if session.held_s == 0 else
                   f'the load was held {session.held_s:.0f} of {hold:.0f} s'
                   if session.phase == 'hold' else
                   f'the load was not taken off and put back ({_DUE[session.phase]})')
            return f'timed out after {timeout:.0f} s: {why}{NOTHING}', goal_handle.abort
        try:
            fit = session.finish()
            written = self._put_creep(fit)
        except (CreepError, OSError, ValueError) as err:
            return f'{err}{NOTHING}', goal_handle.abort
        result.per_decade, result.settle = fit.per_decade, fit.settle_s
        result.recovery = fit.recovery_s
        result.over_48h, result.load_read = fit.over_48_hours(), fit.load_n
        result.success = True
        known = (f'; the load weighs {goal.load:.2f} N, read {fit.load_n:.2f} N at its arrival'
                 if goal.load > 0 else '')
        recovered = (f'; recovers in {fit.recovery_s:.0f} s' if goal.rest > 0 else '')
        # The rate is that of the newtons read: through the assumed film's curve it is off by
        # as much as the skin's own curve bends away from it.
        assumed = ('; fitted on the assumed film (no force calibration in force): calibrate '
                   'force first, then creep' if estimator.calibration.force_curves is None
                   else '')
        return f'{fit.describe()}{recovered}{known}{assumed}{written}', goal_handle.abort


class _Read:
    """A contact as the creep session reads it: where, and its force with the creep undone."""

    __slots__ = ('x_m', 'y_m', 'force_n')

    def __init__(self, x_m: float, y_m: float, force_n: float):
        self.x_m, self.y_m, self.force_n = x_m, y_m, force_n
