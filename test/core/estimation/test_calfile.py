"""The calibration file a skin owns: a refused file is never written; a write keeps a backup."""

import pytest
from skin_driver.core.estimation.calibration.calfile import (backup_of, CalibrationFile,
                                                             FileRefused, refusal)
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinIdentity

ON_16 = SkinIdentity(16, 16, 0.005)


def test_a_write_keeps_the_file_it_replaces_as_a_backup_one_generation(tmp_path):
    path = tmp_path / 'cal.yaml'
    first, second, third = (Calibration(x_p_m=v, presses=3) for v in (1e-4, 2e-4, 3e-4))
    file = CalibrationFile(str(path))
    assert file.save(first) == str(path)
    # Nothing to keep the first time.
    assert not (tmp_path / 'cal.yaml.bak').exists()
    first_bytes = path.read_bytes()
    file.save(second)
    assert (tmp_path / 'cal.yaml.bak').read_bytes() == first_bytes
    second_bytes = path.read_bytes()
    file.save(third)
    assert backup_of(path) == str(tmp_path / 'cal.yaml.bak')
    assert (tmp_path / 'cal.yaml.bak').read_bytes() == second_bytes
    assert Calibration.load_yaml(path) == third
    # Only the file and its one backup: no temporary file is left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == ['cal.yaml', 'cal.yaml.bak']


def test_a_refused_file_is_never_written_and_the_refusal_names_the_way_out(tmp_path):
    path = tmp_path / 'other.yaml'
    Calibration(x_p_m=4e-4, presses=8, skin=SkinIdentity(64, 64, 0.00125)).save_yaml(path)
    before = path.read_bytes()
    problem = refusal(str(path), ON_16)
    assert 'made for 64 x 64 taxels' in problem
    file = CalibrationFile(str(path), problem)
    with pytest.raises(FileRefused) as err:
        file.save(Calibration())
    assert f'{path} is not written: it was refused (' in str(err.value)
    assert "name a file of this skin's own in calibration_file" in str(err.value).lower()
    assert path.read_bytes() == before
    assert not (tmp_path / 'other.yaml.bak').exists()


def test_refusal_of_a_corrupt_an_absent_and_a_fitting_file(tmp_path):
    corrupt = tmp_path / 'corrupt.yaml'
    corrupt.write_text('x_p_m: [unclosed\n')
    assert 'not valid YAML' in refusal(str(corrupt))
    assert refusal(str(tmp_path / 'absent.yaml'), ON_16) == ''
    fits = tmp_path / 'fits.yaml'
    Calibration(x_p_m=1e-4, skin=ON_16).save_yaml(fits)
    assert refusal(str(fits), ON_16) == ''
    # Without a skin (no scan yet) only whether it reads is known.
    assert refusal(str(fits)) == ''
