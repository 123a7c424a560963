"""Input checks shared by the core; each raises ValueError saying what is wrong."""

from __future__ import annotations

import math

import numpy as np

__all__ = ['check_map', 'check_pair', 'check_stack', 'check_number', 'check_int']

_NUMERIC_KINDS = 'uif'


def _as_numeric_array(value, name: str) -> np.ndarray:
    if isinstance(value, np.ndarray):
        arr = value
    else:
        try:
            arr = np.asarray(value)
        except (TypeError, ValueError) as exc:
            raise ValueError(f'{name} is not an array of numbers: {exc}') from None
    if arr.dtype.kind == 'b' or arr.dtype.kind not in _NUMERIC_KINDS:
        raise ValueError(f'{name} must hold integer or float numbers, got dtype {arr.dtype}')
    return arr


def _check_values(arr: np.ndarray, name: str, non_negative: bool) -> None:
    if arr.dtype.kind == 'f':
        if np.isnan(arr).any():
            raise ValueError(f'{name} contains NaN')
        if np.isinf(arr).any():
            raise ValueError(f'{name} contains inf')
    if non_negative and arr.dtype.kind != 'u' and arr.size and arr.min() < 0:
        raise ValueError(f'{name} contains negative values (min {arr.min()})')


def check_map(value, name: str = 'map', non_negative: bool = True) -> np.ndarray:
    """
    Check a 2-D, non-empty, finite (and by default non-negative) numeric map and return it.

    The returned array is the input itself when it is already an ndarray; callers must not write
    into it.
    """
    arr = _as_numeric_array(value, name)
    if arr.ndim != 2:
        raise ValueError(f'{name} must be 2-D (rows x cols), got shape {arr.shape}')
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f'{name} is empty (shape {arr.shape})')
    _check_values(arr, name, non_negative)
    return arr


def check_pair(top, bottom, shape: tuple = None) -> tuple:
    """Check that top and bottom are valid maps of the same shape (and of ``shape`` if given)."""
    t = check_map(top, 'top')
    b = check_map(bottom, 'bottom')
    if t.shape != b.shape:
        raise ValueError(f'top and bottom shapes differ: {t.shape} vs {b.shape}')
    if shape is not None and tuple(t.shape) != tuple(shape):
        raise ValueError(f'maps have shape {t.shape}, expected {tuple(shape)}')
    return t, b


def check_stack(value, name: str) -> np.ndarray:
    """Check a non-empty N x rows x cols stack of finite, non-negative numeric maps."""
    arr = _as_numeric_array(value, name)
    if arr.ndim != 3:
        raise ValueError(f'{name} must be 3-D (frames x rows x cols), got shape {arr.shape}')
    if min(arr.shape) < 1:
        raise ValueError(f'{name} is empty (shape {arr.shape})')
    _check_values(arr, name, True)
    return arr


def check_number(value, name: str, *, positive: bool = False, non_negative: bool = False,
                 low: float = None, high: float = None) -> float:
    """Check a finite real scalar with optional bounds and return it as float."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f'{name} must be a number, got a bool')
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not math.isfinite(v):
        raise ValueError(f'{name} must be finite, got {v}')
    if positive and v <= 0:
        raise ValueError(f'{name} must be positive, got {v}')
    if non_negative and v < 0:
        raise ValueError(f'{name} must be non-negative, got {v}')
    if low is not None and v < low:
        raise ValueError(f'{name} must be >= {low}, got {v}')
    if high is not None and v > high:
        raise ValueError(f'{name} must be <= {high}, got {v}')
    return v


def check_int(value, name: str, *, low: int = None, high: int = None) -> int:
    """Check an integer (not a bool, not a float) with optional bounds and return it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f'{name} must be an integer, got {value!r}')
    if low is not None and value < low:
        raise ValueError(f'{name} must be >= {low}, got {value}')
    if high is not None and value > high:
        raise ValueError(f'{name} must be <= {high}, got {value}')
    return int(value)
