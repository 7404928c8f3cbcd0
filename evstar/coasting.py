"""Positions a gyro carries beyond a track's ends, and how sure they are.

Before a track's first centroid and after its last, a gyro prior carries the star
(estimate.coast_gyro_ms): a star speeding up from rest fires no events at first, and its
track starts 20–150 ms late. The track's fits (crossings, lags, blends) keep coast_ms:
rows beyond it would draw crossings a slow turn distorts into them (a 0.3 Hz dark-sky
sinusoid's measured rows went 0.026 -> 0.040 px when the smoother itself coasted 500 ms).
Instead a plain smoothing of the track's centroids with the gyro coasts its ends that far,
and each of those predictions moves from the fitted end by what that smoothing moves from
the same time (extended), its variance grown by as much.

The smoother's σ there holds the gyro's white noise (its random walk) and the fitted
velocity's error only, not what a gyro's scale factor and axes get wrong, which grows with
how far the gyro moved the star: a MEMS gyro's scale factor is known to 0.1–1 % and its
axes to a fraction of a degree (1 % of the turn across them). Each coasted row beyond a
track's ends holds GYRO_SCALE_SHARE of the gyro's displacement since its track's nearest
other row (gyro_widened).
"""
from __future__ import annotations

import numpy as np

#: share of the gyro's displacement (px) since a track's end that a coasted row may be off
GYRO_SCALE_SHARE = 0.01
#: a track's end this near the sensor's edge (px) is its star leaving the view: not carried
EDGE_PX = 3.0


def open_ends(est, tracks, frames, sensor, margin_px):
    """Those of `tracks` with an end in `est` (ESTIMATE_DTYPE) the gyro could carry further:
    a first row after the recording's first frame or a last before its last (`frames`:
    those two), at least `margin_px` inside the sensor (`sensor`: (width, height); None:
    anywhere). An end at the edge is a star leaving the view."""
    mine = est[np.isin(est["track"], tracks)]
    if not len(mine):
        return []
    mine = mine[np.lexsort((mine["t"], mine["track"]))]
    ids, first = np.unique(mine["track"], return_index=True)
    last = np.r_[first[1:], len(mine)] - 1
    x, y = mine["x"], mine["y"]
    inside = np.ones(len(mine), bool) if sensor is None else (
        (x >= margin_px) & (x <= sensor[0] - 1 - margin_px)
        & (y >= margin_px) & (y <= sensor[1] - 1 - margin_px))
    open_ = ((mine["frame"][first] > frames[0]) & inside[first]) | \
            ((mine["frame"][last] < frames[1]) & inside[last])
    return [int(t) for t in ids[open_]]


def extended(est, coasted, tracks, apart_px):
    """`est` (ESTIMATE_DTYPE, the fitted rows) with, for each of `tracks`, the rows of
    `coasted` (a plain smoothing of its centroids whose ends reach farther) in frames before
    its first and after its last row in `est`, each moved by the difference between the two
    at that end; their variance grows by what `coasted`'s does from there. None lies within
    `apart_px` of another track's row of its frame: a prediction never stands in for a row
    the data gave (a star whose track broke at a slow turn has one on either side). Sorted
    by track, then time."""
    extra = []
    for track in tracks:
        mine, far = est[est["track"] == track], coasted[coasted["track"] == track]
        if not len(mine) or not len(far):
            continue
        mine = mine[np.argsort(mine["t"], kind="stable")]
        far = far[np.argsort(far["t"], kind="stable")]
        for end, beyond in ((mine[0], far["frame"] < mine["frame"][0]),
                            (mine[-1], far["frame"] > mine["frame"][-1])):
            if beyond.any():
                extra.append(_moved(far[beyond], end, far))
    if not extra:
        return est
    extra = np.concatenate(extra)
    extra = extra[~_beside_others(extra, est, apart_px)]
    out = np.concatenate([est, extra])
    return out[np.lexsort((out["t"], out["track"]))]


def _beside_others(rows, est, apart_px):
    """Per row: does a row of another track in `est` lie within apart_px of it in its frame?"""
    from scipy.spatial import cKDTree

    if not len(rows) or not len(est):
        return np.zeros(len(rows), bool)
    # frames set 10 x apart_px apart: a neighbour is one of the same frame
    at = lambda r: np.column_stack([r["frame"] * (10.0 * apart_px), r["x"], r["y"]])  # noqa: E731
    near = cKDTree(at(est)).query_ball_point(at(rows), apart_px)
    return np.array([any(est["track"][j] != tr for j in js) for js, tr in zip(near, rows["track"])],
                    bool)


def _moved(rows, end, far):
    """`rows` of `far` moved by `end`'s position less `far`'s at its time; their variances
    by `end`'s less `far`'s there."""
    t = float(end["t"])
    ts = far["t"].astype(np.float64)
    out = rows.copy()
    for p, s in (("x", "sigma_x"), ("y", "sigma_y")):
        out[p] += end[p] - np.interp(t, ts, far[p])
        grown = rows[s] ** 2 - np.interp(t, ts, far[s]) ** 2
        out[s] = np.sqrt(end[s] ** 2 + np.maximum(grown, 0.0))
    out["centroid"], out["coasted"], out["outlier"] = -1, True, False
    out["source"] = "coasted"
    return out


def gyro_widened(rows, prior):
    """`rows` (CENTROID_DTYPE) with the σ of each track's coasted rows before its first and
    after its last other row widened by GYRO_SCALE_SHARE x the displacement `prior` (a
    velocity prior: the gyro's) gives the star from that row; a new array."""
    from .frames import groups
    from .smoothing import prior_displacements

    out = rows.copy()
    tracked = np.flatnonzero(rows["track"] >= 0)
    if prior is None or not len(tracked):
        return out
    order = tracked[np.lexsort((rows["t"][tracked], rows["track"][tracked]))]
    runs, ends = [], []
    for _, sel in zip(*groups(rows["track"][order])):
        idx = order[sel]
        seen = np.flatnonzero(rows["source"][idx] != "coasted")
        if not len(seen) or (seen[0] == 0 and seen[-1] == len(idx) - 1):
            continue
        t = rows["t"][idx].astype(np.float64)
        z = np.column_stack([rows["x"][idx], rows["y"][idx]]).astype(np.float64)
        runs.append((t, t[seen], z[seen]))
        ends.append((idx, seen[0], seen[-1]))
    for (idx, first, last), d in zip(ends, prior_displacements(prior, runs)):
        k = np.arange(len(idx))
        anchor = np.where(k < first, first, np.where(k > last, last, k))
        moved = np.hypot(*(d - d[anchor]).T)
        # an error along the gyro's motion adds half its variance to each axis's σ
        out["sigma"][idx] = np.sqrt(rows["sigma"][idx] ** 2 + (GYRO_SCALE_SHARE * moved) ** 2 / 2)
    return out
