"""
Real-time scheduling of the thread that reads the skin, and the CPU time its stages take.

A reader at SCHED_FIFO runs as soon as its bytes arrive, ahead of every normal thread on the
machine. Linux allows it to a process with CAP_SYS_NICE or an RLIMIT_RTPRIO (``ulimit -r``) at
least as high as the priority; otherwise the request is refused and the reader stays at normal
priority with a warning that says how to grant it (README.md, "Real-time priority").
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
import os
import resource
import time
from typing import Callable, Optional

__all__ = ['NORMAL', 'Scheduling', 'schedule_this_thread', 'name_this_thread', 'StageCpu']

NORMAL = 'normal (SCHED_OTHER)'
_PR_SET_NAME = 15


@dataclass(frozen=True)
class Scheduling:
    """What a thread got: ``policy`` in words, and ``warning`` when its request was refused."""

    policy: str
    warning: str = ''


def _how_to_grant(priority: int) -> str:
    soft, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
    return (f'the rtprio limit is {soft} and the process lacks CAP_SYS_NICE; grant it with '
            f"'@realtime - rtprio {max(priority, 98)}' in /etc/security/limits.conf (and the "
            "user in group realtime), 'ulimit -r' in the launching shell, or in a container "
            f"'--ulimit rtprio={max(priority, 98)}' or '--cap-add SYS_NICE'")


def schedule_this_thread(priority: int, set_scheduler: Optional[Callable] = None) -> Scheduling:
    """
    Put the calling thread at SCHED_FIFO ``priority`` (1..99); 0 leaves it at normal priority.

    Never raises for a refusal: the thread stays as it was and the returned Scheduling carries
    the warning, for the caller to log. ``set_scheduler``: os.sched_setscheduler unless given.
    """
    if not priority:
        return Scheduling(NORMAL)
    low, high = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    if not low <= priority <= high:
        return Scheduling(NORMAL, f'SCHED_FIFO priority {priority} is outside {low}..{high}; '
                                  'reading at normal priority')
    try:
        # pid 0: the calling thread, not the whole process (Linux schedules threads).
        (set_scheduler or os.sched_setscheduler)(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        return Scheduling(NORMAL, f'SCHED_FIFO {priority} not permitted '
                                  f'({_how_to_grant(priority)}); reading at normal priority')
    except OSError as err:  # a container's real-time budget of 0 says EPERM or EINVAL
        return Scheduling(NORMAL, f'SCHED_FIFO {priority} refused: {err}; reading at normal '
                                  'priority')
    return Scheduling(f'SCHED_FIFO {priority}')


def name_this_thread(name: str) -> None:
    """Give the calling thread an OS name (top -H, /proc/<pid>/task/*/comm); best effort."""
    try:
        ctypes.CDLL(None).prctl(_PR_SET_NAME, name.encode()[:15], 0, 0, 0)
    except (OSError, AttributeError):  # not Linux
        pass


class StageCpu:
    """
    Thread CPU time of the stages of a loop, measured on every ``every``-th pass.

    One pass: begin(), then mark(stage) at the end of each stage and frames(n) for the scans it
    handled. A sample costs a system call per stage; sampling keeps that off most passes.
    take() returns the mean CPU per scan of each stage since the last take.
    """

    def __init__(self, stages, every: int = 8):
        self._stages = tuple(stages)
        self._every = every
        self._passes = 0
        self._on = False
        self._last = 0
        self._reset()

    def _reset(self) -> None:
        self._totals = dict.fromkeys(self._stages, 0)
        self._frames = 0

    def begin(self) -> None:
        """Start a pass (measured or not)."""
        self._passes += 1
        self._on = self._passes % self._every == 0
        if self._on:
            self._last = time.thread_time_ns()

    def mark(self, stage: str) -> None:
        """End ``stage`` of this pass."""
        if self._on:
            now = time.thread_time_ns()
            self._totals[stage] += now - self._last
            self._last = now

    def frames(self, count: int) -> None:
        """Count the scans this pass handled."""
        if self._on:
            self._frames += count

    def take(self) -> dict:
        """Return {stage: mean us of thread CPU per scan} since the last take, and start anew."""
        frames, totals = self._frames, self._totals
        self._reset()
        return {k: (1e-3 * v / frames if frames else 0.0) for k, v in totals.items()}
