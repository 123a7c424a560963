"""
Linear operators from a fine, supersampled axis to taxel cells: blur, then sum per active pad.

A pressure profile sampled on a fine grid (``sub`` samples a taxel), blurred by a Gaussian and
summed over each taxel's active square is linear and separable, so along each axis it folds
into one small matrix: ``cells = A_y @ fine @ A_x.T``. The simulator renders its presses with
these operators; the estimation's own taxel model renders in the kernel (model_fit.c, bound by
:mod:`taxelmodel`), which tabulates the same operators.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

__all__ = ['cell_weights', 'gather', 'blur', 'blur_block', 'axis_operator']


def cell_weights(sub: int, fill: float) -> np.ndarray:
    """Return the overlap of each of ``sub`` fine samples with the centred active pad."""
    edges = np.arange(sub + 1) / sub
    lo, hi = 0.5 - fill / 2.0, 0.5 + fill / 2.0
    return np.clip(np.minimum(edges[1:], hi) - np.maximum(edges[:-1], lo), 0.0, None) * sub


@lru_cache(maxsize=512)
def gather(cells: int, sub: int, fill: float) -> np.ndarray:
    """Return the (cells x cells*sub) matrix that sums a fine axis over each active cell."""
    out = np.zeros((cells, cells * sub))
    weights = cell_weights(sub, fill)
    for k in range(cells):
        out[k, k * sub:(k + 1) * sub] = weights
    out.flags.writeable = False
    return out


@lru_cache(maxsize=512)
def blur(n: int, blur_px: float) -> np.ndarray:
    """Return the (n x n) Gaussian blur of a fine axis (OpenCV's kernel, zero borders)."""
    size = int(round(blur_px * 4 * 2 + 1)) | 1
    kernel = cv2.getGaussianKernel(size, blur_px, cv2.CV_64F).ravel()
    half = size // 2
    offset = np.arange(n)[None, :] - np.arange(n)[:, None] + half
    inside = (offset >= 0) & (offset < size)
    out = np.where(inside, kernel[np.clip(offset, 0, size - 1)], 0.0)
    out.flags.writeable = False
    return out


def blur_block(out_first: int, out_n: int, in_first: int, in_n: int,
               blur_px: float) -> np.ndarray:
    """
    Return the block of :func:`blur` from fine samples ``in_first``.. to ``out_first``..

    Built on the spot, never cached: a fit that learns the blur asks for a new one every step,
    and the whole matrices of long axes would fill the memory.
    """
    if blur_px <= 0:
        out = np.zeros((out_n, in_n))
        rows = np.arange(in_n) + in_first - out_first
        inside = (rows >= 0) & (rows < out_n)
        out[rows[inside], np.flatnonzero(inside)] = 1.0
        return out
    size = int(round(blur_px * 4 * 2 + 1)) | 1
    kernel = cv2.getGaussianKernel(size, blur_px, cv2.CV_64F).ravel()
    half = size // 2
    offset = ((np.arange(in_n) + in_first)[None, :] - (np.arange(out_n) + out_first)[:, None]
              + half)
    inside = (offset >= 0) & (offset < size)
    return np.where(inside, kernel[np.clip(offset, 0, size - 1)], 0.0)


@lru_cache(maxsize=512)
def axis_operator(cells: int, sub: int, fill: float, blur_px: float) -> np.ndarray:
    """
    Return the (cells x cells*sub) matrix that blurs a fine axis and integrates it per taxel.

    The Gaussian is OpenCV's own kernel (``cv2.getGaussianKernel`` with the size
    ``cv2.GaussianBlur`` picks for float images) with zero borders, so the result equals
    blurring the full image with ``cv2.GaussianBlur(..., borderType=BORDER_CONSTANT)`` and
    summing, at a fraction of the cost.
    """
    sums = gather(cells, sub, fill)
    if blur_px <= 0:
        return sums
    operator = sums @ blur(cells * sub, blur_px)
    operator.flags.writeable = False
    return operator
