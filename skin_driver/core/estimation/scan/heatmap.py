"""
Colour and character renderings of a pressure map, for rviz images and the terminal demo.

An image of the skin is drawn as seen from above the skin frame (REP-103: x right, y up): its
row 0 is the grid's last row (the largest y), its column 0 the grid's first (the smallest x).
Its colour scale reaches the strongest taxel of the scan, and never less than a floor: a light
touch fills the scale, and the noise of an idle skin stays dark.
"""

import cv2
import numpy as np

# From light to heavy, one character per level for the terminal heatmap.
SHADES = ' .:-=+*#%@'


def to_unit(values: np.ndarray, full_scale: float) -> np.ndarray:
    """Scale values to [0, 1] with full_scale as 1; NaN and negatives become 0."""
    if not full_scale > 0:
        raise ValueError(f'full_scale must be > 0, got {full_scale}')
    unit = np.nan_to_num(np.asarray(values, dtype=np.float64) / full_scale, nan=0.0,
                         posinf=1.0, neginf=0.0)
    return np.clip(unit, 0.0, 1.0)


def grey_levels(values: np.ndarray, full_scale: float) -> np.ndarray:
    """Return values as uint8 levels 0..255 with full_scale as 255 (the colour map's index)."""
    return np.round(to_unit(values, full_scale) * 255.0).astype(np.uint8)


def colour_map(values: np.ndarray, full_scale: float) -> np.ndarray:
    """Return a rows x cols x 3 uint8 RGB image of values (inferno: dark = none, yellow = full)."""
    bgr = cv2.applyColorMap(grey_levels(values, full_scale), cv2.COLORMAP_INFERNO)
    return np.ascontiguousarray(bgr[..., ::-1])


def display_scale(floor: float, *maps) -> float:
    """Return the top of the colour scale: the strongest taxel of ``maps``, at least ``floor``."""
    if not floor > 0:
        raise ValueError(f'floor must be > 0, got {floor}')
    # NaN (a dead taxel) and infinities say nothing about the scale.
    peak = max((float(np.max(np.nan_to_num(np.asarray(m, dtype=np.float64), nan=0.0,
                                           posinf=0.0, neginf=0.0), initial=0.0))
                for m in maps), default=0.0)
    return max(floor, peak)


def top_down(image: np.ndarray) -> np.ndarray:
    """Return a rows-first image of the grid as seen from above: row 0 is the largest y."""
    return np.ascontiguousarray(image[::-1])


def text_map(values: np.ndarray, full_scale: float) -> list:
    """Return one string per row, two characters per taxel, shading values for a terminal."""
    levels = np.round(to_unit(values, full_scale) * (len(SHADES) - 1)).astype(int)
    return [''.join(SHADES[v] * 2 for v in row) for row in levels]
