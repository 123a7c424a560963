"""Tests of scene loading, validation and evaluation."""

import math

import pytest
from skin_driver.core.sim.paper import paper_presses
from skin_driver.core.sim.physics import Press, SkinModel
from skin_driver.core.sim.scene import bundled_scene_names, find_scene, load_scene
from skin_driver.core.sim.scene import scene_from_dict, ScenePress
import yaml


def press(**over):
    base = {'time_s': 1.0, 'x_m': 0.02, 'y_m': 0.03, 'force_n': 10.0, 'alpha_deg': 45.0,
            'beta_deg': 90.0, 'radius_m': 0.004, 'duration_s': 1.0, 'ramp_s': 0.25}
    base.update(over)
    return base


def test_bundled_scenes_are_listed_and_all_load():
    assert {'seed', 'random', 'two_finger', 'border'} <= set(bundled_scene_names())
    for name in bundled_scene_names():
        scene = load_scene(name)
        assert scene.name == name
        assert scene.presses and scene.duration_s > 0


def test_seed_scene_is_the_papers_experiment():
    scene = load_scene('seed')
    assert (scene.model.rows, scene.model.cols, scene.model.pitch_m) == (16, 16, 0.005)
    assert scene.repeat >= 3
    directions = sorted((p.alpha_deg, p.beta_deg) for p in scene.presses)
    assert directions == [(0.0, 0.0)] + [(45.0, float(b)) for b in range(0, 360, 45)]
    # The one definition of the protocol, the evaluator's `paper` scene and the demo's too.
    assert [p.press() for p in scene.presses] == paper_presses(scene.model)
    for p in scene.presses:
        assert abs(p.x_m - 0.0375) < 0.001 and abs(p.y_m - 0.0375) < 0.001  # near the centre
        assert p.force_n == 10.0


def test_random_scene_is_reproducible_and_stays_on_the_skin():
    a, b = load_scene('random'), load_scene('random')
    assert a.presses == b.presses and len(a.presses) == 40
    for p in a.presses:
        assert 0.005 <= p.x_m <= 0.070 and 0.005 <= p.y_m <= 0.070
        assert 0 <= p.alpha_deg <= 60 and 2 <= p.force_n <= 15


def test_two_finger_scene_has_simultaneous_presses():
    scene = load_scene('two_finger')
    first = scene.presses[0]
    assert len(scene.presses_at(first.time_s + first.duration_s / 2)) == 2


def test_find_scene_by_name_file_name_and_path(tmp_path):
    assert find_scene('seed') == find_scene('seed.yaml')
    path = tmp_path / 'mine.yaml'
    path.write_text(yaml.safe_dump({'presses': [press()]}))
    assert find_scene(str(path)) == path
    assert load_scene(path).name == 'mine'
    with pytest.raises(ValueError, match='bundled scenes are .*seed'):
        find_scene('no_such_scene')


def test_envelope_ramps_up_holds_and_ramps_down():
    p = ScenePress(**press())
    assert p.envelope(1.0) == 0.0
    assert p.envelope(1.125) == pytest.approx(0.5)
    assert p.envelope(1.5) == 1.0
    assert p.envelope(1.875) == pytest.approx(0.5)
    assert p.envelope(2.0) == 0.0 and p.envelope(0.5) == 0.0


def test_presses_at_converts_to_si_and_scales_force():
    scene = scene_from_dict({'presses': [press()]})
    (active,) = scene.presses_at(1.125)
    assert active == Press(x_m=0.02, y_m=0.03, force_n=5.0, alpha_rad=math.radians(45),
                           beta_rad=math.radians(90), radius_m=0.004)
    assert scene.presses_at(0.5) == [] and scene.presses_at(2.5) == []


def test_repeat_and_period():
    scene = scene_from_dict({'repeat': 3, 'period_s': 4.0, 'presses': [press()]})
    assert scene.duration_s == 12.0
    assert [len(scene.presses_at(t)) for t in (1.5, 5.5, 9.5, 13.5)] == [1, 1, 1, 0]
    assert scene.active_at(5.5)[0][0] == 0
    assert [t for t, _ in scene.hold_times()] == [1.5, 5.5, 9.5]


def test_defaults_and_model_overrides():
    scene = scene_from_dict({
        'model': {'rows': 8, 'cols': 12, 'pitch_m': 0.004, 'noise_counts': 0.0,
                  'crosstalk': 0.01, 'dead_taxels': [[1, 2], [0, 3, 3]],
                  'misalignment_m': [0.001, 0.0], 'fsr': {'r_series_ohm': 2000.0}},
        'defaults': {'x_m': 0.01, 'y_m': 0.01, 'radius_m': 0.003, 'duration_s': 0.5},
        'presses': [{'time_s': 0, 'force_n': 3, 'alpha_deg': 0, 'beta_deg': 0}],
    })
    m = scene.model
    assert isinstance(m, SkinModel)
    assert (m.rows, m.cols, m.pitch_m, m.noise_counts, m.crosstalk) == (8, 12, 0.004, 0.0, 0.01)
    assert m.dead_taxels == ((1, 2), (0, 3, 3)) and m.misalignment_m == (0.001, 0.0)
    assert m.fsr.r_series_ohm == 2000.0
    (p,) = scene.presses
    assert (p.x_m, p.radius_m, p.duration_s, p.ramp_s) == (0.01, 0.003, 0.5, 0.1)


def test_labels_name_groups_of_presses_in_script_order():
    scene = scene_from_dict({'defaults': {'label': 'tap'}, 'presses': [
        press(time_s=0.0), press(time_s=2.0, label='push'), press(time_s=4.0)]})
    assert [p.time_s for p in scene.labelled('tap')] == [0.0, 4.0]
    assert [p.time_s for p in scene.labelled('push')] == [2.0]
    assert scene.labelled('other') == []


@pytest.mark.parametrize('bad, message', [
    (press(force_n=-1.0), "press 1: field 'force_n' must be > 0"),
    (press(alpha_deg=90.0), "press 1: field 'alpha_deg' must be in"),
    (press(radius_m=0.0), "press 1: field 'radius_m'"),
    (press(duration_s=0.0), "press 1: field 'duration_s'"),
    (press(time_s=-0.1), "press 1: field 'time_s'"),
    (press(ramp_s=0.6), "press 1: field 'ramp_s'"),
    (press(x_m=float('nan')), "press 1: field 'x_m' must be finite"),
    (press(y_m='near'), "press 1: field 'y_m' must be a number"),
    (press(forse_n=1.0), "press 1: unknown field 'forse_n'"),
    ({k: v for k, v in press().items() if k != 'beta_deg'}, "press 1: missing field 'beta_deg'"),
    ('not a mapping', 'press 1: must be a mapping'),
    (press(label=3), "press 1: field 'label' must be a string"),
])
def test_bad_press_names_index_and_field(bad, message):
    with pytest.raises(ValueError, match=message):
        scene_from_dict({'presses': [press(), bad]})


@pytest.mark.parametrize('data, message', [
    ({'presses': []}, 'no presses'),
    ({'presses': [press()], 'repeat': 0}, 'repeat'),
    ({'presses': [press()], 'period_s': 1.0}, 'period_s'),
    ({'presses': [press()], 'model': {'rows': 0}}, "model: field 'rows'"),
    ({'presses': [press()], 'model': {'noise': 3}}, "model: unknown field 'noise'"),
    ({'presses': [press()], 'model': {'pitch_m': -1.0}}, 'model: '),
    ({'presses': [press()], 'model': {'dead_taxels': [[1, 'a']]}}, 'dead_taxels'),
    ({'presses': [press()], 'model': {'misalignment_m': [1.0]}}, 'misalignment_m'),
    ({'presses': [press()], 'speed': 3}, "unknown key 'speed'"),
    ({'generator': {'kind': 'spiral'}}, 'generator'),
    ({'generator': {'kind': 'random', 'count': -1}}, "generator: field 'count'"),
    ({'generator': {'kind': 'random', 'force_n': [5, 1]}}, "generator: field 'force_n'"),
    ([1, 2], 'must be a mapping'),
])
def test_bad_scene_is_rejected_with_a_clear_message(data, message):
    with pytest.raises(ValueError, match=message):
        scene_from_dict(data)


def test_invalid_yaml_file_is_a_value_error(tmp_path):
    path = tmp_path / 'broken.yaml'
    path.write_text('presses: [\n')
    with pytest.raises(ValueError, match='not valid YAML'):
        load_scene(path)


def test_time_outside_scene_or_not_finite_has_no_presses():
    scene = load_scene('seed')
    assert scene.presses_at(-1.0) == []
    assert scene.presses_at(float('nan')) == []
    assert scene.presses_at(scene.duration_s + 1.0) == []


def test_a_scene_asks_for_drift_with_its_fields_or_its_family_skin_and_gives_its_mount():
    base = {'presses': [{'time_s': 0.0, 'x_m': 0.01, 'y_m': 0.01, 'force_n': 1.0,
                         'alpha_deg': 0.0, 'beta_deg': 0.0, 'radius_m': 0.004,
                         'duration_s': 1.0}]}
    assert not scene_from_dict(base).drifts
    given = scene_from_dict({**base, 'drift': {'creep_per_decade': 0.05}})
    assert given.drifts and given.model.drift.creep_per_decade == 0.05
    family = scene_from_dict({**base, 'skin': 'soft', 'drift': True})
    assert family.drifts and family.model.drift.creeps
    for bad, why in (({'drift': True}, 'needs a skin that drifts'),
                     ({'drift': {'creep_per_decade': -1.0}}, 'creep_per_decade'),
                     ({'drift': {'speed': 1.0}}, 'mapping of creep_per_decade'),
                     ({'mount': {'xyz': [0, 0, 0]}}, 'mount: must be')):
        with pytest.raises(ValueError, match=why):
            scene_from_dict({**base, **bad})
    with pytest.raises(ValueError, match='has no mount'):
        scene_from_dict(base).mount_points()
    # Turned a quarter about z and lifted: (x, y, 0) on the skin is (-y, x, 0.5) on the parent.
    mounted = scene_from_dict({**base, 'mount': {'xyz': [0, 0, 0.5],
                                                 'rpy': [0, 0, math.pi / 2]}})
    assert mounted.mount_points('')[0] == pytest.approx((-0.01, 0.01, 0.5))


def test_a_press_remembers_the_loads_on_its_spot_in_every_repetition():
    scene = scene_from_dict({'repeat': 2, 'period_s': 10.0, 'presses': [
        {'time_s': 1.0, 'x_m': 0.02, 'y_m': 0.02, 'force_n': 1.0, 'alpha_deg': 0.0,
         'beta_deg': 0.0, 'radius_m': 0.004, 'duration_s': 2.0},
        {'time_s': 2.0, 'x_m': 0.025, 'y_m': 0.02, 'force_n': 1.0, 'alpha_deg': 0.0,
         'beta_deg': 0.0, 'radius_m': 0.004, 'duration_s': 2.0},
        {'time_s': 5.0, 'x_m': 0.06, 'y_m': 0.06, 'force_n': 1.0, 'alpha_deg': 0.0,
         'beta_deg': 0.0, 'radius_m': 0.004, 'duration_s': 1.0}]})
    # The first two overlap in place and time: one load from 1 to 4 s, in each repetition.
    assert scene.loads(0) == scene.loads(1) == ((1.0, 4.0), (11.0, 14.0))
    assert scene.loads(2) == ((5.0, 6.0), (15.0, 16.0))
    (_, age), = scene.held_ages(5.5)
    assert age == pytest.approx(0.5)
