"""
End-to-end part of the benchmark: simulated skin -> driver (-> direction node) -> subscriber.

Two layouts, each process as in a deployment (and as ``make demo`` does): split (driver and
direction node, scans over the frame topic) and fused (the driver estimates on its serial reader
thread), both with the shipped parameters; and beside them the rclpy floor
(:mod:`skin_lab.bench.floor`), measured the same way. The simulator prints
``SKIN_EPOCH``, the wall-clock instant of device time 0, so that each scan's device time becomes
a host time; contacts messages carry the scan's sequence number and device time, so the probe
counts losses by sequence and needs no frame subscription.

CPU per scan is split by thread (/proc/<pid>/task: the serial reader, the raw-image thread, the
executor on the main thread, the middleware's threads) and, within the reader and the
estimation, by stage (the nodes' own sampled thread-CPU figures on /diagnostics).
"""

from __future__ import annotations

import importlib.resources
import math
import os
import pstats
import time

from geometry_msgs.msg import WrenchStamped
import numpy as np
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_driver.core.protocol.wire import encode_frame, FrameDecoder
from skin_driver.core.sim.firmware import Framer
from skin_driver.core.sim.physics import Press, render, SkinModel
from skin_driver.core.sim.scene import load_scene
from skin_driver.ros import conversions
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.estimation_host import EstimationHost
from skin_driver.ros.spin import freeze_heap
from skin_driver.tools.harness import (
    grid_params, overrides, ros_args, ros_session, spawn, spin_for, start_nodes, start_sim, stop,
    wait_for, write_params)
from skin_driver.tools.probe import Probe
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray
from std_srvs.srv import Trigger

_TICK = os.sysconf('SC_CLK_TCK')


def cpu_seconds(pid: int) -> float:
    """Return user + system CPU seconds of a process from /proc/<pid>/stat (0 if gone)."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / _TICK


# The threads a node names (core.protocol.link, ros.driver_node); the main thread spins the
# executor; every other thread is the middleware's (or rclpy's).
THREAD_ROLES = {'skin-reader': 'reader', 'skin-images': 'images', 'skin-frames': 'frames'}


def thread_cpu(pid: int) -> dict:
    """Return CPU seconds of a process's threads by role (reader, images, executor, middleware)."""
    out = {}
    try:
        tids = os.listdir(f'/proc/{pid}/task')
    except OSError:
        return out
    for tid in tids:
        try:
            with open(f'/proc/{pid}/task/{tid}/stat') as f:
                stat = f.read()
        except OSError:  # the thread ended meanwhile
            continue
        name = stat[stat.index('(') + 1:stat.rindex(')')]
        fields = stat.rsplit(')', 1)[1].split()
        role = 'executor' if tid == str(pid) else THREAD_ROLES.get(name, 'middleware')
        out[role] = out.get(role, 0.0) + (int(fields[11]) + int(fields[12])) / _TICK
    return out


def stage_means(probe, suffix: str, prefix: str, start: float, end: float) -> dict:
    """Return the mean of each '<prefix><stage> [us]' value of the statuses in the window."""
    reports = [conversions.status_values(status) for t, status in probe.statuses
               if start < t <= end and status.name.endswith(suffix)]
    if not reports:
        return {}
    keys = [k for k in reports[-1] if k.startswith(prefix)]
    return {k[len(prefix):-len(' [us]')]: float(np.mean([float(r[k]) for r in reports if k in r]))
            for k in keys}


# The scene the board plays, looped: the lab's own (skin_lab/skin_lab/scenes/bench.yaml), which
# the simulator takes by its path.
SCENE = str(importlib.resources.files('skin_lab') / 'scenes' / 'bench.yaml')
LAYOUTS = ('split', 'fused')
FLOOR = 'floor'
# The probe's audit queue: deep enough for every scan of a few seconds at 2 kHz, so that only a
# scan never published (or lost by the middleware) is missing from it.
AUDIT_DEPTH = 10000


def where_lost(lost: int, audit_lost: int, never_decoded) -> dict:
    """
    Return where the lost scans of a run went, by stage.

    ``lost``: scans the controller-like subscriber (depth 5) lacks; ``audit_lost``: those the
    audit subscriber (deep queue) lacks as well; ``never_decoded``: the driver's sequence gaps
    over the window (None when the process has no counters, the floor). What the audit has and
    the depth-5 subscriber lacks was dropped at that subscriber's queue.
    """
    at_queue = max(lost - audit_lost, 0)
    if never_decoded is None:
        return {'not delivered': audit_lost, 'subscriber queue': at_queue}
    never_decoded = min(max(int(never_decoded), 0), audit_lost)
    return {'never decoded': never_decoded, 'not delivered': audit_lost - never_decoded,
            'subscriber queue': at_queue}


def realtime_prefix(priority: int) -> list:
    """Return the command prefix that runs a process SCHED_FIFO at priority (none for 0)."""
    return ['chrt', '-f', str(priority)] if priority else []


def _run(executor, probe, layout, nodes, rate, seconds, warmup, port, log, priority, ns):
    """Measure one layout at one rate; return its figures."""
    # /diagnostics is one topic for every skin on the machine: this run's nodes only.
    link, estimation = f'{ns}/skin_driver: skin link', f'{ns}/skin_direction: contact estimation'

    sim = start_sim(executor, SCENE, port, rate, log, loop=True, replay=True,
                    prefix=realtime_prefix(priority))
    probe.reset()
    spin_for(executor, warmup)
    # This process holds the in-process part's results, which a controller would not: frozen,
    # a full collection does not stop the probe's thread while it walks them.
    freeze_heap()
    pids = {'sim': sim.process.pid, **{k: p.pid for k, p in nodes.items()}, 'probe': os.getpid()}
    cpu0 = {k: cpu_seconds(p) for k, p in pids.items()}
    threads0 = {k: thread_cpu(p.pid) for k, p in nodes.items()}
    wall0 = time.monotonic()
    # The probe takes contacts on its own thread; the executor here only gathers /diagnostics,
    # so it wakes for those, not 200 times a second to look at the clock (each wake-up rebuilds
    # rclpy's wait set under the GIL the probe's thread needs).
    spin_for(executor, seconds, period_s=0.1)
    wall = time.monotonic() - wall0
    cpu = {k: cpu_seconds(p) - cpu0[k] for k, p in pids.items()}
    threads = {k: {role: v - threads0[k].get(role, 0.0)
                   for role, v in thread_cpu(p.pid).items()} for k, p in nodes.items()}
    driver = probe.counters(link, wall0, wall0 + wall)
    direction = probe.counters(estimation, wall0, wall0 + wall)
    window = (wall0, wall0 + wall + 0.3)
    spin_for(executor, 0.3)
    sent, dropped = sim.stop()
    expected = int(round(seconds * rate))
    seen = probe.summary((warmup, warmup + seconds), expected=expected, epoch_s=sim.epoch)
    audit = probe.summary((warmup, warmup + seconds), expected=expected, record=probe.audit)
    decoded_hz = driver.get('frames', 0) / driver['span_s'] if driver else None
    estimated_hz = direction.get('frames', 0) / direction['span_s'] if direction else None
    # CPU per scan each process handled: the scans it never saw cost it nothing.
    # The floor counts nothing itself: it read what the board could write (the board drops
    # what does not fit into the pty), over the whole run.
    written = sent / (sent + dropped) if sent else 1.0
    handled_hz = {'sim': rate, 'driver': decoded_hz or rate, FLOOR: rate * written,
                  'direction': estimated_hz or rate, 'probe': seen['received'] / seconds or rate}
    return {
        'layout': layout, 'priority': priority, 'rate_hz': rate, 'seconds': seconds,
        'expected_scans': expected,
        'sim_frames_sent': sent, 'sim_frames_dropped': dropped,
        'received': seen['received'], 'lost': seen['lost'],
        'audit_lost': audit['lost'], 'audit_depth': AUDIT_DEPTH,
        'lost_where': where_lost(seen['lost'], audit['lost'],
                                 driver.get('frames dropped') if driver else None),
        'sequence_gaps': seen['sequence_gaps'],
        'received_rate_hz': seen['received'] / seconds,
        'latency_ms': seen['latency_from_last_byte_ms'],
        # The contact published (the middleware's source timestamp): the driver's own part of
        # the latency, without the subscriber's wake-up (issue #45: p99 <= 1 ms at 1 kHz).
        'published_ms': seen['published_after_last_byte_ms'],
        'published_first_ms': seen['published_first_of_read_ms'],
        'behind_in_read': seen['behind_in_read'],
        'latency_from_device_time_ms': seen['latency_from_device_time_ms'],
        'board_to_driver_ms': seen['last_byte_after_device_time_ms'],
        'scans_with_contact': seen['with_contact'] / max(seen['received'], 1),
        'cpu_percent': {k: 100.0 * v / wall for k, v in cpu.items()},
        'cpu_us_per_scan': {k: 1e6 * v / (handled_hz[k] * wall) for k, v in cpu.items()},
        'threads_us_per_scan': {k: {role: 1e6 * v / (handled_hz[k] * wall)
                                    for role, v in sorted(roles.items())}
                                for k, roles in threads.items()},
        'reader_stages_us': stage_means(probe, link, 'reader CPU per scan, ', *window),
        'estimation_stages_us': stage_means(probe, estimation, 'CPU per scan, ',
                                            *window),
        'driver_decoded_hz': decoded_hz,
        'driver_sequence_gaps': driver.get('sequence gaps') if driver else None,
        'estimated_hz': estimated_hz,
        'estimator_mean_us': (float(direction['latest'].get('mean cost [us]', 'nan'))
                              if direction else None),
    }


def end_to_end(rates, seconds, warmup, workdir, layouts=LAYOUTS, profile=False, log=print,
               priority=0, method=None):
    """
    Run every layout at every rate, one after the other, and return one result per run.

    The layouts take turns at each rate (in alternating order), so that all see the same
    machine: other jobs share it, and only a side-by-side comparison means anything. Layouts:
    'split', 'fused' and FLOOR (the rclpy floor). The nodes run the shipped parameters
    (config/skin.yaml's: raw images, heatmaps and markers offered, nobody subscribing to them),
    with ``method`` for the estimator if given. With a priority, the driver's serial reader runs
    SCHED_FIFO at it (its parameter realtime_priority), and so do the simulated board (hardware
    never waits for a core) and this subscriber, as a force-control deployment runs its loop.
    """
    port = os.path.join(workdir, 'skin0')
    params = write_params(workdir, driver={'reconnect_min': 0.02, 'reconnect_max': 0.1,
                                           'realtime_priority': priority,
                                           **grid_params(load_scene(SCENE))},
                          direction={'method': method} if method else {},
                          name=f'bench_params_{priority}.yaml')
    node_log = open(os.path.join(workdir, 'nodes.log'), 'a')
    if priority:
        # Before rclpy.init: the middleware's threads inherit the policy.
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    results, profiles = [], {}
    try:
        with ros_session() as executor:
            for i, rate in enumerate(rates):
                order = layouts if i % 2 == 0 else tuple(reversed(layouts))
                for layout in order:
                    prof = os.path.join(workdir, f'{layout}.prof') if profile else None
                    results.append(_layout_run(executor, layout, rate, seconds, warmup, params,
                                               port, node_log, prof, priority,
                                               method or DEFAULT_METHOD))
                    r = results[-1]
                    log(f'  {layout} (priority {priority}) {rate:g} Hz: '
                        f'{r["received_rate_hz"]:.0f} Hz received, '
                        f'{r["lost"]} lost, p99 {_ms(r["latency_ms"]["p99"])} ms, '
                        f'published p99 {_ms(r["published_ms"]["p99"])} ms, CPU/scan '
                        + ', '.join(f'{k} {v:.0f} us' for k, v in r['cpu_us_per_scan'].items()))
                    if prof and os.path.exists(prof):
                        profiles[f'{layout} direction node at {rate:g} Hz'] = top_functions(prof)
    finally:
        node_log.close()
        if priority:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    return results, profiles


def _ms(value) -> str:
    return '-' if value is None else f'{value:.2f}'


def _layout_run(executor, layout, rate, seconds, warmup, params, port, log, profile_to,
                priority, method) -> dict:
    """Start one layout's processes, measure them at one rate, stop them; return the figures."""
    ns = f'/skin_bench_{os.getpid()}_{layout}_{int(rate)}_{priority}'
    if layout == FLOOR:
        nodes = {FLOOR: spawn(['-m', 'skin_lab.bench.floor', port, ns, method,
                               '16', '16'], log)}
    else:
        nodes = start_nodes(layout == 'fused', ros_args(ns, params), log, profile_to)
    node = Node('skin_bench_probe', namespace=ns)
    executor.add_node(node)
    probe = Probe(node, diagnostics=2000, own_thread=True, audit_depth=AUDIT_DEPTH)
    tare = node.create_client(Trigger, 'skin_direction/tare')
    try:
        if layout == FLOOR:
            wait_for(executor, lambda: node.count_publishers(f'{ns}/contacts') > 0, 30.0,
                     'the rclpy floor to come up', nodes.values())
        else:
            wait_for(executor, tare.service_is_ready, 30.0, f'the {layout} layout to come up',
                     nodes.values())
        return _run(executor, probe, layout, nodes, rate, seconds, warmup, port, log, priority,
                    ns)
    finally:
        probe.close()
        executor.remove_node(node)
        node.destroy_node()
        stop(nodes.values(), 10.0)


def top_functions(path, count=12) -> list:
    """Return the functions with the most own time in a cProfile file."""
    stats = pstats.Stats(path)
    total = sum(v[2] for v in stats.stats.values()) or 1.0
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:count]
    return [{'function': f'{os.path.basename(k[0])}:{k[1]}({k[2]})', 'calls': v[1],
             'own_s': v[2], 'own_share': v[2] / total, 'cumulative_s': v[3]}
            for k, v in rows]


def _per_call(fn, repeats, rounds=5) -> float:
    """Return the least mean cost (us) of fn over a few rounds: the machine is shared."""
    fn()
    best = math.inf
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(repeats):
            fn()
        best = min(best, 1e6 * (time.perf_counter() - start) / repeats)
    return best


def _paced(fn, calls=300, gap_s=1e-3) -> float:
    """
    Return the median thread CPU (us) of fn called once after each sleep of gap_s.

    At 1 kHz the driver sleeps between two scans: what it runs then runs from cold caches,
    which a loop of calls back to back never shows. Thread CPU: a preemption is not counted.
    """
    fn()
    costs = []
    for _ in range(calls):
        time.sleep(gap_s)
        start = time.thread_time_ns()
        fn()
        costs.append(time.thread_time_ns() - start)
    return 1e-3 * float(np.median(costs))


# The stages stage_costs also times one a millisecond (_paced), as they run at 1 kHz.
PACED = 'one a millisecond (median thread CPU after a 1 ms sleep)'
# Frames in the read of a backlog whose decoding stage_costs times (64 kB of version 1).
BACKLOG_FRAMES = 64


def stage_costs(repeats=500) -> dict:
    """Return the per-scan cost (us) of each stage of the 16 x 16 chain, measured in process."""
    model = SkinModel(misalignment_m=(3e-4, -2e-4))
    rng = np.random.default_rng(0)
    press = [Press(0.0375, 0.0375, 10.0, math.radians(45), 0.5, 0.004)]
    top, bottom = render(model, press, rng)
    raw = encode_frame(1, 1000, top, bottom)
    decoder = FrameDecoder(expected_shape=(16, 16))
    raw_v2 = encode_frame(1, 1000, top, bottom, version=2)
    decoder_v2 = FrameDecoder(expected_shape=(16, 16))
    framer = Framer(16, 16, version=2)
    counts = np.stack([top, bottom]).astype(np.uint16)
    # A backlog: one read that holds many frames (a USB board sends several per transfer).
    backlog = {v: b''.join(encode_frame(i, 1000 * i, top, bottom, version=v)
                           for i in range(BACKLOG_FRAMES)) for v in (1, 2)}
    with ros_session():
        ns = f'/skin_bench_stages_{os.getpid()}'
        node = DirectionNode(subscribe=False, namespace=ns, parameter_overrides=overrides(
            {'calibration_file': os.devnull + '/none', 'viz_rate': 0.0}))
        host: EstimationHost = node.host
        host.prepare(16, 16, 0.005)  # as the fused driver does: no executor serves the check
        est = host.estimator.with_tare(
            *[np.stack([render(model, [], rng)[k] for _ in range(10)]) for k in (0, 1)])
        contacts = est.process(top, bottom)
        pub_frame = node.create_publisher(SkinFrame, 'frame', qos_profile_sensor_data)
        pub_contacts = node.create_publisher(TactileContactArray, 'contacts_fresh',
                                             qos_profile_sensor_data)
        pub_contact = node.create_publisher(TactileContact, 'contact_fresh',
                                            qos_profile_sensor_data)
        pub_wrench = node.create_publisher(WrenchStamped, 'wrench_fresh',
                                           qos_profile_sensor_data)
        header = conversions.make_header(node.get_clock().now().to_msg(), 'skin_link')
        array = conversions.contacts_to_array(header, contacts)
        msg = conversions.skin_frame_to_msg(header, 1, 1000, 0.005, top, bottom)
        cdr = conversions.SerializedMessages('skin_link')
        fields = [conversions.contact_fields(c) for c in contacts]
        stamp = (header.stamp.sec, header.stamp.nanosec)
        out = {
            'sim: physics.render (press on)': _per_call(lambda: render(model, press, rng),
                                                        repeats),
            # The simulated board frames as the firmware does (its core built for the host).
            'sim: frame (firmware core), protocol version 2': _per_call(
                lambda: framer.frame(1, 1000, counts), repeats),
            'driver: decode': _per_call(lambda: decoder.feed(raw), repeats),
            # Measured beside version 1 (and in the same way): only the ratio travels.
            'driver: decode, protocol version 2': _per_call(lambda: decoder_v2.feed(raw_v2),
                                                            repeats),
            f'driver: decode, {BACKLOG_FRAMES} frames in one read, per frame': _per_call(
                lambda: decoder.feed(backlog[1]), max(repeats // BACKLOG_FRAMES, 1))
            / BACKLOG_FRAMES,
            f'driver: decode, {BACKLOG_FRAMES} frames in one read, per frame, protocol version 2':
            _per_call(lambda: decoder_v2.feed(backlog[2]), max(repeats // BACKLOG_FRAMES, 1))
            / BACKLOG_FRAMES,
            'driver: stamp + header': _per_call(lambda: conversions.make_header(
                node.get_clock().now().to_msg(), 'skin_link'), repeats),
            'driver: skin_frame_to_msg + publish SkinFrame': _per_call(
                lambda: pub_frame.publish(conversions.skin_frame_to_msg(
                    header, 1, 1000, 0.005, top, bottom)), repeats),
            'driver: SkinFrame as CDR bytes + publish': _per_call(
                lambda: pub_frame.publish(cdr.frame(*stamp, 1, 1000, 0.005, top, bottom)),
                repeats),
            'direction (split): skin_frame_layers': _per_call(
                lambda: conversions.skin_frame_layers(msg), repeats),
            'estimator.process (1 contact)': _per_call(lambda: est.process(top, bottom),
                                                       repeats),
            'contacts_to_array (new messages) + publish': _per_call(
                lambda: pub_contacts.publish(conversions.contacts_to_array(header, contacts)),
                repeats),
            'contacts as CDR bytes + publish': _per_call(
                lambda: pub_contacts.publish(cdr.contacts(*stamp, 1, 1000, fields)), repeats),
            'publish contact + wrench': _per_call(
                lambda: (pub_contact.publish(array.contacts[0]), pub_wrench.publish(
                    conversions.wrench_stamped(header, contacts))), repeats),
            'EstimationHost.process (estimate; no subscriber, nothing published)': _per_call(
                lambda: host.process(header, 1, 1000, 0.005, top, bottom), repeats),
            f'driver: decode, protocol version 2, {PACED}': _paced(
                lambda: decoder_v2.feed(raw_v2)),
            f'EstimationHost.process, {PACED}': _paced(
                lambda: host.process(header, 1, 1000, 0.005, top, bottom)),
        }
        node.destroy_node()
    return {k: v for k, v in out.items() if math.isfinite(v)}
