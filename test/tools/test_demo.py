"""`make demo` runs the whole pipeline, ends with Table 1 and leaves no process behind."""

import os
import pathlib
import subprocess
import sys
import uuid

import pytest

pytestmark = pytest.mark.ros


def _processes_with(tag):
    found = []
    for pid in filter(str.isdigit, os.listdir('/proc')):
        try:
            environ = pathlib.Path(f'/proc/{pid}/environ').read_bytes()
        except OSError:
            continue
        if tag.encode() in environ:
            found.append(int(pid))
    return found


def test_demo_calibrates_and_prints_table_1_next_to_the_papers():
    tag = f'SKIN_DEMO_TEST={uuid.uuid4().hex}'
    env = dict(os.environ, SKIN_DEMO_TEST=tag.split('=')[1])
    result = subprocess.run(
        [sys.executable, '-m', 'skin_driver.tools.demo', '--plain', '--repeats', '1',
         '--pace', '0.6'],
        capture_output=True, text=True, timeout=180, env=env)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    out = result.stdout
    assert 'calibrated (x_p' in out
    table = out[out.index('Table 1'):]
    for beta in ('0.0', '45.0', '90.0', '135.0', '180.0', '225.0', '270.0', '315.0'):
        assert f'\n{beta:>10}' in table
    summary = next(line for line in table.splitlines() if line.strip().startswith('summary'))
    fields = summary.split()
    default_mean, seed_mean, paper_mean = float(fields[1]), float(fields[4]), float(fields[7])
    assert paper_mean == 3.72
    # The driver's estimator beats the paper's method on the very same scans.
    assert default_mean < seed_mean
    assert _processes_with(tag) == []
