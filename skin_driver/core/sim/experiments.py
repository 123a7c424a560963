"""Render datasets of simulated presses (the evaluator's and the benchmark's experiments)."""

from __future__ import annotations

import math

import numpy as np

from .physics import Press, render, SkinModel
from ..estimation.dataset import Dataset

__all__ = ['make_seed_experiment', 'make_random_experiment', 'add_calibration_frames']


def _tare(model: SkinModel, rng: np.random.Generator, frames: int = 20) -> tuple:
    maps = [render(model, [], rng) for _ in range(frames)]
    return np.stack([t for t, _ in maps]), np.stack([b for _, b in maps])


def _build(model, presses, azimuths, rng) -> Dataset:
    maps = [render(model, [p], rng) for p in presses]
    tare_top, tare_bottom = _tare(model, rng)
    return Dataset(top=np.stack([t for t, _ in maps]), bottom=np.stack([b for _, b in maps]),
                   pitch_m=model.pitch_m, azimuth_deg=np.array(azimuths, dtype=np.float64),
                   alpha_deg=np.array([math.degrees(p.alpha_rad) for p in presses]),
                   force_n=np.array([p.force_n for p in presses]),
                   x_m=np.array([p.x_m for p in presses]),
                   y_m=np.array([p.y_m for p in presses]),
                   tare_top=tare_top, tare_bottom=tare_bottom)


def make_seed_experiment(model: SkinModel = None, repeats: int = 20,
                         rng: np.random.Generator = None, force_n: float = 10.0,
                         radius_m: float = 0.0025, location_m: tuple = None,
                         jitter_m: float = 5e-5, alpha_deg: float = 45.0) -> Dataset:
    """
    Render the seed paper's experiment: normal presses and alpha tilts at eight azimuths.

    Every repeat presses the same spot (robot-like, with ``jitter_m`` repeatability and +-5 %
    force) once along the normal and once at each beta = 0, 45, ..., 315 degrees.
    """
    model = model or SkinModel(misalignment_m=(3e-4, -2e-4))
    rng = rng if rng is not None else np.random.default_rng(0)
    if location_m is None:
        # Off the taxel centres on purpose: a realistic, unaligned placement.
        location_m = ((model.cols - 1) * model.pitch_m * 0.49,
                      (model.rows - 1) * model.pitch_m * 0.51)
    presses, azimuths = [], []
    for _ in range(int(repeats)):
        for beta in [None] + list(range(0, 360, 45)):
            x = location_m[0] + rng.normal(0.0, jitter_m)
            y = location_m[1] + rng.normal(0.0, jitter_m)
            f = force_n * rng.uniform(0.95, 1.05)
            alpha = 0.0 if beta is None else math.radians(alpha_deg)
            presses.append(Press(x, y, f, alpha, math.radians(beta or 0), radius_m))
            azimuths.append(math.nan if beta is None else float(beta))
    return _build(model, presses, azimuths, rng)


def make_random_experiment(model: SkinModel = None, frames: int = 400,
                           rng: np.random.Generator = None, normal_share: float = 0.2,
                           force_range_n: tuple = (5.0, 15.0), alpha_range_deg=(15.0, 60.0),
                           radius_range_m=(0.0015, 0.0035), border_m: float = 0.01) -> Dataset:
    """
    Render presses at random locations, azimuths, tilts and indenter radii.

    A share ``normal_share`` of the frames are normal presses (alpha = 0) for calibration.
    """
    model = model or SkinModel(misalignment_m=(3e-4, -2e-4))
    rng = rng if rng is not None else np.random.default_rng(0)
    width = (model.cols - 1) * model.pitch_m
    height = (model.rows - 1) * model.pitch_m
    presses, azimuths = [], []
    for i in range(int(frames)):
        x = rng.uniform(border_m, max(width - border_m, border_m))
        y = rng.uniform(border_m, max(height - border_m, border_m))
        f = rng.uniform(*force_range_n)
        r = rng.uniform(*radius_range_m)
        if rng.random() < normal_share:
            presses.append(Press(x, y, f, 0.0, 0.0, r))
            azimuths.append(math.nan)
        else:
            beta = rng.uniform(0.0, 360.0)
            alpha = math.radians(rng.uniform(*alpha_range_deg))
            presses.append(Press(x, y, f, alpha, math.radians(beta), r))
            azimuths.append(beta)
    return _build(model, presses, azimuths, rng)


def add_calibration_frames(data: Dataset, model: SkinModel, rng: np.random.Generator = None,
                           normal: int = 16, tilted: int = 16,
                           normal_force_range_n: tuple = (5.0, 60.0),
                           tilted_force_range_n: tuple = (5.0, 15.0),
                           alpha_range_deg: tuple = (20.0, 45.0), radius_m: float = 0.004,
                           border_m: float = 0.015) -> Dataset:
    """
    Return ``data`` with calibration frames of ``model`` in front (dataset format 2 ``split``).

    The calibration frames are what a user with a force gauge or a robot makes: ``normal``
    presses straight down with forces spread evenly over ``normal_force_range_n``, then
    ``tilted`` presses of known force and alpha at random azimuths, all at random places at
    least ``border_m`` inside the skin with an indenter of ``radius_m``. ``data``'s frames keep
    their order and become the scored frames (split 0); its tare frames are kept.
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
    k = len(presses)

    def joined(name, values):
        own = getattr(data, name)
        return None if own is None else np.concatenate([np.asarray(values), own])

    return Dataset(
        top=np.concatenate([np.stack([t for t, _ in maps]), data.top]),
        bottom=np.concatenate([np.stack([b for _, b in maps]), data.bottom]),
        pitch_m=data.pitch_m,
        azimuth_deg=np.concatenate([azimuths, data.azimuth_deg]),
        alpha_deg=np.concatenate([[math.degrees(p.alpha_rad) for p in presses],
                                  data.alpha_deg]),
        force_n=joined('force_n', [p.force_n for p in presses]),
        x_m=joined('x_m', [p.x_m for p in presses]), y_m=joined('y_m', [p.y_m for p in presses]),
        tare_top=data.tare_top, tare_bottom=data.tare_bottom,
        split=np.concatenate([np.ones(k, dtype=np.uint8), np.zeros(data.frames, np.uint8)]))
