"""Section 8: known presses against the error reached, beside the oracle and the bound."""

from skin_lab.bench.direction import direction_learning, direction_markdown, direction_targets
from skin_lab.bench.scoring import _target
from skin_lab.bench.tables import _table, figure


def test_known_presses_against_the_error_with_the_floor_beside():
    # 12 presses, a few over the 10 a correction needs: the rows' shape and the floor are
    # asserted, not how much the presses teach; each one more lengthens the skin's learning.
    res = direction_learning(['default'], {'paper': 1, 'random': 15}, [12], log=lambda s: None)
    assert res['counts'] == [0, 12]  # today's calibration first
    paper, random = res['rows']
    assert (paper['scene'], random['scene']) == ('paper', 'random')
    for row in res['rows']:
        assert set(row['learned']) == {'0', '12'}
        assert not row['learned']['0']['applied']  # no known presses: nothing learned
        assert row['learned']['12']['cv_before_deg'] > 0
        # The floor beside: the oracle's error and the bound, both below the default's.
        assert 0 < row['crb']['mean_abs_error_deg'] < row['learned']['0']['mean_error_deg']
        assert 0 < row['oracle_deg'] < row['learned']['0']['mean_error_deg']
        assert row['ratio'] == (row['learned']['12']['mean_error_deg']
                                / row['learned']['0']['mean_error_deg'])
    lines = '\n'.join(direction_markdown(res, figure, _table))
    assert '| skin | scene | 0 presses [deg] | 12 presses [deg] | applied | ratio | oracle [deg]' \
        in lines
    targets = {t['name']: t for t in direction_targets(res, _target)}
    minutes = targets['robot time of the calibration run [min]']
    assert minutes['measured'] == '0.5' and minutes['met']  # 12 presses of 2.5 s
    assert "paper's protocol with 12 known presses (worst skin)" in targets


def _row(skin, scene, errors):
    return {'skin': skin, 'scene': scene, 'ratio': errors[-1] / errors[0],
            'learned': {str(n): {'mean_error_deg': e, 'us_per_frame': 10.0}
                        for n, e in zip((0, 60, 240), errors)}}


def test_a_cell_made_worse_at_any_number_of_presses_is_named():
    # Worse at 60 presses and back at 240: a user who stops at 60 gets the worse one.
    res = {'counts': [0, 60, 240], 'robot_press_s': 2.5,
           'rows': [_row('default', 'random', (1.0, 0.8, 0.7)),
                    _row('loaded', 'paper', (0.5, 0.6, 0.5))]}
    targets = {t['name']: t for t in direction_targets(res, _target)}
    worse = targets['cells made worse by the known presses (any skin, scene, presses)']
    assert not worse['met'] and worse['measured'] == '1'
    assert 'loaded paper (60)' in worse['note'] and 'default' not in worse['note']
