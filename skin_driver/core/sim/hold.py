"""
Scenes in simulated hours: a press held an hour, released and pressed again; a skin left unloaded.

Each scene is a list of timed frames (seconds after the tare) rendered at those times only: the
creep and the offset drift between two frames are closed forms (:mod:`.drift`), so an hour's
hold costs the frames it is scored at plus a sparse trail (every ``step_s``) that lets a tracker
of the baseline see the time go by, as a live skin's scans would.

``hold_scene``: after ``lead_s`` unloaded, one tilted press at the skin's paper force, held
``hold_s``; frames labelled ``1s``, ``1min``, ``10min``, ``60min`` on the way (each label
``SCORED_FRAMES`` frames, 0.1 s apart); released a
second after ``hold_s`` for ``rest_s``; pressed again the same (``repress``, 1 s into the
second press). ``idle_scene``: no press at all for ``duration_s`` (a frame every ``step_s``).
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from .drift import held_age
from .physics import Press, render_held
from .skins import FamilySkin

__all__ = ['HeldFrame', 'HeldScene', 'hold_scene', 'idle_scene', 'HOLD_LABELS',
           'SCORED_FRAMES']

TARE_FRAMES = 20
# The scored frames of a hold: seconds after the press's start (the second press's for repress).
HOLD_LABELS = {'1s': 1.0, '1min': 60.0, '10min': 600.0, '60min': 3600.0}
# A press's first second, as a scan at 100 Hz and more would see it settle.
_ONSET_S = (0.01, 0.03, 0.1, 0.3, 0.6, 1.0)
# Each label scores this many frames, 0.1 s apart from its time on: one frame's noise is not
# the hold's doing.
SCORED_FRAMES = 5


@dataclass(frozen=True)
class HeldFrame:
    """One frame: its time after the tare (s), raw maps, and its label ('' unscored)."""

    time_s: float
    top: np.ndarray
    bottom: np.ndarray
    label: str = ''


@dataclass(frozen=True)
class HeldScene:
    """A skin's tare frames (N x rows x cols each), its timed frames, and the press held."""

    skin: str
    tare_top: np.ndarray
    tare_bottom: np.ndarray
    frames: tuple
    press: Press = None


def _tare(member: FamilySkin, rng) -> tuple:
    maps = [render_held(member.model, [], [], 0.0, rng) for _ in range(TARE_FRAMES)]
    return np.stack([t for t, _ in maps]), np.stack([b for _, b in maps])


def hold_press(member: FamilySkin) -> Press:
    """Return the press a hold scene holds: the skin's paper force, 45 deg, near the centre."""
    m = member.model
    return Press(x_m=0.49 * m.cols * m.pitch_m, y_m=0.51 * m.rows * m.pitch_m,
                 force_n=member.paper_force_n, alpha_rad=math.radians(45.0),
                 beta_rad=math.radians(30.0), radius_m=0.004)


def hold_scene(member: FamilySkin, seed: int = 0, lead_s: float = 600.0, hold_s: float = 3600.0,
               rest_s: float = 120.0, step_s: float = 60.0) -> HeldScene:
    """Return the hold scene of ``member`` (module doc); the same seed gives the same frames."""
    rng = np.random.default_rng([0x401D, seed])
    press = hold_press(member)
    drift = member.model.drift
    on1 = lead_s
    # released a second after the last scored frame of the hold
    off1 = on1 + hold_s + 1.0
    on2 = off1 + rest_s
    loads = [(on1, off1), (on2, math.inf)]
    starts = {on1 + t: label for label, t in HOLD_LABELS.items() if t <= hold_s}
    starts[on2 + 1.0] = 'repress'
    labels = {t + 0.1 * k: label for t, label in starts.items() for k in range(SCORED_FRAMES)}
    times = set(np.arange(step_s, lead_s, step_s).tolist())
    # a scan just before each press: a live skin's scans come every millisecond or so
    times |= {on1 - 0.01} | {on1 + t for t in _ONSET_S}
    times |= set(np.arange(on1 + step_s, off1, step_s).tolist())
    times |= {on1 + t for t in (3.0, 10.0, 30.0) if t < hold_s} | {off1 - 0.01}
    times |= {off1 + 0.01, off1 + 1.0} | set(np.arange(off1 + 10.0, on2, 10.0).tolist())
    times |= {on2 - 0.01} | {on2 + t for t in _ONSET_S}
    times |= set(labels)
    frames = []
    for t in sorted(times):
        loaded = any(on < t < off for on, off in loads)
        presses, ages = ([press], [held_age(drift, loads, t)]) if loaded else ([], [])
        top, bottom = render_held(member.model, presses, ages, t, rng)
        frames.append(HeldFrame(float(t), top, bottom, labels.get(t, '')))
    return HeldScene(member.name, *_tare(member, rng), tuple(frames), press)


def idle_scene(member: FamilySkin, seed: int = 0, duration_s: float = 8 * 3600.0,
               step_s: float = 10.0) -> HeldScene:
    """Return ``member`` left unloaded for ``duration_s`` after its tare, every frame scored."""
    rng = np.random.default_rng([0x1D1E, seed])
    frames = []
    for t in np.arange(step_s, duration_s + step_s / 2, step_s):
        top, bottom = render_held(member.model, [], [], float(t), rng)
        frames.append(HeldFrame(float(t), top, bottom, 'idle'))
    return HeldScene(member.name, *_tare(member, rng), tuple(frames))
