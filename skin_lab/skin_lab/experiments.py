"""
Scenes of simulated presses, each defined once, rendered as datasets with ground truth.

Scene kinds (``SCENE_KINDS``), all with 20 no-touch tare frames and, except ``paper``, one
frame in five (the first, the sixth, ...) a single normal press at a random interior spot for
calibrating (x_p, y_p):

* ``paper``: the seed paper's protocol: at one spot, one normal press and one alpha = 45 deg
  press at each beta = 0, 45, ..., 315 deg, repeated (``paper_presses``, the driver's
  :mod:`skin_driver.core.sim.paper`, which the simulator's ``seed`` scene and the demo play too).
* ``random``: one press at a random spot, beta, alpha 15..60 deg and indenter diameter 3..7 mm,
  some elliptical.
* ``border``: one tilted press centred within a taxel of an edge or a corner, partly off the skin.
* ``multi``: two or three presses at once, some only 2..3 taxels apart.
* ``one_tip``: ``random`` pressed with the indenter of the user's calibration presses (round,
  8 mm; :func:`add_calibration_frames`): what a user who calibrates with the tip they press with
  gets, the force calibration's own protocol. The first four are the direction's scenes
  (``DIRECTION_KINDS``); the benchmark scores force and alpha on ``one_tip`` as well.

Forces follow the skin (:class:`skins.FamilySkin`): ``paper_force_n`` for the paper's protocol,
``force_range_n`` for the others, so that every skin's shifts are meaningful. Every dataset
carries per-press ground truth (``press_*``, N x K); the frame's own ``azimuth_deg``,
``alpha_deg``, ``force_n``, ``x_m``, ``y_m`` are those of its strongest press.
"""

from __future__ import annotations

import math

import numpy as np
from skin_driver.core.estimation.data.dataset import Dataset, PRESS_FIELDS
from skin_driver.core.sim.paper import (PAPER_ALPHA_DEG, PAPER_BETAS_DEG, PAPER_FORCE_N,
                                        paper_presses, taxel_span)
from skin_driver.core.sim.physics import Press, render, render_plate, SkinModel
from skin_driver.core.sim.skins import family_skin, FamilySkin
from skin_driver.tools.export import render_frames

__all__ = ['SCENE_KINDS', 'DIRECTION_KINDS', 'CALIBRATION_RADIUS_M', 'PAPER_ALPHA_DEG',
           'PAPER_BETAS_DEG', 'paper_presses', 'make_scene', 'make_seed_experiment',
           'make_random_experiment', 'make_border_experiment', 'make_multi_experiment',
           'add_calibration_frames', 'calibrated_scene', 'press_for_shift',
           'add_direction_frames', 'ROBOT_PRESS_S', 'DIRECTION_PRESSES', 'DIRECTION_TIPS_M']

NORMAL_EVERY = 5
DIAMETER_RANGE_M = (0.003, 0.007)
ELLIPTICAL_SHARE = 0.3
# The indenter of the user's calibration presses (:func:`add_calibration_frames`).
CALIBRATION_RADIUS_M = 0.004
ALPHA_RANGE_DEG = (15.0, 60.0)
# A robot's press of known direction: move, approach, load, hold, unload, in about 2.5 s; a
# ten-minute calibration run gives DIRECTION_PRESSES of them (split 4).
ROBOT_PRESS_S = 2.5
DIRECTION_PRESSES = 240
# The tips a robot changes between (diameters, round): the users' indenters are 3..7 mm.
DIRECTION_TIPS_M = (0.003, 0.005, 0.007)


def _default_skin(model: SkinModel) -> SkinModel:
    return model if model is not None else family_skin('default').model


def _random_press(rng, x, y, force_range_n, alpha_range_deg=ALPHA_RANGE_DEG,
                  diameter_range_m=DIAMETER_RANGE_M, normal: bool = False,
                  elliptical_share: float = ELLIPTICAL_SHARE) -> Press:
    """Return a press at (x, y): random force, beta, alpha, round or elliptical indenter."""
    f = rng.uniform(*force_range_n)
    radius = rng.uniform(*diameter_range_m) / 2.0
    aspect, orientation = 1.0, 0.0
    if rng.random() < elliptical_share:
        aspect, orientation = rng.uniform(0.5, 0.8), rng.uniform(0.0, math.pi)
    alpha = 0.0 if normal else math.radians(rng.uniform(*alpha_range_deg))
    beta = rng.uniform(0.0, 2.0 * math.pi) if not normal else 0.0
    return Press(x, y, f, alpha, beta, radius, aspect, orientation)


def _interior_spot(model: SkinModel, rng, margin_m: float) -> tuple:
    width, height = taxel_span(model)
    return (rng.uniform(margin_m, max(width - margin_m, margin_m)),
            rng.uniform(margin_m, max(height - margin_m, margin_m)))


def press_for_shift(model: SkinModel, shift_taxels: float, rng: np.random.Generator,
                    margin_m: float = 0.015) -> Press:
    """
    Return a press at a random interior spot whose layer shift is ``shift_taxels`` taxels.

    Random beta, normal force 5..15 N, indenter radius 1.5..3.5 mm; the tilt is what the
    skin's compliance needs for the wanted shift.
    """
    x, y = _interior_spot(model, rng, margin_m)
    normal = rng.uniform(5.0, 15.0)
    tangential = shift_taxels * model.pitch_m / model.compliance_m_per_n
    return Press(x, y, math.hypot(normal, tangential), math.atan2(tangential, normal),
                 rng.uniform(-math.pi, math.pi), rng.uniform(0.0015, 0.0035))


def make_seed_experiment(model: SkinModel = None, repeats: int = 20,
                         rng: np.random.Generator = None,
                         force_n: float = PAPER_FORCE_N, truth_out: list = None) -> Dataset:
    """Render the paper's protocol (:func:`paper_presses`) with the robot's repeatability."""
    model = _default_skin(model)
    rng = rng if rng is not None else np.random.default_rng(0)
    presses = paper_presses(model, force_n, repeats, rng=rng)
    return render_frames(model, [[p] for p in presses], rng, truth_out)


def make_random_experiment(model: SkinModel = None, frames: int = 400,
                           rng: np.random.Generator = None, force_range_n: tuple = (5.0, 15.0),
                           alpha_range_deg: tuple = ALPHA_RANGE_DEG,
                           diameter_range_m: tuple = DIAMETER_RANGE_M,
                           border_m: float = 0.01, truth_out: list = None,
                           elliptical_share: float = ELLIPTICAL_SHARE) -> Dataset:
    """Render single presses at random spots at least ``border_m`` inside the taxel span."""
    model = _default_skin(model)
    rng = rng if rng is not None else np.random.default_rng(0)
    out = []
    for i in range(int(frames)):
        x, y = _interior_spot(model, rng, border_m)
        out.append([_random_press(rng, x, y, force_range_n, alpha_range_deg, diameter_range_m,
                                  normal=i % NORMAL_EVERY == 0,
                                  elliptical_share=elliptical_share)])
    return render_frames(model, out, rng, truth_out)


def make_border_experiment(model: SkinModel = None, frames: int = 200,
                           rng: np.random.Generator = None,
                           force_range_n: tuple = (5.0, 15.0), truth_out: list = None
                           ) -> Dataset:
    """
    Render tilted presses centred from half a taxel outside to one taxel inside an edge.

    A quarter of them sit at a corner (both coordinates at an edge). The normal presses, for
    the calibration, are at interior spots.
    """
    model = _default_skin(model)
    rng = rng if rng is not None else np.random.default_rng(0)
    width, height = taxel_span(model)
    pitch = model.pitch_m
    out = []
    for i in range(int(frames)):
        if i % NORMAL_EVERY == 0:
            x, y = _interior_spot(model, rng, 2 * pitch)
            out.append([_random_press(rng, x, y, force_range_n, normal=True)])
            continue
        x, y = _interior_spot(model, rng, 0.0)
        depth = rng.uniform(-0.5 * pitch, pitch, 2)
        edge = rng.integers(0, 4)
        if edge == 0 or rng.random() < 0.25:
            x = depth[0] if rng.random() < 0.5 else width - depth[0]
        if edge != 0:
            y = depth[1] if edge == 1 or (edge == 3 and rng.random() < 0.5) else height - depth[1]
        out.append([_random_press(rng, x, y, force_range_n)])
    return render_frames(model, out, rng, truth_out)


def make_multi_experiment(model: SkinModel = None, frames: int = 200,
                          rng: np.random.Generator = None, force_range_n: tuple = (5.0, 15.0),
                          separation_taxels: tuple = (2.0, 8.0), truth_out: list = None
                          ) -> Dataset:
    """
    Render two or three presses at once (one frame in three has three), 2..8 taxels apart.

    A third of the pairs are 2..3 taxels apart. Each press is tilted (alpha 15..60 deg) or, one
    in five, normal.
    """
    model = _default_skin(model)
    rng = rng if rng is not None else np.random.default_rng(0)
    pitch = model.pitch_m
    out = []
    while len(out) < int(frames):
        if len(out) % NORMAL_EVERY == 0:
            x, y = _interior_spot(model, rng, 2 * pitch)
            out.append([_random_press(rng, x, y, force_range_n, normal=True)])
            continue
        count = 3 if rng.random() < 1.0 / 3.0 else 2
        spots = [_interior_spot(model, rng, 2 * pitch)]
        for _ in range(50):
            if len(spots) == count:
                break
            close = rng.random() < 1.0 / 3.0
            low, high = (2.0, 3.0) if close else separation_taxels
            d = rng.uniform(low, high) * pitch
            theta = rng.uniform(0.0, 2.0 * math.pi)
            base = spots[int(rng.integers(len(spots)))]
            spot = (base[0] + d * math.cos(theta), base[1] + d * math.sin(theta))
            width, height = taxel_span(model)
            inside = pitch <= spot[0] <= width - pitch and pitch <= spot[1] <= height - pitch
            apart = all(math.dist(spot, s) >= 2.0 * pitch for s in spots)
            if inside and apart:
                spots.append(spot)
        if len(spots) < count:
            continue
        out.append([_random_press(rng, x, y, force_range_n, normal=rng.random() < 0.2)
                    for x, y in spots])
    return render_frames(model, out, rng, truth_out)


DIRECTION_KINDS = ('paper', 'random', 'border', 'multi')
SCENE_KINDS = DIRECTION_KINDS + ('one_tip',)
_DEFAULT_SIZE = {'paper': 10, 'random': 300, 'border': 200, 'multi': 200, 'one_tip': 300}


def make_scene(kind: str, skin, rng: np.random.Generator = None, size: int = None,
               truth_out: list = None) -> Dataset:
    """
    Render scene ``kind`` on a family skin (a name or a :class:`FamilySkin`).

    ``size`` is the number of repeats for ``paper`` (nine frames each), of frames otherwise.
    ``truth_out``, when given, is extended by each frame's presses (:class:`Press` lists), which
    the oracle (:mod:`oracle`) fits.
    """
    member = skin if isinstance(skin, FamilySkin) else family_skin(skin)
    if kind not in SCENE_KINDS:
        raise ValueError(f'unknown scene kind {kind!r}; kinds are {", ".join(SCENE_KINDS)}')
    size = _DEFAULT_SIZE[kind] if size is None else int(size)
    rng = rng if rng is not None else np.random.default_rng(0)
    model = member.model
    if kind == 'paper':
        return make_seed_experiment(model, size, rng, member.paper_force_n, truth_out)
    if kind == 'one_tip':
        tip = 2.0 * CALIBRATION_RADIUS_M
        return make_random_experiment(model, size, rng, force_range_n=member.force_range_n,
                                      diameter_range_m=(tip, tip), truth_out=truth_out,
                                      elliptical_share=0.0)
    maker = {'random': make_random_experiment, 'border': make_border_experiment,
             'multi': make_multi_experiment}[kind]
    return maker(model, size, rng, force_range_n=member.force_range_n, truth_out=truth_out)


def add_calibration_frames(data: Dataset, model: SkinModel, rng: np.random.Generator = None,
                           normal: int = 16, tilted: int = 16,
                           normal_force_range_n: tuple = (5.0, 60.0),
                           tilted_force_range_n: tuple = (5.0, 15.0),
                           alpha_range_deg: tuple = (20.0, 45.0),
                           radius_m: float = CALIBRATION_RADIUS_M,
                           border_m: float = 0.015, at_use: np.ndarray = None,
                           truth_out: list = None, plates: int = 16) -> Dataset:
    """
    Return ``data`` with calibration frames of ``model`` in front (dataset format 2 ``split``).

    The calibration frames are what a user with a force gauge or a robot makes: first
    ``plates`` frames of a rigid plate over the whole skin, weighted so that a taxel reads about
    half the ADC's range or its film is well past its turn-on (split 3: the per-taxel gains,
    :mod:`estimation.gains`), then ``normal`` presses straight down with forces spread evenly
    over ``normal_force_range_n``, then ``tilted`` presses of known force and alpha at random
    azimuths, all at random places at least ``border_m`` inside the skin with an indenter of
    ``radius_m``. ``data``'s frames keep
    their order and become the scored frames (split 0), except those marked in ``at_use``
    (normal presses where the scored ones are made), which re-take the offset (split 2); its tare
    frames are kept. ``truth_out``, when given, is extended by the calibration frames' presses
    (one list per frame, in the dataset's order).
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    width = (model.cols - 1) * model.pitch_m
    height = (model.rows - 1) * model.pitch_m

    def place():
        return (rng.uniform(border_m, max(width - border_m, border_m)),
                rng.uniform(border_m, max(height - border_m, border_m)))

    presses, azimuths = [], []
    for f in rng.permutation(np.linspace(*normal_force_range_n, int(normal))):
        presses.append(Press(*place(), float(f), 0.0, 0.0, radius_m))
        azimuths.append(math.nan)
    for _ in range(int(tilted)):
        beta = rng.uniform(0.0, 360.0)
        presses.append(Press(*place(), rng.uniform(*tilted_force_range_n),
                             math.radians(rng.uniform(*alpha_range_deg)), math.radians(beta),
                             radius_m))
        azimuths.append(beta)
    maps = [render(model, [p], rng) for p in presses]
    # Drawn after the presses, so that a skin's presses are those it had before plates.
    # The user weighs the plate until a taxel reads about half the range: more where the film
    # turns on only at a higher pressure.
    plate_load = max(float(model.fsr.counts_to_force(model.fsr.full_scale / 2.0)),
                     1.5 * model.turn_on_pa * (model.fill_factor * model.pitch_m) ** 2)
    maps = [render_plate(model, plate_load, rng) for _ in range(int(plates))] + maps
    span = np.array(((model.cols - 1) / 2.0, (model.rows - 1) / 2.0)) * model.pitch_m
    plate_force = plate_load * model.rows * model.cols
    k = len(maps)
    if truth_out is not None:
        truth_out.extend([[]] * int(plates) + [[p] for p in presses])
    azimuths = [math.nan] * int(plates) + azimuths
    own_split = np.zeros(data.frames, np.uint8)
    if at_use is not None:
        own_split[np.asarray(at_use, dtype=bool)] = 2

    def joined(name, values):
        own = getattr(data, name)
        return None if own is None else np.concatenate([np.asarray(values), own])

    def press_truth(name, values):
        # A press frame holds one press: slot 0, the other slots empty; a plate frame none.
        own = getattr(data, name)
        if own is None:
            return None
        pad = np.full((k,) + own.shape[1:], np.nan)
        pad[int(plates):, 0] = values
        return np.concatenate([pad, own])

    n_plates = int(plates)
    return Dataset(
        top=np.concatenate([np.stack([t for t, _ in maps]), data.top]),
        bottom=np.concatenate([np.stack([b for _, b in maps]), data.bottom]),
        pitch_m=data.pitch_m,
        azimuth_deg=np.concatenate([azimuths, data.azimuth_deg]),
        alpha_deg=np.concatenate([[0.0] * n_plates, [math.degrees(p.alpha_rad) for p in presses],
                                  data.alpha_deg]),
        force_n=joined('force_n', [plate_force] * n_plates + [p.force_n for p in presses]),
        x_m=joined('x_m', [span[0]] * n_plates + [p.x_m for p in presses]),
        y_m=joined('y_m', [span[1]] * n_plates + [p.y_m for p in presses]),
        tare_top=data.tare_top, tare_bottom=data.tare_bottom,
        split=np.concatenate([np.full(n_plates, 3, dtype=np.uint8),
                              np.ones(len(presses), dtype=np.uint8), own_split]),
        press_x_m=press_truth('press_x_m', [p.x_m for p in presses]),
        press_y_m=press_truth('press_y_m', [p.y_m for p in presses]),
        press_force_n=press_truth('press_force_n', [p.force_n for p in presses]),
        press_azimuth_deg=press_truth('press_azimuth_deg', azimuths[n_plates:]),
        press_alpha_deg=press_truth('press_alpha_deg',
                                    [math.degrees(p.alpha_rad) for p in presses]),
        press_shift_m=press_truth('press_shift_m', [model.compliance_m_per_n
                                                    * p.tangential_force_n for p in presses]))


def add_direction_frames(data: Dataset, skin, rng: np.random.Generator = None,
                         presses: int = DIRECTION_PRESSES, tips_m: tuple = DIRECTION_TIPS_M,
                         truth_out: list = None) -> Dataset:
    """
    Return ``data`` with a robot's presses of known direction in front (``split`` = 4).

    Each is a tilted press (alpha 15..60 deg, the skin's ``force_range_n``, a random azimuth) at
    a random spot at least a centimetre inside the taxel span, with the robot's round tips in
    turn (``tips_m``, diameters): what a robot calibration run gives (:data:`ROBOT_PRESS_S` a
    press). ``data`` must have a ``split``; its frames follow unchanged. ``truth_out``, when
    given, is extended by the new frames' presses, in order.
    """
    member = skin if isinstance(skin, FamilySkin) else family_skin(skin)
    model = member.model
    rng = rng if rng is not None else np.random.default_rng(0)
    if data.split is None:
        raise ValueError('presses of known direction go in front of a dataset with a split')
    frames = []
    for i in range(int(presses)):
        x, y = _interior_spot(model, rng, 0.01)
        tip = float(tips_m[i % len(tips_m)])
        frames.append([_random_press(rng, x, y, member.force_range_n,
                                     diameter_range_m=(tip, tip), elliptical_share=0.0)])
    front = render_frames(model, frames, rng, truth_out)
    k = max(front.press_x_m.shape[1], data.press_x_m.shape[1])

    def joined(name):
        a, b = getattr(front, name), getattr(data, name)
        if b is None:
            return None
        if name in PRESS_FIELDS:
            a = np.pad(a, ((0, 0), (0, k - a.shape[1])), constant_values=np.nan)
            b = np.pad(b, ((0, 0), (0, k - b.shape[1])), constant_values=np.nan)
        return np.concatenate([a, b])

    names = ('top', 'bottom', 'azimuth_deg', 'alpha_deg', 'force_n', 'x_m', 'y_m', *PRESS_FIELDS)
    return Dataset(pitch_m=data.pitch_m, tare_top=data.tare_top, tare_bottom=data.tare_bottom,
                   split=np.concatenate([np.full(front.frames, 4, np.uint8), data.split]),
                   **{name: joined(name) for name in names})


def calibrated_scene(kind: str, skin, rng: np.random.Generator = None, size: int = None,
                     truth_out: list = None, direction_presses: int = 0) -> Dataset:
    """
    Render scene ``kind`` (:func:`make_scene`) after the user's calibration frames.

    The calibration frames (:func:`add_calibration_frames`, split 1) calibrate force curves,
    offset and compliance. In ``paper`` the scene's own normal presses at its spot re-take the
    offset (split 2): the paper's protocol takes (x_p, y_p) where it presses. ``truth_out``,
    when given, is extended by the presses of every frame in the dataset's order. With
    ``direction_presses``, a robot's presses of known direction go in front
    (:func:`add_direction_frames`, split 4), drawn from a generator of their own.
    """
    member = skin if isinstance(skin, FamilySkin) else family_skin(skin)
    rng = rng if rng is not None else np.random.default_rng(0)
    scene_truth, calibration_truth, direction_truth = [], [], []
    data = make_scene(kind, member, rng, size, scene_truth)
    at_use = data.alpha_deg == 0 if kind == 'paper' else None
    # A child generator for the calibration frames: ``rng`` goes on as after make_scene alone,
    # so a run draws the same scenes with and without calibration frames.
    data = add_calibration_frames(data, member.model, rng.spawn(1)[0], at_use=at_use,
                                  truth_out=calibration_truth)
    if direction_presses:
        # A generator of their own: the scene and the calibration frames stay those drawn
        # without them.
        data = add_direction_frames(data, member, rng.spawn(1)[0], direction_presses,
                                    truth_out=direction_truth)
    if truth_out is not None:
        truth_out.extend(direction_truth + calibration_truth + scene_truth)
    return data
