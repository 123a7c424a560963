"""What happens between the simulated board and the host: line damage, and the device's link."""

from __future__ import annotations

import os

import numpy as np

DAMAGE_KINDS = ('bit flip', 'dropped byte', 'duplicated byte', 'inserted bytes', 'truncated')


def damage(raw: bytes, rng: np.random.Generator) -> bytes:
    """Return raw with one kind of line damage applied at a random place."""
    kind = DAMAGE_KINDS[int(rng.integers(len(DAMAGE_KINDS)))]
    data = bytearray(raw)
    at = int(rng.integers(len(data)))
    if kind == 'bit flip':
        data[at] ^= 1 << int(rng.integers(8))
    elif kind == 'dropped byte':
        del data[at]
    elif kind == 'duplicated byte':
        data.insert(at, data[at])
    elif kind == 'inserted bytes':
        data[at:at] = rng.integers(0, 256, int(rng.integers(1, 9)), dtype=np.uint8).tobytes()
    else:
        del data[max(at, 1):]
    return bytes(data)


def point_link(link: str, target: str) -> None:
    """Atomically make link a symlink to target; never replace anything but a symlink."""
    if os.path.lexists(link) and not os.path.islink(link):
        raise ValueError(f'link path {link!r} exists and is not a symlink; refusing to replace it')
    tmp = f'{link}.tmp{os.getpid()}'
    if os.path.lexists(tmp):
        os.unlink(tmp)
    os.symlink(target, tmp)
    os.replace(tmp, link)


def remove_link(link: str, target: str | None) -> None:
    """Remove link if it still points at target (as udev removes a by-id link on unplug)."""
    try:
        if os.path.islink(link) and os.readlink(link) == target:
            os.unlink(link)
    except OSError:
        pass
