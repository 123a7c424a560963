"""A calibration file bound to the board that said who it is (docs/protocol.md, info frame)."""

import pytest
from skin_driver.core.estimation.calibration.calibration import (Calibration,
                                                                 CalibrationMismatch,
                                                                 SkinIdentity)
import yaml

NUCLEO_UID = '0039001e3438510b34313939'
QEMU_UID = '0' * 24
ON_NUCLEO = SkinIdentity(16, 16, 0.005, '', NUCLEO_UID, 'nucleo-f446re')
ON_QEMU = SkinIdentity(16, 16, 0.005, '', QEMU_UID, 'qemu')
VERSION_1 = SkinIdentity(16, 16, 0.005)


def saved(tmp_path, skin, name='cal.yaml'):
    path = tmp_path / name
    Calibration(x_p_m=2e-4, presses=8, skin=skin).save_yaml(path)
    return path


def test_the_file_keeps_the_board_uid_and_name(tmp_path):
    path = saved(tmp_path, ON_NUCLEO)
    doc = yaml.safe_load(path.read_text())
    assert doc['skin']['board_uid'] == NUCLEO_UID and doc['skin']['board_name'] == 'nucleo-f446re'
    assert Calibration.load_yaml(path).skin == ON_NUCLEO
    assert Calibration.load_yaml(path, ON_NUCLEO).x_p_m == 2e-4


def test_a_file_from_another_board_is_refused_naming_both(tmp_path):
    path = saved(tmp_path, ON_NUCLEO)
    with pytest.raises(CalibrationMismatch) as err:
        Calibration.load_yaml(path, ON_QEMU)
    assert str(err.value) == (
        f'{path}: made on board nucleo-f446re uid {NUCLEO_UID}; this skin is on board qemu uid '
        f'{QEMU_UID}; this skin needs a calibration file of its own')


def test_the_uid_decides_over_a_board_name_or_a_user_name(tmp_path):
    renamed = SkinIdentity(16, 16, 0.005, '', NUCLEO_UID, 'nucleo-renamed')
    assert Calibration.load_yaml(saved(tmp_path, ON_NUCLEO), renamed).x_p_m == 2e-4
    same_name_other_board = SkinIdentity(16, 16, 0.005, '', QEMU_UID, 'nucleo-f446re')
    with pytest.raises(CalibrationMismatch, match=f'uid {QEMU_UID}'):
        Calibration.load_yaml(saved(tmp_path, ON_NUCLEO), same_name_other_board)


def test_a_file_bound_to_no_board_loads_with_a_note(tmp_path):
    path = saved(tmp_path, VERSION_1)
    assert 'board_uid' not in yaml.safe_load(path.read_text())['skin']
    cal = Calibration.load_yaml(path, ON_QEMU)
    warning, note = cal.board_binding(ON_QEMU)
    assert warning == ''
    assert 'bound to no board' in note and f'board qemu uid {QEMU_UID}' in note


def test_a_bound_file_on_a_version_1_board_loads_with_a_warning(tmp_path):
    cal = Calibration.load_yaml(saved(tmp_path, ON_NUCLEO), VERSION_1)
    warning, note = cal.board_binding(VERSION_1)
    assert note == ''
    assert f'made on board nucleo-f446re uid {NUCLEO_UID}' in warning
    assert 'does not say who it is (version-1 stream)' in warning


def test_the_same_board_and_two_silent_boards_need_no_word():
    assert Calibration(skin=ON_NUCLEO).board_binding(ON_NUCLEO) == ('', '')
    assert Calibration(skin=VERSION_1).board_binding(VERSION_1) == ('', '')
    assert Calibration().board_binding(VERSION_1) == ('', '')


def test_a_grid_mismatch_is_still_refused_on_the_same_board():
    other_grid = SkinIdentity(8, 8, 0.005, '', NUCLEO_UID, 'nucleo-f446re')
    assert 'made for 16 x 16' in Calibration(skin=ON_NUCLEO).check_skin(other_grid)


def test_a_malformed_uid_is_refused(tmp_path):
    with pytest.raises(ValueError, match='board_uid'):
        SkinIdentity(16, 16, 0.005, '', 'NUCLEO')
    path = tmp_path / 'bad.yaml'
    doc = yaml.safe_load(saved(tmp_path, ON_NUCLEO).read_text())
    doc['skin']['board_uid'] = 'not-a-uid'
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ValueError, match='board_uid'):
        Calibration.load_yaml(path)
