"""
Start the pipeline's programs as child processes and stop every one of them again.

The demo, the benchmark and the soak all run the simulator and the nodes as separate processes,
as a robot would. Each child gets a session of its own, so Ctrl-C in the terminal reaches only
the parent, which then stops the children in order; on Linux a child also dies with its parent
if the parent is killed outright, so nothing lingers.
"""

import ctypes
import os
import signal
import subprocess
import sys
import time
from typing import Iterable, List, Optional

PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    if sys.platform.startswith('linux'):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def spawn(argv: List[str], log, profile_to: Optional[str] = None, prefix: Iterable[str] = (),
          **popen) -> subprocess.Popen:
    """Run `[prefix...] python argv...` (optionally under cProfile), output to log."""
    head = list(prefix) + [sys.executable]
    if profile_to:
        head += ['-m', 'cProfile', '-o', profile_to]
    popen.setdefault('stdout', log)
    popen.setdefault('stderr', subprocess.STDOUT)
    return subprocess.Popen(head + argv, start_new_session=True, preexec_fn=_die_with_parent,
                            **popen)


def stop(procs: Iterable[subprocess.Popen], timeout_s: float = 5.0) -> None:
    """Interrupt the processes (as Ctrl-C would), then kill what is left after timeout_s."""
    procs = list(procs)
    for proc in procs:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
    deadline = time.monotonic() + timeout_s
    for proc in procs:
        try:
            proc.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
