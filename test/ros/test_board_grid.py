"""The grid and pitch from the board's own word; parameters override it, a contradiction stops."""

from diagnostic_msgs.msg import DiagnosticStatus
from lifecycle_msgs.srv import GetState
from pipeline import call, pipeline, scene
import pytest
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosutil import spin_until
from skin_driver.ros.conversions import status_values
from skin_msgs.msg import SkinInfo

pytestmark = pytest.mark.ros

WAIT_S = 30.0
# Nothing set: every value is the board's.
THE_BOARDS = {'rows': 0, 'cols': 0, 'pitch': 0.0}
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)


def link(probe):
    """Return (level, message, values) of the newest skin link status, or (None, '', {})."""
    status = probe.latest('skin link')
    if status is None:
        return None, '', {}
    return status.level, status.message, status_values(status)


def state(executor, node):
    """Return the driver's lifecycle state, asked through its get_state service."""
    answer = call(executor, node, GetState, '/skin_driver/get_state', GetState.Request())
    return answer.current_state.label


@pytest.mark.parametrize('fused', [False, True], ids=['nodes', 'fused'])
def test_an_unset_grid_and_pitch_are_the_boards(tmp_path, fused):
    # An 8 x 10 board at 4 mm, and a driver told nothing: its frames carry the board's grid and
    # pitch, and a press is estimated where it is on that skin (x = 4 mm * column).
    press = {'time_s': 0.3, 'x_m': 0.02, 'y_m': 0.016, 'force_n': 8.0, 'duration_s': 60.0}
    with pipeline(tmp_path, scene([press], rows=8, cols=10, pitch_m=0.004),
                  driver=THE_BOARDS, fused=fused) as (_, _, _, probe, executor):
        if not fused:
            assert spin_until(executor, lambda: probe.frames, WAIT_S)
            first = probe.frames[0]
            assert (first.rows, first.cols) == (8, 10)
            assert first.pitch == pytest.approx(0.004)
        assert spin_until(executor, lambda: any(msg.contacts for msg in probe.contacts), WAIT_S)
        contact = next(msg for msg in probe.contacts if msg.contacts).contacts[0]
        assert contact.location.x == pytest.approx(0.02, abs=0.004)
        assert contact.location.y == pytest.approx(0.016, abs=0.004)
        said = "8x10 taxels at 4.000 mm pitch; all the board's word"
        assert spin_until(executor, lambda: link(probe)[2].get('grid') == said, WAIT_S)
        assert link(probe)[0] == DiagnosticStatus.OK
        # The skin's description says the board's grid and pitch too.
        described = []
        probe.node.create_subscription(SkinInfo, '/skin_info', described.append, LATCHED)
        assert spin_until(executor, lambda: any(m.board_uid for m in described), WAIT_S)
        info = [m for m in described if m.board_uid][-1]
        assert (info.rows, info.cols) == (8, 10) and info.pitch == pytest.approx(0.004)


def test_a_set_pitch_the_board_contradicts_stops_the_driver_naming_both(tmp_path, capfd):
    with pipeline(tmp_path, scene([]), driver={'pitch': 0.006}) as (_, driver, direction, probe,
                                                                    executor):
        said = ("parameter 'pitch' is 6.000 mm but board sim says its pitch is 5.000 mm: scans "
                'are not used')
        assert spin_until(executor, lambda: said in link(probe)[1]
                          and link(probe)[0] == DiagnosticStatus.ERROR, WAIT_S)
        # The driver deactivated itself, still saying why; it will not read again as it is.
        assert spin_until(executor, lambda: link(probe)[1].startswith('inactive: '), WAIT_S)
        assert link(probe)[0] == DiagnosticStatus.ERROR and said in link(probe)[1]
        assert state(executor, direction) == 'inactive'
        assert driver.trigger_activate() == TransitionCallbackReturn.FAILURE
        assert state(executor, direction) == 'inactive'
        err = capfd.readouterr().err
        assert f'scans not used: {said}' in err and f'not activated: {said}' in err
        # Set as the board says, and configured afresh, it reads.
        driver.trigger_cleanup()
        assert driver.set_parameters([Parameter('pitch', value=0.005)])[0].successful
        driver.trigger_configure()
        driver.trigger_activate()
        probe.reset()
        assert spin_until(executor, lambda: probe.frames and link(probe)[0] is not None, WAIT_S)
        assert link(probe)[0] != DiagnosticStatus.ERROR


def test_a_set_grid_the_board_contradicts_stops_the_driver_naming_both(tmp_path):
    with pipeline(tmp_path, scene([], rows=12, cols=12),
                  driver={'rows': 16, 'cols': 16}) as (_, _, direction, probe, executor):
        said = ("parameter 'rows' is 16; parameter 'cols' is 16 but board sim says its grid is "
                '12x12: scans are not used')
        assert spin_until(executor, lambda: said in link(probe)[1]
                          and link(probe)[1].startswith('inactive: '), WAIT_S)
        assert link(probe)[0] == DiagnosticStatus.ERROR
        assert state(executor, direction) == 'inactive'


def test_a_version_1_board_needs_its_pitch_set(tmp_path):
    # It says no pitch: its scans are held (counted, not published) and /diagnostics says what
    # to set.
    with pipeline(tmp_path, scene([]), driver=THE_BOARDS,
                  identity=None) as (_, _, _, probe, executor):
        assert spin_until(executor, lambda: int(link(probe)[2].get(
            "scans held for the board's word", '0')) > 0, WAIT_S)
        level, message, values = link(probe)
        assert level == DiagnosticStatus.WARN
        assert "waiting for the board's pitch" in message
        assert "set the 'pitch' parameter" in message
        assert values['grid'] == "16x16 taxels at the board's pitch; all the board's word"
        assert probe.frames == []
    with pipeline(tmp_path, scene([]), driver={**THE_BOARDS, 'pitch': 0.005},
                  identity=None) as (_, _, _, probe, executor):
        assert spin_until(executor, lambda: probe.frames, WAIT_S)
        assert probe.frames[0].pitch == pytest.approx(0.005)
