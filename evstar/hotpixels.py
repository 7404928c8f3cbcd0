"""Hot pixels: pixels that fire alone, far above their neighbours, over a long window.

A hot pixel fires at tens to hundreds of Hz by itself; in a pseudo-frame its events can
form a one-pixel "star" (spread 0). Over a long window (``window_us``, 1 s by default) a
pixel is hot when its count

* is improbable under the local background: P(Poisson(λ) ≥ count) ≤ ``alpha``, with λ the
  mean count of the surrounding 9 × 9 pixels (the pixel itself left out), and
* is at least ``neighbour_ratio`` × the count of its brightest 8-neighbour.

A star's pixel fails the second test: the PSF spreads a star over several pixels and a
moving star lights its neighbours in turn (a static star gives no events at all), so a
star pixel's brightest neighbour has a count of its own order.

The map is running: counts are kept in ``_BINS`` sub-windows, the oldest dropped as time
passes, and the mask is re-derived from the window's total after each update.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage, stats

from .parameters import HOTPIXELS

_BINS = 4          # sub-windows of the running window: the map forgets in steps of window/4
_BOX = 9           # px side of the background neighbourhood
_MIN_LAMBDA = 0.1  # counts: the background is never taken as quieter than this
_RING = np.ones((3, 3), bool)
_RING[1, 1] = False


class HotPixelMap:
    """Running hot-pixel map of a width × height sensor: :meth:`update` with events in
    time order, then :attr:`mask` (bool, height × width) or :meth:`is_hot`."""

    def __init__(self, width, height, *, window_us=1_000_000, alpha=1e-6, neighbour_ratio=4.0):
        if not (int(width) == width > 0 and int(height) == height > 0):
            raise ValueError(f"width and height must be positive integers, got {width!r}, {height!r}")
        self.width, self.height = int(width), int(height)
        self.window_us = HOTPIXELS.check("window_us", window_us)
        self.alpha = HOTPIXELS.check("alpha", alpha)
        self.neighbour_ratio = HOTPIXELS.check("neighbour_ratio", neighbour_ratio)
        self._bins = np.zeros((_BINS, self.height, self.width), np.int64)
        self._bin_id = None          # index (time // bin length) of the newest bin
        self.mask = np.zeros((self.height, self.width), bool)

    @property
    def counts(self):
        """Events per pixel in the current window (height × width)."""
        return self._bins.sum(0)

    def update(self, events):
        """Add time-sorted events (evstar.Events or anything with t, x, y arrays); returns
        the updated mask."""
        t = np.asarray(events.t, np.int64)
        if len(t):
            bin_len = max(self.window_us // _BINS, 1)
            ids = t // bin_len
            for b in np.unique(ids):
                sel = ids == b
                self._advance(int(b))
                flat = np.asarray(events.y)[sel].astype(np.int64) * self.width \
                    + np.asarray(events.x)[sel]
                self._bins[b % _BINS] += np.bincount(flat, minlength=self.width * self.height) \
                    .reshape(self.height, self.width)
            self.mask = hot_pixels(self.counts, self.alpha, self.neighbour_ratio)
        return self.mask

    def _advance(self, b):
        """Make bin `b` the newest, clearing the bins that fall out of the window."""
        if self._bin_id is not None and b > self._bin_id:
            if b - self._bin_id >= _BINS:
                self._bins[:] = 0
            else:
                for k in range(self._bin_id + 1, b + 1):
                    self._bins[k % _BINS] = 0
        if self._bin_id is None or b > self._bin_id:
            self._bin_id = b

    def is_hot(self, x, y):
        """Whether the pixels nearest to (x, y) are hot (bool array; False off the sensor)."""
        ix = np.floor(np.asarray(x, float) + 0.5).astype(np.int64)
        iy = np.floor(np.asarray(y, float) + 0.5).astype(np.int64)
        inside = (ix >= 0) & (ix < self.width) & (iy >= 0) & (iy < self.height)
        out = np.zeros(np.shape(ix), bool)
        out[inside] = self.mask[iy[inside], ix[inside]]
        return out

    @property
    def pixels(self):
        """Hot pixel indices y·width + x (as evstar.sim's truth.hot_pixels), sorted."""
        return np.flatnonzero(self.mask.ravel())


def hot_pixels(counts, alpha=1e-6, neighbour_ratio=4.0):
    """Bool mask of the hot pixels of a count image (see the module docstring)."""
    counts = np.asarray(counts, np.float64)
    box = ndimage.uniform_filter(counts, _BOX, mode="constant") * _BOX**2
    lam = np.maximum((box - counts) / (_BOX**2 - 1), _MIN_LAMBDA)
    improbable = stats.poisson.sf(counts - 1, lam) <= alpha      # P(X >= count)
    brightest = ndimage.maximum_filter(counts, footprint=_RING, mode="constant")
    return improbable & (counts >= neighbour_ratio * brightest) & (counts > 0)


def remove_hot_centroids(centroids, hot, max_spread_px=0.5):
    """Copy of `centroids` without those on a hot pixel (`hot`: a HotPixelMap or a bool
    mask) whose spread is at most `max_spread_px` (a star on a hot pixel stays)."""
    max_spread_px = HOTPIXELS.check("max_spread_px", max_spread_px)
    mask = hot.mask if isinstance(hot, HotPixelMap) else np.asarray(hot, bool)
    h, w = mask.shape
    ix = np.floor(centroids["x"] + 0.5).astype(np.int64)
    iy = np.floor(centroids["y"] + 0.5).astype(np.int64)
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    on_hot = np.zeros(len(centroids), bool)
    on_hot[inside] = mask[iy[inside], ix[inside]]
    return centroids[~(on_hot & (centroids["spread"] <= max_spread_px))]
