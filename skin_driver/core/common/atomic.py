"""
Write files so that a reader, or a crash, never sees half of one.

The content goes to a temporary file in the same directory, is flushed to disk, and then
replaces the target in one rename; the directory is synced so that the rename survives a power
cut. A crash at any point leaves either the old file or the new one.

A tool's output goes only where the user pointed it: a missing directory is an error, not created
(only a caller's own state, such as a node's calibration file, asks for its directories).
"""

import os
import tempfile
from typing import Callable, IO


def check_writable(path) -> str:
    """Return ``path`` when a file can be written there, else raise ValueError saying why."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ValueError(f'{path} is a directory; give a file name')
    if not os.path.isdir(directory):
        raise ValueError(f'{path}: directory {directory} does not exist; create it first')
    if not os.access(directory, os.W_OK):
        raise ValueError(f'{path}: directory {directory} is not writable')
    return path


def write_atomically(path, write: Callable[[IO], None], binary: bool = False,
                     make_parents: bool = False) -> None:
    """Call write(file) on a temporary file and move it over path once complete."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if make_parents:
        os.makedirs(directory, exist_ok=True)
    check_writable(path)
    name = os.path.basename(path)
    fd, tmp = tempfile.mkstemp(prefix=f'.{name}.', suffix='.tmp', dir=directory)
    try:
        with os.fdopen(fd, 'wb' if binary else 'w', **({} if binary else {'encoding': 'utf-8'})) \
                as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    _sync_directory(directory)


def _sync_directory(directory: str) -> None:
    try:
        dfd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass  # some file systems cannot sync a directory; the rename has happened anyway
    finally:
        os.close(dfd)
