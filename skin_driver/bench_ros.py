"""
End-to-end part of the benchmark: simulated skin -> driver -> direction node -> subscriber.

Each stage runs in a process of its own, as in a deployment (and as ``make demo`` does). The
simulator prints ``SKIN_EPOCH``, the wall-clock instant of device time 0, so that the device's
timestamp of every scan becomes a host time and the latency to the contact message follows.
"""

from __future__ import annotations

from collections import defaultdict
import math
import os
import pstats
import subprocess
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import WrenchStamped
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from skin_driver import conversions
from skin_driver.core.estimation.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.protocol import encode_frame, FrameDecoder
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.processes import spawn, stop
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_srvs.srv import Trigger
import yaml

_TICK = os.sysconf('SC_CLK_TCK')


def cpu_seconds(pid: int) -> float:
    """Return user + system CPU seconds of a process from /proc/<pid>/stat (0 if gone)."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / _TICK


def bench_scene(seconds: float) -> dict:
    """Return a scene that keeps a tilted press on the skin almost all the time."""
    presses = [{'time_s': 0.05 + 0.5 * i, 'beta_deg': float((45 * i) % 360)}
               for i in range(int(seconds / 0.5) + 2)]
    return {'name': 'bench', 'description': 'a press every 0.5 s, held 0.45 s, alpha 45 deg',
            'model': {'rows': 16, 'cols': 16, 'pitch_m': 0.005},
            'defaults': {'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'radius_m': 0.004,
                         'alpha_deg': 45.0, 'duration_s': 0.45, 'ramp_s': 0.05},
            'presses': presses}


class Probe(Node):
    """Record the frames and contact messages that reach a subscriber, with arrival times."""

    def __init__(self, namespace: str):
        super().__init__('skin_bench_probe', namespace=namespace)
        self.frames = []
        self.contacts = []
        self.create_subscription(SkinFrame, 'frame', self._on_frame, qos_profile_sensor_data)
        self.create_subscription(TactileContactArray, 'contacts', self._on_contacts,
                                 qos_profile_sensor_data)
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 50)
        self.tare = self.create_client(Trigger, 'skin_direction/tare')
        self.prefix = namespace.rstrip('/') + '/'
        self.diagnostics = []

    def _on_diagnostics(self, msg) -> None:
        now = time.monotonic()
        for status in msg.status:
            if status.name.startswith(self.prefix):
                node = 'direction' if 'contact estimation' in status.name else 'driver'
                self.diagnostics.append((now, node, {kv.key: kv.value for kv in status.values}))

    def _on_frame(self, msg) -> None:
        s = msg.header.stamp
        self.frames.append((s.sec * 1_000_000_000 + s.nanosec, msg.sequence,
                            msg.device_time_us))

    def _on_contacts(self, msg) -> None:
        now = time.time()
        s = msg.header.stamp
        self.contacts.append((s.sec * 1_000_000_000 + s.nanosec, now, len(msg.contacts)))

    def reset(self) -> None:
        """Forget everything recorded so far."""
        self.frames, self.contacts, self.diagnostics = [], [], []


def _spin_for(executor, seconds) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.005)


def _match(frames, contacts, epoch, window):
    """Return per-scan (device time s, driver stamp, contact arrival) inside the window."""
    by_stamp = defaultdict(list)
    for stamp, seq, device_us in frames:
        by_stamp[stamp].append(device_us)
    taken = defaultdict(int)
    out = []
    for stamp, arrival, _ in contacts:
        k = taken[stamp]
        taken[stamp] += 1
        if k >= len(by_stamp[stamp]):
            continue
        device_s = by_stamp[stamp][k] * 1e-6
        if window[0] <= device_s < window[1]:
            out.append((epoch + device_s, stamp * 1e-9, arrival))
    return out


def _node_counters(diagnostics, start, end) -> dict:
    """Return what the nodes counted between the reports nearest the window's two ends."""
    out = {}
    for node, keys in (('driver', ('frames', 'sequence gaps', 'frames dropped')),
                       ('direction', ('frames',))):
        reports = [(t, v) for t, n, v in diagnostics if n == node]
        first = [r for r in reports if r[0] <= start]
        last = [r for r in reports if r[0] <= end]
        if not first or not last or last[-1][0] <= first[-1][0]:
            continue
        (t0, a), (t1, b) = first[-1], last[-1]
        view = {}
        for k in keys:
            try:
                view[k] = int(float(b[k])) - int(float(a[k]))
            except (KeyError, ValueError):
                pass
        view['span_s'] = t1 - t0
        if 'frames' in view:
            view['rate_hz'] = view['frames'] / view['span_s']
        if node == 'direction' and 'mean cost [us]' in b:
            view['mean_cost_us_last_period'] = float(b['mean cost [us]'])
            view['max_cost_us_last_period'] = float(b['max cost [us]'])
        out[node] = view
    return out


def _pct(values, q):
    return 1e3 * float(np.percentile(values, q)) if len(values) else None


def _run_rate(executor, probe, rate, seconds, warmup, workdir, scene_path, port, nodes, log):
    sim = spawn(['-m', 'skin_driver.sim', '--scene', scene_path, '--link', port, '--rate',
                 str(rate), '--loop'], log, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                text=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(sim.stderr), daemon=True)
    reader.start()
    deadline = time.monotonic() + 20.0
    while not any(s.startswith('SKIN_EPOCH') for s in lines):
        if time.monotonic() > deadline or sim.poll() is not None:
            stop([sim], 10.0)
            raise RuntimeError(f'the simulator did not start: {"".join(lines)}')
        executor.spin_once(timeout_sec=0.01)
    epoch = float(next(s for s in lines if s.startswith('SKIN_EPOCH')).split()[1])
    probe.reset()
    _spin_for(executor, warmup)
    pids = {'sim': sim.pid, **{k: p.pid for k, p in nodes.items()}, 'probe': os.getpid()}
    cpu0 = {k: cpu_seconds(p) for k, p in pids.items()}
    wall0 = time.monotonic()
    _spin_for(executor, seconds)
    wall = time.monotonic() - wall0
    node_view = _node_counters(probe.diagnostics, wall0, wall0 + wall)
    cpu = {k: 100.0 * (cpu_seconds(p) - cpu0[k]) / wall for k, p in pids.items()}
    _spin_for(executor, 0.3)
    stop([sim], 10.0)
    reader.join(2.0)
    sent = dropped = None
    for s in lines:
        if 'stopped after' in s:
            words = s.split()
            sent, dropped = int(words[words.index('sent,') - 2]), int(words[-2])
    frames, contacts = probe.frames, probe.contacts
    window = (warmup, warmup + seconds)
    matched = _match(frames, contacts, epoch, window)
    seqs = sorted({seq for _, seq, d in frames if window[0] <= d * 1e-6 < window[1]})
    gaps = (seqs[-1] - seqs[0] + 1 - len(seqs)) if seqs else 0
    expected = int(round(seconds * rate))
    total = [a - d for d, _, a in matched]
    to_driver = [s - d for d, s, _ in matched]
    to_probe = [a - s for _, s, a in matched]
    return {
        'rate_hz': rate, 'seconds': seconds, 'expected_scans': expected,
        'frames_seen': len(seqs), 'contact_messages': len(matched),
        'received_rate_hz': len(matched) / seconds,
        'dropped_scans': max(expected - len(matched), 0),
        'frame_sequence_gaps': gaps, 'lost_after_driver': max(len(seqs) - len(matched), 0),
        'sim_frames_sent': sent, 'sim_frames_dropped': dropped,
        'latency_p50_ms': _pct(total, 50), 'latency_p99_ms': _pct(total, 99),
        'latency_max_ms': _pct(total, 100),
        'device_to_driver_p50_ms': _pct(to_driver, 50),
        'device_to_driver_p99_ms': _pct(to_driver, 99),
        'driver_to_contact_p50_ms': _pct(to_probe, 50),
        'driver_to_contact_p99_ms': _pct(to_probe, 99),
        'scans_with_contact': sum(1 for c in contacts if c[2]) / max(len(contacts), 1),
        'cpu_percent': cpu,
        'node_counters': node_view,
    }


def end_to_end(rates, seconds, warmup, workdir, domain_note='', profile=False, log=print):
    """Run the chain once per rate with the same nodes; return one result per rate."""
    scene = bench_scene(seconds + warmup + 2.0)
    scene_path = os.path.join(workdir, 'bench_scene.yaml')
    with open(scene_path, 'w') as f:
        yaml.safe_dump(scene, f)
    port = os.path.join(workdir, 'skin0')
    ns = f'/skin_bench_{os.getpid()}'
    node_log = open(os.path.join(workdir, 'nodes.log'), 'w')
    ros = ['--ros-args', '-r', f'__ns:={ns}', '--log-level', 'warn']
    # Only the direction node: the driver's work runs on its reader thread, which cProfile
    # (main thread only) does not see.
    prof = {'direction': os.path.join(workdir, 'direction.prof') if profile else None,
            'driver': None}
    nodes = {
        'direction': spawn(['-m', 'skin_driver.direction_node'] + ros + [
            '-p', 'viz_rate:=0.0',
            '-p', f'calibration_file:={os.path.join(workdir, "calibration.yaml")}'],
            node_log, prof['direction']),
        'driver': spawn(['-m', 'skin_driver.driver_node'] + ros + [
            '-p', f'port:={port}', '-p', 'reconnect_min:=0.02', '-p', 'reconnect_max:=0.1',
            '-p', 'publish_images:=false'], node_log, prof['driver']),
    }
    rclpy.init()
    executor = SingleThreadedExecutor()
    probe = Probe(ns)
    executor.add_node(probe)
    results = []
    try:
        deadline = time.monotonic() + 30.0
        while not probe.tare.service_is_ready():
            if time.monotonic() > deadline:
                raise RuntimeError('the direction node did not come up')
            executor.spin_once(timeout_sec=0.05)
        for rate in rates:
            results.append(_run_rate(executor, probe, rate, seconds, warmup, workdir,
                                     scene_path, port, nodes, node_log))
            r = results[-1]
            log(f'  end to end {rate:g} Hz: {r["received_rate_hz"]:.0f} Hz received, '
                f'p99 {r["latency_p99_ms"]} ms')
    finally:
        executor.shutdown()
        probe.destroy_node()
        rclpy.try_shutdown()
        for p in nodes.values():
            stop([p], 10.0)
        node_log.close()
    profiles = {}
    for k, path in prof.items():
        if path and os.path.exists(path):
            profiles[k] = top_functions(path)
    return results, profiles


def top_functions(path, count=12) -> list:
    """Return the functions with the most own time in a cProfile file."""
    stats = pstats.Stats(path)
    total = sum(v[2] for v in stats.stats.values()) or 1.0
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:count]
    return [{'function': f'{os.path.basename(k[0])}:{k[1]}({k[2]})', 'calls': v[1],
             'own_s': v[2], 'own_share': v[2] / total, 'cumulative_s': v[3]}
            for k, v in rows]


def _per_call(fn, repeats) -> float:
    fn()
    start = time.perf_counter()
    for _ in range(repeats):
        fn()
    return 1e6 * (time.perf_counter() - start) / repeats


def stage_costs(repeats=500) -> dict:
    """Return the per-scan cost (us) of each stage of the 16 x 16 chain, measured in process."""
    model = SkinModel(misalignment_m=(3e-4, -2e-4))
    rng = np.random.default_rng(0)
    press = [Press(0.0375, 0.0375, 10.0, math.radians(45), 0.5, 0.004)]
    top, bottom = render(model, press, rng)
    raw = encode_frame(1, 1000, top, bottom)
    decoder = FrameDecoder(expected_shape=(16, 16))
    est = ContactEstimator(EstimatorConfig())
    est.tare(*[np.stack([render(model, [], rng)[k] for _ in range(10)]) for k in (0, 1)])
    contacts = est.process(top, bottom)
    rclpy.init()
    try:
        node = Node('skin_bench_stages', namespace=f'/skin_bench_stages_{os.getpid()}')
        pub_frame = node.create_publisher(SkinFrame, 'frame', qos_profile_sensor_data)
        pub_contacts = node.create_publisher(TactileContactArray, 'contacts',
                                             qos_profile_sensor_data)
        pub_contact = node.create_publisher(TactileContact, 'contact', qos_profile_sensor_data)
        pub_wrench = node.create_publisher(WrenchStamped, 'wrench', qos_profile_sensor_data)
        header = conversions.make_header(node.get_clock().now().to_msg(), 'skin_link')
        array = conversions.contacts_to_array(header, contacts)
        msg = conversions.skin_frame_to_msg(header, 1, 1000, 0.005, top, bottom)
        out = {
            'sim: physics.render (press on)': _per_call(lambda: render(model, press, rng),
                                                        repeats),
            'sim: physics.render (no press)': _per_call(lambda: render(model, [], rng), repeats),
            'sim: encode_frame': _per_call(lambda: encode_frame(1, 1000, top, bottom), repeats),
            'driver: decode': _per_call(lambda: decoder.feed(raw), repeats),
            'driver: skin_frame_to_msg': _per_call(lambda: conversions.skin_frame_to_msg(
                header, 1, 1000, 0.005, top, bottom), repeats),
            'driver: publish SkinFrame': _per_call(lambda: pub_frame.publish(msg), repeats),
            'direction: skin_frame_layers': _per_call(
                lambda: conversions.skin_frame_layers(msg), repeats),
            'direction: estimator.process (1 contact)': _per_call(
                lambda: est.process(top, bottom), repeats),
            'direction: contacts_to_array + publish': _per_call(
                lambda: pub_contacts.publish(conversions.contacts_to_array(header, contacts)),
                repeats),
            'direction: publish contact + wrench': _per_call(
                lambda: (pub_contact.publish(array.contacts[0]), pub_wrench.publish(
                    conversions.wrench_stamped(header, contacts[0].force_xyz_n))), repeats),
        }
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return {k: v for k, v in out.items() if math.isfinite(v)}
