"""
`make demo`: the whole pipeline on the simulated skin, watched live in the terminal.

Starts the direction node and the serial driver, then the simulated skin on a pseudo-terminal
playing the seed paper's experiment (normal presses, then alpha = 45 deg at the eight azimuths) on
a skin whose FSR curve and compliance are not the driver's assumed ones. It tares, calibrates
(x_p, y_p), the force curve (presses of known force) and the compliance (presses of known tilted
load) through the calibration actions, shows what the skin feels, and ends with Table 1 of the
paper next to the same table for this driver's estimator and the paper's method, measured on the
same scans, and the force and alpha errors. Ctrl-C stops it; every process it started is stopped
with it.
"""

import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
from rclpy.action import ActionClient
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from skin_driver.core.common.boardinfo import BoardInfo
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.scan.heatmap import text_map, top_down
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD, REFERENCES
from skin_driver.core.sim.scene import find_scene, scene_from_dict
from skin_driver.ros import conversions, qos
from skin_driver.tools.harness import (
    BoardProcess, call_service, grid_params, ros_args, ros_session, send_goal, spawn, spin_until,
    start_nodes, start_sim, stop, wait_for, write_params, write_scene)
from skin_driver.tools.probe import Probe
from skin_lab.evaluate.scoring import summarise
from skin_lab.evaluate.tables import format_table
from skin_msgs.action import Calibrate, CalibrateCompliance, CalibrateForce
from skin_msgs.msg import SkinFrame, TactileContactArray
from std_msgs.msg import String
from std_srvs.srv import Trigger
import yaml


BOARDS = {'sim': 'board: the simulated skin (skin_driver sim) on a pseudo-terminal',
          'qemu': 'board: the skin firmware on an emulated STM32 board in QEMU (the image is '
                  'built on first use), on a pseudo-terminal'}


def demo_scene(repeats: int, pace: float = 1.0) -> dict:
    """
    Return the demo's scene (skin_driver/scenes/demo.yaml) with its rounds and pace.

    ``repeats`` rounds of the eight directions; pace < 1 plays everything after the lead-in
    faster (the lead-in, before the first press, is what start-up needs and stays).
    """
    data = yaml.safe_load(find_scene('demo').read_text())
    lead_in = min(p['time_s'] for p in data['presses'])
    for entry in [data['defaults']] + data['presses']:
        for key in ('duration_s', 'ramp_s'):
            if key in entry:
                entry[key] *= pace
        if 'time_s' in entry:
            entry['time_s'] = lead_in + (entry['time_s'] - lead_in) * pace
    generator = data['generator']
    generator['start_s'] = lead_in + (generator['start_s'] - lead_in) * pace
    for key in ('interval_s', 'duration_s', 'ramp_s'):
        generator[key] *= pace
    generator['repeats'] = repeats
    return data


class DemoMonitor:
    """Watch frames and contacts through a Probe, drive the services, compare with the truth."""

    def __init__(self, node, scene, method: str, live: bool):
        self.node = node
        self.scene = scene
        self.live = live
        self.method = method
        self.device_time_us = 0
        self.last_frame = None
        self.last_contacts = []
        self.last_truth = []
        self.frames = 0
        self.estimates = 0
        self.calibration = Calibration()
        self.calibrated = False
        # The paper's method runs here on the very scans the node sees, for the side-by-side table.
        self.seed = ContactEstimator(EstimatorConfig(), self.calibration,
                                     shift=REFERENCES['seed'])
        self.results = {method: [], 'seed': []}
        # (true |F|, estimated |F|, true alpha, estimated alpha) of the node's contacts.
        self.forces = []
        self.status = 'waiting for the skin'
        self.probe = Probe(node, on_frame=self._on_frame, on_contacts=self._on_contacts)
        self.board = None  # the BoardInfo the driver heard, once it has
        node.create_subscription(String, 'board_info', self._on_board_info, qos.latched())
        self.tare = node.create_client(Trigger, 'skin_direction/tare')
        self.calibrate = ActionClient(node, Calibrate, 'skin_direction/calibrate')
        self.calibrate_force = ActionClient(node, CalibrateForce,
                                            'skin_direction/calibrate_force')
        self.calibrate_compliance = ActionClient(node, CalibrateCompliance,
                                                 'skin_direction/calibrate_compliance')
        self._last_draw = 0.0

    def _on_board_info(self, msg: String) -> None:
        # Who answered, in its own words: the board information frame, via the driver. Said
        # when it comes (about a second in), holding nothing up: the scene plays on.
        try:
            info = BoardInfo.parse(msg.data)
        except ValueError as err:
            self.status = f'board_info not understood: {err}'
            return
        if info != self.board:
            print(f'board answered: {info.describe()}', flush=True)
        self.board = info

    def truth(self, t: float):
        """Return the press at full force at scene time t, or None."""
        for index, press in self.scene.active_at(t):
            spec = self.scene.presses[index]
            if press.force_n >= spec.force_n * 0.999:
                return spec
        return None

    def _on_frame(self, msg: SkinFrame) -> None:
        self.frames += 1
        self.device_time_us = max(self.device_time_us, msg.device_time_us)
        top, bottom = conversions.skin_frame_layers(msg)
        self.last_frame = (top, bottom)
        self.last_truth = self.scene.active_at(msg.device_time_us * 1e-6)
        if self.calibrated:
            spec = self.truth(msg.device_time_us * 1e-6)
            if spec is not None and spec.alpha_deg > 0:
                contacts = self.seed.process(top, bottom)
                self._record('seed', spec, contacts[0] if contacts else None)

    def _on_contacts(self, msg: TactileContactArray) -> None:
        self.estimates += 1
        self.last_contacts = msg.contacts
        if self.calibrated:
            spec = self.truth(msg.device_time_us * 1e-6)
            if spec is not None and spec.alpha_deg > 0:
                contact = msg.contacts[0] if msg.contacts else None
                self._record(self.method, spec, contact)
                if contact is not None and contact.direction_valid:
                    f = contact.wrench.force
                    self.forces.append((spec.force_n, math.sqrt(f.x * f.x + f.y * f.y + f.z * f.z),
                                        spec.alpha_deg, math.degrees(contact.polar)))
        self.draw()

    def _record(self, method, spec, contact) -> None:
        valid = contact is not None and contact.direction_valid
        azimuth = math.degrees(contact.azimuth if hasattr(contact, 'azimuth')
                               else contact.azimuth_rad) if valid else math.nan
        self.results[method].append((spec.beta_deg, azimuth))

    def now(self) -> float:
        """Return the scene time of the newest scan seen (s), or 0."""
        return self.device_time_us * 1e-6

    def set_calibration(self, path: str) -> None:
        """Give the side-by-side seed estimator the calibration the node wrote."""
        self.calibration = Calibration.load_yaml(path)
        self.seed = self.seed.with_calibration(self.calibration)
        self.calibrated = True

    @staticmethod
    def _contact_line(c) -> str:
        if c.direction_valid:
            beta = f'{math.degrees(c.azimuth) % 360.0:5.1f} deg'
            alpha = f'{math.degrees(c.polar):4.1f} deg'
        else:
            beta, alpha = '    -    ', '   -    '
        return (f'x {c.location.x * 1e3:5.1f} mm  y {c.location.y * 1e3:5.1f} mm  '
                f'|F| {c.magnitude:5.2f} N  beta {beta}  alpha {alpha}  '
                f'confidence {c.confidence:.2f}')

    @staticmethod
    def _press_line(press) -> str:
        return (f'x {press.x_m * 1e3:5.1f} mm  y {press.y_m * 1e3:5.1f} mm  '
                f'|F| {press.normal_force_n:5.2f} N  '
                f'beta {math.degrees(press.beta_rad) % 360.0:5.1f} deg  '
                f'alpha {math.degrees(press.alpha_rad):4.1f} deg')

    def draw(self, force: bool = False) -> None:
        """Redraw the live view at most ten times a second."""
        now = time.monotonic()
        if not force and now - self._last_draw < (0.1 if self.live else 2.0):
            return
        self._last_draw = now
        lines = [f'skin_driver demo - {self.status}', '']
        if self.last_frame is not None and self.live:
            top, bottom = (layer.astype(np.float64) for layer in self.last_frame)
            # Seen from above, as the heatmap images: x to the right, y up.
            left, right = (text_map(top_down(layer), 3000.0) for layer in (top, bottom))
            lines.append(f'{"top layer":<34}bottom layer')
            lines += [f'{a}  {b}' for a, b in zip(left, right)]
            lines.append('')
        felt = [self._contact_line(c) for c in self.last_contacts[:3]] or ['no contact']
        truth = [self._press_line(p) for _, p in self.last_truth[:1]]
        if self.live:
            lines += ['skin feels: ' + line for line in felt]
            lines += ['simulated:  ' + line for line in truth]
            sys.stdout.write('\x1b[H\x1b[J' + '\n'.join(lines) + '\n')
        else:
            sys.stdout.write(f'{lines[0]} | {felt[0]}\n')
        sys.stdout.flush()


def _step(executor, monitor, client, request, status: str, label: str = None):
    """Send one calibration goal before the presses labelled ``label``; return its result."""
    if label is not None:
        # In the middle of the quiet gap before them: the presses of the step before must not
        # count for this one.
        scene = monitor.scene
        first = scene.labelled(label)[0]
        before = max((p.end_s for p in scene.presses if p.end_s <= first.time_s), default=0.0)
        start_s = (before + first.time_s) / 2.0
        wait_for(executor, lambda: monitor.now() >= start_s, 120.0,
                 f'the scene to reach {start_s:.1f} s')
    monitor.status = status

    def on_press(feedback):
        monitor.status = (f'{status} ({feedback.presses_done}/{feedback.presses_wanted}, last '
                          f'{feedback.last_force:.1f} N)')
    _, response = send_goal(executor, client, request, 120.0, on_press)
    if response is None:
        raise RuntimeError(f'{status.split(":")[0]}: the goal was rejected')
    if not response.success:
        raise RuntimeError(f'{status.split(":")[0]} failed: {response.message}')
    return response


def offset_step(scene, timeout: float) -> tuple:
    """Return the offset goal and what the demo says of it, its count the goal's own."""
    normal = len(scene.labelled('offset'))
    # One spare: the first normal press may have begun before the goal is taken.
    wanted = normal - 1
    return (Calibrate.Goal(presses=wanted, timeout=timeout),
            f'calibrating (x_p, y_p) from {wanted} normal presses (the scene makes {normal}: '
            'one spare)')


def calibrate(executor, monitor, path: str) -> None:
    """Calibrate the offset, the force curve and the compliance through the actions."""
    scene = monitor.scene
    timeout = 60.0
    goal, status = offset_step(scene, timeout)
    offset = _step(executor, monitor, monitor.calibrate, goal, status)
    print(f'calibrated (x_p {offset.x_p * 1e3:.2f} mm, y_p {offset.y_p * 1e3:.2f} mm) from '
          f'{offset.presses_used} normal presses')
    forces = [p.force_n for p in scene.labelled('force')]
    force = _step(executor, monitor, monitor.calibrate_force,
                  CalibrateForce.Goal(forces=forces, timeout=timeout),
                  f'calibrating the force curve: presses of known force '
                  f'{", ".join(f"{f:g}" for f in forces)} N', 'force')
    print('force calibrated from {} presses; fitted/known: {}'.format(
        force.presses_used, ', '.join(f'{a:.1f}/{k:g} N' for a, k in zip(force.fitted, forces))))
    tilted = scene.labelled('compliance')
    compliance = _step(
        executor, monitor, monitor.calibrate_compliance,
        CalibrateCompliance.Goal(forces=[p.force_n for p in tilted],
                                 alphas=[math.radians(p.alpha_deg) for p in tilted],
                                 timeout=timeout),
        'calibrating the compliance: presses of known tilted load', 'compliance')
    print(f'compliance calibrated: {compliance.compliance:.3e} m/N '
          f'(the simulated skin has {scene.model.compliance_m_per_n:.3e})')
    monitor.set_calibration(path)
    monitor.status = 'calibrated; alpha = 45 deg presses at 8 azimuths'


def start_firmware_board(executor, scene_path: str, duration_s: float, port: str,
                         rate_hz: float, log) -> BoardProcess:
    """
    Start the firmware on the emulated board (QEMU) playing the scene, linked at port.

    It builds the image on first use and renders the scene, with a few seconds of the unloaded
    skin after it, into the scans the board reads; spin executor until it plays.
    """
    scans = round((duration_s + 5.0) * rate_hz)
    return _board_started(executor, ['-m', 'skin_driver.tools.firmware_board', '--scene',
                                     scene_path, '--link', port, '--rate', str(rate_hz),
                                     '--scans', str(scans)], log, 'the emulated board')


def _board_started(executor, argv: list, log, what: str) -> BoardProcess:
    """Spawn a board tool; spin executor until it says its epoch (RuntimeError if it stops)."""
    board = BoardProcess(spawn(argv, log, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True))

    def started() -> bool:
        return board.epoch is not None or board.process.poll() is not None

    if not spin_until(executor, started, 180.0, period_s=0.05) or board.epoch is None:
        board.stop()
        raise RuntimeError(f'{what} did not start: {"".join(board.lines)}')
    return board


def start_rehost_board(executor, scene_path: str, duration_s: float, port: str,
                       log) -> BoardProcess:
    """
    Start the unmodified Nucleo image on the rehosted chip playing the scene, linked at port.

    It builds the image on first use; the skin plays the scene, then a few seconds unloaded, at
    the firmware's own scan rate.
    """
    from skin_driver.tools.rehost.board import PINS
    from skin_driver.tools.rehost.wiring import load_wiring
    scans = round((duration_s + 5.0) * load_wiring(PINS).scan_rate_hz)
    return _board_started(executor, ['-m', 'skin_driver.tools.rehost', '--scene', scene_path,
                                     '--link', port, '--scans', str(scans)], log,
                          'the rehosted board')


def run(args, workdir: str) -> int:
    """Run the demo in workdir; return the exit status."""
    scene_dict = demo_scene(args.repeats, args.pace)
    scene = scene_from_dict(scene_dict, name='demo')
    scene_path = write_scene(workdir, scene_dict, 'demo.yaml')
    port = os.path.join(workdir, 'skin0')
    ns = '/skin_demo'
    log = open(os.path.join(workdir, 'nodes.log'), 'w')
    params = write_params(workdir, driver={'reconnect_max': 0.2, 'publish_images': False,
                                           **grid_params(scene)},
                          direction={'method': args.method})
    procs = list(start_nodes(args.fused, ros_args(ns, params), log).values())
    try:
        with ros_session() as executor:
            node = Node('skin_demo', namespace=ns)
            monitor = DemoMonitor(node, scene, args.method, live=args.live)
            executor.add_node(node)
            try:
                wait_for(executor, monitor.tare.service_is_ready, 20.0, 'the direction node',
                         procs)
                print(BOARDS[args.board])
                if args.board == 'qemu':
                    board = start_firmware_board(executor, scene_path, scene.duration_s, port,
                                                 args.rate, log)
                elif args.board == 'rehost':
                    board = start_rehost_board(executor, scene_path, scene.duration_s, port, log)
                else:
                    board = start_sim(executor, scene_path, port, args.rate, log)
                procs.append(board.process)
                # Tare needs its scans in the direction node, which sees them after the driver.
                wait_for(executor, lambda: monitor.estimates >= 30, 20.0,
                         'contacts from the direction node', procs)
                monitor.status = 'taring the unloaded skin'
                result = call_service(executor, monitor.tare, Trigger.Request(), 10.0)
                if not result.success:
                    raise RuntimeError(f'tare refused: {result.message}')
                calibrate(executor, monitor, os.path.join(workdir, 'calibration.yaml'))
                wait_for(executor, lambda: monitor.now() > scene.duration_s + 0.3,
                         scene.duration_s + 30.0, 'the scene')
                monitor.draw(force=True)
            finally:
                node.destroy_node()
    finally:
        stop(procs)
        log.close()
    report = {'methods': {name: summarise([r[0] for r in rows], [r[1] for r in rows])
                          for name, rows in monitor.results.items()}}
    where = 'the fused driver' if args.fused else 'the direction node'
    print(f'\nTable 1: azimuth error at alpha = 45 deg, every scan at full force, '
          f'{args.repeats} rounds at {args.rate:g} Hz; {args.method} ran in {where}, '
          "seed (the paper's plain phase correlation) on the same scans\n")
    print(format_table(report))
    if monitor.forces:
        rows = np.array(monitor.forces)
        force_error = 100.0 * np.abs(rows[:, 1] / rows[:, 0] - 1.0).mean()
        alpha_error = np.abs(rows[:, 3] - rows[:, 2]).mean()
        print(f'\nafter calibration, on {len(rows)} scans: |F| mean error {force_error:.1f} %, '
              f'alpha mean error {alpha_error:.1f} deg ({args.method}, direction node)')
    return 0


def main(argv=None) -> int:
    """Run the demo from the command line."""
    parser = argparse.ArgumentParser(prog='demo', description=__doc__.split('\n\n')[0])
    parser.add_argument('--method', default=DEFAULT_METHOD, help='estimator of the direction node')
    parser.add_argument('--repeats', type=int, default=3, help='rounds of the eight directions')
    parser.add_argument('--rate', type=float, default=100.0, help='scans per second of the skin')
    parser.add_argument('--pace', type=float, default=1.0,
                        help='time scale of the presses (0.5: twice as fast), 0.3 to 3')
    parser.add_argument('--fused', action='store_true',
                        help='estimate in the driver process (fused) instead of a direction node')
    parser.add_argument('--board', choices=('sim', 'qemu', 'rehost'), default='sim',
                        help='the skin: the simulator (sim) or the firmware on an emulated STM32 '
                             'fed with the same scene (qemu: the core on QEMU, needs the ARM '
                             'toolchain and QEMU, see tools/setup-firmware.sh; rehost: the '
                             'unmodified Nucleo image on modelled STM32F446 peripherals, needs '
                             'the ARM toolchain)')
    parser.add_argument('--plain', dest='live', action='store_false',
                        help='print status lines instead of redrawing the terminal')
    parser.set_defaults(live=sys.stdout.isatty())
    args = parser.parse_args(argv)
    if not 0.3 <= args.pace <= 3.0 or args.repeats < 1 or not 10.0 <= args.rate <= 2000.0:
        parser.error('--pace takes 0.3 to 3, --repeats 1 or more, --rate 10 to 2000')
    workdir = tempfile.mkdtemp(prefix='skin_demo_')
    keep = False
    try:
        return run(args, workdir)
    except (KeyboardInterrupt, ExternalShutdownException):
        print('\ndemo stopped')
        return 130
    except RuntimeError as err:
        keep = True
        print(f'\ndemo: {err} (node output kept in {workdir}/nodes.log)', file=sys.stderr)
        return 1
    finally:
        if not keep:
            shutil.rmtree(workdir, ignore_errors=True)


if __name__ == '__main__':
    sys.exit(main())
