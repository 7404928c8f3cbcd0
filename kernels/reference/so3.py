"""Rotations in numpy: hat/exp/log maps, quaternions (x, y, z, w — scalar last, as scipy and
Warp), slerp and gyro integration. Every function takes stacked inputs (..., 3) or (..., 4).

Convention of the gyro integration (docs/design.md, "Conventions"): R_cw maps world vectors into the
camera, the gyro measures the body rate ω in the camera frame and dR_cw/dt = −[ω]× R_cw, so a
step of constant rate gives R_cw(t + dt) = Exp(−ω·dt) · R_cw(t).

The quaternion exponential uses a Taylor polynomial below `SMALL_ANGLE` (exact to double
precision there and free of sin/cos); the Warp kernels evaluate the same expressions in the
same order, which is what makes their predictions bit-identical to these.
"""
from __future__ import annotations

import numpy as np

#: angle² below which quat_exp uses its polynomial (angle < 0.01 rad; truncation < 1e-20)
SMALL_ANGLE2 = 1e-4


def hat(v):
    """(..., 3) vectors -> (..., 3, 3) skew matrices with hat(a) @ b == cross(a, b)."""
    v = np.asarray(v, dtype=np.float64)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1),
                     np.stack([-y, x, z], -1)], -2)


def vee(m):
    """Inverse of hat: (..., 3, 3) -> (..., 3) (the antisymmetric part)."""
    m = np.asarray(m, dtype=np.float64)
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                           m[..., 1, 0] - m[..., 0, 1]], -1)


def exp_so3(rotvec):
    """Rotation vectors (..., 3) -> rotation matrices (..., 3, 3) (Rodrigues)."""
    return quat_to_matrix(quat_exp(rotvec))


def log_so3(R):
    """Rotation matrices (..., 3, 3) -> rotation vectors (..., 3) with angle in [0, π]."""
    return quat_log(quat_from_matrix(R))


def quat_identity(n=None):
    q = np.array([0.0, 0.0, 0.0, 1.0])
    return q if n is None else np.tile(q, (n, 1))


def quat_mul(a, b):
    """Hamilton product a ⊗ b (R(a ⊗ b) = R(a) R(b)); term order shared with the Warp kernels."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], -1)


def quat_conj(q):
    q = np.asarray(q, dtype=np.float64)
    return np.concatenate([-q[..., :3], q[..., 3:]], -1)


def quat_normalize(q):
    q = np.asarray(q, dtype=np.float64)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return q / np.sqrt(x * x + y * y + z * z + w * w)[..., None]


def quat_exp(rotvec):
    """Rotation vectors (..., 3) -> unit quaternions (..., 4)."""
    v = np.asarray(rotvec, dtype=np.float64)
    tx, ty, tz = v[..., 0], v[..., 1], v[..., 2]
    a2 = tx * tx + ty * ty + tz * tz
    w_poly = 1.0 - a2 * (0.125 - a2 * (0.0026041666666666665 - a2 * 2.170138888888889e-05))
    s_poly = 0.5 - a2 * (0.020833333333333332 - a2 * (0.00026041666666666666
                                                      - a2 * 1.5500992063492063e-06))
    small = a2 < SMALL_ANGLE2
    angle = np.sqrt(np.where(small, 1.0, a2))
    half = 0.5 * angle
    w = np.where(small, w_poly, np.cos(half))
    s = np.where(small, s_poly, np.sin(half) / angle)
    return np.stack([s * tx, s * ty, s * tz, w], -1)


def quat_log(q):
    """Unit quaternions (..., 4) -> rotation vectors (..., 3), angle in [0, π]."""
    q = np.asarray(q, dtype=np.float64)
    q = np.where(q[..., 3:] < 0, -q, q)  # q and −q are the same rotation
    v, w = q[..., :3], q[..., 3]
    n = np.sqrt(np.sum(v * v, axis=-1))
    tiny = n < 1e-12
    scale = np.where(tiny, 2.0 / np.where(w > 0, w, 1.0),
                     2.0 * np.arctan2(n, w) / np.where(tiny, 1.0, n))
    return v * scale[..., None]


def right_jacobian(rotvec):
    """J_r(u) (..., 3, 3) with Exp(u + v) = Exp(u)·Exp(J_r(u)·v) + O(|v|²) (the right
    Jacobian of SO(3)); a series below 1e-4 rad, where the closed form loses digits."""
    u = np.asarray(rotvec, dtype=np.float64)
    a2 = np.sum(u * u, -1)[..., None, None]
    small = a2 < 1e-8
    a = np.sqrt(np.where(small, 1.0, a2))
    c1 = np.where(small, 0.5 - a2 / 24.0, (1.0 - np.cos(a)) / (a * a))
    c2 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (a - np.sin(a)) / (a * a * a))
    h = hat(u)
    return np.eye(3) - c1 * h + c2 * (h @ h)


def quat_to_matrix(q):
    q = quat_normalize(q)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def quat_from_matrix(R):
    """Rotation matrices (..., 3, 3) -> unit quaternions with w >= 0 (Shepperd's method)."""
    R = np.asarray(R, dtype=np.float64)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = m00 + m11 + m22
    cands = np.stack([  # 4·q·q_k for the four choices of pivot k, each (..., 4)
        np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                  R[..., 1, 0] - R[..., 0, 1], 1 + tr], -1),
        np.stack([1 + m00 - m11 - m22, R[..., 0, 1] + R[..., 1, 0],
                  R[..., 0, 2] + R[..., 2, 0], R[..., 2, 1] - R[..., 1, 2]], -1),
        np.stack([R[..., 0, 1] + R[..., 1, 0], 1 - m00 + m11 - m22,
                  R[..., 1, 2] + R[..., 2, 1], R[..., 0, 2] - R[..., 2, 0]], -1),
        np.stack([R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1],
                  1 - m00 - m11 + m22, R[..., 1, 0] - R[..., 0, 1]], -1)], -2)
    pivot = np.argmax(np.stack([tr, m00, m11, m22], -1), axis=-1)
    q = np.take_along_axis(cands, pivot[..., None, None], axis=-2)[..., 0, :]
    q = quat_normalize(q)
    return np.where(q[..., 3:] < 0, -q, q)


def quat_rotate(q, v):
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4): R(q) v."""
    q, v = np.asarray(q, dtype=np.float64), np.asarray(v, dtype=np.float64)
    qx, qy, qz, qw = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    tx = 2.0 * (qy * vz - qz * vy)  # t = 2 u × v, then v + w·t + u × t
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return np.stack([vx + qw * tx + (qy * tz - qz * ty), vy + qw * ty + (qz * tx - qx * tz),
                     vz + qw * tz + (qx * ty - qy * tx)], -1)


def slerp(q0, q1, s):
    """Geodesic interpolation from q0 (s = 0) to q1 (s = 1); shortest path (sign-aligned)."""
    q0, q1 = np.asarray(q0, dtype=np.float64), np.asarray(q1, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    d = quat_mul(quat_conj(q0), q1)
    return quat_normalize(quat_mul(q0, quat_exp(s[..., None] * quat_log(d))))


def integrate_rates(q0, omega, dt):
    """Attitudes after each step of constant body rate: q[k+1] = Exp(−ω[k]·dt[k]) ⊗ q[k].

    q0 (4,), omega (M, 3) rad/s, dt (M,) s -> (M + 1, 4). The product is formed by a
    parallel prefix scan (log2 M vectorised passes; rounding grows with log M, not M).
    """
    omega, dt = np.asarray(omega, dtype=np.float64), np.asarray(dt, dtype=np.float64)
    steps = quat_exp(-omega * dt[:, None])
    offset = 1
    while offset < len(steps):  # Hillis–Steele: steps[k] <- steps[k] ⊗ steps[k − offset]
        steps[offset:] = quat_mul(steps[offset:], steps[:-offset])
        offset *= 2
    q0 = quat_normalize(np.asarray(q0, dtype=np.float64))
    return np.concatenate([q0[None], quat_normalize(quat_mul(steps, q0))])
