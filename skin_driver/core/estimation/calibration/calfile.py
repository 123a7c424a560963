"""
The calibration file a skin owns: which file may be written, and how.

A node reads its calibration from one file and writes every new calibration back to it. A file it
refused (made for another skin, grid or board, or unreadable) is not this skin's: it is never
written, neither by a calibration nor by a reset, so another skin's calibration, or a file a
person can still mend, is never lost. Writing to it is refused with the reason and the way out:
name a file of this skin's own (a path that does not exist yet is made by the first
calibration), or move the refused file away.

Every write keeps the file it replaces beside it as ``<file>.bak`` (one generation); both are
written atomically, so a crash leaves the old file, the new one, or both.
"""

from dataclasses import dataclass
import os

from .calibration import Calibration, SkinIdentity
from ...common.atomic import write_atomically

__all__ = ['BACKUP_SUFFIX', 'CalibrationFile', 'FileRefused', 'backup_of', 'refusal']

BACKUP_SUFFIX = '.bak'


class FileRefused(ValueError):
    """A calibration file this skin refused, which is therefore never written."""


def backup_of(path) -> str:
    """Return where the file at ``path`` keeps the calibration it replaced."""
    return os.fspath(path) + BACKUP_SUFFIX


def refusal(path, skin: SkinIdentity = None) -> str:
    """
    Return why the file at ``path`` is not a calibration of ``skin`` ('' when it is, or is absent).

    ``skin`` None: only whether the file reads as a calibration at all (its skin is checked once
    the scans show it).
    """
    if not os.path.exists(path):
        return ''
    try:
        Calibration.load_yaml(path, skin)
    except (OSError, ValueError) as err:
        return str(err)
    return ''


@dataclass(frozen=True)
class CalibrationFile:
    """
    The file a skin's calibration is read from and written to.

    ``refused`` says why it is not this skin's ('' when it is): such a file is never written.
    """

    path: str
    refused: str = ''

    def problem(self) -> str:
        """Return why nothing may be written to this file ('' when it may)."""
        if not self.refused:
            return ''
        return (f'{self.path} is not written: it was refused ({self.refused}); it is left as it '
                "is. Name a file of this skin's own in calibration_file (a new path is made by "
                'the first calibration), or move this one away')

    def save(self, calibration: Calibration) -> str:
        """
        Write ``calibration``, keeping the file it replaces as ``<file>.bak``; return the path.

        Raises FileRefused for a refused file, OSError or ValueError when it cannot be written
        (then the file is as it was).
        """
        problem = self.problem()
        if problem:
            raise FileRefused(problem)
        if os.path.isfile(self.path):
            with open(self.path, 'rb') as f:
                previous = f.read()
            write_atomically(backup_of(self.path), lambda f: f.write(previous), binary=True)
        # The node's own state: its folder (by default under ROS_HOME) is made as needed.
        calibration.save_yaml(self.path, make_parents=True)
        return self.path
