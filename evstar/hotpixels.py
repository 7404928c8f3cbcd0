"""Hot pixels: pixels that fire alone, far above their neighbours, over a long window.

A hot pixel fires at tens to hundreds of Hz by itself; in a pseudo-frame its events can
form a one-pixel "star" (spread 0). Over a long window (``window_us``, 1 s by default) a
pixel is hot when its count

* is improbable under the local background: P(Poisson(λ) ≥ count) ≤ ``alpha``, with λ the
  mean count of the surrounding 9 × 9 pixels (the pixel itself left out), and
* is at least ``neighbour_ratio`` × the count of its second-brightest 8-neighbour.

A star's pixel fails the second test: the PSF spreads a star over several pixels and a
moving star lights its neighbours in turn (a static star gives no events at all), so at
least two of a star pixel's neighbours (those ahead and behind it on the track, or across
it) have counts of its own order. The second-brightest, not the brightest: hot pixels come
in pairs too, each the other's brightest neighbour (two adjacent pixels at ~100 Hz on a
0.1 Hz sensor made a one-pixel "star" in 4 frames of 100).

The map is running: counts are kept in ``_BINS`` sub-windows, the oldest dropped as time
passes, and the mask is re-derived from the window's total after each update.

A run drops the events of the hot pixels of its calibration window (the first chunk_frames
frames) before extraction, and the tracks that stay still where others move
(still_tracks): a pixel that turns hot later.
"""
from __future__ import annotations

import numpy as np

from .parameters import HOTPIXEL_MAP, HOTPIXELS
from .errors import ParameterError
from evstar_kernels.reference import poisson

_BINS = 4          # sub-windows of the running window: the map forgets in steps of window/4
_BOX = 9           # px side of the background neighbourhood
_PAD = _BOX // 2   # zeros around the count image: every window read fits
_MIN_LAMBDA = 0.1  # counts: the background is never taken as quieter than this
_RING = np.ones((3, 3), bool)
_RING[1, 1] = False


class HotPixelMap:
    """Running hot-pixel map of a width × height sensor: :meth:`update` with events in
    time order, then :attr:`mask` (bool, height × width) or :meth:`is_hot`. The mask is
    derived when read (and cached until the next update), so updating costs a bincount."""

    def __init__(self, width, height, *, window_us=1_000_000, alpha=1e-6, neighbour_ratio=4.0):
        if not (int(width) == width > 0 and int(height) == height > 0):
            raise ParameterError(f"width and height must be positive integers, got {width!r}, {height!r}")
        self.width, self.height = int(width), int(height)
        self.window_us = HOTPIXEL_MAP.check("window_us", window_us)
        self.alpha = HOTPIXELS.check("alpha", alpha)
        self.neighbour_ratio = HOTPIXELS.check("neighbour_ratio", neighbour_ratio)
        self._bins = np.zeros((_BINS, self.height * self.width), np.int32)
        self._total = np.zeros(self.height * self.width, np.int64)
        self._bin_id = None          # index (time // bin length) of the newest bin
        self._mask = None            # cached mask; None when counts changed

    @property
    def counts(self):
        """Events per pixel in the current window (height × width)."""
        return self._total.reshape(self.height, self.width)

    @property
    def mask(self):
        """Bool (height × width): the hot pixels of the current window."""
        if self._mask is None:
            self._mask = hot_pixels(self.counts, self.alpha, self.neighbour_ratio)
        return self._mask

    def update(self, events):
        """Add time-sorted events (evstar.Events or anything with t, x, y arrays); returns self."""
        t = np.asarray(events.t, np.int64)
        if not len(t):
            return self
        ids = t // max(self.window_us // _BINS, 1)
        cuts = np.flatnonzero(np.diff(ids)) + 1
        flat = np.asarray(events.y, np.int64) * self.width + np.asarray(events.x, np.int64)
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(t)]):
            self._advance(int(ids[a]))
            add = np.bincount(flat[a:b], minlength=self.width * self.height)
            self._bins[ids[a] % _BINS] += add.astype(np.int32)
            self._total += add
        self._mask = None
        return self

    def _advance(self, b):
        """Make bin `b` the newest, clearing the bins that fall out of the window."""
        if self._bin_id is not None and b > self._bin_id:
            for k in range(self._bin_id + 1, min(b, self._bin_id + _BINS) + 1):
                self._total -= self._bins[k % _BINS]
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
    counts = np.asarray(counts)
    padded = _padded(counts)
    # the neighbour test first: it leaves a handful of pixels for the costly Poisson tail;
    # none below the count that could pass the tail at the quietest background
    floor = poisson.isf(alpha, _MIN_LAMBDA) + 1          # P(X >= floor) <= alpha
    iy, ix = np.nonzero(_neighbour_candidates(padded, neighbour_ratio) & (counts >= floor))
    near = counts[iy, ix] >= neighbour_ratio * _second_neighbour(padded, iy, ix)
    iy, ix = iy[near], ix[near]
    c = counts[iy, ix].astype(np.float64)
    lam = np.maximum((_box_sums(padded, iy, ix) - c) / (_BOX**2 - 1), _MIN_LAMBDA)
    hot = poisson.sf(c - 1, lam) <= alpha                      # P(X >= count)
    out = np.zeros(counts.shape, bool)
    out[iy[hot], ix[hot]] = True
    return out


def _padded(counts):
    """The count image padded with _PAD zeros on every side (int32), read by the neighbour
    and background tests below: the image is copied once, not once per test."""
    return np.pad(np.asarray(counts, np.int32), _PAD)


def _neighbour_candidates(padded, ratio):
    """Pixels that may pass the neighbour test, by a cheap necessary condition: the 8
    neighbours make 4 opposite pairs, and were both of a pair above count / ratio, the
    second brightest would be too."""
    h, w = padded.shape[0] - 2 * _PAD, padded.shape[1] - 2 * _PAD

    def at(dy, dx):
        return padded[_PAD + dy:_PAD + dy + h, _PAD + dx:_PAD + dx + w]

    pairs = np.minimum(at(0, -1), at(0, 1))
    for (ay, ax) in ((-1, 0), (-1, -1), (-1, 1)):
        np.maximum(pairs, np.minimum(at(ay, ax), at(-ay, -ax)), out=pairs)
    counts = at(0, 0)
    return (counts > 0) & (counts >= ratio * pairs)


def _windows(padded, iy, ix, size):
    """(n, size²) counts of the size × size pixels centred on each (iy, ix), 0 beyond the
    image (the few candidates only)."""
    dy, dx = np.mgrid[0:size, 0:size] + (_PAD - size // 2)
    return padded[iy[:, None] + dy.ravel(), ix[:, None] + dx.ravel()]


def _second_neighbour(padded, iy, ix):
    """The second-brightest 8-neighbour's count of each pixel (iy, ix)."""
    ring = _windows(padded, iy, ix, 3)[:, _RING.ravel()]
    return np.partition(ring, 6, axis=1)[:, 6]


def _box_sums(padded, iy, ix):
    """Counts of the _BOX × _BOX pixels centred on each (iy, ix)."""
    return _windows(padded, iy, ix, _BOX).sum(axis=1).astype(np.float64)


#: a track whose centroids lie within this (px) of their median position ...
STILL_PX = 0.5
#: ... this share of them (a background event that joins a hot pixel's cluster moves its
#: centroid: 1st-99th percentile 39.4-40.3 px on one) ...
STILL_SHARE = 0.8
#: ... for at least this long (µs), at least STILL_MIN_CENTROIDS of them, is a pixel firing
#: by itself: an event camera sees no still star (a star makes events only as its light
#: moves over pixels), and a pixel that turns hot after the calibration window (whose map
#: drops the hot pixels it sees) otherwise made a track of 95-144 rows within 0.2 px
STILL_US = 500_000
STILL_MIN_CENTROIDS = 10
#: ... where another track of the run spans at least this (px): a camera at rest sees only
#: what flickers, and nothing there is judged (a track spanning less is examined: a
#: background event in a hot pixel's cluster moves its centroid by up to ~eps/2)
MOVING_PX = 5.0


def still_tracks(centroids):
    """Ids of the tracks of the linked `centroids` that stay still (STILL_SHARE within
    STILL_PX of their median, over STILL_US or longer) where another track moves
    (MOVING_PX): hot pixels the calibration window's map did not see."""
    tracked = centroids[centroids["track"] >= 0]
    if not len(tracked):
        return np.zeros(0, np.int64)
    tr = tracked[np.argsort(tracked["track"], kind="stable")]
    starts = np.r_[0, np.flatnonzero(np.diff(tr["track"])) + 1]
    ends = np.r_[starts[1:], len(tr)]

    def ptp(v):
        return np.maximum.reduceat(v, starts) - np.minimum.reduceat(v, starts)

    extent = np.maximum(ptp(tr["x"]), ptp(tr["y"]))
    long = (ptp(tr["t"]) >= STILL_US) & (ends - starts >= STILL_MIN_CENTROIDS)
    candidates = np.flatnonzero(long & (extent < MOVING_PX))
    if not len(candidates) or not np.any(extent >= MOVING_PX):
        return np.zeros(0, np.int64)
    still = [i for i in candidates if _still(tr[starts[i]:ends[i]])]
    return tr["track"][starts[still]].astype(np.int64)


def _still(rows):
    """Whether STILL_SHARE of a track's rows lie within STILL_PX of their median position."""
    d = np.hypot(rows["x"] - np.median(rows["x"]), rows["y"] - np.median(rows["y"]))
    return np.mean(d <= STILL_PX) >= STILL_SHARE


def remove_hot_centroids(centroids, hot, max_spread_px=0.5):
    """Copy of `centroids` without those on a hot pixel (`hot`: a HotPixelMap or a bool
    mask) whose spread is at most `max_spread_px` (a star on a hot pixel stays)."""
    max_spread_px = HOTPIXEL_MAP.check("max_spread_px", max_spread_px)
    mask = hot.mask if isinstance(hot, HotPixelMap) else np.asarray(hot, bool)
    h, w = mask.shape
    ix = np.floor(centroids["x"] + 0.5).astype(np.int64)
    iy = np.floor(centroids["y"] + 0.5).astype(np.int64)
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    on_hot = np.zeros(len(centroids), bool)
    on_hot[inside] = mask[iy[inside], ix[inside]]
    return centroids[~(on_hot & (centroids["spread"] <= max_spread_px))]
