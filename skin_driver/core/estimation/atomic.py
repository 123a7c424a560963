"""
Write files so that a reader, or a crash, never sees half of one.

The content goes to a temporary file in the same directory, is flushed to disk, and then
replaces the target in one rename; the directory is synced so that the rename survives a power
cut. A crash at any point leaves either the old file or the new one.
"""

import os
import tempfile
from typing import Callable, IO


def write_atomically(path, write: Callable[[IO], None], binary: bool = False) -> None:
    """Call write(file) on a temporary file and move it over path once complete."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
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
