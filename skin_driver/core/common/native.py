"""Where a compiled library of this repository's colcon packages is looked for (ctypes)."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path


def library_places(package: str, library: str, variable: str) -> list:
    """
    Return the places ``library`` of colcon ``package`` is looked for, in order, as (where, path).

    The file the environment variable ``variable`` names, alone when it is set; else the install
    prefix skin_driver is installed under (``<prefix>/lib/python3.X/site-packages``:
    ``<prefix>/lib``, and a colcon workspace's ``install/<package>/lib`` beside
    ``install/skin_driver``); the workspace next to a source checkout
    (``<checkout>/install/<package>/lib``); then the ament index, when importable (path None when
    it is not, or does not know the package).
    """
    named = os.environ.get(variable)
    if named:
        # Named explicitly: that file or nothing, never another one found by chance.
        return [(variable, Path(named))]
    out = []
    above = Path(__file__).resolve().parents[3]  # the folder that holds skin_driver
    if above.name in ('site-packages', 'dist-packages') and above.parent.parent.name == 'lib':
        prefix = above.parent.parent.parent
        out.append(('install prefix', prefix / 'lib' / library))
        out.append(('colcon workspace', prefix.parent / package / 'lib' / library))
    else:
        out.append(('source checkout', above / 'install' / package / 'lib' / library))
    try:
        from ament_index_python.packages import get_package_prefix, PackageNotFoundError
    except ImportError:
        out.append(('ament index', None))
    else:
        try:
            out.append(('ament index', Path(get_package_prefix(package)) / 'lib' / library))
        except PackageNotFoundError:
            out.append(('ament index', None))
    return out


def open_library(places: list, package: str, library: str, fix: str, missing: type) -> tuple:
    """
    Return (the loaded library, its path): the first of ``places`` that loads.

    Raise ``missing`` (an exception class) saying where it looked, then ``fix``, when none does.
    """
    looked = []
    for where, path in places:
        if path is None:
            looked.append(f'{where}: not available')
            continue
        if not path.is_file():
            looked.append(f'{where}: no {path}')
            continue
        try:
            return ctypes.CDLL(str(path)), path
        except OSError as exc:
            looked.append(f'{where}: {path} does not load ({exc})')
    raise missing(f'{package}: no {library} found; looked at ' + '; '.join(looked) + f'. {fix}')
