"""
Wrenches of contacts about the skin frame's origin, as a force/torque sensor there would report.

A force F applied at r = (x, y, 0) on the skin has the torque r x F about the origin; the net
wrench of several contacts is the sum of their forces and of their torques (zero when nothing
touches). Without r x F a transform to another frame would move a force's line of action.
"""

from __future__ import annotations

from typing import Iterable, Sequence

__all__ = ['torque_about_origin', 'net_wrench']


def torque_about_origin(x_m: float, y_m: float, force_xyz_n: Sequence[float]) -> tuple:
    """Return r x F (N m) of ``force_xyz_n`` applied at (x_m, y_m, 0)."""
    fx, fy, fz = force_xyz_n
    return (y_m * fz, -x_m * fz, x_m * fy - y_m * fx)


def net_wrench(contacts: Iterable) -> tuple:
    """Return (force, torque) summed over contacts (``x_m``, ``y_m``, ``force_xyz_n`` each)."""
    force = [0.0, 0.0, 0.0]
    torque = [0.0, 0.0, 0.0]
    for c in contacts:
        for i, (f, t) in enumerate(zip(c.force_xyz_n,
                                       torque_about_origin(c.x_m, c.y_m, c.force_xyz_n))):
            force[i] += f
            torque[i] += t
    return tuple(force), tuple(torque)
