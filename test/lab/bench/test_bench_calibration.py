"""The force calibration part of the benchmark: |F| and alpha per skin, tip and method."""


def test_calibration_accuracy_scores_the_default_and_the_oracle_with_both_tips(results):
    cal = results['calibration']
    cells = {(r['scene'], r['method']) for r in cal['rows']}
    assert cells == {(k, m) for k in ('one_tip', 'random') for m in ('taxel_fit', 'oracle')}
    for r in cal['rows']:
        assert r['skin'] == 'saturating' and r['force_error_pct'] >= 0.0
    # The oracle fits the simulator itself: far below any calibrated estimator.
    oracle = [r for r in cal['rows'] if r['method'] == 'oracle']
    assert max(r['force_error_pct'] for r in oracle) < 1.0
    assert cal['worst']['one_tip_force_error_pct'][1] == 'saturating'
