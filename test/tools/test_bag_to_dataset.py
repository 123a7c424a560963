"""What a robot saw, as a dataset: live frames recorded, rosbag2 bags converted, then scored."""

import json
import pathlib

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
from skin_driver.core.estimation.data.dataset import load_dataset
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_driver.tools import bag_to_dataset
from skin_lab.evaluate import cli as evaluate
from skin_lab.experiments import make_scene

ROOT = pathlib.Path(__file__).resolve().parents[2]
SKIN_FRAME = 'skin_msgs/msg/SkinFrame'


@pytest.fixture(scope='module')
def pressed():
    """Return (tare top, tare bottom, top, bottom, pitch) of the paper's presses at beta 90."""
    data = make_scene('paper', 'default', np.random.default_rng(3), 2)
    at_90 = np.flatnonzero((data.alpha_deg == 45.0) & (data.azimuth_deg == 90.0))
    assert at_90.size == 2
    return (data.tare_top, data.tare_bottom, data.top[at_90], data.bottom[at_90], data.pitch_m)


def _write_bag(path, scans, pitch_m, storage, topic='/skin/frame', board_info=()):
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(
        (ROOT / 'skin_msgs' / 'msg' / 'SkinFrame.msg').read_text(), SKIN_FRAME))
    frame = store.types[SKIN_FRAME]
    header = store.types['std_msgs/msg/Header']
    stamp = store.types['builtin_interfaces/msg/Time']
    with Writer(path, version=9, storage_plugin=storage) as writer:
        connection = writer.add_connection(topic, SKIN_FRAME, typestore=store)
        if board_info:
            # As the driver publishes it: a std_msgs/String beside the frame topic.
            info = writer.add_connection(topic.rsplit('/', 1)[0] + '/board_info',
                                         'std_msgs/msg/String', typestore=store)
            for i, text in enumerate(board_info):
                writer.write(info, 999_000_000 + i, store.serialize_cdr(
                    store.types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String'))
        for i, (top, bottom) in enumerate(scans):
            msg = frame(header=header(stamp=stamp(sec=1, nanosec=i * 1000), frame_id='skin_link'),
                        sequence=i, device_time_us=i * 1000, rows=top.shape[0],
                        cols=top.shape[1], pitch=pitch_m, top=top.ravel().astype(np.uint16),
                        bottom=bottom.ravel().astype(np.uint16))
            writer.write(connection, 1_000_000_000 + i * 1_000_000,
                         store.serialize_cdr(msg, SKIN_FRAME))


@pytest.mark.parametrize('storage', [StoragePlugin.SQLITE3, StoragePlugin.MCAP],
                         ids=['sqlite3', 'mcap'])
def test_a_bag_of_frames_becomes_a_dataset_the_evaluator_scores(
        tmp_path, pressed, storage, capsys):
    tare_top, tare_bottom, top, bottom, pitch = pressed
    bag = tmp_path / 'bag'
    _write_bag(bag, list(zip(tare_top, tare_bottom)) + list(zip(top, bottom)), pitch, storage)
    out = tmp_path / 'seen.npz'
    assert bag_to_dataset.main([str(bag), str(out), '--tare-frames', str(len(tare_top)),
                                '--azimuth-deg', '90', '--alpha-deg', '45']) == 0
    data = load_dataset(out)
    # Counts arrive exactly as recorded; the tare is the unloaded scans.
    assert np.array_equal(data.top, top) and np.array_equal(data.bottom, bottom)
    assert np.array_equal(data.tare_top, tare_top)
    assert data.pitch_m == pytest.approx(pitch, rel=1e-6)
    capsys.readouterr()
    assert evaluate.main([str(out), '--json']) == 0
    summary = json.loads(capsys.readouterr().out)['methods'][DEFAULT_METHOD]['summary']
    # The default skin's paper presses: every direction valid and within a few degrees.
    assert summary['frames'] == 2 and summary['valid'] == 2
    assert summary['max_error_deg'] < 5.0


def test_a_bag_without_a_skin_frame_topic_is_refused_with_the_topics_it_holds(
        tmp_path, pressed, capsys):
    tare_top, tare_bottom, *_ = pressed
    bag = tmp_path / 'bag'
    _write_bag(bag, list(zip(tare_top, tare_bottom))[:2], 0.005, StoragePlugin.SQLITE3,
               topic='/left/frame')
    assert bag_to_dataset.main([str(bag), str(tmp_path / 'x.npz'), '--topic', '/skin/frame']) == 2
    err = capsys.readouterr().err
    assert "no skin_msgs/msg/SkinFrame topic '/skin/frame'" in err and '/left/frame' in err
    assert not (tmp_path / 'x.npz').exists()


@pytest.mark.parametrize('make, expected', [
    (lambda path: None, 'no such bag'),
    (lambda path: path.mkdir(), 'cannot read as a rosbag2 bag'),
])
def test_what_is_not_a_bag_is_one_line_saying_so(tmp_path, make, expected, capsys):
    bag = tmp_path / 'bag'
    make(bag)
    assert bag_to_dataset.main([str(bag), str(tmp_path / 'x.npz')]) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count('\n') == 1


def test_a_bag_holding_only_the_tare_is_refused(tmp_path, pressed, capsys):
    tare_top, tare_bottom, *_ = pressed
    bag = tmp_path / 'bag'
    _write_bag(bag, list(zip(tare_top, tare_bottom)), 0.005, StoragePlugin.MCAP)
    assert bag_to_dataset.main([str(bag), str(tmp_path / 'x.npz'),
                                '--tare-frames', str(len(tare_top))]) == 2
    assert 'needs more than the 20 tare scans' in capsys.readouterr().err


NUCLEO = ('board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;pitch_um=5000;'
          'rate_hz=1000')


def test_a_bag_with_the_board_identity_stamps_the_dataset(tmp_path, pressed, capsys):
    tare_top, tare_bottom, top, bottom, pitch = pressed
    bag = tmp_path / 'bag'
    _write_bag(bag, list(zip(top, bottom)), pitch, StoragePlugin.MCAP, board_info=[NUCLEO])
    out = tmp_path / 'seen.npz'
    assert bag_to_dataset.main([str(bag), str(out)]) == 0
    assert 'board nucleo-f446re uid 0039001e3438510b34313939' in capsys.readouterr().out
    data = load_dataset(out)
    assert data.board_info == NUCLEO and data.board().uid == '0039001e3438510b34313939'
    # A bag of a version-1 board (no board_info) gives a dataset without it.
    _write_bag(tmp_path / 'old', list(zip(top, bottom)), pitch, StoragePlugin.MCAP)
    assert bag_to_dataset.main([str(tmp_path / 'old'), str(tmp_path / 'old.npz')]) == 0
    assert load_dataset(tmp_path / 'old.npz').board_info is None


def test_a_bag_of_two_boards_is_refused(tmp_path, pressed, capsys):
    *_, top, bottom, pitch = pressed
    other = NUCLEO.replace('uid=0039001e3438510b34313939', 'uid=' + '0' * 24)
    _write_bag(tmp_path / 'bag', list(zip(top, bottom)), pitch, StoragePlugin.SQLITE3,
               board_info=[NUCLEO, other])
    assert bag_to_dataset.main([str(tmp_path / 'bag'), str(tmp_path / 'x.npz')]) == 2
    assert 'now sends; the recording is of board nucleo-f446re' in capsys.readouterr().err
    assert not (tmp_path / 'x.npz').exists()
