"""
The simulated skin's presses rendered offline as datasets with per-press ground truth.

``sim --export`` renders a scene with :func:`render_scene`; the lab's experiments render their
frames with :func:`render_frames`. A dataset starts with ``TARE_FRAMES`` no-touch frames.
"""

from __future__ import annotations

import math

import numpy as np
from skin_driver.core.common.validate import check_int
from skin_driver.core.estimation.data.dataset import Dataset
from skin_driver.core.sim.physics import layer_shift_m, Press, render, SkinModel

__all__ = ['TARE_FRAMES', 'render_frames', 'render_scene']

TARE_FRAMES = 20


def _azimuth_deg(press: Press) -> float:
    return math.degrees(press.beta_rad) % 360.0 if press.alpha_rad > 0 else math.nan


def _tare(model: SkinModel, rng: np.random.Generator) -> tuple:
    maps = [render(model, [], rng) for _ in range(TARE_FRAMES)]
    return np.stack([t for t, _ in maps]), np.stack([b for _, b in maps])


def render_frames(model: SkinModel, frames: list, rng: np.random.Generator,
                  truth_out: list = None) -> Dataset:
    """
    Render frames (each a list of presses) into a dataset with per-press ground truth.

    ``truth_out``, when given, is extended by each frame's presses in the dataset's order.
    """
    frames = [sorted(f, key=lambda p: -p.force_n) for f in frames]
    if truth_out is not None:
        truth_out.extend(frames)
    maps = [render(model, f, rng) for f in frames]
    tare_top, tare_bottom = _tare(model, rng)
    k = max(len(f) for f in frames)
    truth = {name: np.full((len(frames), k), np.nan) for name in (
        'x_m', 'y_m', 'force_n', 'azimuth_deg', 'alpha_deg', 'shift_m')}
    no_misalignment = SkinModel(**{**model.__dict__, 'misalignment_m': (0.0, 0.0)})
    for i, presses in enumerate(frames):
        for j, p in enumerate(presses):
            values = {'x_m': p.x_m, 'y_m': p.y_m, 'force_n': p.force_n,
                      'azimuth_deg': _azimuth_deg(p), 'alpha_deg': math.degrees(p.alpha_rad),
                      'shift_m': math.hypot(*layer_shift_m(no_misalignment, p))}
            for name, value in values.items():
                truth[name][i, j] = value
    return Dataset(top=np.stack([t for t, _ in maps]), bottom=np.stack([b for _, b in maps]),
                   pitch_m=model.pitch_m, azimuth_deg=truth['azimuth_deg'][:, 0],
                   alpha_deg=truth['alpha_deg'][:, 0], force_n=truth['force_n'][:, 0],
                   x_m=truth['x_m'][:, 0], y_m=truth['y_m'][:, 0],
                   tare_top=tare_top, tare_bottom=tare_bottom,
                   **{'press_' + name: arr for name, arr in truth.items()})


def render_scene(scene, noise_seed: int = 0, samples_per_press: int = 1) -> Dataset:
    """
    Render a scene (:class:`skin_driver.core.sim.scene.Scene`) offline as a dataset with truth.

    Samples are taken during the hold phase of every press (every repetition), at full force, with
    all presses active at that moment rendered together; the tare frames have no press.
    """
    check_int(samples_per_press, 'samples_per_press', low=1)
    times = []
    for k in range(scene.repeat):
        for p in scene.presses:
            hold = max(p.duration_s - 2 * p.ramp_s, 0.0)
            times += [k * scene.period_s + p.time_s + p.ramp_s
                      + hold * (j + 0.5) / samples_per_press for j in range(samples_per_press)]
    # A validated scene has at least one press, so there is at least one sample.
    return render_frames(scene.model, [scene.presses_at(t) for t in times],
                         np.random.default_rng(noise_seed))
