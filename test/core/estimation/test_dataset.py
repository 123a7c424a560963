"""Tests of the offline dataset format and generators."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.data.dataset import Dataset, load_dataset, save_dataset
from skin_driver.core.estimation.data.recording import Recording
from skin_driver.core.sim.physics import SkinModel
from skin_lab.experiments import make_random_experiment, make_seed_experiment


def small(n=3):
    return {'top': np.zeros((n, 4, 5), np.uint16), 'bottom': np.ones((n, 4, 5), np.uint16),
            'pitch_m': 0.005, 'azimuth_deg': np.array([math.nan, 45.0, 90.0][:n]),
            'alpha_deg': np.array([0.0, 45.0, 45.0][:n])}


def test_seed_experiment_layout():
    data = make_seed_experiment(SkinModel(), repeats=2, rng=np.random.default_rng(0))
    assert data.frames == 18 and data.shape == (16, 16)
    assert data.top.dtype == np.uint16
    assert np.isnan(data.azimuth_deg[data.alpha_deg == 0]).all()
    assert sorted(set(data.azimuth_deg[data.alpha_deg > 0])) == list(range(0, 360, 45))
    assert set(data.alpha_deg) == {0.0, 45.0}
    assert data.tare_top.shape[1:] == (16, 16)


def test_random_experiment_ranges():
    data = make_random_experiment(frames=40, rng=np.random.default_rng(1))
    tilted = data.alpha_deg > 0
    assert tilted.any() and (~tilted).any()
    assert (data.alpha_deg[tilted] >= 15).all() and (data.alpha_deg[tilted] <= 60).all()
    assert np.isfinite(data.azimuth_deg[tilted]).all()


def test_round_trip(tmp_path):
    data = make_seed_experiment(repeats=1, rng=np.random.default_rng(2))
    path = tmp_path / 'd.npz'
    save_dataset(path, data)
    back = load_dataset(path)
    assert np.array_equal(back.top, data.top) and np.array_equal(back.bottom, data.bottom)
    np.testing.assert_array_equal(back.azimuth_deg, data.azimuth_deg)
    np.testing.assert_array_equal(back.force_n, data.force_n)
    assert back.pitch_m == data.pitch_m


def test_minimal_file_without_optional_arrays(tmp_path):
    path = tmp_path / 'm.npz'
    np.savez(path, **small())
    data = load_dataset(path)
    assert data.force_n is None and data.tare_top is None


@pytest.mark.parametrize('change, message', [
    ({'top': np.zeros((3, 4, 4), np.uint16)}, 'shapes differ'),
    ({'top': np.full((3, 4, 5), -1.0)}, 'negative'),
    ({'top': np.full((3, 4, 5), 0.5)}, 'whole ADC counts'),
    ({'pitch_m': 0.0}, 'pitch_m must be positive'),
    ({'alpha_deg': np.array([0.0, 45.0])}, 'shape'),
    ({'alpha_deg': np.array([0.0, 95.0, 45.0])}, 'alpha_deg'),
    ({'azimuth_deg': np.array([math.nan, math.nan, 90.0])}, 'azimuth_deg is NaN'),
    ({'force_n': np.array([1.0, -1.0, 1.0])}, 'force_n must be non-negative'),
    ({'split': np.array([0, 5, 1])}, 'split must be'),
    ({'split': np.array([0, 1])}, 'split must be'),
])
def test_validation(change, message):
    with pytest.raises(ValueError, match=message):
        Dataset(**{**small(), **change})


def test_missing_arrays_and_garbage(tmp_path):
    path = tmp_path / 'bad.npz'
    fields = small()
    del fields['alpha_deg']
    np.savez(path, **fields)
    with pytest.raises(ValueError, match='missing arrays: alpha_deg'):
        load_dataset(path)
    junk = tmp_path / 'junk.npz'
    junk.write_bytes(b'not a zip')
    with pytest.raises(ValueError, match='cannot read'):
        load_dataset(junk)


def test_arrays_are_read_only_copies():
    fields = small()
    data = Dataset(**fields)
    fields['top'][0, 0, 0] = 7
    assert data.top[0, 0, 0] == 0
    with pytest.raises(ValueError):
        data.top[0, 0, 0] = 1


def test_format_1_loads_and_format_2_keeps_the_split(tmp_path):
    old = tmp_path / 'v1.npz'
    np.savez(old, format_version=np.int64(1), **small())
    assert load_dataset(old).split is None
    path = tmp_path / 'v2.npz'
    # 2: a normal press at the place of use, which re-takes the offset; never scored.
    save_dataset(path, Dataset(**small(), split=np.array([1, 2, 0])))
    with np.load(path) as npz:
        assert int(npz['format_version']) == 2
    back = load_dataset(path)
    assert back.split.dtype == np.uint8 and back.split.tolist() == [1, 2, 0]
    assert back.scored_frames().tolist() == [2]
    np.savez(tmp_path / 'v3.npz', format_version=np.int64(3), **small())
    with pytest.raises(ValueError, match='unsupported format_version 3'):
        load_dataset(tmp_path / 'v3.npz')


BOARD = ('board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=2x2;pitch_um=5000;'
         'rate_hz=1000;adc=3')


def _tiny(**extra):
    maps = np.zeros((3, 2, 2), np.uint16)
    return Dataset(top=maps, bottom=maps, pitch_m=0.005, azimuth_deg=np.full(3, np.nan),
                   alpha_deg=np.zeros(3), **extra)


def test_the_board_identity_round_trips_and_old_files_have_none(tmp_path):
    data = _tiny(board_info=BOARD)
    save_dataset(tmp_path / 'b.npz', data)
    back = load_dataset(tmp_path / 'b.npz')
    assert back.board_info == BOARD
    assert back.board().uid == '0039001e3438510b34313939' and back.board().extra == (('adc', '3'),)
    assert back.select([0, 2]).board_info == BOARD
    save_dataset(tmp_path / 'none.npz', _tiny())
    assert load_dataset(tmp_path / 'none.npz').board_info is None
    assert load_dataset(tmp_path / 'none.npz').board() is None
    with np.load(tmp_path / 'none.npz') as npz:
        assert 'board_info' not in npz.files


def test_a_malformed_board_identity_is_refused(tmp_path):
    with pytest.raises(ValueError, match='board_info is not a board information text'):
        _tiny(board_info='board=x')
    maps = np.zeros((1, 2, 2), np.uint16)
    arrays = {'top': maps, 'bottom': maps, 'pitch_m': 0.005, 'azimuth_deg': [np.nan],
              'alpha_deg': [0.0], 'board_info': np.array([1, 2])}
    np.savez(tmp_path / 'bad.npz', **arrays)
    with pytest.raises(ValueError, match='board_info must be one string'):
        load_dataset(tmp_path / 'bad.npz')


def test_a_recording_is_stamped_with_one_board():
    recording = Recording()
    recording.add(0.005, np.zeros((2, 2), np.uint16), np.zeros((2, 2), np.uint16))
    assert recording.dataset().board_info is None
    recording.set_board(BOARD)
    recording.set_board(BOARD.replace('fw=0.1.0', 'fw=0.2.0'))  # the same board, updated
    assert recording.dataset().board().fw == '0.2.0'
    with pytest.raises(ValueError, match='uid 000000000000000000000000 now sends; the '
                                         'recording is of board nucleo-f446re'):
        recording.set_board(BOARD.replace('0039001e3438510b34313939', '0' * 24))
    with pytest.raises(ValueError, match='lacks'):
        recording.set_board('board=x')
