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

One shared bias the field does see: a time. A faint star's crossings are one level pair
deep, and where pixels lag (a dark sky) their lag is the least known; on a Scorpius EVK4
field on a 20 °/s sinusoid faint stars' rows trailed their stars by 2–4 ms, 3–6 px at the
peak speed (rows no star matched: perf/study_false_rows.py). The bright stars fix R_f, so
a track's rows that trail by L lie −v·L from the field's positions, v their velocity;
where the speed varies (a turn), L is fitted per track (with a constant offset, which d_i
shares) and, where significant, the rows move forward by v·L and the track's direction is
fitted again (the rotations stay the field's: refitted with the moved tracks, they moved
every star by 0.03 px median) before the field's positions are taken. On a pan L is a
constant offset, one with d_i: nothing moves. A lag's error is a fraction of the lag: no
track moves by more than the largest lag the estimator corrected (none where it corrected
none), nor where another track's row lies within NEIGHBOUR_PX in half its frames, nor
where no row would move beyond the field's acceptance.
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
#: a track's rows move by the time they trail the field where it exceeds this many standard
#: errors (_lags)
LAG_SIGNIFICANCE = 3.0
#: ... and only where its speed varies by at least this (weighted RMS, px/µs: 0.2 px/ms
#: moves a row by 0.2 px per ms of lag, a faint row's σ per 2 ms)
MIN_SPEED_SPREAD = 2e-4
#: ... and not where another track's row lies within this (px) in half its frames: a close
#: pair's rows are pulled by the other's events as the motion turns, which looks like a lag
#: (at 5 °/s on a dark-sky EVK4 field, pairs 5-6 px apart showed 0.7-11 ms)
NEIGHBOUR_PX = 8.0


def refine(rows, camera, min_stars, max_lag_us=0.0):
    """Rows (CENTROID_DTYPE, the estimator's) with their tracked stars' positions from the
    field's rotations where those are better determined (see the module doc); a new array.
    max_lag_us: the largest pixel lag the estimator corrected (µs); a track's rows move by
    the time they trail the field only within it (0: none move)."""
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
    v = _velocities(t, xy, ti)
    shift = v * ((np.bincount(fi, t) / np.bincount(fi))[fi] - t)[:, None]
    ray = camera.unproject(xy + shift)
    sig = rows["sigma"][sel] / camera.fx                     # px -> rad (near the axis)
    w = 1.0 / sig ** 2
    stars_in = np.bincount(fi, minlength=len(frames))
    rows_of = np.bincount(ti, minlength=len(tracks))
    good = (stars_in[fi] >= min_stars) & (rows_of[ti] >= MIN_ROWS)
    if np.count_nonzero(good) == 0:
        return out
    R = _chained_start(fi, ti, ray, w, len(frames))
    R, d, pred, z = _fit(R, fi, ti, ray, w, sig, good, len(tracks))
    moved = np.zeros(len(sel), bool)
    if max_lag_us > 0:
        lag = _track_lags(camera, pred, xy + shift, v, fi, ti, xy, w * good,
                          rows["sigma"][sel], max_lag_us, len(tracks))
        moved = lag[ti] != 0
    if moved.any():   # the moved tracks' directions again; the rotations stay the field's
        xy = xy + v * lag[ti][:, None]
        _, d, p2, z2 = _fit(R, fi, ti, camera.unproject(xy + shift), w, sig, good, len(tracks),
                            rotations=False)
        pred[moved], z[moved] = p2[moved], z2[moved]
    agree = good & (pred[:, 2] > 0) & (z <= ACCEPT_SIGMA)
    # a track most of whose rows disagree is no star of the field (a satellite, a lost track):
    # it keeps its rows, unmoved
    rigid = np.bincount(ti, agree, len(tracks)) >= 0.5 * np.bincount(ti, good, len(tracks))
    use = agree & rigid[ti]
    moved &= rigid[ti] & ~use
    out["x"][sel[moved]], out["y"][sel[moved]] = xy[moved, 0], xy[moved, 1]
    uv = camera.project(pred[use]) - shift[use]
    out["x"][sel[use]], out["y"][sel[use]] = uv[:, 0], uv[:, 1]
    return out


def _fit(R, fi, ti, ray, w, sig, good, n_tracks, rotations=True):
    """(R_f, d_i, predicted rays, residuals in σ) after ITERATIONS rounds of the alternating
    Cauchy-weighted fit from rotations R (rotations False: the directions alone, R kept)."""
    wt = w * good
    for _ in range(ITERATIONS):
        d = _directions(R, fi, ti, ray, wt, n_tracks)
        if rotations:
            R = _rotations(fi, ti, ray, d, wt, len(R))
        pred = np.einsum("nij,nj->ni", R.take(fi, 0), d.take(ti, 0))
        z = np.linalg.norm(pred - ray, axis=1) / sig
        wt = good * w / (1.0 + (z / CAUCHY_SIGMA) ** 2)
    return R, d, pred, z


def _track_lags(camera, pred, at, v, fi, ti, xy, w, sigma_px, max_lag_us, n_tracks):
    """Per track, the time (µs) its rows `at` trail the field's rays `pred` (module doc):
    _lags, within max_lag_us, without a close neighbour, and only where some row would
    leave the field's acceptance (within it the field's positions serve, and a small L is
    as much the bright stars' own lag error as this track's); 0 elsewhere."""
    front = pred[:, 2] > 0
    resid = np.zeros_like(at)
    resid[front] = camera.project(pred[front]) - at[front]
    lag = _lags(resid, v, ti, w * front, n_tracks)
    lag[np.abs(lag) > max_lag_us] = 0.0
    if lag.any():
        lag[_crowded(fi, ti, xy, n_tracks)] = 0.0
    far = np.linalg.norm(v, axis=1) * np.abs(lag[ti]) > ACCEPT_SIGMA * sigma_px
    lag[np.bincount(ti, far, n_tracks) == 0] = 0.0
    return lag


def _lags(resid, v, ti, w, n_tracks):
    """Per track, the time L (µs) its rows trail the field's positions, where it exceeds
    LAG_SIGNIFICANCE standard errors (else 0): weighted least squares of the residuals
    (field − row, px) as a + v·L, a constant offset a per track (its direction's share) and
    v its rows' velocities (px/µs). Where a track's speed stays the same (a pan), a and v·L
    are one: L's error is unbounded and nothing moves."""
    sums = lambda q: np.bincount(ti, w * q, n_tracks)
    n, sw = np.bincount(ti, w > 0, n_tracks), sums(np.ones(len(ti)))
    mean = lambda q: np.divide(sums(q), sw, out=np.zeros(n_tracks), where=sw > 0)
    vx, vy = v[:, 0] - mean(v[:, 0])[ti], v[:, 1] - mean(v[:, 1])[ti]
    rx, ry = resid[:, 0] - mean(resid[:, 0])[ti], resid[:, 1] - mean(resid[:, 1])[ti]
    spread = sums(vx * vx + vy * vy)                # the speed's weighted variation
    ok = (spread > MIN_SPEED_SPREAD ** 2 * sw) & (n > MIN_ROWS)
    lag = np.divide(sums(vx * rx + vy * ry), spread, out=np.zeros(n_tracks), where=ok)
    chi2 = sums((rx - vx * lag[ti]) ** 2 + (ry - vy * lag[ti]) ** 2)
    # 2 residuals per row; 3 unknowns per track
    scale = np.divide(chi2, 2 * n - 3, out=np.full(n_tracks, np.inf), where=ok)
    se = np.sqrt(np.divide(scale, spread, out=np.full(n_tracks, np.inf), where=ok))
    return np.where(ok & (np.abs(lag) > LAG_SIGNIFICANCE * se), lag, 0.0)


def _crowded(fi, ti, xy, n_tracks):
    """Per track, does another track's row lie within NEIGHBOUR_PX of its own in at least
    half its frames? (A close pair keeps its separation; a faint star's short second track,
    or its track before and after a gap, shares few frames or none.)"""
    from scipy.spatial import cKDTree

    apart = 4.0 * NEIGHBOUR_PX + np.ptp(xy, axis=0).max(initial=0.0)   # frames never meet
    pairs = cKDTree(np.column_stack([xy, fi * apart])).query_pairs(NEIGHBOUR_PX,
                                                                  output_type="ndarray")
    near = np.zeros(len(ti), bool)
    near[pairs[ti[pairs[:, 0]] != ti[pairs[:, 1]]].reshape(-1)] = True
    return np.bincount(ti, near, n_tracks) >= 0.5 * np.bincount(ti, minlength=n_tracks)


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
    back = np.einsum("nji,nj->ni", R.take(fi, 0), ray)
    s = np.stack([np.bincount(ti, wt * back[:, c], n_tracks) for c in range(3)], axis=1)
    norm = np.linalg.norm(s, axis=1, keepdims=True)
    return np.divide(s, norm, out=np.zeros_like(s), where=norm > 0)


def _rotations(fi, ti, ray, d, wt, n_frames):
    """R_f: Wahba's problem of the frame's rows against their stars' directions."""
    # take: a[index]'s rows at a tenth of its cost on (n, 3) arrays
    outer = wt[:, None, None] * ray[:, :, None] * d.take(ti, 0)[:, None, :]
    return wahba_batch(_per_frame(fi, outer, n_frames))


def _per_frame(fi, outer, n_frames):
    """Sums of 3x3 matrices `outer` (N, 3, 3) per frame index fi."""
    return np.stack([np.bincount(fi, outer[:, a, b], n_frames) for a in range(3)
                     for b in range(3)], axis=1).reshape(n_frames, 3, 3)
