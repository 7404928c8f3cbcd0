"""Quaternion functions for Warp kernels (x, y, z, w in a vec4d), written term by term in
the order of `evstar_kernels.reference.so3` so that CPU results are bit-identical to it
(the kernels that use them compile with FMA contraction off)."""
import warp as wp


@wp.func
def quat_mul(a: wp.vec4d, b: wp.vec4d):
    """Hamilton product a ⊗ b."""
    return wp.vec4d(a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
                    a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
                    a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
                    a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2])


@wp.func
def quat_exp(tx: wp.float64, ty: wp.float64, tz: wp.float64):
    """Rotation vector -> unit quaternion; Taylor polynomial below 0.01 rad (no sin/cos)."""
    a2 = tx * tx + ty * ty + tz * tz
    w = wp.float64(0.0)
    s = wp.float64(0.0)
    if a2 < wp.float64(1e-4):
        w = wp.float64(1.0) - a2 * (wp.float64(0.125) - a2 * (
            wp.float64(0.0026041666666666665) - a2 * wp.float64(2.170138888888889e-05)))
        s = wp.float64(0.5) - a2 * (wp.float64(0.020833333333333332) - a2 * (
            wp.float64(0.00026041666666666666) - a2 * wp.float64(1.5500992063492063e-06)))
    else:
        angle = wp.sqrt(a2)
        half = wp.float64(0.5) * angle
        w = wp.cos(half)
        s = wp.sin(half) / angle
    return wp.vec4d(s * tx, s * ty, s * tz, w)


@wp.func
def quat_normalize(q: wp.vec4d):
    n = wp.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return wp.vec4d(q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@wp.func
def quat_rotate(q: wp.vec4d, v: wp.vec3d):
    """R(q) v = v + w·t + u × t with t = 2 u × v."""
    tx = wp.float64(2.0) * (q[1] * v[2] - q[2] * v[1])
    ty = wp.float64(2.0) * (q[2] * v[0] - q[0] * v[2])
    tz = wp.float64(2.0) * (q[0] * v[1] - q[1] * v[0])
    return wp.vec3d(v[0] + q[3] * tx + (q[1] * tz - q[2] * ty),
                    v[1] + q[3] * ty + (q[2] * tx - q[0] * tz),
                    v[2] + q[3] * tz + (q[0] * ty - q[1] * tx))
