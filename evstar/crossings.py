"""When a moving star's centre passes each pixel: level-paired ON/OFF event times.

A star crossing pixel q raises its log intensity to a peak and lowers it again. The pixel
fires ON events as the intensity rises through its reference levels L_top, L_top − C,
L_top − 2C, ... (read backwards from the last ON) and then OFF events as it falls through
L_top − C, L_top − 2C, ... So the j-th OFF after the polarity change and the (j+1)-th ON
before it mark the same level on the two flanks of the pixel's intensity profile, and for a
symmetric PSF moving at constant speed their mean time is the time of the peak — the time
the star's centre was closest to q. Unlike the mean position of events (ON events lead the
centre, OFF events trail it by amounts that depend on the thresholds, the PSF and the pixel's
bandwidth), this needs no model of the sensor: the count imbalance between ON and OFF,
mismatched thresholds or a skipped level shift the pairs, not their midpoints.

A pixel low-pass delays the peak by ~1/(2π f_c), f_c growing with intensity; the number of
level pairs k (∝ the pixel's peak contrast) comes with each crossing, so that delay can be
measured against brightness downstream.
"""
from __future__ import annotations

import numpy as np

CROSSING_DTYPE = np.dtype([("x", "<i4"), ("y", "<i4"), ("t", "<f8"), ("pairs", "<i4"),
                           ("t_spread", "<f8")])


def pixel_crossings(t, x, y, p, max_pairs=16):
    """One row per ON→OFF change of a pixel with at least one level pair: the pixel, the mean
    of its paired midpoint times (µs, float), the number of pairs and their std (µs).

    t, x, y, p: events (any order); p 1 = ON, 0 = OFF.
    """
    t = np.asarray(t, np.int64)
    key = np.asarray(y, np.int64) * (int(np.max(x, initial=0)) + 1) + np.asarray(x, np.int64)
    order = np.lexsort((t, key))
    key, t, pol = key[order], t[order], np.asarray(p)[order] > 0
    n = len(t)
    same = key[1:] == key[:-1]
    # i: last ON before an OFF at the same pixel
    change = np.flatnonzero(same & pol[:-1] & ~pol[1:])
    sums = np.zeros(len(change))
    sq = np.zeros(len(change))
    pairs = np.zeros(len(change), np.int64)
    alive = np.ones(len(change), bool)
    for j in range(1, max_pairs + 1):
        on, off = change - j, change + j
        ok = alive & (on >= 0) & (off < n)
        on_c, off_c = np.clip(on, 0, n - 1), np.clip(off, 0, n - 1)
        ok &= (key[on_c] == key[change]) & (key[off_c] == key[change]) & pol[on_c] & ~pol[off_c]
        alive = ok
        if not ok.any():
            break
        mid = 0.5 * (t[on_c] + t[off_c])
        sums += np.where(ok, mid, 0.0)
        sq += np.where(ok, mid * mid, 0.0)
        pairs += ok
    keep = pairs > 0
    out = np.zeros(int(keep.sum()), CROSSING_DTYPE)
    idx = order[change[keep]]
    out["x"], out["y"] = np.asarray(x)[idx], np.asarray(y)[idx]
    k = pairs[keep]
    mean = sums[keep] / k
    out["t"], out["pairs"] = mean, k
    out["t_spread"] = np.sqrt(np.maximum(sq[keep] / k - mean ** 2, 0.0))
    return out[np.argsort(out["t"], kind="stable")]


def near_pixels(x, y, width, height, radius_px):
    """Bool (height, width): pixels within `radius_px` (square) of any pixel in (x, y) —
    where a star's flank events are, including those a density filter dropped."""
    from scipy import ndimage

    img = np.zeros((height, width), bool)
    img[np.asarray(y, np.int64), np.asarray(x, np.int64)] = True
    r = int(np.ceil(radius_px))
    return ndimage.binary_dilation(img, np.ones((2 * r + 1, 2 * r + 1), bool)) if r else img


def along_track(crossings, tracks, max_offset_px=3.0, min_speed_px_s=1.0):
    """Assign crossings to tracks and project them on each track's motion.

    tracks: rows with t (µs), track, x, y, vx, vy (px, px/s), sorted by track then time (e.g.
    evstar.smoothing's estimates). A crossing belongs to the track whose position at the
    crossing's time is nearest, within `max_offset_px`, while the track moves at least
    `min_speed_px_s` (a star that stands still crosses nothing). Returns (index into
    crossings, track id, unit motion direction (n, 2), along residual px = (pixel − track
    position)·direction) for the assigned crossings.
    """
    t = crossings["t"]
    q = np.column_stack([crossings["x"], crossings["y"]]).astype(np.float64)
    best = np.full(len(t), np.inf)
    owner = np.full(len(t), -1, np.int64)
    u = np.zeros((len(t), 2))
    resid = np.zeros(len(t))
    for tid in np.unique(tracks["track"]):
        tr = tracks[tracks["track"] == tid]
        inside = (t >= tr["t"][0]) & (t <= tr["t"][-1])
        if not inside.any() or len(tr) < 2:
            continue
        ti = t[inside]
        pos = np.column_stack([np.interp(ti, tr["t"], tr["x"]), np.interp(ti, tr["t"], tr["y"])])
        vel = np.column_stack([np.interp(ti, tr["t"], tr["vx"]), np.interp(ti, tr["t"], tr["vy"])])
        speed = np.linalg.norm(vel, axis=1)
        d = q[inside] - pos
        dist = np.linalg.norm(d, axis=1)
        win = (dist < np.minimum(best[inside], max_offset_px)) & (speed >= min_speed_px_s)
        idx = np.flatnonzero(inside)[win]
        best[idx], owner[idx] = dist[win], tid
        u[idx] = vel[win] / speed[win, None]
        resid[idx] = (d[win] * u[idx]).sum(1)
    got = np.flatnonzero(owner >= 0)
    return got, owner[got], u[got], resid[got]
