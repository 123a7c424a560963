"""ROS style checks: ament_flake8 (ROS configuration) and ament_pep257 over our Python."""

import pathlib

from ament_flake8.main import main_with_errors
from ament_pep257.main import main as pep257_main
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PATHS = [str(ROOT / p) for p in ('skin_driver', 'test', 'launch', 'setup.py')]


@pytest.mark.linter
def test_flake8():
    rc, errors = main_with_errors(argv=PATHS)
    assert rc == 0, f'{len(errors)} flake8 errors:\n' + '\n'.join(errors)


@pytest.mark.linter
def test_pep257():
    rc = pep257_main(argv=PATHS)
    assert rc == 0, 'pep257 found problems (listed above)'
