"""Which track each pixel crossing belongs to.

A crossing (evstar.crossings) is its nearest track's where it lies within REACH_PX of that
track's position at its time. The tracks assigned to are smoothed frame centroids, and
behind a pixel low-pass a centroid and a crossing of one star are late by different times:
the centroid averages every event, the OFF ones of a slow photoreceptor's long relaxation
included, the crossing pairs each level's rise and fall. At a fast star's speed the
difference leaves its crossings outside the reach (EVK4 16 mm, a 10°/1 Hz sinusoid on a
30 Hz dark sky: centroids 2.2 ms behind the crossings, 6 px at its 2700 px/s peak, where a
third of its frames then had no crossing and trailed by 2.5 px). Such a track — one that
trails its crossings: a bright star's OFF events pull its centroids back — is moved in time
by that difference, the median over its crossings within a wide reach of how long it takes
to reach them, before the crossings are assigned.
"""
from __future__ import annotations

import numpy as np

from .crossings import near_tracks, within
from .frames import groups
from .smoothing import _speed_at

#: a crossing is a track's within this (px) of its position at the crossing's time
REACH_PX = 3.0
#: the most a track's centroids may be late or early against its crossings (µs): a 16 Hz
#: photoreceptor's time constant
MAX_SHIFT_US = 10_000.0
#: crossings that measure a track's shift lie this near (px) its path across the motion ...
SHIFT_ACROSS_PX = 1.5
#: ... where it moves at least this fast (px/s: slower, a px of noise is many ms)
SHIFT_MIN_SPEED_PX_S = 50.0
#: ... and a track needs this many of them
SHIFT_MIN_CROSSINGS = 30


def assign(crossings, tracks, shift=None):
    """(within's assignment of `crossings` to `tracks` (rows t, track, x, y, vx, vy, sorted
    by track, then time) within REACH_PX, each track that trails its crossings by more than
    that at its top speed moved in time onto them first; the ids of the tracks moved).
    shift: track_shifts(crossings, tracks) where the caller has it."""
    if shift is None:
        shift = track_shifts(crossings, tracks)
    moved = tracks.copy()
    dt = np.zeros(len(tracks))
    for tid, rows in zip(*groups(tracks["track"])):
        dt[rows] = shift.get(int(tid), 0.0)
    moved["t"] = tracks["t"] - np.round(dt).astype(tracks["t"].dtype)
    return (within(near_tracks(crossings, moved, REACH_PX), REACH_PX),
            np.array(sorted(shift), np.int64))


def track_shifts(crossings, tracks):
    """{track id: µs} for the tracks that trail their crossings by more than REACH_PX along
    the motion at the track's top speed: how much later than a crossing the track reaches
    its pixel, the median over its crossings within SHIFT_ACROSS_PX of its path and
    MAX_SHIFT_US of it. Not where the track leads them: a faint star's crossings lag more
    than its events, and the crossings a move brings in are the most lagged ones, whose lag
    the profiles under-correct and the run's own fit, which bright crossings dominate, does
    not hold either (held-out Carina EVK4 16 mm dark-sky 25 °/s sinusoid with the IMU:
    isolated stars' median 0.27 -> 0.36 px when moved both ways)."""
    if not len(tracks) or not len(crossings):
        return {}
    speed = np.hypot(tracks["vx"], tracks["vy"])
    wide = REACH_PX + float(speed.max()) * MAX_SHIFT_US * 1e-6
    ci, tid, dx, dy, ux, uy = near_tracks(crossings, tracks, wide)
    along, across = dx * ux + dy * uy, dy * ux - dx * uy
    t = crossings["t"][ci]
    mine = dict(zip(*groups(tid)))
    out = {}
    for track, rows in zip(*groups(tracks["track"])):
        m = mine.get(track, np.zeros(0, np.int64))
        r = tracks[rows]
        s = _speed_at(r, t[m])
        late = along[m] / np.maximum(s, SHIFT_MIN_SPEED_PX_S) * 1e6
        ok = ((np.abs(across[m]) < SHIFT_ACROSS_PX) & (s >= SHIFT_MIN_SPEED_PX_S)
              & (np.abs(late) <= MAX_SHIFT_US))
        if ok.sum() < SHIFT_MIN_CROSSINGS:
            continue
        shift = float(np.median(late[ok]))
        if shift * 1e-6 * speed[rows].max() > REACH_PX:
            out[int(track)] = shift
    return out
