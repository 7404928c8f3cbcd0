"""Star point-spread function: a Gaussian integrated over each pixel's square.

Pixel i covers [i - 0.5, i + 0.5) (docs/design.md), so the fraction of a star's flux that lands
on pixel (i, j) is the product of two 1-D erf differences — separable, which lets the
simulator build a window from 2·(W + 1) erf calls instead of W² integrals.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr

#: largest window half-width the simulator will render (pixels)
MAX_HALF_WIDTH = 24


def pixel_profile(center, first, n, sigma_px):
    """1-D pixel-integrated Gaussian: fraction of flux on pixels first .. first + n - 1.

    center, first: arrays of the same shape S; returns shape S + (n,).
    """
    edges = np.asarray(first, np.float64)[..., None] + (np.arange(n + 1) - 0.5)
    cdf = ndtr((edges - np.asarray(center, np.float64)[..., None]) / sigma_px)
    return np.diff(cdf, axis=-1)


def window_half_width(flux, sigma_px, min_log_change):
    """Smallest half-width h such that every pixel outside the (2h+1)² window around the
    star's nearest pixel changes its log intensity by less than `min_log_change`.

    flux is in units of the per-pixel background; a pixel outside the window is at least
    h + 0.5 px from the star along one axis and gets at most the peak fraction along the other.
    """
    core = float(pixel_profile(0.0, 0.0, 1, sigma_px)[0])
    limit = math.expm1(min_log_change)
    for h in range(MAX_HALF_WIDTH + 1):
        # worst case: star 0.5 px off its nearest pixel, towards the first pixel left out
        edge = float(pixel_profile(0.5, h + 1, 1, sigma_px)[0]) * core
        if flux * edge < limit:
            return h
    return MAX_HALF_WIDTH
