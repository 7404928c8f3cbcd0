"""Launch of the Taichi Kalman kernels: evstar.kalman's problems in, its results out."""
import numpy as np

from . import launch
from .kalman import cv_rts as _cv_rts, innovation_loglik as _loglik

#: steps per launch at most (the scratch holds ~500 bytes a step)
MAX_STEPS = 200_000


def cv_rts(ti, problems, diffuse):
    """[(smoothed states (n, 4), covariances (n, 4, 4))] per evstar.kalman.CVProblem."""
    out, batch, steps = [], [], 0
    for p in problems:
        if batch and steps + len(p.ts) > MAX_STEPS:
            out += _cv_rts_batch(ti, batch, diffuse)
            batch, steps = [], 0
        batch.append(p)
        steps += len(p.ts)
    return out + (_cv_rts_batch(ti, batch, diffuse) if batch else [])


def _cv_rts_batch(ti, problems, diffuse):
    start = _starts([len(p.ts) for p in problems])
    n = int(start[-1])
    h = np.zeros(n)
    measured = np.zeros(n, np.int32)
    z, R = np.zeros((n, 2)), np.zeros((n, 2, 2))
    for p, a, b in zip(problems, start[:-1], start[1:]):
        h[a + 1:b] = np.diff(p.ts)
        sel = a + np.flatnonzero(p.measured)
        measured[sel] = 1
        z[sel], R[sel] = p.z, p.R
        z[a] = p.z[0]                        # the start: the first measured position
    q = np.array([p.q for p in problems], np.float64)
    w = np.array([p.w for p in problems], np.float64)
    arrays = launch.Arrays(ti)
    outs = [arrays.empty(shape, np.float64) for shape in ((n, 4), (n, 4, 4)) * 3]
    with launch.RUNTIME_LOCK:
        _cv_rts(*(arrays.put(a) for a in (start, h, measured, z, R, q, w)), float(diffuse), *outs)
    xs, Ps = (np.empty((n, 4)), np.empty((n, 4, 4))) if arrays.on_device else outs[4:]
    if arrays.on_device:
        arrays.get(outs[4], xs)
        arrays.get(outs[5], Ps)
    return [(xs[a:b], Ps[a:b]) for a, b in zip(start[:-1], start[1:])]


def innovation_loglik(ti, tracks, q_grid, v0_var, huber_c, w=0.0):
    """[log-likelihood (len(q_grid),)] per track (ts (n,) s, z (n, 2), σ (n,)), position
    random walk w (px²/s)."""
    if not tracks:
        return []
    start = _starts([len(t[0]) for t in tracks])
    ts = np.concatenate([np.asarray(t[0], np.float64) for t in tracks])
    z = np.concatenate([np.asarray(t[1], np.float64) for t in tracks])
    s2 = np.concatenate([np.asarray(t[2], np.float64) ** 2 for t in tracks])
    grid = np.ascontiguousarray(q_grid, np.float64)
    arrays = launch.Arrays(ti)
    ll = arrays.empty((len(tracks), len(grid)), np.float64)
    with launch.RUNTIME_LOCK:
        _loglik(*(arrays.put(a) for a in (start, ts, z, s2, grid)), float(v0_var),
                float(huber_c), float(w), ll)
    out = np.empty((len(tracks), len(grid)))
    arrays.get(ll, out)
    return list(out)


def _starts(lengths):
    """int32 offsets of concatenated tracks: track i holds steps start[i] .. start[i + 1] − 1."""
    return np.r_[0, np.cumsum(np.asarray(lengths, np.int64))].astype(np.int32)
