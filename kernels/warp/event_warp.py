"""Warp kernel that moves events to their reference times: u' = π(K·R(t_ref ← t)·K⁻¹ ũ).

The math of evstar.motion.warping (its numpy form is the reference): the attitude at an
event's time is Exp(s·φ_k) ⊗ q_k between attitude nodes k, k+1 (slerp), the reference
attitudes are given per distinct reference time, and radial distortion (k1, k2) is removed by
fixed-point iteration and applied again after the rotation, as evstar.Camera does.
"""
import warp as wp

from .so3 import quat_exp, quat_mul, quat_rotate


@wp.func
def _distortion_scale(xn: wp.float64, yn: wp.float64, k1: wp.float64, k2: wp.float64):
    r2 = xn * xn + yn * yn
    return wp.float64(1.0) + k1 * r2 + k2 * r2 * r2


@wp.kernel
def warp_events(t: wp.array(dtype=wp.float64), x: wp.array(dtype=wp.float64),
                y: wp.array(dtype=wp.float64), ref_index: wp.array(dtype=wp.int32),
                ref_q: wp.array(dtype=wp.vec4d), node_t: wp.array(dtype=wp.float64),
                node_q: wp.array(dtype=wp.vec4d), node_phi: wp.array(dtype=wp.vec3d),
                fx: wp.float64, fy: wp.float64, cx: wp.float64, cy: wp.float64,
                k1: wp.float64, k2: wp.float64, undistort_iterations: int,
                out_x: wp.array(dtype=wp.float64), out_y: wp.array(dtype=wp.float64)):
    """(out_x, out_y)[i] = event i moved to its reference attitude ref_q[ref_index[i]].

    Specification: `evstar.motion.warping.warp_to_reference` with backend="numpy" (its
    numpy form lives beside the estimator, not in evstar_kernels.reference)."""
    i = wp.tid()
    ti = t[i]
    n = node_t.shape[0]
    lo = int(0)
    hi = n
    while lo < hi:  # searchsorted(node_t, t, side="right")
        mid = (lo + hi) // 2
        if node_t[mid] <= ti:
            lo = mid + 1
        else:
            hi = mid
    k = wp.clamp(lo - 1, 0, n - 2)
    s = (ti - node_t[k]) / (node_t[k + 1] - node_t[k])
    phi = node_phi[k]
    q_t = quat_mul(quat_exp(s * phi[0], s * phi[1], s * phi[2]), node_q[k])
    q_t_inv = wp.vec4d(-q_t[0], -q_t[1], -q_t[2], q_t[3])
    q_rel = quat_mul(ref_q[ref_index[i]], q_t_inv)
    xd = (x[i] - cx) / fx
    yd = (y[i] - cy) / fy
    xn = xd
    yn = yd
    for _ in range(undistort_iterations):
        sc = _distortion_scale(xn, yn, k1, k2)
        xn = xd / sc
        yn = yd / sc
    r = quat_rotate(q_rel, wp.vec3d(xn, yn, wp.float64(1.0)))
    if r[2] <= wp.float64(0.0):  # turned behind the camera
        out_x[i] = wp.float64(wp.nan)
        out_y[i] = wp.float64(wp.nan)
        return
    xo = r[0] / r[2]
    yo = r[1] / r[2]
    if undistort_iterations > 0:
        sc = _distortion_scale(xo, yo, k1, k2)
        xo = xo * sc
        yo = yo * sc
    out_x[i] = fx * xo + cx
    out_y[i] = fy * yo + cy
