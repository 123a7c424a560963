"""
A named, seeded family of simulated skins that the evaluator, the benchmark and the tests share.

Each skin differs from the project's own simulated skin (``default``) in one or more ways a real
skin can: FSR curve and saturation, layer compliance (shifts from 0.1 to 6 taxels), cover and
elastic-layer spread, per-taxel gains and offsets, passive-matrix crosstalk, noise, layer
misalignment, films that turn on at a pressure with a step to a few kilohms, tips whose contact
grows with the load (Hertz), a zero shift that moves with the normal load, creep under a held
load and drift of the offsets over hours (:mod:`.drift`). Each also names the
forces its scenes press with, so that its shifts are meaningful: ``paper_force_n`` for the
paper's protocol (alpha = 45 deg) and ``force_range_n`` for random presses. Everything is
fixed by the skin's ``seed``: the same name always gives the same skin.

``held_out:N`` names a skin drawn at random (seed N) within the family's ranges: once an
estimator has been tuned on the named skins, these are data it has never seen. ``NAME@N`` is
skin NAME with N x N taxels over the same patch (:func:`on_grid`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import math

import numpy as np

from .drift import Drift
from .fsr import FsrFilm
from .physics import SkinModel

__all__ = ['FamilySkin', 'HELD_OUT', 'GRID', 'skin_names', 'get_skin', 'family_skin',
           'held_out_skin', 'on_grid', 'model_on_grid', 'skin_for_grid', 'PATCH_M']

HELD_OUT = 'held_out:'
GRID = '@'
# The seed's 16 x 16 patch at 5 mm pitch: finer grids (skin_for_grid) cover the same area.
PATCH_M = 0.08


@dataclass(frozen=True)
class FamilySkin:
    """One member of the family: its model, a line of description and the forces it takes."""

    name: str
    description: str
    model: SkinModel
    paper_force_n: float
    force_range_n: tuple

    def shift_taxels(self, force_n: float, alpha_deg: float) -> float:
        """Return the layer shift (taxels) that a press of this force and tilt causes."""
        return (self.model.compliance_m_per_n * force_n * math.sin(math.radians(alpha_deg))
                / self.model.pitch_m)


_SOFT_FSR = FsrFilm(force_at_r_max_n=0.5, force_at_r_min_n=60.0)
_SATURATING_FSR = FsrFilm(r_min_ohm=200.0, r_max_ohm=6000.0, force_at_r_max_n=0.1,
                          force_at_r_min_n=3.0)
_FLAT_FSR = FsrFilm(r_min_ohm=500.0, r_max_ohm=2500.0, force_at_r_max_n=0.3,
                    force_at_r_min_n=40.0)

_FILM_FSR = FsrFilm(r_series_ohm=2200.0, r_min_ohm=250.0, r_max_ohm=3500.0,
                    force_at_r_max_n=0.3, force_at_r_min_n=12.0)

_FAMILY = (
    FamilySkin('default', "the project's own simulated skin (seed prototype), 0.36 mm misaligned",
               SkinModel(misalignment_m=(3e-4, -2e-4),
                         drift=Drift(0.015, 0.2, 1.0, 60.0, 6.0, 15.0)), 10.0, (5.0, 15.0)),
    FamilySkin('soft', 'soft thick layer: 3-6 taxel shifts at 25-40 N, wide bottom imprint',
               SkinModel(compliance_m_per_n=9e-4, spread_m=0.003, cover_spread_m=0.0015,
                         fsr=_SOFT_FSR, misalignment_m=(-4e-4, 3e-4), seed=2,
                         drift=Drift(0.05, 0.3, 2.0, 120.0, -4.0, 25.0, 3.0 * 3600.0, 0.2)),
               32.0, (25.0, 40.0)),
    FamilySkin('stiff', 'stiff thin layer: shifts of 0.1-1 taxel at 10-60 N',
               SkinModel(compliance_m_per_n=1.2e-4, spread_m=0.001, fsr=_SOFT_FSR,
                         noise_counts=4.0, seed=3,
                         drift=Drift(0.005, 0.1, 0.5, 30.0, 2.0, 8.0)),
               20.0, (10.0, 60.0)),
    FamilySkin('crosstalk', 'strong passive-matrix crosstalk (1.2 % of each row and column)',
               SkinModel(crosstalk=0.012, baseline_spread_counts=10.0, seed=4,
                         drift=Drift(0.02, 0.2, 1.0, 60.0, 10.0, 10.0, 6.0 * 3600.0, 0.1)),
               12.0, (6.0, 18.0)),
    FamilySkin('saturating', 'FSRs saturate at 3 N per taxel: flat-topped imprints',
               SkinModel(compliance_m_per_n=3e-4, fsr=_SATURATING_FSR, seed=5,
                         drift=Drift(0.03, 0.2, 1.5, 90.0, 8.0, 20.0)),
               20.0, (10.0, 60.0)),
    FamilySkin('noisy', 'noise 10 counts, gains +-10 %, offsets, misaligned by half a taxel',
               SkinModel(compliance_m_per_n=5e-4, noise_counts=10.0, gain_spread=0.1,
                         baseline_spread_counts=20.0, misalignment_m=(2.0e-3, -1.5e-3), seed=6,
                         drift=Drift(0.025, 0.3, 1.0, 60.0, 12.0, 30.0, 2.0 * 3600.0, 0.3)),
               15.0, (8.0, 30.0)),
    FamilySkin('sharp', 'thin cover and layer (0.2 / 0.6 mm spread), 80 % fill: sharp imprints',
               SkinModel(compliance_m_per_n=4e-4, spread_m=0.0006, cover_spread_m=0.0002,
                         fill_factor=0.8, seed=7,
                         drift=Drift(0.01, 0.2, 0.7, 45.0, -6.0, 12.0)),
               15.0, (8.0, 30.0)),
    FamilySkin('blurred', 'thick cover and layer (2 / 4 mm spread), compliant',
               SkinModel(compliance_m_per_n=1e-3, spread_m=0.004, cover_spread_m=0.002, seed=8,
                         drift=Drift(0.04, 0.2, 2.0, 90.0, 5.0, 20.0, 8.0 * 3600.0)),
               10.0, (5.0, 20.0)),
    FamilySkin('flat_fsr', 'weak FSR response (flat curve) and 8 counts of noise',
               SkinModel(compliance_m_per_n=6e-4, fsr=_FLAT_FSR, noise_counts=8.0,
                         gain_spread=0.05, seed=9,
                         drift=Drift(0.035, 0.25, 1.0, 60.0, 9.0, 15.0)),
               15.0, (8.0, 30.0)),
    FamilySkin('harsh', 'everything at once: crosstalk, gains, offsets, noise, misalignment',
               SkinModel(compliance_m_per_n=8e-4, spread_m=0.0025, crosstalk=0.006,
                         gain_spread=0.1, baseline_spread_counts=15.0, noise_counts=8.0,
                         misalignment_m=(-1.5e-3, 2.0e-3), fsr=_SOFT_FSR, seed=10,
                         drift=Drift(0.055, 0.3, 2.5, 150.0, 15.0, 30.0, 3.0 * 3600.0, 0.3)),
               20.0, (10.0, 40.0)),
    FamilySkin('film', 'films open below 20 kPa, stepping to 4 kOhm; Hertz tips; floor at 12 N',
               SkinModel(compliance_m_per_n=4e-4, spread_m=0.0015, cover_spread_m=0.0005,
                         fsr=_FILM_FSR, turn_on_pa=2.0e4, turn_on_ohm=4000.0,
                         hertz_reference_n=20.0, gain_spread=0.05, noise_counts=5.0,
                         misalignment_m=(1.0e-3, 5e-4), seed=11,
                         drift=Drift(0.02, 0.2, 1.0, 60.0, -8.0, 20.0)),
               20.0, (10.0, 40.0)),
    FamilySkin('loaded', 'zero shift moving 0.2 taxel per 20 N of normal load, Hertz tips',
               SkinModel(compliance_m_per_n=6e-4, hertz_reference_n=15.0,
                         normal_shift_m_per_n=(4e-5, -3e-5), turn_on_pa=1.0e4,
                         crosstalk=0.004, gain_spread=0.04, seed=12,
                         drift=Drift(0.03, 0.2, 1.5, 60.0, 7.0, 25.0, 5.0 * 3600.0, 0.2)),
               15.0, (8.0, 30.0)),
)
_BY_NAME = {s.name: s for s in _FAMILY}


def skin_names() -> list:
    """Return the names of the family's skins, the project's default first."""
    return [s.name for s in _FAMILY]


def _films_and_tips(pick, rng, force: float, pitch: float, fsr: FsrFilm) -> dict:
    """Return the held-out draw's turn-on, Hertz tip, normal-load shift and divider."""
    extra = {'fsr': replace(fsr, r_series_ohm=pick(1000.0, 3300.0))}
    if rng.random() < 2.0 / 3.0:
        extra['turn_on_pa'] = pick(5e3, 3e4)
        if rng.random() < 0.5:
            extra['turn_on_ohm'] = fsr.r_max_ohm * pick(1.0, 1.5)
    if rng.random() < 2.0 / 3.0:
        extra['hertz_reference_n'] = force
    if rng.random() < 0.5:
        size, angle = pick(0.0, 0.2) * pitch / force, pick(0.0, 2.0 * math.pi)
        extra['normal_shift_m_per_n'] = (size * math.cos(angle), size * math.sin(angle))
    return extra


def _drift(pick) -> Drift:
    """Return a held-out draw's creep (2.5-30 % over 48 h) and offset drift."""
    settle = pick(0.5, 3.0)
    decades = math.log10(1.0 + 48.0 * 3600.0 / settle)
    return Drift(creep_per_decade=pick(0.025, 0.30) / decades, creep_spread=pick(0.0, 0.3),
                 settle_s=settle, recovery_s=pick(30.0, 180.0),
                 offset_counts_per_hour=pick(-15.0, 15.0), thermal_counts=pick(0.0, 30.0),
                 thermal_period_s=pick(2.0, 8.0) * 3600.0, offset_spread=pick(0.0, 0.3))


def held_out_skin(seed: int) -> FamilySkin:
    """
    Return a skin drawn at random within the family's ranges, named ``held_out:<seed>``.

    Its paper press (alpha = 45 deg) shifts the layers by 0.3 to 5 taxels at 8 to 40 N; random
    presses take half to one and a half times that force. Two in three draws have films that
    turn on at 5 to 30 kPa (half of them stepping to a few kilohms), two in three Hertz tips,
    one in two a zero shift that moves with the normal load (up to 0.2 taxel at the paper
    force); the divider's series resistor is 1 to 3.3 kOhm; every draw creeps by 2.5 to 30 %
    over 48 h and its offsets drift (:mod:`.drift`). These are drawn after the rest, so the
    other parameters of a seed are those it always had.
    """
    seed = int(seed)
    if seed < 0:
        raise ValueError(f'a held-out skin needs a seed >= 0, got {seed}')
    rng = np.random.default_rng([0x5EED, seed])
    pick = (lambda low, high: float(rng.uniform(low, high)))
    pitch = 0.005
    force = pick(8.0, 40.0)
    shift_taxels = math.exp(pick(math.log(0.3), math.log(5.0)))
    fsr = FsrFilm(r_min_ohm=pick(200.0, 500.0), r_max_ohm=pick(2500.0, 6000.0),
                  force_at_r_max_n=pick(0.1, 0.5),
                  force_at_r_min_n=math.exp(pick(math.log(3.0), math.log(60.0))))
    offset, angle = pick(0.0, 0.5 * pitch), pick(0.0, 2.0 * math.pi)
    model = SkinModel(
        compliance_m_per_n=shift_taxels * pitch / (force * math.sin(math.radians(45.0))),
        spread_m=pick(0.0006, 0.004), cover_spread_m=pick(0.0002, 0.002),
        fill_factor=pick(0.8, 0.95), fsr=fsr,
        crosstalk=pick(0.0, 0.012) if rng.random() < 0.5 else 0.0,
        gain_spread=pick(0.0, 0.1), baseline_spread_counts=pick(0.0, 20.0),
        noise_counts=pick(2.0, 10.0),
        misalignment_m=(offset * math.cos(angle), offset * math.sin(angle)), seed=1000 + seed)
    model = replace(model, **_films_and_tips(pick, rng, force, pitch, fsr))
    model = replace(model, drift=_drift(pick))
    return FamilySkin(f'{HELD_OUT}{seed}',
                      f'held out (seed {seed}): {shift_taxels:.1f} taxel shift at {force:.0f} N, '
                      f'saturates at {fsr.force_at_r_min_n:.0f} N per taxel'
                      + ''.join(f', {label}' for label, on in (
                          ('turn-on', model.turn_on_pa > 0), ('step', model.turn_on_ohm > 0),
                          ('Hertz tips', model.hertz_reference_n > 0),
                          ('load-dependent zero', any(model.normal_shift_m_per_n))) if on),
                      model, force, (0.5 * force, 1.5 * force))


def model_on_grid(model: SkinModel, n: int) -> SkinModel:
    """
    Return ``model`` with n x n taxels over the same patch: finer pitch, same materials.

    A smaller FSR carries a smaller share of the load; made of the same film, it reads the same
    counts at the same pressure, so its forces scale with its area. Spreads and compliance are
    the skin's own (metres and newtons do not change with the grid).
    """
    if not 1 <= int(n) <= 128:
        raise ValueError(f'a grid of {n} x {n} taxels is not in 1..128')
    pitch = model.pitch_m * model.cols / int(n)
    area = (pitch / model.pitch_m) ** 2
    fsr = model.fsr
    fsr = replace(fsr, force_at_r_max_n=fsr.force_at_r_max_n * area,
                  force_at_r_min_n=fsr.force_at_r_min_n * area,
                  activation_n=fsr.activation_n * area)
    return replace(model, rows=int(n), cols=int(n), pitch_m=pitch, fsr=fsr)


def on_grid(member: FamilySkin, n: int) -> FamilySkin:
    """Return the family member on an n x n grid over the same patch (:func:`model_on_grid`)."""
    return replace(member, name=f'{member.name}{GRID}{int(n)}',
                   description=f'{member.description}; {int(n)} x {int(n)} taxels',
                   model=model_on_grid(member.model, n))


def family_skin(name: str) -> FamilySkin:
    """Return the family member ``name`` (model, description, forces); ValueError if unknown."""
    base, grid, size = name.partition(GRID)
    if grid:
        if not size.isdigit():
            raise ValueError(f'{name!r}: a grid is NAME{GRID}N with N taxels a side')
        return on_grid(family_skin(base), int(size))
    if name.startswith(HELD_OUT) and name[len(HELD_OUT):].isdigit():
        return held_out_skin(int(name[len(HELD_OUT):]))
    try:
        return _BY_NAME[name]
    except KeyError:
        raise ValueError(f'unknown skin {name!r}; the family has {", ".join(skin_names())}, '
                         f'and {HELD_OUT}N (N >= 0) draws a held-out one') from None


def get_skin(name: str) -> SkinModel:
    """Return the physics model of the family's skin ``name``."""
    return family_skin(name).model


def skin_for_grid(n: int, noise_counts: float = 6.0) -> SkinModel:
    """Return the project's simulated skin as n x n taxels over the seed's 80 mm patch."""
    return model_on_grid(SkinModel(noise_counts=noise_counts), n)
