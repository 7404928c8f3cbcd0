"""Rigid-field refinement: every star's image moves with the one camera rotation.

Stars are at infinity, so a star i seen in frame f lies at π(R_f d_i): one direction d_i per
star and one rotation R_f per frame, shared by all stars. A track's smoothed positions
(evstar.estimation) carry errors that wander along the track (a faint star's few events per
frame); with several stars in view the field fixes R_f far better than one star can, and a
star's own rows then only have to fix d_i — every row of the track averages into it.

The fit alternates the two weighted least-squares problems (Wahba's for each R_f, a mean of
back-rotated rays for each d_i) with Cauchy weights, so a track that lost its star, or a
target that is no star, pulls little. A row takes the field's position only in a frame with
at least `min_stars` tracked stars, and only where that position lies within ACCEPT_SIGMA
x the row's own σ (otherwise the row is not this rigid star: a blend, a satellite). Its σ
stays: averaging removes the wander, not the bias a track's rows share (a lobe's, a lag's,
the pixels' threshold mismatch across the motion); on crowded fields the errors shrank by
20–40 % where a σ from the averaging alone would have shrunk 2–4×.
"""
from __future__ import annotations

import numpy as np

#: rounds of the alternating fit (from the chained start, 5 left positions within 0.003 px
#: median of their limit on a crowded sinusoid, 10 within 0.0001 px)
ITERATIONS = 8
#: scale (in σ) of the Cauchy weights of a row's residual
CAUCHY_SIGMA = 3.0
#: fewest rows of a track for the field to refine it (a shorter one gains little)
MIN_ROWS = 5
#: a row keeps its own position where the field's lies farther than this x its σ (on crowded
#: fields, without this test blends' and lost tracks' rows moved by px; 3 and 4 alike)
ACCEPT_SIGMA = 4.0


def refine(rows, camera, min_stars):
    """Rows (CENTROID_DTYPE, the estimator's) with their tracked stars' positions from the
    field's rotations where those are better determined (see the module doc); a new array."""
    sel = np.flatnonzero((rows["track"] >= 0) & (rows["sigma"] > 0) & np.isfinite(rows["sigma"]))
    out = rows.copy()
    if len(sel) == 0:
        return out
    frames, fi = np.unique(rows["frame"][sel], return_inverse=True)
    tracks, ti = np.unique(rows["track"][sel], return_inverse=True)
    t = rows["t"][sel].astype(np.float64)
    xy = np.stack([rows["x"][sel], rows["y"][sel]], axis=1)
    # rows of a frame refer to their own times (their events' mean): move each to the
    # frame's mean time along its track, so that one rotation holds for the frame's rows
    shift = _velocities(t, xy, ti) * ((np.bincount(fi, t) / np.bincount(fi))[fi] - t)[:, None]
    ray = camera.unproject(xy + shift)
    sig = rows["sigma"][sel] / camera.fx                     # px -> rad (near the axis)
    w = 1.0 / sig ** 2
    stars_in = np.bincount(fi, minlength=len(frames))
    rows_of = np.bincount(ti, minlength=len(tracks))
    good = (stars_in[fi] >= min_stars) & (rows_of[ti] >= MIN_ROWS)
    if np.count_nonzero(good) == 0:
        return out
    R = _chained_start(fi, ti, ray, w, len(frames))
    wt = w * good
    for _ in range(ITERATIONS):
        d = _directions(R, fi, ti, ray, wt, len(tracks))
        R = _rotations(fi, ti, ray, d, wt, len(frames))
        pred = np.einsum("nij,nj->ni", R[fi], d[ti])
        z = np.linalg.norm(pred - ray, axis=1) / sig
        wt = good * w / (1.0 + (z / CAUCHY_SIGMA) ** 2)
    agree = good & (pred[:, 2] > 0) & (z <= ACCEPT_SIGMA)
    # a track most of whose rows disagree is no star of the field (a satellite, a lost track)
    rigid = np.bincount(ti, agree, len(tracks)) >= 0.5 * np.bincount(ti, good, len(tracks))
    use = agree & rigid[ti]
    uv = camera.project(pred[use]) - shift[use]
    out["x"][sel[use]], out["y"][sel[use]] = uv[:, 0], uv[:, 1]
    return out


def wahba_batch(B):
    """Rotations R_f maximising tr(R_fᵀ B_f) for a stack of 3x3 matrices B (SVD)."""
    U, _, Vt = np.linalg.svd(B)
    U = U.copy()
    U[:, :, 2] *= np.sign(np.linalg.det(U) * np.linalg.det(Vt))[:, None]
    return U @ Vt


def _velocities(t, xy, ti):
    """Per row, its track's velocity (px/µs): the mean of the slopes to its track's previous
    and next rows (one of them at a track's ends; 0 for a track of one row)."""
    o = np.lexsort((t, ti))
    dt = np.diff(t[o])
    same = (np.diff(ti[o]) == 0) & (dt > 0)
    slope = np.diff(xy[o], axis=0) / np.where(same, dt, 1.0)[:, None] * same[:, None]
    edge = np.zeros((1, 2))
    total = np.vstack([edge, slope]) + np.vstack([slope, edge])
    count = np.concatenate([[0], same]) + np.concatenate([same, [0]])
    v = np.empty_like(xy)
    v[o] = total / np.maximum(count, 1)[:, None]
    return v


def _chained_start(fi, ti, ray, w, n_frames):
    """R_f chained frame to frame: each frame's rotation from the previous one's rows of the
    same tracks (Wahba's problem of the pairs), R_0 = I (the gauge: any common rotation)."""
    o = np.lexsort((fi, ti))
    a, b = o[:-1], o[1:]
    pair = (ti[a] == ti[b]) & (fi[b] == fi[a] + 1)
    a, b = a[pair], b[pair]
    wab = w[a] * w[b] / (w[a] + w[b])
    outer = wab[:, None, None] * ray[b][:, :, None] * ray[a][:, None, :]
    step = wahba_batch(_per_frame(fi[b], outer, n_frames))
    step[np.bincount(fi[b], minlength=n_frames) < 2] = np.eye(3)
    R = np.empty((n_frames, 3, 3))
    R[0] = np.eye(3)
    for f in range(1, n_frames):
        R[f] = step[f] @ R[f - 1]
    return R


def _directions(R, fi, ti, ray, wt, n_tracks):
    """d_i: the weighted mean of its rows' rays with their frames' rotations undone."""
    back = np.einsum("nji,nj->ni", R[fi], ray)
    s = np.stack([np.bincount(ti, wt * back[:, c], n_tracks) for c in range(3)], axis=1)
    norm = np.linalg.norm(s, axis=1, keepdims=True)
    return np.divide(s, norm, out=np.zeros_like(s), where=norm > 0)


def _rotations(fi, ti, ray, d, wt, n_frames):
    """R_f: Wahba's problem of the frame's rows against their stars' directions."""
    return wahba_batch(_per_frame(fi, wt[:, None, None] * ray[:, :, None] * d[ti][:, None, :],
                                  n_frames))


def _per_frame(fi, outer, n_frames):
    """Sums of 3x3 matrices `outer` (N, 3, 3) per frame index fi."""
    return np.stack([np.bincount(fi, outer[:, a, b], n_frames) for a in range(3)
                     for b in range(3)], axis=1).reshape(n_frames, 3, 3)
