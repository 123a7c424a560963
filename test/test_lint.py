"""ROS style checks: ament_flake8 (ROS configuration) and ament_pep257 over our Python."""

import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PATHS = [str(ROOT / p) for p in ('skin_driver', 'skin_lab', 'test', 'launch', 'setup.py')]


def _run(code):
    # A fresh interpreter: flake8 forks workers, and forking a process that runs ROS threads
    # (earlier tests in this one) can deadlock.
    return subprocess.run([sys.executable, '-c', code, *PATHS], capture_output=True, text=True,
                          timeout=240)


@pytest.mark.linter
def test_flake8():
    result = _run('import sys; from ament_flake8.main import main_with_errors\n'
                  'rc, errors = main_with_errors(argv=sys.argv[1:])\n'
                  'print("\\n".join(errors)); sys.exit(rc)')
    assert result.returncode == 0, 'flake8 errors:\n' + result.stdout[-5000:]


@pytest.mark.linter
def test_pep257():
    result = _run('import sys; from ament_pep257.main import main\n'
                  'sys.exit(main(argv=sys.argv[1:]))')
    problems = [line for line in result.stdout.splitlines() if ': D' in line]
    assert result.returncode == 0, 'pep257 problems:\n' + '\n'.join(problems)
