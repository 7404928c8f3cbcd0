"""Constant-acceleration Kalman filter + RTS smoother and its innovation likelihood, batched
over tracks (numpy).

The model the track smoother (:mod:`evstar.smoothing`) fits where a track speeds up or slows
down and no velocity prior says how: state (x, vx, ax, y, vy, ay), per axis
F = [[1, h, h²/2], [0, 1, h], [0, 0, 1]] and white-jerk process noise
q·[[h⁵/20, h⁴/8, h³/6], [h⁴/8, h³/3, h²/2], [h³/6, h²/2, h]] (q px²/s⁵), positions measured
with a 2×2 covariance R — the data of a :class:`evstar.kalman.CVProblem`, its q read as the
jerk density. A steady acceleration costs this model nothing, where the constant-velocity
one bends it straight at a track's ends: a slew's star led by 0.27 px while it sped up from
rest and trailed by as much while it stopped (perf/study_accuracy.py, fresh-40), and the
crossings' speed-change correction, read off that fit, moved them a third of what the
acceleration asks.

The filter's arithmetic is :mod:`evstar.kalman`'s (a diffuse start about the first position,
the Joseph-form update, its RTS smoother); tests hold it against filterpy's.
"""
from __future__ import annotations

import numpy as np

from .kalman import DIFFUSE, _groups, _huber, _padded, _rts

_POS = [0, 3]            # the measured state components
#: jerk densities (px²/s⁵) the likelihood chooses among (decades: half-decades cost twice as
#: much and moved fresh-40's slews by < 0.002 px)
Q_GRID = 10.0 ** np.arange(2.0, 12.5, 1.0)
#: measured steps that only set the start (position, velocity, acceleration): no likelihood
_START_STEPS = 3


def ca_rts(problems):
    """Smoothed (x, vx, y, vy) states (n, 4) and their covariances (n, 4, 4) per problem (a
    list of CVProblem, q the jerk density): the shape evstar.kalman.cv_rts gives."""
    out = [None] * len(problems)
    for group in _groups([len(p.ts) for p in problems]):
        for i, res in zip(group, _ca_rts_batch([problems[i] for i in group])):
            out[i] = res
    return out


def loglik(problems, q_grid=Q_GRID, second=None, first=None):
    """Log-likelihood (len(q_grid),) per problem of its filter's innovations for each jerk
    density of q_grid: the measured steps after the first _START_STEPS, each −½·log det S
    less evstar.kalman's Huber term of its squared Mahalanobis length. second: the second
    axis's density, fixed (the grid then varies the first's alone); first: per problem,
    the first axis's, fixed (the grid varies the second's)."""
    q_grid = np.asarray(q_grid, float)
    out = [None] * len(problems)
    for group in _groups([len(p.ts) * len(q_grid) for p in problems]):
        tiled = [problems[i]._replace(q=(q, second) if second is not None else
                                      (first[i], q) if first is not None else q)
                 for i in group for q in q_grid]
        ll = _forward(*_padded(tiled), _qs(tiled), _firsts(tiled), keep=False)
        for j, i in enumerate(group):
            out[i] = ll[j * len(q_grid):(j + 1) * len(q_grid)]
    return out


def best(problems, q_grid=Q_GRID, second=None, first=None):
    """(q of q_grid with the largest loglik, that log-likelihood) per problem."""
    return [(float(q_grid[int(np.argmax(ll))]), float(np.max(ll)))
            for ll in loglik(problems, q_grid, second, first)]


def _transitions(h, q):
    """F and Q (L, T, 6, 6) of every step; q (L, T, 2): each axis's density."""
    F = np.broadcast_to(np.eye(6), h.shape + (6, 6)).copy()
    Q = np.zeros(h.shape + (6, 6))
    block = np.stack([np.stack([h**5 / 20, h**4 / 8, h**3 / 6], -1),
                      np.stack([h**4 / 8, h**3 / 3, h**2 / 2], -1),
                      np.stack([h**3 / 6, h**2 / 2, h], -1)], -2)
    for axis, i in enumerate(_POS):
        F[..., i, i + 1] = F[..., i + 1, i + 2] = h
        F[..., i, i + 2] = h * h / 2
        Q[..., i:i + 3, i:i + 3] = block * q[..., axis, None, None]
    return F, Q


def _qs(problems):
    """(T, 2) process-noise densities per axis (a problem's q: one for both, or a pair)."""
    return np.array([np.broadcast_to(np.asarray(p.q, float), (2,)) for p in problems])


def _firsts(problems):
    """(T, 2) first measured position of each problem: the diffuse start's centre."""
    return np.array([p.z[0] for p in problems], float)


def _forward(h, meas, z, R, q, first, keep=True):
    """The filter over padded steps: (xf, Pf, xp, Pp, F, Q) when `keep`, else the innovations'
    log-likelihood per track (see loglik)."""
    L, T = h.shape
    F, Q = _transitions(h, np.broadcast_to(q, (L,) + q.shape))
    x = np.zeros((T, 6, 1))
    x[:, _POS, 0] = first                        # a diffuse start about the first position
    P = np.tile(np.eye(6) * DIFFUSE, (T, 1, 1))
    eye = np.tile(np.eye(6), (T, 1, 1))
    stored = [np.empty((L, T, 6, 1)), np.empty((L, T, 6, 6)), np.empty((L, T, 6, 1)),
              np.empty((L, T, 6, 6))] if keep else None
    ll = np.zeros(T)
    seen = np.zeros(T, np.int64)                 # measured steps so far
    for k in range(L):
        xp = F[k] @ x
        Pp = F[k] @ P @ F[k].swapaxes(-1, -2) + Q[k]
        PHT = Pp[:, :, _POS]
        S = PHT[:, _POS] + R[k]
        Si = np.linalg.inv(S)
        y = z[k] - xp[:, _POS]
        m = meas[k]
        if not keep:
            m2 = (y.swapaxes(-1, -2) @ Si @ y)[:, 0, 0]
            term = 0.5 * np.log(np.linalg.det(S)) + _huber(np.maximum(m2, 0.0))
            ll -= np.where(m & (seen >= _START_STEPS), term, 0.0)
            seen += m
        K = (PHT @ Si) * m[:, None, None]       # K = 0 where nothing is measured
        x = xp + K @ y
        I_KH = eye.copy()
        I_KH[:, :, _POS] -= K
        P = I_KH @ Pp @ I_KH.swapaxes(-1, -2) + K @ R[k] @ K.swapaxes(-1, -2)
        if keep:
            for a, v in zip(stored, (x, P, xp, Pp)):
                a[k] = v
    return (*stored, F, Q) if keep else ll


def _ca_rts_batch(problems):
    h, meas, z, R = _padded(problems)
    xf, Pf, xp, Pp, F, Q = _forward(h, meas, z, R, _qs(problems), _firsts(problems))
    xs, Ps = _rts(xf, Pf, xp, Pp, F.swapaxes(-1, -2), Q, [len(p.ts) for p in problems])
    cv = [0, 1, 3, 4]                            # (x, vx, y, vy)
    return [(xs[:len(p.ts), i][:, cv, 0], Ps[:len(p.ts), i][:, cv][:, :, cv])
            for i, p in enumerate(problems)]
