"""Taichi kernel that moves events to their reference times: u' = π(K·R(t_ref ← t)·K⁻¹ ũ).

The Warp kernel `evstar_kernels.warp.event_warp`'s math in another order: the relative
rotation q_ref ⊗ conj(Exp(s·φ_k) ⊗ q_k) is applied as the matrix of q_ref ⊗ conj(q_k),
made once per run of events sharing the node k and the reference (a block's events
nearly all do), after the small rotation Exp(−s·φ_k) — ~65 flops an event where the
quaternion products took ~110 (within 1e-12 px of them). A parallel loop over blocks of
events: Taichi runs it on every CPU core (a Warp CPU launch runs on one thread). The
attitude node is found by a forward walk from a per-block start instead of a binary search
(the same node: docs/kernels.md).
Specification: `evstar.motion.warping.warp_to_reference` with backend="reference".
"""
import taichi as ti

from .arrays import f64_2d, u8_1d, u16_1d

vec3d = ti.types.vector(3, ti.f64)
vec4d = ti.types.vector(4, ti.f64)


@ti.func
def quat_mul(a: vec4d, b: vec4d) -> vec4d:
    """Hamilton product a ⊗ b, (x, y, z, w)."""
    return vec4d(a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
                 a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
                 a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
                 a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2])


@ti.func
def quat_exp(tx: ti.f64, ty: ti.f64, tz: ti.f64) -> vec4d:
    """Rotation vector -> unit quaternion; Taylor polynomial below 0.01 rad (no sin/cos)."""
    a2 = tx * tx + ty * ty + tz * tz
    w = ti.f64(0.0)
    s = ti.f64(0.0)
    if a2 < 1e-4:
        w = 1.0 - a2 * (0.125 - a2 * (0.0026041666666666665 - a2 * 2.170138888888889e-05))
        s = 0.5 - a2 * (0.020833333333333332 - a2 * (
            0.00026041666666666666 - a2 * 1.5500992063492063e-06))
    else:
        angle = ti.sqrt(a2)
        w = ti.cos(0.5 * angle)
        s = ti.sin(0.5 * angle) / angle
    return vec4d(s * tx, s * ty, s * tz, w)


@ti.func
def quat_rotate(q: vec4d, v: vec3d) -> vec3d:
    """R(q) v = v + w·t + u × t with t = 2 u × v."""
    tx = 2.0 * (q[1] * v[2] - q[2] * v[1])
    ty = 2.0 * (q[2] * v[0] - q[0] * v[2])
    tz = 2.0 * (q[0] * v[1] - q[1] * v[0])
    return vec3d(v[0] + q[3] * tx + (q[1] * tz - q[2] * ty),
                 v[1] + q[3] * ty + (q[2] * tx - q[0] * tz),
                 v[2] + q[3] * tz + (q[0] * ty - q[1] * tx))


@ti.func
def distortion_scale(xn: ti.f64, yn: ti.f64, k1: ti.f64, k2: ti.f64) -> ti.f64:
    r2 = xn * xn + yn * yn
    return 1.0 + k1 * r2 + k2 * r2 * r2


@ti.func
def rotation_matrix(q: vec4d) -> ti.types.matrix(3, 3, ti.f64):
    """R(q) of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    return ti.Matrix([[1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
                      [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
                      [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)]],
                     ti.f64)


@ti.func
def node_at(ti_: ti.f64, node_t: ti.template(), start: ti.i32) -> ti.i32:
    """The last attitude node at or before ti_ (searchsorted side='right', kept within
    0 .. n − 2), walked forward from `start` (a node at or before it, or −1)."""
    n = node_t.shape[0]
    lo = start + 1
    while lo < n and node_t[lo] <= ti_:
        lo += 1
    return ti.min(ti.max(lo - 1, 0), n - 2)


@ti.func
def undistorted(xd: ti.f64, yd: ti.f64, k1: ti.f64, k2: ti.f64, iterations: ti.i32):
    xn, yn = xd, yd
    for _ in range(iterations):
        sc = distortion_scale(xn, yn, k1, k2)
        xn, yn = xd / sc, yd / sc
    return xn, yn


#: events per entry of warp_events' `start` (the last node at or before the block's first
#: time) and per iteration of its parallel loop
BLOCK = 256


@ti.kernel
def warp_events(t: ti.types.ndarray(), x: ti.types.ndarray(), y: ti.types.ndarray(),
                start: ti.types.ndarray(), ref_index: ti.types.ndarray(), ref_q: ti.types.ndarray(),
                node_t: ti.types.ndarray(), node_q: ti.types.ndarray(),
                node_phi: ti.types.ndarray(), fx: ti.f64, fy: ti.f64, cx: ti.f64, cy: ti.f64,
                k1: ti.f64, k2: ti.f64, undistort_iterations: ti.i32, width: ti.i32,
                height: ti.i32, out_xy: f64_2d, out_px: u16_1d, out_py: u16_1d,
                out_inside: u8_1d, distorted: ti.template()):
    """out_xy[i] = event i moved to its reference attitude ref_q[ref_index[i]];
    NaN where the rotation turns its ray behind the camera. (out_px, out_py, out_inside)[i]:
    its rounded pixel and whether that lies on the width x height sensor (0, 0, 0 where not:
    reference.pixels.rounded_pixels). distorted: a compile-time switch (False: the
    iterations are not read; a loop of a run-time count slowed the pinhole by ~15 %)."""
    n = t.shape[0]
    for block in range((n + BLOCK - 1) // BLOCK):
        k_made, r_made = -1, -1
        m = ti.Matrix.zero(ti.f64, 3, 3)    # R(q_ref ⊗ conj(q_k)) of (k_made, r_made)
        for i in range(block * BLOCK, ti.min(block * BLOCK + BLOCK, n)):
            t_i = ti.cast(t[i], ti.f64)
            k = node_at(t_i, node_t, start[block])
            r_i = ref_index[i]
            if k != k_made or r_i != r_made:
                q_ref = vec4d(ref_q[r_i, 0], ref_q[r_i, 1], ref_q[r_i, 2], ref_q[r_i, 3])
                m = rotation_matrix(quat_mul(q_ref, vec4d(-node_q[k, 0], -node_q[k, 1],
                                                          -node_q[k, 2], node_q[k, 3])))
                k_made, r_made = k, r_i
            s = (t_i - node_t[k]) / (node_t[k + 1] - node_t[k])
            step_back = quat_exp(-(s * node_phi[k, 0]), -(s * node_phi[k, 1]), -(s * node_phi[k, 2]))
            xn = (ti.cast(x[i], ti.f64) - cx) / fx
            yn = (ti.cast(y[i], ti.f64) - cy) / fy
            if ti.static(distorted):
                xn, yn = undistorted(xn, yn, k1, k2, undistort_iterations)
            r = m @ quat_rotate(step_back, vec3d(xn, yn, 1.0))
            px, py, inside = ti.u16(0), ti.u16(0), ti.u8(0)
            if r[2] <= 0.0:
                out_xy[i, 0] = ti.math.nan
                out_xy[i, 1] = ti.math.nan
            else:
                xo, yo = r[0] / r[2], r[1] / r[2]
                if ti.static(distorted):
                    sc = distortion_scale(xo, yo, k1, k2)
                    xo, yo = xo * sc, yo * sc
                u = fx * xo + cx
                v = fy * yo + cy
                out_xy[i, 0] = u
                out_xy[i, 1] = v
                # pixel i covers [i - 1/2, i + 1/2)
                rx, ry = ti.floor(u + 0.5), ti.floor(v + 0.5)
                if rx >= 0.0 and rx < width and ry >= 0.0 and ry < height:
                    px, py, inside = ti.cast(rx, ti.u16), ti.cast(ry, ti.u16), ti.u8(1)
            out_px[i] = px
            out_py[i] = py
            out_inside[i] = inside
