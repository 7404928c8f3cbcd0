"""Constant-velocity Kalman filter + RTS smoother and its innovation likelihood, batched
over tracks.

The model of :mod:`evstar.smoothing`: state (x, vx, y, vy), per axis F = [[1, h], [0, 1]]
and white-acceleration process noise q·[[h³/3, h²/2], [h²/2, h]] plus a position random walk
w·h on the position (w px²/s: the noise a velocity prior's integrated displacement carries, a
gyro's white noise; 0 without a prior), positions measured with
a 2×2 covariance R (full: along-track crossings couple the axes). filterpy's
``batch_filter`` + ``rts_smoother`` run it one measurement at a time in Python (~80 µs a
step); here every step is a handful of numpy operations on all tracks at once, and the
smoother's gains are computed for all steps in one call. The filter's arithmetic is
filterpy's (Joseph-form update, the same diffuse start, the same matrix products and
inverses), so states agree with :func:`cv_rts_filterpy` to the last bit or nearly; the
smoother's covariances come in a Joseph-like form (_rts) that stays positive where
filterpy's difference loses every digit (tests: against 60-digit arithmetic).

Tracks of different lengths are padded at the end with steps of length 0 and no
measurement, which leave a filter's state and covariance bit-for-bit unchanged and so
do not alter what the smoother reads.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

DIFFUSE = 1e8            # px², (px/s)²: the filter's prior knows nothing
V0_VAR = 1e8             # (px/s)²: the likelihood's first velocity is unknown
HUBER_C = 3.0            # σ: innovations beyond it count linearly in the likelihood
_MAX_CELLS = 100_000     # tracks × steps per batch (bounds memory: ~1.3 KiB a cell)
_POS = [0, 2]            # the measured state components


class CVProblem(NamedTuple):
    """One track: step times ts (s, non-decreasing, n), which steps are measured (n bool),
    the measured steps' positions z (m, 2) and covariances R (m, 2, 2), q (px²/s³) and the
    position's random-walk density w (px²/s)."""
    ts: np.ndarray
    measured: np.ndarray
    z: np.ndarray
    R: np.ndarray
    q: float
    w: float = 0.0


def diagonal_covariances(sigma):
    """(m, 2, 2) covariances σ²·I of per-axis σ (m,)."""
    return np.asarray(sigma, float)[:, None, None] ** 2 * np.eye(2)


def cv_rts(problems):
    """Smoothed states (n, 4) and covariances (n, 4, 4) per problem (a list of CVProblem)."""
    out = [None] * len(problems)
    for group in _groups([len(p.ts) for p in problems]):
        for i, res in zip(group, _cv_rts_batch([problems[i] for i in group])):
            out[i] = res
    return out


def cv_rts_taichi(problems):
    """:func:`cv_rts` as a Taichi kernel, a thread per track (evstar_kernels.taichi.kalman;
    this module is its specification), on the arch Taichi runs on in this process."""
    from evstar_kernels.taichi import kalman_launch

    from .backends import taichi_running

    return kalman_launch.cv_rts(taichi_running(), problems, DIFFUSE)


def cv_rts_filterpy(problems):
    """The reference: :func:`cv_rts` through filterpy, one problem and step at a time."""
    return [_filterpy_one(p) for p in problems]


def _groups(lengths):
    """Indices batched together: similar lengths (little padding), bounded cells."""
    order = np.argsort(lengths, kind="stable")[::-1]
    groups, cur = [], []
    for i in order:
        if cur and (len(cur) + 1) * lengths[cur[0]] > _MAX_CELLS:
            groups.append(cur)
            cur = []
        cur.append(int(i))
    return groups + [cur] if cur else groups


def _padded(problems):
    """Time-major arrays, padded to the longest track: step lengths h (L, T), measured mask
    (L, T), positions (L, T, 2, 1) and covariances (L, T, 2, 2) (identity where nothing is
    measured)."""
    T, L = len(problems), max(len(p.ts) for p in problems)
    h, meas = np.zeros((L, T)), np.zeros((L, T), bool)
    z, R = np.zeros((L, T, 2, 1)), np.tile(np.eye(2), (L, T, 1, 1))
    for i, p in enumerate(problems):
        n = len(p.ts)
        h[1:n, i] = np.diff(p.ts)
        meas[:n, i] = p.measured
        z[:n, i][p.measured] = p.z[:, :, None]
        R[:n, i][p.measured] = p.R
    return h, meas, z, R


def _transitions(h, q, w):
    """F and Q (L, T, 4, 4) of every step (filterpy's Q expression, w·h added to the
    positions' variance)."""
    F = np.broadcast_to(np.eye(4), h.shape + (4, 4)).copy()
    F[..., 0, 1] = F[..., 2, 3] = h
    Q = np.zeros(h.shape + (4, 4))
    for i in _POS:
        Q[..., i, i] = q * (h**3 / 3) + w * h
        Q[..., i, i + 1] = Q[..., i + 1, i] = q * (h**2 / 2)
        Q[..., i + 1, i + 1] = q * h
    return F, Q


def _cv_rts_batch(problems):
    h, meas, z, R = _padded(problems)
    L, T = h.shape
    F, Q = _transitions(h, np.array([p.q for p in problems], float),
                        np.array([p.w for p in problems], float))
    FT = F.swapaxes(-1, -2)
    xp, Pp = np.empty((L, T, 4, 1)), np.empty((L, T, 4, 4))   # predicted
    xf, Pf = np.empty((L, T, 4, 1)), np.empty((L, T, 4, 4))   # filtered
    x = np.zeros((T, 4, 1))
    x[:, ::2, 0] = [p.z[0] for p in problems]      # a diffuse start about the first position
    P = np.tile(np.eye(4) * DIFFUSE, (T, 1, 1))
    eye, tmp = np.tile(np.eye(4), (T, 1, 1)), np.empty((T, 4, 4))
    gate = meas[:, :, None, None].astype(float)
    for k in range(L):
        # matmul as filterpy's dot (BLAS, same rounding): results then agree bit for bit
        np.matmul(F[k], x, out=xp[k])
        np.matmul(np.matmul(F[k], P, out=tmp), FT[k], out=Pp[k])
        Pp[k] += Q[k]
        # Joseph-form update; K = 0 where nothing is measured leaves x and P exactly as they are
        PHT = Pp[k][:, :, ::2]
        K = PHT @ np.linalg.inv(PHT[:, ::2] + R[k])
        K *= gate[k]
        np.add(xp[k], K @ (z[k] - xp[k][:, ::2]), out=xf[k])
        I_KH = eye.copy()
        I_KH[:, :, ::2] -= K
        KT = K.swapaxes(-1, -2)
        np.add(I_KH @ Pp[k] @ I_KH.swapaxes(-1, -2), K @ R[k] @ KT, out=Pf[k])
        x, P = xf[k], Pf[k]
    xs, Ps = _rts(xf, Pf, xp, Pp, FT, Q, [len(p.ts) for p in problems])
    return [(xs[:len(p.ts), i, :, 0], Ps[:len(p.ts), i]) for i, p in enumerate(problems)]


def _rts(xf, Pf, xp, Pp, FT, Q, lengths):
    """Rauch–Tung–Striebel: gains G_k = P_k Fᵀ (P⁻_{k+1})⁻¹ for every step at once (they need
    only the forward pass), then the backward recursion. The covariance in the Joseph-like
    form (I − G F) P_k (I − G F)ᵀ + G (Q + P^s_{k+1}) Gᵀ, equal to filterpy's
    P_k + G (P^s_{k+1} − P⁻_{k+1}) Gᵀ in exact arithmetic: a sum of positive semi-definite
    terms, where filterpy's difference lost every digit on tracks whose crossings' covariances
    span 14 orders of magnitude (negative variances, σ reported as 0). A track's padding
    (steps past its length) keeps its covariance as filtered, bit for bit, as it is then."""
    L = len(xf)
    if L < 2:
        return xf, Pf
    G = Pf[:-1] @ FT[1:] @ np.linalg.inv(Pp[1:])
    GT = G.swapaxes(-1, -2)
    A = np.eye(xf.shape[-2]) - G @ FT[1:].swapaxes(-1, -2)
    AT = A.swapaxes(-1, -2)
    xs, Ps = xf.copy(), Pf.copy()
    inside = np.arange(L)[:, None] < np.asarray(lengths)[None, :] - 1   # (L, T)
    for k in range(L - 2, -1, -1):
        xs[k] += G[k] @ (xs[k + 1] - xp[k + 1])
        back = A[k] @ Pf[k] @ AT[k] + G[k] @ (Q[k + 1] + Ps[k + 1]) @ GT[k]
        Ps[k] = np.where(inside[k][:, None, None], back, Pf[k])
    return xs, Ps


def _filterpy_one(p):
    from filterpy.kalman import KalmanFilter

    n = len(p.ts)
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    kf.x = np.array([p.z[0, 0], 0.0, p.z[0, 1], 0.0])
    kf.P = np.eye(4) * DIFFUSE
    h = np.r_[0.0, np.diff(p.ts)]
    Fs = np.tile(np.eye(4), (n, 1, 1))
    Fs[:, 0, 1] = Fs[:, 2, 3] = h
    block = p.q * np.stack([np.stack([h**3 / 3, h**2 / 2], -1), np.stack([h**2 / 2, h], -1)], -2)
    block[:, 0, 0] += p.w * h
    Qs = np.zeros((n, 4, 4))
    Qs[:, :2, :2] = Qs[:, 2:, 2:] = block
    zs, Rs = [None] * n, [kf.R] * n
    for k, i in enumerate(np.flatnonzero(p.measured)):
        zs[i], Rs[i] = p.z[k], p.R[k]
    mu, cov, _, _ = kf.batch_filter(zs, Fs=list(Fs), Qs=list(Qs), Rs=Rs)
    x, P, _, _ = kf.rts_smoother(mu, cov, Fs=list(Fs), Qs=list(Qs))
    return x, P


# -- the likelihood of q ------------------------------------------------------------------
def innovation_loglik(tracks, q_grid, w=0.0):
    """Log-likelihood (len(q_grid),) per track of the innovations of a per-axis CV filter
    (both axes share q; every track's position random walk w px²/s); tracks: (ts (n,) s,
    z (n, 2), σ (n,)) each, every step measured.
    The first two steps, which only set the initial position and velocity, are left out;
    innovations beyond HUBER_C σ count linearly (one jump does not decide q)."""
    out = [None] * len(tracks)
    for group in _groups([len(t[0]) for t in tracks]):
        for i, ll in zip(group, _loglik_batch([tracks[i] for i in group], q_grid, w)):
            out[i] = ll
    return out


def innovation_loglik_taichi(tracks, q_grid, w=0.0):
    """:func:`innovation_loglik` as a Taichi kernel, a thread per track and q."""
    from evstar_kernels.taichi import kalman_launch

    from .backends import taichi_running

    return kalman_launch.innovation_loglik(taichi_running(), tracks, np.asarray(q_grid, float),
                                           V0_VAR, HUBER_C, w)


def innovation_loglik_one(ts, z, sigma, q_grid, w=0.0):
    """The reference: :func:`innovation_loglik` of one track, the filter run for every q at
    once (the arithmetic of the batch, without padding)."""
    q = q_grid[:, None]
    shape = (len(q_grid), 2)
    p, v = np.broadcast_to(z[0], shape).copy(), np.zeros(shape)
    p00, p01, p11 = np.full(shape, sigma[0] ** 2), np.zeros(shape), np.full(shape, V0_VAR)
    ll = np.zeros(shape)
    for k in range(1, len(ts)):
        h = ts[k] - ts[k - 1]
        p = p + h * v
        p00 = p00 + 2 * h * p01 + h * h * p11 + q * h**3 / 3 + w * h
        p01 = p01 + h * p11 + q * h * h / 2
        p11 = p11 + q * h
        s = p00 + sigma[k] ** 2
        y = z[k] - p
        if k >= 2:
            ll -= 0.5 * np.log(s) + _huber(y * y / s)
        k0, k1 = p00 / s, p01 / s
        p, v = p + k0 * y, v + k1 * y
        p11 = p11 - k1 * p01
        p00, p01 = (1 - k0) * p00, (1 - k0) * p01
    return ll.sum(1)


def _loglik_batch(tracks, q_grid, w=0.0):
    """innovation_loglik_one's arithmetic on (axis, track, grid) arrays (the long axes last:
    numpy's inner loops run over them); padded steps add 0. The covariances, the same for
    both axes (one σ), are computed once on (track, grid)."""
    T, L, G = len(tracks), max(len(t[0]) for t in tracks), len(q_grid)
    h, s2, z = np.zeros((L, T, 1)), np.ones((L, T, 1)), np.zeros((L, 2, T, 1))
    valid = np.zeros((L, T), bool)
    for i, (ts, zi, sig) in enumerate(tracks):
        n = len(ts)
        h[1:n, i, 0], s2[:n, i, 0], valid[2:n, i] = np.diff(ts), np.asarray(sig) ** 2, True
        z[:n, :, i, 0] = zi
    full = valid.all(1)                                  # steps no track is padded in
    q = q_grid[None, :]
    p, v = np.repeat(z[0], G, 2), np.zeros((2, T, G))
    p00, p01, p11 = np.repeat(s2[0], G, 1), np.zeros((T, G)), np.full((T, G), V0_VAR)
    ll = np.zeros((2, T, G))
    for k in range(1, L):
        hk = h[k]
        p = p + hk * v
        p00 = p00 + 2 * hk * p01 + hk * hk * p11 + q * hk**3 / 3 + w * hk
        p01 = p01 + hk * p11 + q * hk * hk / 2
        p11 = p11 + q * hk
        s = p00 + s2[k]
        y = z[k] - p
        if k >= 2:
            term = 0.5 * np.log(s) + _huber(y * y / s)
            ll -= term if full[k] else np.where(valid[k, :, None], term, 0.0)
        k0, k1 = p00 / s, p01 / s
        p, v = p + k0 * y, v + k1 * y
        p11 = p11 - k1 * p01
        p00, p01 = (1 - k0) * p00, (1 - k0) * p01
    return list(ll[0] + ll[1])


def _huber(u):
    """−log-likelihood of a squared normalised innovation u, Gaussian up to HUBER_C σ and
    linear beyond it."""
    return np.where(u <= HUBER_C**2, u / 2, HUBER_C * np.sqrt(u) - HUBER_C**2 / 2)
