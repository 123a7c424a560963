"""
Which mount of the skin is in force: the one measured on it, or the one typed in.

A skin's pose on its parent link comes from one of two places. ``~/calibrate_mount`` measures it
from touches and stores it in the skin's calibration file, so it lasts across restarts; the
parameters ``parent_frame`` and ``mount_x`` .. ``mount_yaw`` (the launch arguments of the same
names) give it as typed numbers, for this run only. The measured mount wins: it was found on
this very skin, and a launch file's numbers are often a default copied from another robot. When
both are there and disagree, the warning names both and says which wins. With neither, the
skin's frame stands alone (no transform).
"""

from dataclasses import dataclass
import math

__all__ = ['CALIBRATED', 'GIVEN', 'Mount', 'mount_in_force']

CALIBRATED = 'calibration'
GIVEN = 'parameters'
# Two mounts closer than this are the same (a calibrated pose pasted into the launch file).
_SAME_M = 1e-4
_SAME_RAD = 1e-3


@dataclass(frozen=True)
class Mount:
    """The skin frame's pose on ``parent_frame`` and where it comes from (CALIBRATED or GIVEN)."""

    parent_frame: str
    xyz_m: tuple
    rpy_rad: tuple
    source: str

    def describe(self) -> str:
        """Return the link and the pose, e.g. 'base_link at xyz (0.100, 0.000, 0.050) m, ...'."""
        xyz = ', '.join(f'{v:.3f}' for v in self.xyz_m)
        rpy = ', '.join(f'{v:.3f}' for v in self.rpy_rad)
        return f'{self.parent_frame} at xyz ({xyz}) m, rpy ({rpy}) rad'

    def same_as(self, other: 'Mount') -> bool:
        """Return whether ``other`` places the skin at the same pose on the same link."""
        return (self.parent_frame == other.parent_frame
                and all(math.isclose(a, b, abs_tol=_SAME_M)
                        for a, b in zip(self.xyz_m, other.xyz_m))
                and all(math.isclose(a, b, abs_tol=_SAME_RAD)
                        for a, b in zip(self.rpy_rad, other.rpy_rad)))


def mount_in_force(calibrated, given_parent: str, given_xyz=(0.0, 0.0, 0.0),
                   given_rpy=(0.0, 0.0, 0.0), where: str = 'the calibration file') -> tuple:
    """
    Return (mount in force or None, warning or '') from the calibrated and the given mount.

    ``calibrated``: the calibration's mount (anything with parent_frame, xyz_m, rpy_rad; None:
    not calibrated). ``given_parent`` '': no mount given. ``where`` names the calibration file.
    """
    given = (Mount(given_parent, tuple(map(float, given_xyz)), tuple(map(float, given_rpy)),
                   GIVEN) if given_parent else None)
    if calibrated is None:
        return given, ''
    measured = Mount(calibrated.parent_frame, tuple(calibrated.xyz_m),
                     tuple(calibrated.rpy_rad), CALIBRATED)
    if given is None or given.same_as(measured):
        return measured, ''
    return measured, (
        f'two mounts for this skin: {where} has {measured.describe()} (~/calibrate_mount), the '
        f'parameters parent_frame and mount_* give {given.describe()}. The calibrated mount '
        'wins and goes on /tf_static; to use the other, run ~/calibrate_mount on '
        f'{given.parent_frame} (or reset the calibration, which drops every calibrated part)')
