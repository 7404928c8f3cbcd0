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
    arrays = launch.Arrays(ti)
    lengths = np.array([len(p.ts) for p in problems], np.int64)
    slot, n_slots = _slots(ti, lengths, arrays.on_device)
    sizes = np.ones(n_slots, np.int64)            # an idle slot: one unmeasured step
    sizes[slot] = lengths
    start = _starts(sizes)
    n, first = int(start[-1]), start[slot]         # rows; each problem's first
    inputs = _steps(problems, first, lengths, n)
    q, w = np.zeros(n_slots), np.zeros(n_slots)
    q[slot], w[slot] = [p.q for p in problems], [p.w for p in problems]
    outs = [arrays.empty(shape, np.float64) for shape in ((n, 4), (n, 4, 4)) * 3]
    with launch.RUNTIME_LOCK:
        _cv_rts(*(arrays.put(a) for a in (start, *inputs, q, w)), float(diffuse), *outs)
    xs, Ps = (np.empty((n, 4)), np.empty((n, 4, 4))) if arrays.on_device else outs[4:]
    if arrays.on_device:
        arrays.get(outs[4], xs)
        arrays.get(outs[5], Ps)
    return [(xs[a:a + m], Ps[a:a + m]) for a, m in zip(first, lengths)]


def _slots(ti, lengths, on_device):
    """(each problem's slot (track index) in the kernel's loop, slots). Taichi gives a CPU
    thread blocks of >= 512 iterations of a loop: over the few dozen tracks alone it ran on
    one thread. So on the CPU each thread's block of 512 slots gets every thread-th problem
    by length, the longest first (balanced), the other slots idle tracks of one step; the
    kernel as it is, so its results keep their bits. On a device, or with more problems
    than that, the problems themselves."""
    n, threads = len(lengths), launch.cpu_threads(ti)
    if on_device or n > 512 * threads:
        return np.arange(n), n
    rank = np.arange(n)
    slot = np.empty(n, np.int64)
    slot[np.argsort(-lengths, kind="stable")] = (rank % threads) * 512 + rank // threads
    return slot, 512 * threads


def _steps(problems, first, lengths, n):
    """(h, measured, z, R) of n rows, each problem's steps from its row `first` on (the
    others zeros), in one assignment per array (a loop over the problems took ~3 ms a
    launch)."""
    rows = np.arange(lengths.sum()) + np.repeat(first - (np.cumsum(lengths) - lengths), lengths)
    ts = np.concatenate([p.ts for p in problems])
    step = np.zeros(len(ts))
    step[1:] = ts[1:] - ts[:-1]                   # np.diff's bits; 0 at each track's start
    step[np.cumsum(lengths) - lengths] = 0.0
    h = np.zeros(n)
    h[rows] = step
    at = rows[np.concatenate([np.asarray(p.measured, bool) for p in problems])]
    measured = np.zeros(n, np.int32)
    measured[at] = 1
    z, R = np.zeros((n, 2)), np.zeros((n, 2, 2))
    z[at] = np.concatenate([p.z for p in problems])
    R[at] = np.concatenate([p.R for p in problems])
    z[first] = [p.z[0] for p in problems]         # the start: the first measured position
    return h, measured, z, R


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
