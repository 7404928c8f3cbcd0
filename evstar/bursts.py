"""Bursts: a spot of pixels firing at once, as a particle's hit (radiation) makes them, and
a flash of the whole scene.

A star's light moves over the pixels, so the events of its cluster come all through a
frame; a particle that hits the sensor fires a spot of pixels within a fraction of a
millisecond. In a frame such a spot is a cluster of tens of events that DBSCAN reports and
no track takes, and the background test for untracked centroids (its size) passes it: 50
hits of 30 events in 1 s of the paper's scene made 53 false rows. An untracked centroid
whose nearby events in its frame are bunched in time — their interquartile range under
BURST_SHARE of the frame — is dropped; so is a short track most of whose centroids are
(at 200 hits a second the tracker linked hits by chance: 5 tracks, 72 rows).

A flash (a glint, a lamp) fires much of the sensor within a millisecond: its events join
every star's cluster of that frame (three flashes a second took the paper's scene from
0.022 to 0.088 px). A bin of FLASH_US (or a frame's divisor of it) holding events of more
than FLASH_SHARE of the pixels, and FLASH_RATIO times the chunk's median bin, is a flash;
a run treats its events as lost (Pipeline._chunk).
"""
from __future__ import annotations

import numpy as np

#: the events within this (px, each axis) of an untracked centroid's pixel are its own (a
#: hit's spot; the background's events beside it are a few, which the interquartile range
#: ignores)
BURST_PX = 3
#: ... and bunched where their interquartile time range is under this share of the frame (a
#: star's: about half of it, its light passing all through the frame)
BURST_SHARE = 0.1
#: a track of at most this many centroids, more than half of them bunched, is hits linked
#: by chance
SHORT_TRACK = 10


def bunched(rows, near, t0_us, dt_us):
    """Per row of `rows` (untracked centroids, CENTROID_DTYPE): whether the events `near`
    ((t, x, y) in time order, those about the run's frame centroids) within BURST_PX of it
    in its frame span less than BURST_SHARE of the frame between their quartiles."""
    t, x, y = near
    out = np.zeros(len(rows), bool)
    if not len(t):
        return out
    starts = t0_us + rows["frame"] * dt_us
    a, b = np.searchsorted(t, starts), np.searchsorted(t, starts + dt_us)
    for i in range(len(rows)):
        mine = ((np.abs(x[a[i]:b[i]] - np.rint(rows["x"][i])) <= BURST_PX)
                & (np.abs(y[a[i]:b[i]] - np.rint(rows["y"][i])) <= BURST_PX))
        if np.count_nonzero(mine) >= 4:
            q1, q3 = np.percentile(t[a[i]:b[i]][mine], [25, 75])
            out[i] = q3 - q1 < BURST_SHARE * dt_us
    return out


def burst_tracks(centroids, near, t0_us, dt_us):
    """Ids of the tracks of the linked `centroids` with at most SHORT_TRACK centroids, more
    than half of them bunched (`near`, t0_us, dt_us: as bunched takes them)."""
    tracked = centroids[centroids["track"] >= 0]
    ids, counts = np.unique(tracked["track"], return_counts=True)
    short = ids[counts <= SHORT_TRACK]
    if not len(short):
        return short
    rows = tracked[np.isin(tracked["track"], short)]
    hits = np.bincount(np.searchsorted(short, rows["track"]),
                       bunched(rows, near, t0_us, dt_us), len(short))
    return short[hits > counts[counts <= SHORT_TRACK] / 2]


#: a flash: a bin of this many µs (the greatest common divisor with the frame's length, so
#: that bins never straddle a streamed chunk) ...
FLASH_US = 1000
#: ... holding events of more than this share of the sensor's pixels (a 50-star EVK4 field
#: at 1.25 M events/s: 0.14 % a millisecond) ...
FLASH_SHARE = 0.05
#: ... and this many times the median bin of the chunk (a busy sensor's own rate is no flash)
FLASH_RATIO = 10.0


def flashes(t, t0_us, dt_us, n_pixels):
    """Bool per event (`t`: time-sorted µs of a chunk of a run with frame origin t0_us and
    frames of dt_us; n_pixels: the sensor's): in a flash's bin."""
    out = np.zeros(len(t), bool)
    if not len(t):
        return out
    bin_us = int(np.gcd(FLASH_US, int(dt_us)))
    first, last = (int(t[0]) - t0_us) // bin_us, (int(t[-1]) - t0_us) // bin_us
    cuts = np.searchsorted(t, t0_us + np.arange(first, last + 2) * bin_us)
    counts = np.diff(cuts)
    flash = np.flatnonzero((counts > FLASH_SHARE * n_pixels)
                           & (counts > FLASH_RATIO * max(np.median(counts), 1.0)))
    for k in flash:
        out[cuts[k]:cuts[k + 1]] = True
    return out
