"""Taichi kernels of the constant-velocity Kalman filter + RTS smoother and of its innovation
likelihood: one thread per track (per track and q for the likelihood). A track's steps are
sequential, tracks are not; the numpy batch steps every track together through Python, one
step at a time, which costs ~15 array operations per step whatever the track count.

Specification: evstar.kalman (cv_rts and innovation_loglik_one, numpy), term by term: state
(x, vx, y, vy), F = [[1, h], [0, 1]] per axis, Q = q·[[h³/3, h²/2], [h²/2, h]] with w·h
added to the position's variance, the Joseph
update and its like in the smoother (kalman._rts), the diffuse start about the first
position. Tracks are concatenated: track i holds steps start[i] .. start[i + 1] − 1 of the
flat arrays (int32 offsets: a smoother launch holds at most kalman_launch.MAX_STEPS steps, a
likelihood launch the tracks' steps, far below 2³¹).

The matrix algebra loops at run time over dynamically indexed local matrices, F's products
add h × the velocity rows or columns: Taichi's front end unrolls static loops and `@` into
one expression per term, and it runs in every process before the kernel can be looked up
in the offline cache (the unrolled smoother took ~1 s of each process's first call; this one
~0.3 s, and ~2 ms more per launch).
"""
import taichi as ti

from .arrays import f64_1d, f64_2d, f64_3d, i32_1d

mat4 = ti.types.matrix(4, 4, ti.f64)
mat2 = ti.types.matrix(2, 2, ti.f64)
vec4 = ti.types.vector(4, ti.f64)


@ti.func
def _noise(h: ti.f64, q: ti.f64, w: ti.f64) -> mat4:
    Q = mat4(0.0)
    for half in range(2):
        a = 2 * half
        Q[a, a] = q * (h ** 3 / 3) + w * h
        Q[a, a + 1] = q * (h ** 2 / 2)
        Q[a + 1, a] = q * (h ** 2 / 2)
        Q[a + 1, a + 1] = q * h
    return Q


@ti.func
def _f_times(A: mat4, h: ti.f64) -> mat4:
    """F @ A: F = [[1, h], [0, 1]] per axis adds h × each velocity row to its position row."""
    B = A
    for half, c in ti.ndrange(2, 4):
        B[2 * half, c] += h * A[2 * half + 1, c]
    return B


@ti.func
def _times_ft(A: mat4, h: ti.f64) -> mat4:
    """A @ Fᵀ."""
    B = A
    for r, half in ti.ndrange(4, 2):
        B[r, 2 * half] += h * A[r, 2 * half + 1]
    return B


@ti.func
def _times_f(A: mat4, h: ti.f64) -> mat4:
    """A @ F: adds h × each position column to its velocity column."""
    B = A
    for r, half in ti.ndrange(4, 2):
        B[r, 2 * half + 1] += h * A[r, 2 * half]
    return B


@ti.func
def _mm(A: mat4, B: mat4) -> mat4:
    C = mat4(0.0)
    for r, c in ti.ndrange(4, 4):
        s = A[r, 0] * B[0, c]
        for m in range(1, 4):
            s += A[r, m] * B[m, c]
        C[r, c] = s
    return C


@ti.func
def _mmt(A: mat4, B: mat4) -> mat4:
    """A @ Bᵀ."""
    return _mm(A, B.transpose())


@ti.func
def _mv(A: mat4, v: vec4) -> vec4:
    w = vec4(0.0)
    for r in range(4):
        s = A[r, 0] * v[0]
        for m in range(1, 4):
            s += A[r, m] * v[m]
        w[r] = s
    return w


@ti.func
def _inv4(A: mat4) -> mat4:
    """A⁻¹ by Gauss–Jordan elimination with partial pivoting (as LAPACK's LU, which numpy's
    inv uses: the cofactor formula loses digits on the filter's diffuse first steps, where
    entries span 12 orders of magnitude)."""
    M = A
    X = ti.Matrix.identity(ti.f64, 4)
    for c in range(4):
        piv = c
        big = ti.abs(M[c, c])
        for r in range(c + 1, 4):
            if ti.abs(M[r, c]) > big:
                big = ti.abs(M[r, c])
                piv = r
        if piv != c:
            for j in range(4):
                M[c, j], M[piv, j] = M[piv, j], M[c, j]
                X[c, j], X[piv, j] = X[piv, j], X[c, j]
        d = M[c, c]
        for j in range(4):
            M[c, j] /= d
            X[c, j] /= d
        for r in range(4):
            if r != c:
                f = M[r, c]
                for j in range(4):
                    M[r, j] -= f * M[c, j]
                    X[r, j] -= f * X[c, j]
    return X


@ti.func
def _get4(a: ti.template(), k: ti.i32) -> mat4:
    m = mat4(0.0)
    for r, c in ti.ndrange(4, 4):
        m[r, c] = a[k, r, c]
    return m


@ti.func
def _put4(a: ti.template(), k: ti.i32, m: mat4):
    for r, c in ti.ndrange(4, 4):
        a[k, r, c] = m[r, c]


@ti.func
def _getv(a: ti.template(), k: ti.i32) -> vec4:
    v = vec4(0.0)
    for r in range(4):
        v[r] = a[k, r]
    return v


@ti.func
def _putv(a: ti.template(), k: ti.i32, v: vec4):
    for r in range(4):
        a[k, r] = v[r]


@ti.kernel
def cv_rts(start: i32_1d, h: f64_1d, measured: i32_1d, z: f64_2d, R: f64_3d, q: f64_1d,
           w: f64_1d, diffuse: ti.f64, xp: f64_2d, Pp: f64_3d, xf: f64_2d, Pf: f64_3d, xs: f64_2d,
           Ps: f64_3d):
    """Filter then smooth each track; xp, Pp, xf, Pf: predicted and filtered scratch;
    xs, Ps: the smoothed states and covariances. z, R: per step (read where measured; the
    first step is measured and gives the start). The gain K (4×2) and R (2×2) are held in
    columns and rows 0 and 2 of 4×4 matrices, zero elsewhere (H picks x and y)."""
    for i in range(start.shape[0] - 1):
        a, b = start[i], start[i + 1]
        x = vec4(z[a, 0], 0.0, z[a, 1], 0.0)
        P = ti.Matrix.identity(ti.f64, 4) * diffuse
        for k in range(a, b):
            x[0] += h[k] * x[1]
            x[2] += h[k] * x[3]
            P = _times_ft(_f_times(P, h[k]), h[k]) + _noise(h[k], q[i], w[i])
            _putv(xp, k, x)
            _put4(Pp, k, P)
            if measured[k]:
                R4 = mat4(0.0)
                for r, c in ti.ndrange(2, 2):
                    R4[2 * r, 2 * c] = R[k, r, c]
                S = mat2([[P[0, 0] + R4[0, 0], P[0, 2] + R4[0, 2]],
                          [P[2, 0] + R4[2, 0], P[2, 2] + R4[2, 2]]]).inverse()
                K = mat4(0.0)
                for r, c in ti.ndrange(4, 2):
                    K[r, 2 * c] = P[r, 0] * S[0, c] + P[r, 2] * S[1, c]
                y0, y1 = z[k, 0] - x[0], z[k, 1] - x[2]
                for r in range(4):
                    x[r] = x[r] + (K[r, 0] * y0 + K[r, 2] * y1)
                IKH = ti.Matrix.identity(ti.f64, 4) - K
                P = _mmt(_mm(IKH, P), IKH) + _mmt(_mm(K, R4), K)
            _putv(xf, k, x)
            _put4(Pf, k, P)
        # Rauch–Tung–Striebel, backwards from the last step
        xn, Pn = x, P
        _putv(xs, b - 1, xn)
        _put4(Ps, b - 1, Pn)
        for j in range(b - a - 1):
            k = b - 2 - j
            Ppn = _get4(Pp, k + 1)
            Pk = _get4(Pf, k)
            G = _mm(_times_ft(Pk, h[k + 1]), _inv4(Ppn))
            xn = _getv(xf, k) + _mv(G, xn - _getv(xp, k + 1))
            A = ti.Matrix.identity(ti.f64, 4) - _times_f(G, h[k + 1])
            Pn = _mmt(_mm(A, Pk), A) + _mmt(_mm(G, _noise(h[k + 1], q[i], w[i]) + Pn), G)
            _putv(xs, k, xn)
            _put4(Ps, k, Pn)


@ti.func
def _huber(u: ti.f64, c: ti.f64) -> ti.f64:
    out = ti.f64(u / 2)
    if u > c * c:
        out = c * ti.sqrt(u) - c * c / 2
    return out


@ti.kernel
def innovation_loglik(start: i32_1d, ts: f64_1d, z: f64_2d, s2: f64_1d, q_grid: f64_1d,
                      v0_var: ti.f64, huber_c: ti.f64, w: ti.f64, ll: f64_2d):
    """ll[i, g]: the log-likelihood of track i's innovations under q_grid[g] and the
    position random walk w, both axes (every step measured with per-axis variance s2; the
    first two steps left out)."""
    n_q = q_grid.shape[0]
    for i, g in ti.ndrange(start.shape[0] - 1, n_q):
        a, b = start[i], start[i + 1]
        q = q_grid[g]
        total = ti.f64(0.0)
        for axis in range(2):
            p, v = z[a, axis], ti.f64(0.0)
            p00, p01, p11 = s2[a], ti.f64(0.0), v0_var
            acc = ti.f64(0.0)
            for k in range(a + 1, b):
                hk = ts[k] - ts[k - 1]
                p = p + hk * v
                p00 = p00 + 2 * hk * p01 + hk * hk * p11 + q * hk ** 3 / 3 + w * hk
                p01 = p01 + hk * p11 + q * hk * hk / 2
                p11 = p11 + q * hk
                s = p00 + s2[k]
                y = z[k, axis] - p
                if k >= a + 2:
                    acc -= 0.5 * ti.log(s) + _huber(y * y / s, huber_c)
                k0, k1 = p00 / s, p01 / s
                p, v = p + k0 * y, v + k1 * y
                p11 = p11 - k1 * p01
                p00, p01 = (1 - k0) * p00, (1 - k0) * p01
            total += acc
        ll[i, g] = total
