"""Atomic writes: a failure part-way leaves the previous file whole and no temporary behind."""

import os

import pytest
from skin_driver.core.common.atomic import write_atomically


def test_write_replaces_the_file_and_creates_missing_directories_when_asked(tmp_path):
    target = tmp_path / 'deep' / 'er' / 'calibration.yaml'
    write_atomically(target, lambda f: f.write('x_p_m: 0.001\n'), make_parents=True)
    assert target.read_text() == 'x_p_m: 0.001\n'
    write_atomically(target, lambda f: f.write(b'new'), binary=True)
    assert target.read_bytes() == b'new'
    assert os.listdir(target.parent) == ['calibration.yaml']


def test_a_tools_output_in_a_missing_directory_is_refused_and_nothing_is_created(tmp_path):
    target = tmp_path / 'nodir' / 'out.npz'
    with pytest.raises(ValueError, match='nodir does not exist; create it first'):
        write_atomically(target, lambda f: f.write('x'))
    with pytest.raises(ValueError, match='is a directory'):
        write_atomically(tmp_path, lambda f: f.write('x'))
    assert list(tmp_path.iterdir()) == []


def test_a_failure_mid_write_keeps_the_previous_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / 'calibration.yaml'
    target.write_text('previous\n')

    def half_then_fail(f):
        f.write('half of the new cont')
        raise OSError('disk full')

    with pytest.raises(OSError, match='disk full'):
        write_atomically(target, half_then_fail)
    assert target.read_text() == 'previous\n'
    assert os.listdir(tmp_path) == ['calibration.yaml']
