"""`make soak` on a short run: every frame accounted for, equal to the truth, both layouts."""

import json

import pytest
from skin_driver.tools import soak

pytestmark = pytest.mark.ros


@pytest.mark.parametrize('fused', [False, True], ids=['split', 'fused'])
def test_a_short_soak_balances_its_frame_accounts(tmp_path, fused, capsys):
    out = tmp_path / 'soak.json'
    argv = ['--duration', '9', '--rate', '200', '--json', str(out)] + (['--fused'] * fused)
    assert soak.main(argv) == 0, capsys.readouterr().out[-3000:]
    report = json.loads(out.read_text())
    assert report['layout'] == ('fused' if fused else 'split')
    assert report['balance'] == {'device': 0, 'line': 0, 'driver': 0}
    assert report['subscriber']['frames_received'] > 0
    assert report['subscriber']['frames_not_equal_to_truth'] == 0
    assert all(report['nodes_alive_at_end'].values())
