"""Tests of the simulated skin on a real pseudo-terminal, read with pyserial and the decoder."""

from dataclasses import replace
import os
import select
import struct
import time

import numpy as np
from port_reader import read_from, Reader
import pytest

from skin_driver.core.protocol.wire import (BoardInfo, encode_frame, encode_info, FrameDecoder,
                                            header_crc, SYNC)
from skin_driver.core.sim.board import sim_board_info, SIM_UID, SimulatedSkin
from skin_driver.core.sim.drift import Drift
from skin_driver.core.sim.physics import render, render_held
from skin_driver.core.sim.scene import scene_from_dict

RATE_HZ = 200.0


def held_press_scene():
    """Return a scene with one tilted press held at the centre for the whole test."""
    return scene_from_dict({'presses': [{
        'time_s': 0.0, 'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'alpha_deg': 45.0,
        'beta_deg': 135.0, 'radius_m': 0.004, 'duration_s': 1000.0, 'ramp_s': 0.0}]})


@pytest.fixture
def skin():
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, noise_seed=3)
    yield sim
    sim.stop()


def assert_equal_to_truth(sim, frames):
    truth = sim.ground_truth
    for f in frames:
        t = truth[f.seq]
        assert f.device_time_us == t.device_time_us
        np.testing.assert_array_equal(f.top, t.top)
        np.testing.assert_array_equal(f.bottom, t.bottom)


def assert_no_frame_lost(sim, frames):
    """Every frame the simulator queued between the first and last decoded one was decoded."""
    seqs = [f.seq for f in frames]
    queued = [s for s in sim.ground_truth if seqs[0] <= s <= seqs[-1]]
    assert seqs == sorted(queued)


def test_every_frame_equals_the_ground_truth(skin):
    reader = Reader(skin.start())
    try:
        reader.read_frames(60)
    finally:
        reader.close()
    frames = reader.frames
    assert_equal_to_truth(skin, frames)
    assert_no_frame_lost(skin, frames)
    # The press is really in the frames: a 10 N press lifts the centre well above the baseline.
    assert int(frames[-1].top.max()) > 1000 and int(frames[-1].bottom.max()) > 500
    truth = skin.truth(frames[-1].seq)
    assert len(truth.presses) == 1 and truth.press_indices == (0,)
    # Device time follows the frame index at the configured rate.
    f0, f1 = frames[0], frames[-1]
    assert f1.device_time_us - f0.device_time_us == round((f1.seq - f0.seq) * 1e6 / RATE_HZ)
    # Joining mid-frame costs what came before the first frame; nothing after it is lost.
    stats = reader.stats_since_joined()
    assert stats.crc_errors == 0 and stats.bytes_discarded == 0


def test_garbage_between_frames_costs_no_frame(skin):
    reader = Reader(skin.start())
    head = SYNC + bytes([1, 0]) + bytes(12) + bytes([16, 16])
    fake_header = head + struct.pack('<H', header_crc(head)) + b'\x33' * 40
    damaged = bytearray(encode_frame(999_999, 0, np.ones((16, 16), np.uint16),
                                     np.ones((16, 16), np.uint16)))
    damaged[100] ^= 0xFF
    garbage = [b'\x00\xff' * 50, SYNC * 3, fake_header, bytes(damaged), b'\xa5']
    try:
        reader.read_frames(5)
        for junk in garbage:
            skin.inject_garbage(junk)
            reader.read_frames(5)
        reader.read_frames(5)
    finally:
        reader.close()
    frames = reader.frames
    assert_equal_to_truth(skin, frames)
    assert_no_frame_lost(skin, frames)
    stats = reader.stats_since_joined()
    assert stats.bytes_discarded == sum(len(g) for g in garbage)
    # The fake header and the damaged frame fail their CRC; each of the three repeated markers
    # is followed by 0xA5 where the version byte would be.
    assert (stats.crc_errors, stats.size_errors, stats.version_errors) == (2, 0, 3)
    assert 999_999 not in [f.seq for f in frames]


def test_unplug_and_replug_on_the_link_is_survived(tmp_path):
    link = str(tmp_path / 'skin')
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, link_path=link)
    try:
        assert sim.start() == link
        assert os.path.realpath(link) == sim.port
        reader = Reader(link)
        reader.read_frames(10)
        before = reader.frames[-1].seq
        sim.unplug()
        assert not os.path.lexists(link)  # like udev removing the by-id link
        reader.read_until(lambda: reader.disconnects == 1)
        time.sleep(0.1)  # the device clock runs on while unplugged
        assert sim.replug() == link
        assert os.path.realpath(link) == sim.port
        reader.read_frames(10)
        reader.close()
    finally:
        sim.stop()
    after = [f for f in reader.frames if f.seq > before]
    assert len(after) >= 10
    assert after[0].seq - before >= 0.1 * RATE_HZ
    assert_equal_to_truth(sim, reader.frames)
    assert_no_frame_lost(sim, after)
    assert reader.decoder.stats.seq_gaps == 0  # reset() after the reconnect forgot the old seq
    assert not os.path.lexists(link)


def test_ground_truth_is_bounded_and_stop_is_idempotent():
    sim = SimulatedSkin('two_finger', rate_hz=RATE_HZ, truth_capacity=7)
    read_from(sim, 20)
    sim.stop()
    truth = sim.ground_truth
    assert len(truth) == 7
    assert max(truth) >= 19 and sim.frames_sent >= 20
    assert sim.port is None


def test_bad_arguments_are_rejected(tmp_path):
    with pytest.raises(ValueError, match='rate_hz'):
        SimulatedSkin('seed', rate_hz=0)
    with pytest.raises(ValueError, match='truth_capacity'):
        SimulatedSkin('seed', truth_capacity=0)
    with pytest.raises(ValueError, match='bundled scenes'):
        SimulatedSkin('no_such_scene')
    occupied = tmp_path / 'file'
    occupied.write_text('keep me')
    sim = SimulatedSkin('seed', link_path=str(occupied))
    with pytest.raises(ValueError, match='not a symlink'):
        sim.start()
    assert occupied.read_text() == 'keep me'


def test_a_replaying_board_sends_its_first_pass_again_under_new_numbers():
    # A 0.1 s scene at 200 Hz: 20 scans to a pass; 60 frames are three passes.
    scene = scene_from_dict({'presses': [{
        'time_s': 0.02, 'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'alpha_deg': 45.0,
        'beta_deg': 90.0, 'radius_m': 0.004, 'duration_s': 0.05, 'ramp_s': 0.0}],
        'period_s': 0.1})
    sim = SimulatedSkin(scene, rate_hz=RATE_HZ, noise_seed=3, loop=True, replay=True)
    frames = read_from(sim, 60).frames
    assert_equal_to_truth(sim, frames)
    assert_no_frame_lost(sim, frames)
    by_seq = {f.seq: f for f in frames}
    pairs = [(by_seq[s], by_seq[s + 20]) for s in by_seq if s + 20 in by_seq]
    assert len(pairs) >= 20
    for first, again in pairs:
        np.testing.assert_array_equal(first.top, again.top)  # the same scan, noise and all
        assert again.device_time_us - first.device_time_us == 100_000
    assert any(int(f.top.max()) > 1000 for f in frames)  # the press is in the pass


def test_only_a_looped_board_replays():
    with pytest.raises(ValueError, match='replay needs loop'):
        SimulatedSkin('seed', replay=True)


def test_the_board_says_who_it_is_before_its_first_frame_then_once_a_second():
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, noise_seed=3)
    # A plain open: pyserial's would flush what the board wrote before it.
    port = os.open(sim.start(), os.O_RDONLY | os.O_NOCTTY)
    decoder, frames, first = FrameDecoder(expected_shape=(16, 16)), [], b''
    try:
        deadline = time.monotonic() + 10.0
        while not frames or frames[-1].device_time_us < 1_200_000:
            assert time.monotonic() < deadline, 'timed out waiting for frames'
            if select.select([port], [], [], 0.02)[0]:
                data = os.read(port, 4096)
                first = first or data
                frames += decoder.feed(data)
    finally:
        os.close(port)
        sim.stop()
    info = sim_board_info(16, 16, 0.005, RATE_HZ)
    assert (info.board, info.uid, info.rate_hz) == ('sim', SIM_UID, RATE_HZ)
    assert sim.identity == info
    assert first.startswith(encode_info(info))
    assert decoder.board_info == info
    assert frames[0].seq == 0 and all(b.seq == a.seq + 1 for a, b in zip(frames, frames[1:]))
    # One before the first frame, one ahead of the first frame of each later second (the next
    # one may already be read, ahead of a frame that is not).
    seconds = len({f.device_time_us // 1_000_000 for f in frames})
    assert seconds == 2
    assert decoder.stats.info_frames in (seconds, seconds + 1)
    assert decoder.stats.bytes_discarded == decoder.stats.crc_errors == 0


def test_a_version_1_board_sends_no_identity_and_another_its_own():
    board = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, identity=None)
    frames = read_from(board, 5).frames
    assert len(frames) >= 5
    qemu = BoardInfo('qemu', '0' * 24, '0.1.0', 16, 16, 0.005, 1000)
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, identity=qemu)
    reader = Reader(sim.start())
    try:
        # pyserial's open may flush the first one: the next comes a second of device time later.
        reader.read_until(lambda: reader.decoder.board_info is not None)
    finally:
        reader.close()
        sim.stop()
    assert reader.decoder.board_info == qemu
    v1 = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, identity=None)
    reader = read_from(v1, 5)
    assert reader.decoder.board_info is None and v1.info_frames_sent == 0
    with pytest.raises(ValueError, match='identity'):
        SimulatedSkin('seed', identity='nucleo')


def drifting_scene(**drift):
    """Return a noiseless skin, idle for 0.25 s, then pressed at the centre, that drifts."""
    return scene_from_dict({'model': {'noise_counts': 0.0}, 'drift': drift, 'presses': [{
        'time_s': 0.25, 'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'alpha_deg': 0.0,
        'beta_deg': 0.0, 'radius_m': 0.004, 'duration_s': 1000.0, 'ramp_s': 0.0}]})


def test_a_scene_that_drifts_creeps_under_its_press_and_drifts_by_the_boards_clock():
    # 10 counts a second of offset drift, 20 % a decade of creep: plain within a second.
    scene = drifting_scene(creep_per_decade=0.2, offset_counts_per_hour=36000.0)
    frames = read_from(SimulatedSkin(scene, rate_hz=RATE_HZ), 200).frames
    press = scene.presses[0].press()
    for f in frames:
        t = f.device_time_us / 1e6
        if t < 0.25:
            # Idle: every taxel reads its offset, risen by the drift so far.
            assert (f.top == np.rint(20.0 + 10.0 * t)).all(), t
        elif t > 0.25:
            top, bottom = render_held(scene.model, [press], [t - 0.25], t, None)
            np.testing.assert_array_equal(f.top, top)
            np.testing.assert_array_equal(f.bottom, bottom)
    # The press reads more the longer it is held; without drift it would not.
    loaded = [f for f in frames if f.device_time_us > 300_000]
    assert loaded[-1].top.max() > loaded[0].top.max()
    still = render(replace(scene.model, drift=Drift()), [press], None)[0]
    assert loaded[-1].top.max() > still.max() + 20


def test_a_scene_without_drift_renders_as_before_and_one_with_it_cannot_be_replayed():
    scene = drifting_scene(offset_counts_per_hour=36000.0)
    still = replace(scene, drifts=False)
    frames = read_from(SimulatedSkin(still, rate_hz=RATE_HZ), 20).frames
    assert all((f.top == 20).all() for f in frames)
    with pytest.raises(ValueError, match='cannot be replayed'):
        SimulatedSkin(replace(scene, period_s=2000.0), loop=True, replay=True)


@pytest.mark.parametrize('protocol', [2, 1])
def test_the_board_sends_version_2_by_default_and_version_1_on_request(protocol):
    kwargs = {} if protocol == 2 else {'protocol': 1}
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, noise_seed=3, **kwargs)
    reader = read_from(sim, 20)
    assert {f.version for f in reader.frames} == {protocol}
    assert_equal_to_truth(sim, reader.frames)


def test_rows_the_board_failed_to_sample_are_marked_with_its_fault_bits():
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, noise_seed=3)
    row_valid = np.ones((2, 16), bool)
    row_valid[0, 7] = False  # the pressed centre's row of the top layer
    sim.set_row_faults(row_valid, faults=0b11)
    reader = read_from(sim, 10)
    for frame in reader.frames:
        assert frame.faults == 0b11 and np.array_equal(frame.row_valid, row_valid)
        truth = sim.truth(frame.seq)
        # The sampled rows are the scan's; the failed one carries meaningless full-scale counts.
        np.testing.assert_array_equal(np.delete(frame.top, 7, axis=0),
                                      np.delete(truth.top, 7, axis=0))
        assert (frame.top[7] == 4095).all() and not (truth.top[7] == 4095).all()
        np.testing.assert_array_equal(frame.bottom, truth.bottom)


def test_a_version_1_board_cannot_report_failed_rows_or_faults():
    sim = SimulatedSkin(held_press_scene(), rate_hz=RATE_HZ, protocol=1)
    with pytest.raises(ValueError, match='version-1 board cannot report'):
        sim.set_row_faults(faults=1)
    with pytest.raises(ValueError, match='protocol must be one of'):
        SimulatedSkin(held_press_scene(), protocol=3)
