"""A calibration file of another grid: refused, and the skin it has is estimated all the same."""

import numpy as np
from pipeline import call, pipeline, scene
import pytest
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinIdentity
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

# Presses on a 12 x 12 skin, one every second for a while.
PRESSES = [{'time_s': 1.0 + 1.0 * i, 'x_m': 0.03, 'y_m': 0.025, 'duration_s': 0.6}
           for i in range(12)]


def pressed(probe):
    """Return how many contact arrays with a contact the probe has seen."""
    return sum(1 for msg in probe.contacts if msg.contacts)


def test_a_16_by_16_file_on_a_12_by_12_skin_is_refused_and_contacts_flow(tmp_path):
    """Issue #37: after the refusal every frame was dropped; #47: reset wrote the other's file."""
    path = tmp_path / 'calibration.yaml'
    Calibration(x_p_m=4e-4, presses=8, gains=(np.full((16, 16), 1.2), np.full((16, 16), 0.8)),
                skin=SkinIdentity(16, 16, 0.005)).save_yaml(path)
    with pipeline(tmp_path, scene(PRESSES, rows=12, cols=12), rate_hz=100.0,
                  driver={'rows': 12, 'cols': 12}) as (_, _, direction, probe, executor):
        assert spin_until(executor, lambda: pressed(probe) >= 5, 20.0), \
            'no contacts on the 12 x 12 skin after the refusal'
        assert direction.host.estimator.calibration.gains is None
        # The other grid's file is not this skin's: reset does not write it (issue #47), and
        # the defaults it would put in force already are.
        before = path.read_bytes()
        answer = call(executor, direction, Trigger, '/skin_direction/reset_calibration',
                      Trigger.Request())
        assert not answer.success and f'{path} is not written' in answer.message
        seen = pressed(probe)
        assert spin_until(executor, lambda: pressed(probe) >= seen + 3, 20.0), \
            'no contacts after reset_calibration'
    assert path.read_bytes() == before
