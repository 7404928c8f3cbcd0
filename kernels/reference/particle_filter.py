"""Particle filter on SO(3) in numpy: the executable specification of the Warp kernels.

Particles hold an attitude quaternion q (x, y, z, w; R_cw maps world vectors into the camera)
and a gyro bias b (rad/s, camera frame; the gyro reads ω + b + noise).

Random numbers are counter-based, so any thread count — and the Warp kernels — draw the same
values: the normal for (seed, particle, step, component) is Φ⁻¹ of a uniform made from a
PCG hash of those four integers (Φ⁻¹ by Wichura's AS241, accurate to 1e-16 and free of
transcendental calls in its central region). Components:

  0–2  gyro noise of a prediction block       3–5  bias random walk of a prediction block
       (both keyed by the block's last step)
  6–8  initial bias spread (step 0)           9–11 initial attitude spread (step 0)

The systematic-resampling offset of update k uses particle 0xFFFFFFFF, step k, component 0.
"""
from __future__ import annotations

import numpy as np

from .so3 import (quat_exp, quat_identity, quat_mul, quat_normalize, quat_rotate, quat_to_matrix,
                  right_jacobian)

_M32 = np.uint64(0xFFFFFFFF)
RESAMPLE_PARTICLE = 0xFFFFFFFF
GYRO, WALK, INIT_BIAS, INIT_ATTITUDE = 0, 3, 6, 9


# -- counter-based random numbers ---------------------------------------------------------
def pcg_hash(v):
    """PCG-RXS-M-XS 32-bit hash (Jarzynski & Olano 2020) of uint32 values, as Warp's rand_pcg."""
    v = np.asarray(v, dtype=np.uint64) & _M32
    b = (v * np.uint64(747796405) + np.uint64(2891336453)) & _M32
    c = (((b >> ((b >> np.uint64(28)) + np.uint64(4))) ^ b) * np.uint64(277803737)) & _M32
    return (c >> np.uint64(22)) ^ c


def counter_key(seed, particle, step):
    """Key of (seed, particle, step): pcg(pcg(pcg(seed) + particle) + step), uint32 arithmetic."""
    k = pcg_hash(np.asarray(seed, dtype=np.uint64) & _M32)
    k = pcg_hash(k + (np.asarray(particle, dtype=np.uint64) & _M32))
    return pcg_hash(k + (np.asarray(step, dtype=np.uint64) & _M32))


def counter_uniform(key, component):
    """Uniform in (0, 1) from a key and a component index: (pcg(key + c) + 0.5) / 2³²."""
    h = pcg_hash(np.asarray(key, dtype=np.uint64) + np.uint64(component))
    return (h.astype(np.float64) + 0.5) * 2.3283064365386963e-10


_A = (2509.0809287301226727, 33430.575583588128105, 67265.770927008700853, 45921.953931549871457,
      13731.693765509461125, 1971.5909503065514427, 133.14166789178437745, 3.387132872796366608)
_B = (5226.495278852545925, 28729.085735721942674, 39307.89580009271061, 21213.794301586595867,
      5394.1960214247511077, 687.1870074920579083, 42.313330701600911252, 1.0)
_C = (7.7454501427834140764e-4, 0.0227238449892691845833, 0.24178072517745061177,
      1.27045825245236838258, 3.64784832476320460504, 5.7694972214606914055,
      4.6303378461565452959, 1.42343711074968357734)
_D = (1.05075007164441684324e-9, 5.475938084995344946e-4, 0.0151986665636164571966,
      0.14810397642748007459, 0.68976733498510000455, 1.6763848301838038494,
      2.05319162663775882187, 1.0)
_E = (2.01033439929228813265e-7, 2.71155556874348757815e-5, 0.0012426609473880784386,
      0.026532189526576123093, 0.29656057182850489123, 1.7848265399172913358,
      5.4637849111641143699, 6.6579046435011037772)
_F = (2.04426310338993978564e-15, 1.4215117583164458887e-7, 1.8463183175100546818e-5,
      7.868691311456132591e-4, 0.0148753612908506148525, 0.13692988092273580531,
      0.59983220655588793769, 1.0)


def _horner(coeffs, r):
    acc = coeffs[0] * r + coeffs[1]
    for c in coeffs[2:-1]:
        acc = acc * r + c
    return acc * r + coeffs[-1]


def normal_icdf(p):
    """Standard-normal quantile Φ⁻¹(p) for p in (0, 1) (Wichura 1988, AS241 PPND16)."""
    p = np.asarray(p, dtype=np.float64)
    q = p - 0.5
    r = 0.180625 - q * q
    central = q * _horner(_A, r) / _horner(_B, r)
    rt = np.sqrt(-np.log(np.where(q > 0.0, 1.0 - p, p)))
    near = rt <= 5.0
    rn, rf = rt - 1.6, rt - 5.0
    tail = np.where(near, _horner(_C, rn) / _horner(_D, rn), _horner(_E, rf) / _horner(_F, rf))
    tail = np.where(q < 0.0, -tail, tail)
    return np.where(np.abs(q) <= 0.425, central, tail)


def counter_normals(seed, n_particles, step, component0, count=3):
    """Normals (n_particles, count) for components component0 .. component0 + count − 1."""
    key = counter_key(seed, np.arange(n_particles), step)
    return np.stack([normal_icdf(counter_uniform(key, component0 + c)) for c in range(count)], 1)


# -- particle operations --------------------------------------------------------------------
def block_motions(omega, dt, starts, ends):
    """Gyro preintegration of prediction blocks (Forster et al. 2017, first order in the bias):
    block j covers IMU steps starts[j] .. ends[j] − 1 of the rates omega (K, 3) and lengths
    dt (K,). Returns P (B, 4) = Exp(−ω_{K−1}·dt_{K−1}) ⊗ … ⊗ Exp(−ω_0·dt_0), the gyro's
    rotation over the block; M (B, 3, 3) = Σ_k dt_k·R(S_k)ᵀ·J_r(−ω_k·dt_k), S_k the block's
    steps before k, so that a particle of bias b turns by
    Π_k Exp(−(ω_k − b)·dt_k) = P ⊗ Exp(M·b) to O(|b|²T²) (~1e-11 rad for 0.5 °/s over 10 ms
    at 10 °/s: far below the block's gyro noise, ~3e-5 rad); and T (B,) = Σ dt, s.
    Why: the particles then turn once a block, not once an IMU step (that loop was ~2/3
    of the filter's time), and the steps are integrated once, not once per particle.
    All blocks at once: one pass per step index, finished blocks turning by Exp(0) = 1."""
    omega, dt = np.asarray(omega, np.float64), np.asarray(dt, np.float64)
    starts, ends = np.asarray(starts, np.int64), np.asarray(ends, np.int64)
    lengths = ends - starts
    s, m = quat_identity(len(starts)), np.zeros((len(starts), 3, 3))
    for i in range(int(lengths.max(initial=0))):
        k = np.minimum(starts + i, len(dt) - 1)
        h = np.where(lengths > i, dt[k], 0.0)
        u = -omega[k] * h[:, None]
        m = m + h[:, None, None] * (np.swapaxes(quat_to_matrix(s), -1, -2) @ right_jacobian(u))
        s = quat_mul(quat_exp(u), s)
    total = np.r_[0.0, np.cumsum(dt)]
    return s, m, total[ends] - total[starts]


def predict(q, b, rotation, bias_jacobian, duration, *, gyro_noise, bias_walk, seed=0, step=0,
            gyro_normals=None, walk_normals=None):
    """Propagate particles through one prediction block (see block_motions: rotation P,
    bias_jacobian M, duration T seconds):

        q <- Exp(−gyro_noise·√T·n_gyro) ⊗ P ⊗ Exp(M·b) ⊗ q, normalised;
        b <- b + bias_walk·√T·n_walk   (the bias is held constant within a block).

    The gyro noise of the whole block is drawn once, at its end: the filter looks at the
    attitude only there (an observation time), where the steps' independent noise
    rotations add up, to first order, to one isotropic Gaussian of variance
    gyro_noise²·T per axis. gyro_noise is a density (rad/s/√Hz), bias_walk rad/s/√s.
    Normals come from the counter generator, keyed by `step` (the block's last IMU step),
    unless given: gyro_normals (N, 3), walk_normals (N, 3).
    """
    q = np.asarray(q, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    m = np.asarray(bias_jacobian, dtype=np.float64)
    n = len(q)
    v = np.stack([m[r, 0] * b[:, 0] + m[r, 1] * b[:, 1] + m[r, 2] * b[:, 2] for r in range(3)], 1)
    q = quat_mul(np.asarray(rotation, np.float64), quat_mul(quat_exp(v), q))
    if gyro_normals is None:
        gyro_normals = counter_normals(seed, n, step, GYRO)
    if walk_normals is None:
        walk_normals = counter_normals(seed, n, step, WALK)
    span = np.sqrt(duration)
    q = quat_mul(quat_exp(-((gyro_noise * span) * gyro_normals)), q)
    return quat_normalize(q), b + (bias_walk * span) * walk_normals


def log_likelihood(q, stars_world, uv, *, fx, fy, cx, cy, pixel_sigma, gate):
    """Σ over stars of −½·min(|pinhole(R(q)·d) − uv|² / σ², gate²) per particle (N,).

    Each star is a fixed unit world direction d; a star behind the camera costs gate²/2 too,
    so one bad association cannot dominate (truncated Gaussian).
    """
    q = np.asarray(q, dtype=np.float64)
    out = np.zeros(len(q))
    inv = 1.0 / pixel_sigma
    g2 = gate * gate
    for d, (mu, mv) in zip(np.asarray(stars_world, np.float64), np.asarray(uv, np.float64)):
        c = quat_rotate(q, d)
        front = c[:, 2] > 0.0
        z = np.where(front, c[:, 2], 1.0)
        ru = ((fx * c[:, 0] / z + cx) - mu) * inv
        rv = ((fy * c[:, 1] / z + cy) - mv) * inv
        r2 = np.where(front, np.minimum(ru * ru + rv * rv, g2), g2)
        out = out - 0.5 * r2
    return out


def weight_sums(logw, q, b, q_ref):
    """Weights w = exp(logw − max logw) and the sums behind resampling and the estimate.

    Returns the cumulative weights cdf (N,) and sums (9,) = [Σw, Σw², Σ w·s·q (4), Σ w·b (3)],
    s = ±1 aligning each q with q_ref. Every sum runs in index order (cumsum), as the Warp
    CPU kernel does, so both give the same bits.
    """
    logw = np.asarray(logw, dtype=np.float64)
    q, b = np.asarray(q, np.float64), np.asarray(b, np.float64)
    w = np.exp(logw - np.max(logw))
    r = np.asarray(q_ref, np.float64)
    dot = q[:, 0] * r[0] + q[:, 1] * r[1] + q[:, 2] * r[2] + q[:, 3] * r[3]
    ws = np.where(dot < 0.0, -w, w)
    cdf = np.cumsum(w)
    sums = np.concatenate([[cdf[-1], np.cumsum(w * w)[-1]], np.cumsum(ws[:, None] * q, axis=0)[-1],
                           np.cumsum(w[:, None] * b, axis=0)[-1]])
    return cdf, sums


def estimate_from_sums(sums):
    """(q_mean, b_mean, effective sample size) from weight_sums' nine sums."""
    sums = np.asarray(sums, dtype=np.float64)
    total, total2 = sums[0], sums[1]
    return quat_normalize(sums[2:6]), sums[6:9] / total, float(total * total / total2)


def resample_offset(seed, update):
    """Systematic-resampling offset u0 in (0, 1) for update number `update`."""
    return float(counter_uniform(counter_key(seed, RESAMPLE_PARTICLE, update), 0))


def systematic_resample(cdf, u0):
    """Parent index of each of the N children: first i with cdf[i] > (u0 + j)/N · cdf[−1]."""
    cdf = np.asarray(cdf, dtype=np.float64)
    n = len(cdf)
    positions = (u0 + np.arange(n)) / n * cdf[-1]
    return np.minimum(np.searchsorted(cdf, positions, side="right"), n - 1)
