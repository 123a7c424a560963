"""
End to end: the firmware on the emulated board (QEMU netduinoplus2) through the driver's link.

It streams 10 000 scans of a simulator scene through the driver's serial link and decoder;
every frame arrives intact and in order, the information frames between them are read as the
board's identity (docs/protocol.md) and discard nothing, and the contacts estimated from the
received scans are those of the rendered scans.
"""

import os
import re
import signal
import struct
import subprocess
import sys
import time

from port_reader import Collector, TapDecoder
import pytest
import serial

from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.protocol.link import CONNECTED, SerialLink
from skin_driver.core.protocol.wire import frame_size, FrameDecoder, header_crc
from skin_driver.core.sim.scene import load_scene
from skin_driver.tools import firmware_board

SCANS = 10_000
# What the board is told: faster than QEMU emulates it, so it scans back to back.
RATE_HZ = 1000
# The image speaks protocol version 2 unless built for version 1.
FRAME = frame_size(*firmware_board.QEMU_GRID, 2)
# The emulated board's health: QEMU stubs the RCC (no reset flags) and the IWDG; no fault. A
# version-2 board counts the frames it sent with a row marked (flagged), not dropped ones.
INFO_TEXT = re.compile(rb'board=qemu-netduinoplus2;uid=0{24};fw=\d+\.\d+\.\d+;grid=16x16;'
                       rb'pitch_um=5000;rate_hz=1000;reset=unknown;flagged=0;adc_ovr=0;adc_to=0;'
                       rb'link_to=0;hse_lost=0;mux=0')


def _split_stream(raw: bytes, start: int):
    """Walk raw from start as data frames and information frames; return (frames, infos)."""
    frames, infos, at = 0, [], start
    while len(raw) - at >= 4:
        if raw[at:at + 2] == b'\xa5\x5a':
            if len(raw) - at < FRAME:
                break
            frames += 1
            at += FRAME
        elif raw[at:at + 2] == b'\xa5\x69':
            size = 6 + raw[at + 3]
            if len(raw) - at < size:
                break
            infos.append(bytes(raw[at:at + size]))
            at += size
        else:
            raise AssertionError(f'byte {at} of the stream starts neither kind of frame')
    return frames, infos


# QEMU's speed is the host's: about a minute on an idle two-core machine, longer on a busy one.
@pytest.mark.timeout(400)
def test_ten_thousand_scans_through_the_driver(qemu_image, tmp_path):
    scene = load_scene('random')
    # One pass of the scene over the whole file: presses and quiet scans alike.
    top, bottom = firmware_board.render_scans(scene, SCANS, SCANS / scene.duration_s)
    firmware_board.write_scans(tmp_path / firmware_board.SCAN_FILE, top, bottom, RATE_HZ)
    decoder = TapDecoder(expected_shape=firmware_board.QEMU_GRID)
    collector = Collector(SCANS)
    received, enough = collector.frames, collector.enough

    board = firmware_board.QemuBoard(qemu_image, tmp_path, str(tmp_path / 'skin0'))
    port = board.start()
    states = []
    # A busy host may pause QEMU for a while: the link must wait rather than reopen the port
    # (QEMU drops what it writes to a pty nobody holds open).
    link = SerialLink(port, 921600, decoder, collector,
                      on_state=lambda state, detail: states.append(state), stall_timeout_s=60.0)
    started = time.monotonic()
    try:
        link.start()
        assert enough.wait(360), (f'{len(received)} frames in 360 s; QEMU said: '
                                  f'{"".join(board.lines)}')
    finally:
        link.stop()
        board.stop()
    took = time.monotonic() - started
    frames = received[:SCANS]

    stats = decoder.stats
    assert states.count(CONNECTED) == 1, f'the link reopened the port: {states}'
    assert (stats.seq_gaps, stats.frames_missed, stats.seq_implausible) == (0, 0, 0)
    first = frames[0].seq
    assert [f.seq for f in frames] == list(range(first, first + SCANS))
    times = [f.device_time_us for f in frames]
    assert all(b > a for a, b in zip(times, times[1:]))

    # The stream after the first frame is data and information frames and nothing else; the
    # decoder accepts every information frame (the one at boot too, when it was read) and
    # discards only what came before the first whole frame of either kind.
    raw = bytes(decoder.raw)
    assert {f.version for f in frames} == {2}
    assert stats.rows_flagged == stats.fault_frames == 0
    start = raw.find(struct.pack('<BBBBI', 0xA5, 0x5A, 2, 0, first))
    assert start >= 0
    # From the first whole frame on, not one check fails: the stream itself, decoded afresh
    # (before it, the reader came in mid-frame, and a marker in a header or a CRC there is
    # a rejected candidate, as on any link joined mid-stream).
    again = FrameDecoder(expected_shape=firmware_board.QEMU_GRID)
    again.feed(raw[start:])
    checked = again.stats
    assert (checked.crc_errors, checked.size_errors, checked.version_errors) == (0, 0, 0)
    assert checked.frames >= SCANS and checked.bytes_discarded == 0
    count, infos = _split_stream(raw, start)
    assert count >= SCANS
    boot = raw.find(b'\xa5\x69', 0, start)
    if boot >= 0:
        _, infos_from_boot = _split_stream(raw, boot)
        assert (stats.bytes_discarded, stats.info_frames) == (boot, len(infos_from_boot))
    else:
        assert (stats.bytes_discarded, stats.info_frames) == (start, len(infos))
    assert stats.info_errors == 0
    assert INFO_TEXT.fullmatch(decoder.board_info.text.encode('ascii'))
    for info in infos:
        assert info[2] == 1 and info[3] == len(info) - 6
        assert INFO_TEXT.fullmatch(info[4:-2]), info
        assert int.from_bytes(info[-2:], 'little') == header_crc(info[:-2])
    # Once a second of device time, give or take the one at either end.
    seconds = (times[-1] - times[0]) / 1e6
    assert abs(len(infos) - seconds) <= 1.5, (len(infos), seconds)

    # The counts are those of the rendered scan of the frame's device time (the file looped), so
    # the contacts are the simulator's for that scan. The board reads the clock for the scan
    # after the core stamps the frame, usually within the same scan period, but QEMU's clock is
    # the host's and a busy host may pause QEMU in between: the scan is never an earlier one
    # and, loosely, not one of a second later (reading the file in order instead of by time
    # would fall behind by seconds here, as QEMU scans slower than the rate).
    rendered = {top[i].tobytes() + bottom[i].tobytes(): i for i in range(SCANS)}
    assert len(rendered) == SCANS  # every scan tells which it is
    estimator = ContactEstimator()
    with_contacts = late = 0
    for frame in frames:
        index = rendered.get(frame.top.tobytes() + frame.bottom.tobytes())
        assert index is not None, f'seq {frame.seq} carries no rendered scan'
        due = frame.device_time_us * RATE_HZ // 1_000_000
        assert (index - due) % SCANS < RATE_HZ, (frame.seq, index, due)
        late += (index - due) % SCANS > 1
        got = estimator.process(frame.top, frame.bottom)
        assert got == estimator.process(top[index], bottom[index]), f'seq {frame.seq}'
        with_contacts += bool(got)
    assert with_contacts > SCANS // 10  # the comparison covered touches, not only quiet scans
    print(f'\n{SCANS} scans in {took:.1f} s ({SCANS / took:.0f} frames/s), device time '
          f'{seconds:.1f} s, {len(infos)} information frames, {with_contacts} scans with contacts,'
          f' {stats.bytes_discarded} bytes discarded, {late} scans read over a period late')


def test_a_scan_file_of_another_grid_stops_the_board(qemu_image, tmp_path):
    rows, cols = 8, 8
    with open(tmp_path / firmware_board.SCAN_FILE, 'wb') as f:
        f.write(firmware_board.SCAN_HEADER.pack(b'SKNS', 1, rows, cols, 0, 100, 1))
        f.write(bytes(4 * rows * cols))
    board = firmware_board.QemuBoard(qemu_image, tmp_path)
    board.start()
    try:
        board.process.wait(30)
    finally:
        board.stop()
    assert 'has another grid than this firmware' in ''.join(board.lines)


@pytest.mark.parametrize('protocol', [2, 1])
def test_command_line_board_streams_on_its_link_and_stops_with_qemu(qemu_image, tmp_path,
                                                                    protocol):
    link = tmp_path / 'skin0'
    proc = subprocess.Popen(
        [sys.executable, '-m', 'skin_driver.tools.firmware_board', '--scene', 'seed',
         '--rate', '200', '--scans', '50', '--link', str(link), '--protocol', str(protocol)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline().split()
        assert first == ['SKIN_PORT', str(link)]
        decoder = FrameDecoder(expected_shape=firmware_board.QEMU_GRID)
        port = serial.serial_for_url(str(link), timeout=0.2)
        frames = []
        try:
            for _ in range(100):
                frames += decoder.feed(port.read(4096))
                if len(frames) >= 20:
                    break
        finally:
            port.close()
        assert len(frames) >= 20
        assert {f.version for f in frames} == {protocol}
        qemu = [int(p) for p in os.listdir('/proc') if p.isdigit()
                and _parent(int(p)) == proc.pid]
        assert qemu, 'QEMU is not a child of the board process'
        proc.send_signal(signal.SIGINT)
        assert proc.wait(20) == 0
        assert not link.exists()
        # Stopped and reaped by the board process, not left running on its own.
        assert not any(os.path.exists(f'/proc/{pid}') for pid in qemu)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _parent(pid: int) -> int:
    try:
        with open(f'/proc/{pid}/stat') as f:
            return int(f.read().rsplit(')', 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return -1
