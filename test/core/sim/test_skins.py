"""Tests of the skin family, its physics ranges, its scenes and per-press ground truth."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.calibration.session import CalibrationSession
from skin_driver.core.estimation.data.dataset import Dataset, load_dataset, save_dataset
from skin_driver.core.sim.physics import (
    layer_shift_m, Press, render, render_force, SkinModel, taxel_spread)
from skin_driver.core.sim.skins import (family_skin, FamilySkin, get_skin, skin_for_grid,
                                        skin_names)
from skin_lab.experiments import (calibrated_scene, CALIBRATION_RADIUS_M, make_scene,
                                  PAPER_BETAS_DEG, press_for_shift, SCENE_KINDS)


def test_family_names_at_least_eight_seeded_skins_with_a_description():
    names = skin_names()
    assert len(names) >= 8 and names[0] == 'default' and len(set(names)) == len(names)
    for name in names:
        assert isinstance(get_skin(name), SkinModel)
        assert get_skin(name) == get_skin(name)
        text = family_skin(name).description
        assert text and '\n' not in text
    with pytest.raises(ValueError, match='the family has default'):
        get_skin('no_such_skin')


def test_family_spans_the_ranges_of_real_skins():
    skins = [family_skin(n) for n in skin_names()]
    smallest = min(s.shift_taxels(s.force_range_n[0], 15.0) for s in skins)
    largest = max(s.shift_taxels(s.force_range_n[1], 60.0) for s in skins)
    assert smallest <= 0.1 and largest >= 6.0
    models = [s.model for s in skins]
    assert max(m.noise_counts for m in models) == 10.0
    assert max(m.gain_spread for m in models) == 0.1
    assert max(m.crosstalk for m in models) > 0.01
    half = max(math.hypot(*m.misalignment_m) / m.pitch_m for m in models)
    assert 0.45 <= half <= 0.5
    # The soft skin's paper press shifts the layers by 3-6 taxels, at 25-40 N.
    soft = family_skin('soft')
    assert 25.0 <= soft.paper_force_n <= 40.0 and 3 <= soft.shift_taxels(soft.paper_force_n,
                                                                         45.0) <= 6


def test_held_out_skins_are_drawn_within_the_ranges_and_reproducible():
    skins = [family_skin(f'held_out:{n}') for n in range(30)]
    assert family_skin('held_out:3') == skins[3] and skins[3] != skins[4]
    assert len({s.model for s in skins}) == 30
    for s in skins:
        assert 0.3 <= s.shift_taxels(s.paper_force_n, 45.0) <= 5.0
        assert s.model.noise_counts <= 10 and s.model.gain_spread <= 0.1
        assert math.hypot(*s.model.misalignment_m) <= 0.5 * s.model.pitch_m
        assert s.force_range_n[0] < s.paper_force_n < s.force_range_n[1]
    for bad in ('held_out:', 'held_out:x', 'held_out:-1'):
        with pytest.raises(ValueError, match='held_out:N'):
            family_skin(bad)
    # The named family stays as it is.
    assert not any(n.startswith('held_out') for n in skin_names())


def test_saturating_skin_saturates_below_sixty_newtons():
    model = get_skin('saturating')
    top, _ = render(model, [Press(0.037, 0.038, 30.0, radius_m=0.004)],
                    np.random.default_rng(0))
    assert top.max() >= model.fsr.saturation_counts - 3 * model.noise_counts


def test_taxel_gains_and_offsets_are_fixed_by_the_seed():
    model = get_skin('noisy')
    gain, offset = taxel_spread(model)
    assert gain.shape == offset.shape == (2, 16, 16)
    assert (abs(gain - 1.0) <= model.gain_spread).all() and gain.std() > 0.03
    again, _ = taxel_spread(SkinModel(**{**model.__dict__}))
    other, _ = taxel_spread(SkinModel(**{**model.__dict__, 'seed': model.seed + 1}))
    assert np.array_equal(gain, again) and not np.array_equal(gain, other)
    plain, base = taxel_spread(SkinModel())
    assert (plain == 1.0).all() and (base == SkinModel().baseline_counts).all()


def test_elliptical_indenter_is_long_along_its_orientation_and_keeps_the_force():
    # Full fill: every newton lands on a taxel, so the map sums to the press's force.
    model = SkinModel(cover_spread_m=0.0005, fill_factor=1.0)
    ys, xs = np.mgrid[0:16, 0:16]

    def spread(press):
        top, _ = render_force(model, [press])
        w = top / top.sum()
        cx, cy = (w * xs).sum(), (w * ys).sum()
        return top.sum(), (w * (xs - cx) ** 2).sum(), (w * (ys - cy) ** 2).sum()

    round_sum, _, _ = spread(Press(0.037, 0.038, 10.0, radius_m=0.008))
    along_x = spread(Press(0.037, 0.038, 10.0, radius_m=0.008, aspect=0.3))
    along_y = spread(Press(0.037, 0.038, 10.0, radius_m=0.008, aspect=0.3,
                           orientation_rad=math.pi / 2))
    assert along_x[1] > 2 * along_x[2] and along_y[2] > 2 * along_y[1]
    assert along_x[1] == pytest.approx(along_y[2], rel=0.05)
    assert along_x[0] == pytest.approx(10.0) and round_sum == pytest.approx(10.0)
    with pytest.raises(ValueError, match='aspect'):
        Press(0.0, 0.0, 1.0, aspect=0.0)


def test_every_scene_carries_per_press_truth_with_the_strongest_first():
    for kind in SCENE_KINDS:
        data = make_scene(kind, 'default', np.random.default_rng(3), size=1 if kind == 'paper'
                          else 10)
        assert data.press_x_m.shape[0] == data.frames and data.tare_top is not None
        assert np.array_equal(data.press_force_n[:, 0], data.force_n)
        assert np.array_equal(data.press_x_m[:, 0], data.x_m)
        assert np.array_equal(data.press_alpha_deg[:, 0], data.alpha_deg)
        forces = np.where(np.isfinite(data.press_force_n), data.press_force_n, -1.0)
        assert (np.diff(forces, axis=1) <= 0).all()
        # Every scene gives the evaluator normal presses to calibrate from.
        assert (data.alpha_deg == 0).any()


@pytest.mark.parametrize('kind', SCENE_KINDS)
def test_a_calibrated_scene_is_the_same_scene_after_the_users_calibration_frames(kind):
    size = 1 if kind == 'paper' else 10
    scene = make_scene(kind, 'film', np.random.default_rng(4), size)
    truth = []
    data = calibrated_scene(kind, 'film', np.random.default_rng(4), size, truth)
    assert len(truth) == data.frames == 48 + scene.frames
    # First the plate for the gains (no press), then the presses of the calibration.
    assert data.split[:48].tolist() == [3] * 16 + [1] * 32
    assert truth[:16] == [[]] * 16 and np.isnan(data.press_x_m[:16]).all()
    own = data.split[48:]
    # The scene's frames are the very draws of the scene alone.
    assert np.array_equal(data.top[48:], scene.top)
    assert [p[0].x_m for p in truth[48:]] == pytest.approx(scene.x_m.tolist())
    if kind == 'paper':
        # The paper's protocol takes (x_p, y_p) at its spot: its normal presses do (split 2).
        assert own.tolist() == [2 if a == 0 else 0 for a in scene.alpha_deg]
    else:
        assert not own.any()


def test_normal_presses_at_the_place_of_use_re_take_the_offset_after_the_calibration():
    data = calibrated_scene('paper', 'film', np.random.default_rng(0), 3)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert [n.split(':')[0] for n in notes] == [
        'gains', 'offset', 'force', 'compliance', 'offset']
    assert notes[-1].endswith('(at the place of use)') and 'from 3 normal presses' in notes[-1]
    calibration = est.calibration
    assert calibration.presses == 3 and calibration.force_presses == 16
    assert calibration.compliance_presses == 16
    # The scored frames stay apart: the split 2 frames are normal presses, never scored.
    assert not (data.alpha_deg[data.scored_frames()] == 0).any()


def test_the_plate_frames_give_the_taxel_gains_before_the_presses_calibrate():
    # 'noisy' has taxels up to 10 % apart (and 10 counts of noise): the plate finds them.
    data = calibrated_scene('random', 'noisy', np.random.default_rng(0), 2)
    est, notes = prepared_estimator(data, 'taxel_fit')
    assert notes[0].startswith('gains: taxel gains from 16 presses covering 100 %')
    sensitivity, _ = taxel_spread(family_skin('noisy').model)
    evened = est.conditioning.gain_maps() * sensitivity
    assert np.std(sensitivity) > 0.05
    assert np.std(evened / np.median(evened)) < 0.4 * np.std(sensitivity)


def test_the_plate_gains_take_off_the_crosstalk_the_force_presses_showed():
    # Hard case: a passive matrix leaking 1.2 % of a line's load onto each of its taxels, and
    # taxels 10 % apart. Under a plate every line is loaded, so every taxel reads a third more.
    model = SkinModel(crosstalk=0.012, gain_spread=0.1, seed=5)
    skin = FamilySkin('leaky', 'crosstalk and gains', model, 20.0, (10.0, 30.0))
    data = calibrated_scene('random', skin, np.random.default_rng(0), 2)
    est, _ = prepared_estimator(data, 'taxel_fit')
    assert est.calibration.crosstalk_share == pytest.approx(0.012, rel=0.1)
    # The same plate frames with the crosstalk left on.
    blind = est.with_calibration(est.calibration.updated(crosstalk_share=0.0))
    session = CalibrationSession(blind, 'gains', presses=16)
    for i in np.flatnonzero(data.split == 3):
        top, bottom = data.top[i], data.bottom[i]
        session.add_press(session.record(top, bottom, blind.process(top, bottom)))
    blind = blind.with_calibration(session.finish().calibration)
    sensitivity = np.log(taxel_spread(skin.model)[0]).ravel()

    def follows(e):
        # How much of the true pattern the gains undo (1: all of it).
        return np.polyfit(sensitivity, -np.log(e.conditioning.gain_maps()).ravel(), 1)[0]
    assert abs(follows(est) - 1.0) < 0.05 < 0.08 < abs(follows(blind) - 1.0)


def test_paper_scene_presses_the_skins_own_force_at_the_eight_betas():
    data = make_scene('paper', 'soft', np.random.default_rng(0), size=2)
    tilted = data.alpha_deg > 0
    assert sorted(set(data.azimuth_deg[tilted])) == list(PAPER_BETAS_DEG)
    assert data.force_n == pytest.approx(family_skin('soft').paper_force_n, rel=0.06)
    shift = data.press_shift_m[tilted, 0] / data.pitch_m
    assert (shift >= 3).all() and (shift <= 6).all()


def test_border_scene_presses_within_a_taxel_of_an_edge():
    data = make_scene('border', 'default', np.random.default_rng(1), size=40)
    tilted = data.alpha_deg > 0
    x, y, pitch = data.x_m[tilted], data.y_m[tilted], data.pitch_m
    far = 15 * pitch
    edge = np.minimum.reduce([x, y, far - x, far - y])
    assert (edge <= pitch + 1e-12).all() and (edge >= -0.5 * pitch - 1e-12).all()
    assert (edge < 0).any()  # some centred off the skin


def test_multi_scene_has_pairs_and_triples_some_close_none_overlapping():
    data = make_scene('multi', 'default', np.random.default_rng(2), size=60)
    counts = np.isfinite(data.press_x_m).sum(axis=1)
    assert set(counts) == {1, 2, 3}
    gaps = []
    for i in np.flatnonzero(counts >= 2):
        presses = data.presses(i)
        gaps += [math.hypot(a['x_m'] - b['x_m'], a['y_m'] - b['y_m']) / data.pitch_m
                 for j, a in enumerate(presses) for b in presses[j + 1:]]
    assert min(gaps) >= 2.0 and any(g < 3.0 for g in gaps) and any(g >= 3.0 for g in gaps)


def test_format_2_round_trip_and_format_1_still_loads(tmp_path):
    data = make_scene('multi', 'stiff', np.random.default_rng(4), size=6)
    path = tmp_path / 'multi.npz'
    save_dataset(path, data)
    back = load_dataset(path)
    assert int(np.load(path)['format_version']) == 2
    for name in ('press_x_m', 'press_azimuth_deg', 'press_shift_m'):
        assert np.array_equal(getattr(back, name), getattr(data, name), equal_nan=True)
    for i in range(data.frames):
        assert [p['x_m'] for p in back.presses(i)] == [p['x_m'] for p in data.presses(i)]
    old = tmp_path / 'v1.npz'
    np.savez(old, format_version=np.int64(1), top=data.top, bottom=data.bottom,
             pitch_m=np.float64(0.005), azimuth_deg=data.azimuth_deg, alpha_deg=data.alpha_deg)
    v1 = load_dataset(old)
    assert v1.press_x_m is None and v1.frames == data.frames
    assert v1.presses(1)[0]['alpha_deg'] == data.alpha_deg[1]


def _two_presses(**over):
    nan = math.nan
    arrays = {'press_x_m': [[0.02, 0.04]], 'press_y_m': [[0.03, 0.03]],
              'press_force_n': [[10.0, 5.0]], 'press_azimuth_deg': [[90.0, nan]],
              'press_alpha_deg': [[30.0, 0.0]]}
    arrays.update(over)
    return Dataset(top=np.zeros((1, 4, 4)), bottom=np.zeros((1, 4, 4)), pitch_m=0.005,
                   azimuth_deg=[90.0], alpha_deg=[30.0], **arrays)


@pytest.mark.parametrize('over, problem', [
    ({'press_azimuth_deg': [[math.nan, math.nan]]}, 'press_azimuth_deg is NaN'),
    ({'press_y_m': [[0.03, math.nan]]}, 'finite exactly where press_x_m'),
    ({'press_alpha_deg': [[30.0, 90.0]]}, r'press_alpha_deg must be in \[0, 90\)'),
    ({'press_force_n': [[10.0]]}, 'must have shape'),
    ({'press_x_m': None}, 'per-press arrays need all of'),
])
def test_bad_per_press_arrays_are_refused_by_name(over, problem):
    assert len(_two_presses().presses(0)) == 2
    with pytest.raises(ValueError, match=problem):
        _two_presses(**over)


def test_finer_grids_cover_the_same_patch_and_read_the_same_pressure():
    coarse, fine = skin_for_grid(16), skin_for_grid(32)
    assert coarse.cols * coarse.pitch_m == pytest.approx(fine.cols * fine.pitch_m)
    assert fine.fsr.force_at_r_max_n == pytest.approx(coarse.fsr.force_at_r_max_n / 4)
    assert coarse == SkinModel(noise_counts=coarse.noise_counts)


@pytest.mark.parametrize('grid, shift_taxels', [(16, 0.5), (16, 2.0), (64, 1.0)])
def test_a_press_for_a_shift_shifts_the_layers_by_that_many_taxels_inside_the_skin(
        grid, shift_taxels):
    model = skin_for_grid(grid)
    rng = np.random.default_rng(3)
    span = (model.cols - 1) * model.pitch_m
    for _ in range(20):
        press = press_for_shift(model, shift_taxels, rng)
        aligned = SkinModel(**{**model.__dict__, 'misalignment_m': (0.0, 0.0)})
        assert math.hypot(*layer_shift_m(aligned, press)) == pytest.approx(
            shift_taxels * model.pitch_m, rel=1e-9)
        assert 0.015 <= press.x_m <= span - 0.015 and 0.015 <= press.y_m <= span - 0.015
        assert 5.0 - 1e-9 <= press.normal_force_n <= 15.0 + 1e-9


def test_a_skin_on_a_finer_grid_covers_the_same_patch_with_the_same_film():
    coarse = family_skin('saturating')
    fine = family_skin('saturating@64')
    assert (fine.model.rows, fine.model.cols) == (64, 64)
    assert fine.model.pitch_m * 64 == pytest.approx(coarse.model.pitch_m * 16)
    # A taxel a sixteenth the area saturates at a sixteenth the force: the same pressure.
    assert fine.model.fsr.force_at_r_min_n == pytest.approx(
        coarse.model.fsr.force_at_r_min_n / 16)
    assert fine.force_range_n == coarse.force_range_n
    with pytest.raises(ValueError, match='NAME@N'):
        family_skin('saturating@x')


def test_the_one_tip_scene_presses_with_the_calibrations_own_indenter():
    truth = []
    data = calibrated_scene('one_tip', 'default', np.random.default_rng(6), 20, truth)
    tips = {(p.radius_m, p.aspect) for presses in truth for p in presses}
    assert tips == {(CALIBRATION_RADIUS_M, 1.0)}
    # The random scene's own draws, tips aside: tilted presses at random spots and azimuths.
    scored = data.scored_frames()
    assert (data.alpha_deg[scored] > 0).sum() == 16 and len(set(data.azimuth_deg[scored])) > 10
