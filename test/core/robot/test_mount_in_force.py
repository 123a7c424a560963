"""Which mount is in force: the calibrated one wins over the one given, saying so."""

from skin_driver.core.estimation.calibration.calibration import SkinMount
from skin_driver.core.robot.mount import CALIBRATED, GIVEN, mount_in_force

MEASURED = SkinMount('base_link', (0.1, 0.0, 0.05), (0.0, 0.0, 1.5708), 0.001, 6)


def test_the_calibrated_mount_wins_and_the_warning_names_both():
    mount, warning = mount_in_force(MEASURED, 'left_forearm_link', (0.0, 0.0, 0.05),
                                    (0.0, 1.5708, 0.0), where='/tmp/cal.yaml')
    assert (mount.parent_frame, mount.source) == ('base_link', CALIBRATED)
    assert mount.xyz_m == (0.1, 0.0, 0.05)
    assert warning.startswith(
        'two mounts for this skin: /tmp/cal.yaml has base_link at xyz (0.100, 0.000, 0.050) m, '
        'rpy (0.000, 0.000, 1.571) rad (~/calibrate_mount), the parameters parent_frame and '
        'mount_* give left_forearm_link at xyz (0.000, 0.000, 0.050) m, rpy (0.000, 1.571, '
        '0.000) rad. The calibrated mount wins')


def test_the_same_mount_given_twice_is_no_conflict():
    mount, warning = mount_in_force(MEASURED, 'base_link', (0.1, 0.0, 0.05),
                                    (0.0, 0.0, 1.57085))
    assert mount.source == CALIBRATED and warning == ''


def test_the_given_mount_is_in_force_without_a_calibrated_one_and_none_without_either():
    mount, warning = mount_in_force(None, 'left_forearm_link', (0.0, 0.0, 0.05))
    assert (mount.parent_frame, mount.xyz_m, mount.rpy_rad, mount.source, warning) == (
        'left_forearm_link', (0.0, 0.0, 0.05), (0.0, 0.0, 0.0), GIVEN, '')
    assert mount_in_force(None, '') == (None, '')
    assert mount_in_force(MEASURED, '')[0].source == CALIBRATED
