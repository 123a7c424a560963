"""
`make soak`: the whole pipeline at 1 kHz under injected faults for a bounded time.

The simulated skin runs in this process (so its fault injection and its exact counters are at
hand); the driver and the direction node run as subprocesses, as on a robot. A cycle of faults
repeats until the time is up: line noise, a stall, an unplug and replug, a sequence gap and a
burst. A subscriber checks every published SkinFrame against the simulator's ground truth, and
the resident memory (VmRSS) of both nodes is sampled throughout.

Frame accounting (all counts exact; "balance" lines must be 0):

* device: every sequence number the board used = frames sent + frames never sent (unplugged,
  output queue full) + sequence numbers skipped by the firmware;
* line: frames sent = frames published by the driver + frames damaged by line noise + frames
  still unread in the pty when the cable was pulled + frames discarded when the driver opened
  the port (pyserial empties the input buffer on open, so what the board sent into a freshly
  plugged pty before the driver opened it is gone: the first sequence number the driver
  publishes after each (re)plug, less the first one the board sent into that pty);
* driver: the sequence numbers from its first published frame to its last = frames published +
  its 'frames dropped' (sequence gaps within a connection plus frames lost while the device was
  away, which includes the frames discarded at a reopen; frames lost after its last frame, it
  cannot know of).

``python -m skin_driver.tools.soak --duration 300 --json soak.json``
prints a summary and writes it.
"""

import argparse
import collections
import json
import os
import random
import shutil
import sys
import tempfile
import time

import numpy as np
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.ros.conversions import skin_frame_layers, status_values
from skin_driver.tools.harness import (
    grid_params, ros_args, ros_session, start_nodes, stop, wait_for, write_params)
from skin_driver.tools.probe import Probe
from skin_msgs.msg import SkinFrame

FAULT_PERIOD_S = 4.0      # one fault starts every this many seconds
MEMORY_PERIOD_S = 2.0     # resident memory sampled this often
WARM_UP_S = 20.0          # memory samples before this are left out of the drift fit
DRAIN_S = 3.0             # after the board stops, time for the last frames to come through
FAULTS = ('noise', 'stall', 'unplug', 'gap', 'burst')


def rss_mb(pid: int) -> float:
    """Return the resident memory of a process in MB, or NaN once it is gone."""
    try:
        with open(f'/proc/{pid}/status') as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float('nan')


def drift_mb_per_hour(samples) -> float:
    """Return the least-squares slope of (seconds, MB) samples, in MB per hour."""
    pts = np.array([(t, m) for t, m in samples if t >= WARM_UP_S and m == m])
    if len(pts) < 3:
        pts = np.array([(t, m) for t, m in samples if m == m])
    if len(pts) < 2:
        return float('nan')
    slope = np.polyfit(pts[:, 0], pts[:, 1], 1)[0]
    return float(slope * 3600.0)


class SoakMonitor:
    """Count and check what the pipeline publishes, through a Probe on node."""

    def __init__(self, node, sim: SimulatedSkin):
        self.sim = sim
        self.received = 0
        self.first_seq = None
        self.last_seq = None
        self.seqs_after_mark = []
        self.mismatched = 0
        self.unknown = 0
        self.last_frame_s = 0.0
        self.link = None
        self.levels = collections.Counter()
        self.seen = collections.Counter()
        self.diag_count = 0
        self._prefix = node.get_namespace().rstrip('/') + '/'
        self.probe = Probe(node, depth=5000, on_frame=self._on_frame, on_status=self._on_status)

    @property
    def contacts(self) -> int:
        """Return the number of contacts messages received."""
        return len(self.probe.record.sequence)

    def _on_frame(self, msg: SkinFrame) -> None:
        self.received += 1
        self.last_frame_s = time.monotonic()
        if self.first_seq is None:
            self.first_seq = msg.sequence
        self.last_seq = msg.sequence
        first_on_pty = self.sim.first_seq_since_plug
        # A frame of the previous pty may still be on its way after a replug: not the first.
        if not self.seqs_after_mark and first_on_pty is not None and msg.sequence >= first_on_pty:
            self.seqs_after_mark.append(msg.sequence)
        truth = self.sim.truth(msg.sequence)
        if truth is None:
            self.unknown += 1
            return
        try:
            top, bottom = skin_frame_layers(msg)
        except ValueError:
            self.mismatched += 1
            return
        if (msg.device_time_us != truth.device_time_us or not np.array_equal(top, truth.top)
                or not np.array_equal(bottom, truth.bottom)):
            self.mismatched += 1

    def _on_status(self, status) -> None:
        if not status.name.startswith(self._prefix) or not status.name.endswith('skin link'):
            return
        self.diag_count += 1
        self.link = status_values(status)
        self.link['level'] = int.from_bytes(status.level, 'little') \
            if isinstance(status.level, bytes) else int(status.level)
        self.link['message'] = status.message
        self.levels[self.link['level']] += 1
        for word in ('stalled', 'disconnected', 'corrupt', 'dropped', 'wrong grid'):
            if word in status.message:
                self.seen[word] += 1


class FaultCycle:
    """Inject the faults one after the other and remember what was done."""

    def __init__(self, sim: SimulatedSkin, seed: int):
        self.sim = sim
        self.rng = random.Random(seed)
        self.injected = collections.Counter()
        self.reconnect_s = []
        self.discarded_at_open = 0
        self._index = 0
        self._replug_at = None
        self._noise_until = None

    def step(self, now: float, monitor: SoakMonitor) -> None:
        """Start the next fault, end the running ones that are due."""
        if self._noise_until is not None and now >= self._noise_until:
            self.sim.set_line_noise(0.0)
            self._noise_until = None
        if self._replug_at is not None and self._replug_at[0] is not None \
                and now >= self._replug_at[0]:
            self.sim.replug()
            monitor.seqs_after_mark = []
            self._replug_at = (None, time.monotonic(), None)
        if self._replug_at is not None and self._replug_at[0] is None \
                and monitor.seqs_after_mark:
            self.reconnect_s.append(monitor.last_frame_s - self._replug_at[1])
            first_on_new_pty = self.sim.first_seq_since_plug
            self.discarded_at_open += monitor.seqs_after_mark[0] - first_on_new_pty
            self._replug_at = None

    def start_next(self, now: float) -> None:
        """Inject the next fault of the cycle."""
        fault = FAULTS[self._index % len(FAULTS)]
        self._index += 1
        if fault == 'noise':
            self.sim.set_line_noise(self.rng.choice((0.01, 0.05, 0.2)))
            self._noise_until = now + 1.5
        elif fault == 'stall':
            self.sim.stall(self.rng.uniform(1.5, 2.5))
        elif fault == 'unplug':
            if self._replug_at is not None:
                return
            self.sim.unplug()
            self._replug_at = (now + self.rng.uniform(0.3, 1.5), None, None)
        elif fault == 'gap':
            self.sim.skip_sequence(self.rng.randint(1, 100))
        else:
            self.sim.burst(self.rng.uniform(0.02, 0.05))
        self.injected[fault] += 1


def run(args, workdir: str) -> dict:
    """Run the soak in workdir and return its summary."""
    ns = f'/skin_soak_{os.getpid()}'
    log = open(os.path.join(workdir, 'nodes.log'), 'w')
    sim = SimulatedSkin(args.scene, rate_hz=args.rate, link_path=os.path.join(workdir, 'skin0'),
                        noise_seed=args.noise_seed, loop=True,
                        truth_capacity=max(10_000, int(args.rate * 20)))
    params = write_params(workdir, driver=grid_params(sim.scene))
    procs = start_nodes(args.fused, ros_args(ns, params, 'error'), log)
    try:
        with ros_session() as executor:
            node = Node('skin_soak', namespace=ns)
            executor.add_node(node)
            try:
                return _soak(args, executor, node, sim, procs)
            finally:
                node.destroy_node()
    finally:
        stop(procs.values())
        sim.stop()
        log.close()


def _soak(args, executor, node, sim, procs) -> dict:
    """Play the faults for the duration, let the pipeline drain; return the summary."""
    monitor = SoakMonitor(node, sim)
    memory = {name: [] for name in procs}
    faults = FaultCycle(sim, args.noise_seed)
    wait_for(executor, lambda: monitor.link is not None, 30.0, 'the driver to come up',
             procs.values())
    # The frames are counted from the first one received: the subscription must see the
    # driver's publisher before the board plays (on a busy machine discovery lags the
    # diagnostics, and the first frames went unseen and were counted as never published).
    frames = [sub for sub in node.subscriptions if sub.topic_name.endswith('/frame')]
    wait_for(executor, lambda: frames and all(sub.get_publisher_count() > 0 for sub in frames),
             30.0, "the subscription to the driver's frames", procs.values())
    sim.start()
    start = time.monotonic()
    next_fault, next_sample, next_print = start + FAULT_PERIOD_S, start, start + 30.0
    while (now := time.monotonic()) < start + args.duration:
        executor.spin_once(timeout_sec=0.01)
        faults.step(now, monitor)
        if now >= next_fault and now < start + args.duration - FAULT_PERIOD_S:
            faults.start_next(now)
            next_fault += FAULT_PERIOD_S
        if now >= next_sample:
            for name, proc in procs.items():
                memory[name].append((now - start, rss_mb(proc.pid)))
            next_sample += MEMORY_PERIOD_S
        if now >= next_print:
            print(f'soak: {now - start:5.0f} s, {monitor.received} frames received, '
                  f'{dict(faults.injected)}', flush=True)
            next_print += 30.0
        for name, proc in procs.items():
            if proc.poll() is not None:
                raise RuntimeError(f'the {name} node died (exit {proc.returncode})')
    # Stop the board (the pty stays open) and let the pipeline drain.
    sim.set_line_noise(0.0)
    faults.step(float('inf'), monitor)
    sim.stall(3600.0)
    end = time.monotonic() + DRAIN_S
    diag_before = monitor.diag_count
    while time.monotonic() < end or monitor.diag_count < diag_before + 2:
        executor.spin_once(timeout_sec=0.05)
        faults.step(time.monotonic(), monitor)
        if time.monotonic() > end + 10.0:
            break
    alive = {name: proc.poll() is None for name, proc in procs.items()}
    return summarise(args, sim, monitor, faults, memory, alive)


def summarise(args, sim, monitor, faults, memory, alive) -> dict:
    """Put the counts side by side and check that they balance."""
    link = monitor.link or {}
    published = int(link.get('frames', 0))
    dropped = int(link.get('frames dropped', 0))
    used = sim.next_seq
    first = monitor.first_seq or 0
    # The driver learns of a frame lost only from a later one: its span ends at its last frame.
    last = monitor.last_seq if monitor.last_seq is not None else first - 1
    discarded = first + faults.discarded_at_open
    lost_on_line = sim.frames_damaged + sim.frames_wrong_shape + sim.frames_unread + discarded
    report = {
        'duration_s': args.duration, 'rate_hz': args.rate, 'scene': args.scene,
        'layout': 'fused' if args.fused else 'split',
        'faults_injected': dict(faults.injected),
        'reconnect_s_max': max(faults.reconnect_s, default=float('nan')),
        'device': {'sequence_numbers_used': used, 'frames_sent': sim.frames_sent,
                   'frames_never_sent': sim.frames_dropped,
                   'sequence_numbers_skipped': sim.seq_skipped},
        'line': {'frames_damaged_by_noise': sim.frames_damaged,
                 'frames_wrong_shape': sim.frames_wrong_shape,
                 'frames_unread_at_unplug': sim.frames_unread,
                 'frames_discarded_at_open': discarded},
        'driver': {'frames_published': published, 'frames_dropped': dropped,
                   'frames_lost_while_disconnected': int(
                       link.get('frames lost while disconnected', 0)),
                   'crc_errors': int(link.get('crc errors', 0)),
                   'bytes_discarded': int(link.get('bytes discarded', 0)),
                   'connects': int(link.get('connects', 0)),
                   'disconnects': int(link.get('disconnects', 0))},
        'subscriber': {'frames_received': monitor.received,
                       'frames_not_equal_to_truth': monitor.mismatched,
                       'frames_of_unknown_seq': monitor.unknown,
                       'contact_arrays': monitor.contacts},
        'diagnostics': {'reports': monitor.diag_count,
                        'levels': {str(k): v for k, v in sorted(monitor.levels.items())},
                        'reports_mentioning': dict(monitor.seen)},
        'balance': {
            'device': used - (sim.frames_sent + sim.frames_dropped + sim.seq_skipped),
            'line': sim.frames_sent - (published + lost_on_line),
            'driver': last + 1 - first - (published + dropped),
        },
        'memory': {name: {
            'start_mb': samples[0][1] if samples else float('nan'),
            'end_mb': samples[-1][1] if samples else float('nan'),
            'max_mb': max((m for _, m in samples), default=float('nan')),
            'drift_mb_per_hour': drift_mb_per_hour(samples),
            'drift_mb_per_hour_second_half': drift_mb_per_hour(samples[len(samples) // 2:]),
            'samples': len(samples)}
            for name, samples in memory.items()},
        'nodes_alive_at_end': alive,
    }
    report['ok'] = (all(v == 0 for v in report['balance'].values()) and monitor.mismatched == 0
                    and all(alive.values()))
    return report


def main(argv=None) -> int:
    """Run the soak from the command line."""
    parser = argparse.ArgumentParser(prog='soak', description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=300.0, help='seconds (300)')
    parser.add_argument('--rate', type=float, default=1000.0, help='scans per second (1000)')
    parser.add_argument('--scene', default='random', help='bundled scene or YAML (random)')
    parser.add_argument('--fused', action='store_true',
                        help='estimate in the driver process (fused) instead of a direction node')
    parser.add_argument('--noise-seed', type=int, default=0,
                        help='seed of the faults and the noise (0)')
    parser.add_argument('--json', default=os.path.join('log', 'soak.json'),
                        help='where to write the summary (log/soak.json)')
    args = parser.parse_args(argv)
    if not (args.duration > 2 * FAULT_PERIOD_S):
        parser.error(f'--duration must exceed {2 * FAULT_PERIOD_S:g} s')
    workdir = tempfile.mkdtemp(prefix='skin_soak_')
    try:
        report = run(args, workdir)
    except (KeyboardInterrupt, ExternalShutdownException):
        print('\nsoak stopped')
        return 130
    except RuntimeError as err:
        print(f'soak: {err} (node output kept in {workdir}/nodes.log)', file=sys.stderr)
        return 1
    shutil.rmtree(workdir, ignore_errors=True)
    print(json.dumps(report, indent=2))
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
        with open(args.json, 'w') as f:
            json.dump(report, f, indent=2)
        print(f'soak: summary written to {args.json}')
    return 0 if report['ok'] else 1


if __name__ == '__main__':
    sys.exit(main())
