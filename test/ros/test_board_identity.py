"""The board's identity through the nodes: /diagnostics, board_info and the calibration binding."""

from diagnostic_msgs.msg import DiagnosticStatus
from pipeline import call, pipeline, scene
import pytest
from rclpy.parameter import Parameter
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinIdentity
from skin_driver.core.protocol.wire import BoardInfo
from skin_driver.core.sim.board import SIM_UID
from skin_driver.ros import qos
from skin_driver.ros.conversions import status_values
from std_msgs.msg import String
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

NUCLEO_UID = '0039001e3438510b34313939'
ON_NUCLEO = SkinIdentity(16, 16, 0.005, '', NUCLEO_UID, 'nucleo-f446re')
ON_SIM = SkinIdentity(16, 16, 0.005, '', SIM_UID, 'sim')


def latest(probe, suffix):
    """Return (values, level, message) of the newest status whose name ends with suffix."""
    statuses = probe.statuses_of(suffix)
    if not statuses:
        return {}, None, ''
    return status_values(statuses[-1]), statuses[-1].level, statuses[-1].message


def link_values(probe):
    return latest(probe, 'skin link')[0]


def estimation(probe):
    return latest(probe, 'contact estimation')


def save(path, x_p_m, skin):
    Calibration(x_p_m=x_p_m, presses=8, skin=skin).save_yaml(path)
    return str(path)


@pytest.mark.parametrize('fused', [False, True], ids=['nodes', 'fused'])
def test_another_boards_calibration_is_refused_and_the_board_is_reported(tmp_path, fused):
    save(tmp_path / 'calibration.yaml', 4e-4, ON_NUCLEO)
    with pipeline(tmp_path, scene([]), fused=fused) as (sim, driver, direction, probe, executor):
        # The driver says who the board is.
        assert spin_until(executor, lambda: link_values(probe).get('board') == 'sim')
        values = link_values(probe)
        assert (values['board uid'], values['board firmware'], values['board grid'],
                values['board pitch [mm]'], values['board scan rate [Hz]']) == (
            SIM_UID, '0.1.0', '16x16', '5', '200')
        assert latest(probe, 'skin link')[1] == DiagnosticStatus.OK
        # and says it on board_info, latched for a late subscriber.
        heard = []
        late = direction.create_subscription(String, '/board_info', heard.append, qos.latched())
        assert spin_until(executor, lambda: heard)
        direction.destroy_subscription(late)
        assert BoardInfo.parse(heard[0].data) == sim.identity
        # The calibration made on the nucleo board is refused on the sim board, naming both.
        # (Until the board says who it is, the file is in force, with a note naming its board.)
        assert spin_until(executor, lambda: 'this skin is on board sim' in estimation(probe)[2])
        _, level, message = estimation(probe)
        assert level == DiagnosticStatus.WARN
        assert (f'made on board nucleo-f446re uid {NUCLEO_UID}; this skin is on board sim uid '
                f'{SIM_UID}') in message
        assert direction.host.estimator.calibration == Calibration()

        # The nucleo's file is never written (issue #47: reset wrote the defaults into it).
        nucleo_bytes = (tmp_path / 'calibration.yaml').read_bytes()
        answer = call(executor, direction, Trigger, '/skin_direction/reset_calibration',
                      Trigger.Request())
        assert not answer.success
        assert f"{tmp_path / 'calibration.yaml'} is not written" in answer.message
        assert (tmp_path / 'calibration.yaml').read_bytes() == nucleo_bytes

        # A file bound to no board loads, with a note.
        unbound = save(tmp_path / 'old.yaml', 2e-4, SkinIdentity(16, 16, 0.005))
        assert direction.set_parameters([Parameter('calibration_file',
                                                   value=unbound)])[0].successful
        assert direction.host.estimator.calibration.x_p_m == 2e-4
        assert direction.host.calibration.warning == ''
        assert 'bound to no board' in direction.host.calibration.binding
        assert spin_until(executor, lambda: estimation(probe)[0].get(
            'calibration file') == unbound)
        assert 'bound to no board' in estimation(probe)[0]['calibration board']
        assert estimation(probe)[1] == DiagnosticStatus.OK, estimation(probe)[2]

        # A calibration made now is bound to this board, in the file in force.
        answer = call(executor, direction, Trigger, '/skin_direction/reset_calibration',
                      Trigger.Request())
        assert answer.success and f'in {unbound} (' in answer.message
        made_here = Calibration.load_yaml(unbound)
        assert made_here.skin == ON_SIM
        assert direction.host.estimator.calibration == made_here
        assert spin_until(executor, lambda: estimation(probe)[0].get(
            'calibration board') == f'bound to board sim uid {SIM_UID}')
        assert estimation(probe)[1] == DiagnosticStatus.OK, estimation(probe)[2]

        # A file from another board set at run time is refused by the set, with the reason:
        # the calibration in force stays, and so does the file it came from.
        other = save(tmp_path / 'nucleo.yaml', 3e-4, ON_NUCLEO)
        result = direction.set_parameters([Parameter('calibration_file', value=other)])[0]
        assert not result.successful
        assert result.reason.startswith(
            f'calibration file refused: {other}: made on board nucleo-f446re uid {NUCLEO_UID}; '
            f'this skin is on board sim uid {SIM_UID}')
        assert direction.get_parameter('calibration_file').value == unbound
        assert direction.host.estimator.calibration == made_here

        # So is a skin name under which the file in force would be another skin's.
        assert direction.set_parameters([Parameter('calibration.skin_id',
                                                   value='left')])[0].successful
        assert call(executor, direction, Trigger, '/skin_direction/reset_calibration',
                    Trigger.Request()).success
        named = Calibration.load_yaml(unbound)
        assert named.skin.board_id == 'left'
        result = direction.set_parameters([Parameter('calibration.skin_id', value='right')])[0]
        assert not result.successful
        assert result.reason.startswith(f'calibration file refused: {unbound}: made for ')
        assert direction.get_parameter('calibration.skin_id').value == 'left'
        assert direction.host.estimator.calibration == named
    assert (tmp_path / 'calibration.yaml').read_bytes() == nucleo_bytes


def test_a_version_1_board_is_anonymous_and_a_bound_file_loads_with_a_warning(tmp_path):
    save(tmp_path / 'calibration.yaml', 4e-4, ON_NUCLEO)
    with pipeline(tmp_path, scene([]), identity=None) as (sim, _, direction, probe, executor):
        assert spin_until(executor, lambda: link_values(probe).get('frames', '0') != '0'
                          and 'does not say who it is' in estimation(probe)[2])
        assert link_values(probe)['board'] == 'no board identity (version-1 stream)'
        assert 'board uid' not in link_values(probe)
        _, level, message = estimation(probe)
        assert level == DiagnosticStatus.WARN
        assert f'calibration made on board nucleo-f446re uid {NUCLEO_UID}' in message
        assert direction.host.estimator.calibration.x_p_m == 4e-4
