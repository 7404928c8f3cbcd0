"""Warp kernels of the SO(3) particle filter (math only; launches live in particle_launch.py).

One thread per particle; a prediction kernel moves the particles through a whole block of
IMU steps (preintegrated on the host) per launch.
Each kernel mirrors a function of `evstar_kernels.reference.particle_filter` term by term;
FMA contraction is switched off for this module so that CPU results are bit-identical.
"""
import warp as wp

from .counter_rng import counter_key, counter_normal
from .so3 import quat_exp, quat_mul, quat_normalize, quat_rotate

wp.set_module_options({"cpu_compiler_flags": (wp.config.cpu_compiler_flags or "-march=native")
                       + " -ffp-contract=off"})

_GYRO = wp.constant(wp.uint32(0))
_WALK = wp.constant(wp.uint32(3))


@wp.func
def block_rotation(q: wp.vec4d, b: wp.vec3d, rotation: wp.vec4d, m: wp.mat33d):
    """P ⊗ Exp(M·b) ⊗ q: the gyro's rotation over the block, with the particle's bias."""
    v0 = m[0, 0] * b[0] + m[0, 1] * b[1] + m[0, 2] * b[2]
    v1 = m[1, 0] * b[0] + m[1, 1] * b[1] + m[1, 2] * b[2]
    v2 = m[2, 0] * b[0] + m[2, 1] * b[1] + m[2, 2] * b[2]
    return quat_mul(rotation, quat_mul(quat_exp(v0, v1, v2), q))


@wp.func
def block_end(q: wp.vec4d, gyro_sigma: wp.float64, g: wp.vec3d):
    """Exp(−gyro_sigma·g) ⊗ q, normalised: the block's gyro noise."""
    return quat_normalize(quat_mul(quat_exp(-(gyro_sigma * g[0]), -(gyro_sigma * g[1]),
                                            -(gyro_sigma * g[2])), q))


@wp.func
def walk(b: wp.vec3d, walk_sigma: wp.float64, w: wp.vec3d):
    """b + walk_sigma·w: the block's bias walk."""
    return b + wp.vec3d(walk_sigma * w[0], walk_sigma * w[1], walk_sigma * w[2])


@wp.kernel
def predict_counter(q: wp.array(dtype=wp.vec4d), b: wp.array(dtype=wp.vec3d),
                    rotation: wp.vec4d, bias_jacobian: wp.mat33d, seed: wp.uint32,
                    step: wp.uint32, gyro_sigma: wp.float64, walk_sigma: wp.float64,
                    first: wp.int32):
    """One prediction block (rotation P, bias Jacobian M: reference.block_motions), then
    its gyro noise (gyro_sigma = gyro_noise·√T) and bias walk (walk_sigma = bias_walk·√T)
    with counter-based normals keyed by `step` (the block's last IMU step). Thread t moves
    particle first + t (a launch may cover a range of the particles).

    Specification: `evstar_kernels.reference.particle_filter.predict`."""
    i = wp.tid() + first
    bi = b[i]
    qi = block_rotation(q[i], bi, rotation, bias_jacobian)
    key = counter_key(seed, wp.uint32(i), step)
    g = wp.vec3d(counter_normal(key, _GYRO), counter_normal(key, _GYRO + wp.uint32(1)),
                 counter_normal(key, _GYRO + wp.uint32(2)))
    w = wp.vec3d(counter_normal(key, _WALK), counter_normal(key, _WALK + wp.uint32(1)),
                 counter_normal(key, _WALK + wp.uint32(2)))
    q[i] = block_end(qi, gyro_sigma, g)
    b[i] = walk(bi, walk_sigma, w)


@wp.kernel
def predict_given(q: wp.array(dtype=wp.vec4d), b: wp.array(dtype=wp.vec3d),
                  rotation: wp.vec4d, bias_jacobian: wp.mat33d,
                  gyro_normals: wp.array(dtype=wp.vec3d), walk_normals: wp.array(dtype=wp.vec3d),
                  gyro_sigma: wp.float64, walk_sigma: wp.float64):
    """predict_counter with the normals supplied: gyro_normals (N), walk_normals (N).

    Specification: `evstar_kernels.reference.particle_filter.predict` (gyro_normals=, walk_normals=)."""
    i = wp.tid()
    bi = b[i]
    qi = block_rotation(q[i], bi, rotation, bias_jacobian)
    q[i] = block_end(qi, gyro_sigma, gyro_normals[i])
    b[i] = walk(bi, walk_sigma, walk_normals[i])


@wp.kernel
def counter_normals(seed: wp.uint32, step: wp.uint32, component0: wp.uint32,
                    out: wp.array2d(dtype=wp.float64)):
    """out[i, c] = normal of (seed, particle i, step, component0 + c).

    Specification: `evstar_kernels.reference.particle_filter.counter_normals`."""
    i, c = wp.tid()
    out[i, c] = counter_normal(counter_key(seed, wp.uint32(i), step), component0 + wp.uint32(c))


@wp.kernel
def add_log_likelihood(q: wp.array(dtype=wp.vec4d), stars: wp.array(dtype=wp.vec3d),
                       uv: wp.array(dtype=wp.vec2d), fx: wp.float64, fy: wp.float64,
                       cx: wp.float64, cy: wp.float64, inv_sigma: wp.float64, gate2: wp.float64,
                       logw: wp.array(dtype=wp.float64), first: wp.int32):
    """logw += Σ_j −½·min(|pinhole(R(q)·d_j) − uv_j|²/σ², gate²); a star behind costs gate²/2.
    Thread t scores particle first + t (a launch may cover a range of the particles).

    Specification: `evstar_kernels.reference.particle_filter.log_likelihood`."""
    i = wp.tid() + first
    qi = q[i]
    acc = wp.float64(0.0)
    for j in range(stars.shape[0]):
        c = quat_rotate(qi, stars[j])
        r2 = gate2
        if c[2] > wp.float64(0.0):
            ru = ((fx * c[0] / c[2] + cx) - uv[j][0]) * inv_sigma
            rv = ((fy * c[1] / c[2] + cy) - uv[j][1]) * inv_sigma
            r2 = wp.min(ru * ru + rv * rv, gate2)
        acc = acc - wp.float64(0.5) * r2
    logw[i] = logw[i] + acc


@wp.kernel
def weight_sums_sequential(logw: wp.array(dtype=wp.float64), q: wp.array(dtype=wp.vec4d),
                           b: wp.array(dtype=wp.vec3d), q_ref: wp.vec4d,
                           cdf: wp.array(dtype=wp.float64), sums: wp.array(dtype=wp.float64)):
    """One thread, index order: cdf = cumsum(w), sums = [Σw, Σw², Σ w·s·q, Σ w·b] (CPU path).

    Specification: `evstar_kernels.reference.particle_filter.weight_sums` (bit-identical)."""
    n = logw.shape[0]
    m = logw[0]
    for i in range(1, n):
        m = wp.max(m, logw[i])
    total = wp.float64(0.0)
    total2 = wp.float64(0.0)
    sq = wp.vec4d()
    sb = wp.vec3d()
    for i in range(n):
        w = wp.exp(logw[i] - m)
        qi = q[i]
        dot = qi[0] * q_ref[0] + qi[1] * q_ref[1] + qi[2] * q_ref[2] + qi[3] * q_ref[3]
        ws = w
        if dot < wp.float64(0.0):
            ws = -w
        total = total + w
        cdf[i] = total
        total2 = total2 + w * w
        sq = wp.vec4d(sq[0] + ws * qi[0], sq[1] + ws * qi[1], sq[2] + ws * qi[2], sq[3] + ws * qi[3])
        bi = b[i]
        sb = wp.vec3d(sb[0] + w * bi[0], sb[1] + w * bi[1], sb[2] + w * bi[2])
    sums[0] = total
    sums[1] = total2
    for c in range(4):
        sums[2 + c] = sq[c]
    for c in range(3):
        sums[6 + c] = sb[c]


@wp.kernel
def log_weight_max(logw: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    """out[0] = max(logw) by atomics: the shift of weight_terms (GPU path).

    Specification: the max that `evstar_kernels.reference.particle_filter.weight_sums` subtracts."""
    i = wp.tid()
    wp.atomic_max(out, 0, logw[i])


@wp.kernel
def weight_terms(logw: wp.array(dtype=wp.float64), q: wp.array(dtype=wp.vec4d),
                 b: wp.array(dtype=wp.vec3d), q_ref: wp.vec4d, max_logw: wp.array(dtype=wp.float64),
                 w_out: wp.array(dtype=wp.float64), sums: wp.array(dtype=wp.float64)):
    """Parallel form of weight_sums_sequential (GPU path): sums by atomics, cdf by a scan.

    Specification: `evstar_kernels.reference.particle_filter.weight_sums` (equal to rounding)."""
    i = wp.tid()
    w = wp.exp(logw[i] - max_logw[0])
    qi = q[i]
    dot = qi[0] * q_ref[0] + qi[1] * q_ref[1] + qi[2] * q_ref[2] + qi[3] * q_ref[3]
    ws = w
    if dot < wp.float64(0.0):
        ws = -w
    w_out[i] = w
    wp.atomic_add(sums, 0, w)
    wp.atomic_add(sums, 1, w * w)
    for c in range(4):
        wp.atomic_add(sums, 2 + c, ws * qi[c])
    bi = b[i]
    for c in range(3):
        wp.atomic_add(sums, 6 + c, w * bi[c])


@wp.func
def resample_position(u0: wp.float64, j: int, n: int, total: wp.float64):
    return (u0 + wp.float64(j)) / wp.float64(n) * total


@wp.kernel
def systematic_resample(cdf: wp.array(dtype=wp.float64), u0: wp.float64,
                        q_in: wp.array(dtype=wp.vec4d), b_in: wp.array(dtype=wp.vec3d),
                        q_out: wp.array(dtype=wp.vec4d), b_out: wp.array(dtype=wp.vec3d),
                        parent: wp.array(dtype=wp.int32), count: wp.int32):
    """Child j copies the first particle i with cdf[i] > (u0 + j)/N · cdf[N−1]. Thread t
    places children t·count .. (t+1)·count − 1: a binary search for the first, then a walk
    up the cdf (the positions rise with j), so one thread places all N children in O(N)
    (the CPU launch; N binary searches of mispredicted branches cost ~10x more) and a GPU
    runs count = 1.

    Specification: `evstar_kernels.reference.particle_filter.systematic_resample`."""
    n = cdf.shape[0]
    j0 = wp.tid() * count
    total = cdf[n - 1]
    pos = resample_position(u0, j0, n, total)
    lo = int(0)
    hi = n
    while lo < hi:  # numpy.searchsorted(cdf, pos, side="right")
        mid = (lo + hi) // 2
        if cdf[mid] <= pos:
            lo = mid + 1
        else:
            hi = mid
    for j in range(j0, wp.min(j0 + count, n)):
        pos = resample_position(u0, j, n, total)
        while lo < n:  # the same search, from the previous child's particle
            if cdf[lo] > pos:
                break
            lo = lo + 1
        i = wp.min(lo, n - 1)
        parent[j] = i
        q_out[j] = q_in[i]
        b_out[j] = b_in[i]
