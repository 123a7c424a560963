"""The benchmark's ROS-free measurements on tiny inputs: rows for every method and point."""

import math

import numpy as np
import pytest
from skin_lab.bench import costs, estimators as bench_core


def test_accuracy_rows_cover_every_method_and_hold_finite_figures(results):
    rows = results['accuracy']['rows']
    assert sorted(r['method'] for r in rows) == sorted(['poc', 'seed', bench_core.SKIMAGE])
    for r in rows:
        assert r['frames'] == 2 and 0 <= r['valid'] <= 2
        assert math.isfinite(r['median_us']) and r['median_us'] > 0
        assert r['mean_error_deg'] is None or 0 <= r['mean_error_deg'] <= 180


def test_skimage_reference_reports_the_displacement_of_the_bottom_map():
    top = np.zeros((16, 16))
    top[6:9, 5:9] = 1.0
    top[7, 6] = 3.0
    bottom = np.roll(top, (1, 2), axis=(0, 1))
    dx, dy, conf, _ = bench_core.skimage_shift(np.stack((top, bottom)))
    assert (dx, dy, conf) == pytest.approx((2.0, 1.0, 1.0), abs=0.02)
    assert bench_core.skimage_shift(np.stack((top, np.zeros_like(top)))).confidence == 0.0


def test_scaling_has_a_point_per_grid_contact_count_and_method(results):
    scale = results['scaling']
    assert {(r['grid'], r['method']) for r in scale['by_grid']} == {(16, 'poc'), (16, 'seed')}
    assert {(r['contacts'], r['method']) for r in scale['by_contacts']} >= {
        (1, 'poc'), (2, 'poc'), (1, 'seed'), (2, 'seed')}
    assert all(r['median_us'] > 0 for r in scale['by_grid'] + scale['by_contacts'])


def test_scaling_times_the_default_back_to_back_too():
    scale = bench_core.scaling([16], [1], ['taxel_fit'], 1, 1, log=lambda s: None)
    assert [r['method'] for r in scale['by_grid']] == ['taxel_fit']
    # The default is also timed back to back, as a driver runs it.
    assert scale['by_grid'][0]['alone_median_us'] > 0


def test_family_scores_every_skin_scene_and_method_and_names_the_worst(results):
    fam = results['family']
    # The floor (the simulator's model fitted from the truth) is scored beside the methods.
    methods = ['taxel_fit', 'seed', 'plain_centroid', 'oracle']
    assert fam['methods'] == methods
    assert {(r['skin'], r['scene'], r['method']) for r in fam['rows']} == {
        (s, k, m) for s in ('default', 'soft') for k in ('paper', 'random', 'border', 'multi')
        for m in methods}
    assert {(c['skin'], c['method']) for c in fam['costs']} == {
        (s, m) for s in ('default', 'soft') for m in methods}
    for m in methods:
        worst = fam['worst'][m]['random']
        # A method with no valid direction on a skin has no error there (None).
        errors = {r['skin']: r['mean_error_deg'] for r in fam['rows']
                  if r['method'] == m and r['scene'] == 'random'
                  and r['mean_error_deg'] is not None}
        assert worst['mean_error_deg'] == max(errors.values())
        assert errors[worst['error_skin']] == worst['mean_error_deg']
    for kind in ('paper', 'random'):
        # Nothing estimates the azimuth better than the floor on its own frames.
        assert fam['worst']['taxel_fit'][kind]['ratio_to_oracle'] > 1.0
    assert all(s > 0 and 0 <= e <= 180 for s, e, _, _ in fam['sigma_vs_error'])


def test_the_default_is_also_timed_back_to_back_per_skin_and_scene(results):
    fam = results['family']
    frames = {(r['skin'], r['scene']): r['frames'] for r in fam['rows']
              if r['method'] == 'taxel_fit'}
    alone = {c['skin']: c['alone'] for c in fam['costs'] if 'alone' in c}
    # Only the default, on every skin, over all of its scored frames, each scene apart.
    assert {(c['skin'], c['method']) for c in fam['costs'] if 'alone' in c} == {
        ('default', 'taxel_fit'), ('soft', 'taxel_fit')}
    for skin, a in alone.items():
        assert a['frames'] == sum(n for (s, _), n in frames.items() if s == skin)
        assert set(a['scenes']) == {'paper', 'random', 'border', 'multi'}
        assert 0 < a['median_us'] <= a['p90_us']
        # Two or three presses at once: more contacts per frame than one press.
        assert a['scenes']['multi']['contacts'] > a['scenes']['random']['contacts'] > 0
        assert all(v['per_contact_us'] > 0 for v in a['scenes'].values())
    worst = fam['worst']['taxel_fit']
    assert worst['alone_median_us'] == max(a['median_us'] for a in alone.values())
    assert alone[worst['alone_skin']]['median_us'] == worst['alone_median_us']
    assert fam['worst']['seed']['alone_median_us'] is None


def test_alone_costs_give_the_cost_per_contact_only_of_frames_with_contacts():
    class Counted:

        def process(self, top, bottom):
            return [object()] * int(top)

    got = costs.alone_costs([('random', Counted(), [(0, 0), (2, 0), (2, 0)])], repeats=2)
    assert got['frames'] == 3 and got['repeats'] == 2
    scene = got['scenes']['random']
    assert scene['contacts'] == pytest.approx(4 / 3)
    assert 0 < scene['per_contact_us'] and scene['median_us'] > 0


def test_alone_costs_take_each_frames_least_pass_with_the_passes_round_the_scenes(monkeypatch):
    # Scripted clocks, no timing: a burst of other jobs (the 9 s) spoils one pass of a frame.
    calls = []
    seconds = iter([1.0, 9.0, 3.0, 2.0, 1.0, 5.0, 3.0, 2.0])

    def scripted(est, top, bottom):
        calls.append(est.name)
        return next(seconds), [object()] * int(top)

    class Named:

        def __init__(self, name):
            self.name = name

        def process(self, top, bottom):
            return []

    monkeypatch.setattr(costs, 'timed', scripted)
    got = costs.alone_costs([('paper', Named('paper'), [(1, 0), (1, 0)]),
                             ('multi', Named('multi'), [(2, 0), (2, 0)])], repeats=2)
    # The passes go round the scenes: paper, multi, then paper, multi again.
    assert calls == ['paper'] * 2 + ['multi'] * 2 + ['paper'] * 2 + ['multi'] * 2
    assert got['scenes']['paper']['median_us'] == pytest.approx(1e6 * (1.0 + 5.0) / 2)
    assert got['scenes']['multi']['median_us'] == pytest.approx(1e6 * (3.0 + 2.0) / 2)
    assert got['scenes']['multi']['per_contact_us'] == pytest.approx(1e6 * 2.5 / 2)
    assert got['median_us'] == pytest.approx(1e6 * 2.5) and got['frames'] == 4


def test_every_family_method_gets_the_users_calibration_and_only_scored_frames_count(results):
    fam = results['family']
    # Only the scene's frames are scored: the 16 plate and 32 calibration frames (and in the
    # paper's protocol its normal press, which re-takes the offset) never are.
    frames = {(r['skin'], r['scene']): r['frames'] for r in fam['rows']}
    assert frames[('default', 'paper')] == 8 and frames[('soft', 'random')] == 5
    notes = {(n['skin'], n['scene'], n['method']): n['notes'] for n in fam['calibration_notes']}
    assert {m for _, _, m in notes} == {'taxel_fit', 'seed', 'plain_centroid'}
    for (skin, kind, method), parts in notes.items():
        names = [p.split(':')[0] for p in parts]
        assert names == ['gains', 'offset', 'force', 'compliance'] + (
            ['offset'] if kind == 'paper' else [])
        # The same gains and force curves for every method: they come from the same frames.
        assert parts[:3:2] == notes[(skin, kind, 'taxel_fit')][:3:2]


def test_the_worst_valid_share_for_large_shifts_says_how_many_presses_it_is_of():
    def row(skin, scene, share, presses):
        return {'skin': skin, 'scene': scene, 'method': 'taxel_fit', 'mean_error_deg': 1.0,
                'valid_share': 1.0, 'large_shift_valid_share': share,
                'large_shift_frames': presses, 'separate_share_far': None}
    rows = [row('stiff', 'random', 1.0, 4), row('stiff', 'border', 0.0, 1),
            row('saturating', 'border', 0.53, 36), row('saturating', 'paper', None, 0)]
    worst = bench_core.family_worst(rows, [], ['taxel_fit'])['taxel_fit']
    # One border press with a shift of a taxel is the worst: the share says it is one.
    assert (worst['large_shift_valid_share'], worst['large_shift_skin'],
            worst['large_shift_presses']) == (0.0, 'stiff', 1)


def test_the_worst_case_holds_the_oracles_figures_there_and_the_multi_press_ratio():
    def row(skin, scene, method, error, valid):
        return {'skin': skin, 'scene': scene, 'method': method, 'mean_error_deg': error,
                'valid_share': valid, 'large_shift_valid_share': None, 'large_shift_frames': 0,
                'separate_share_far': None}
    rows = [row('soft', 'random', 'taxel_fit', 0.2, 1.0),
            row('soft', 'multi', 'taxel_fit', 19.0, 0.95),
            row('sharp', 'random', 'taxel_fit', 4.0, 0.8),
            row('sharp', 'multi', 'taxel_fit', 6.0, 0.88),
            row('stiff', 'border', 'taxel_fit', 2.0, 0.38),
            row('sharp', 'border', 'taxel_fit', 7.0, 0.6),
            row('stiff', 'border', 'oracle', 0.26, 0.97),
            row('sharp', 'border', 'oracle', 0.45, 0.64)]
    worst = bench_core.family_worst(rows, [], ['taxel_fit'])['taxel_fit']
    assert (worst['border']['oracle_error_deg'], worst['border']['oracle_valid_share']) == (
        0.45, 0.97)
    # soft: 19 / 0.2 with several presses against sharp's 6 / 4.
    assert worst['multi']['ratio_to_single_skin'] == 'soft'
    assert abs(worst['multi']['ratio_to_single'] - 95.0) < 1e-9
