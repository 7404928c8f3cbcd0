"""The batched constant-velocity Kalman filter + RTS smoother equals filterpy's, and the
batched innovation likelihood the per-track one, on random tracks: missing measurements,
repeated times, diagonal and full covariances, process noise from 0 to 10⁶ px²/s³, with and
without a position random walk (a velocity prior's noise)."""
import numpy as np
import pytest

from evstar import kalman

GRID = np.r_[0.0, np.logspace(-2, 9, 45)]


def problem(rng, n, full):
    ts = np.cumsum(np.r_[0.0, rng.exponential(0.01, n - 1)])
    if n > 6:
        ts[4:6] = ts[3]                                   # steps at one time
    measured = rng.random(n) < 0.7
    measured[0] = True
    m = int(measured.sum())
    z = 100 + np.cumsum(rng.normal(0, 1, (m, 2)), 0)
    if full:                                              # along-track crossings: axes coupled
        a = rng.normal(size=(m, 2, 2))
        R = a @ a.transpose(0, 2, 1) * 0.01 + np.eye(2) * 1e-4
    else:
        R = kalman.diagonal_covariances(rng.uniform(0.02, 0.5, m))
    q = 0.0 if rng.random() < 0.2 else float(10 ** rng.uniform(-2, 6))
    w = 0.0 if rng.random() < 0.5 else float(10 ** rng.uniform(-3, 1))
    return kalman.CVProblem(ts, measured, z, R, q, w)


@pytest.fixture(scope="module")
def problems():
    rng = np.random.default_rng(3)
    return [problem(rng, int(n), i % 2) for i, n in enumerate([1, 2, 3, *rng.integers(4, 120, 13)])]


def _exact(p, digits=60):
    """The filter + smoother in 60-digit decimal arithmetic (filterpy's formulas, its
    P + G (Pˢ − P⁻) Gᵀ, Gauss–Jordan inverses): smoothed covariances (n, 4, 4), exact to
    float64 for these problems."""
    import decimal

    ctx = decimal.Context(prec=digits)
    D = lambda v: ctx.create_decimal_from_float(float(v))          # noqa: E731

    def mm(A, B):
        return [[sum((A[i][k] * B[k][j] for k in range(len(B))), D(0)) for j in range(len(B[0]))]
                for i in range(len(A))]

    def tr(A):
        return [list(r) for r in zip(*A)]

    def add(A, B, sign=1):
        return [[a + sign * b for a, b in zip(ra, rb)] for ra, rb in zip(A, B)]

    def inv(A):
        n = len(A)
        M = [list(r) + [D(i == j) for j in range(n)] for i, r in enumerate(A)]
        for c in range(n):
            piv = max(range(c, n), key=lambda r: abs(M[r][c]))
            M[c], M[piv] = M[piv], M[c]
            M[c] = [v / M[c][c] for v in M[c]]
            for r in range(n):
                if r != c:
                    M[r] = [a - M[r][c] * b for a, b in zip(M[r], M[c])]
        return [r[n:] for r in M]

    with decimal.localcontext(ctx):
        H = [[D(1), D(0), D(0), D(0)], [D(0), D(0), D(1), D(0)]]
        P = [[D(kalman.DIFFUSE) * D(i == j) for j in range(4)] for i in range(4)]
        Fs, Qs, Pps, Pfs, m = [], [], [], [], 0
        for k in range(len(p.ts)):
            h = D(p.ts[k]) - D(p.ts[k - 1]) if k else D(0)
            F = [[D(i == j) for j in range(4)] for i in range(4)]
            F[0][1] = F[2][3] = h
            q, w = D(p.q), D(p.w)
            Q = [[D(0)] * 4 for _ in range(4)]
            for i in (0, 2):
                Q[i][i], Q[i][i + 1] = q * h ** 3 / 3 + w * h, q * h ** 2 / 2
                Q[i + 1][i], Q[i + 1][i + 1] = q * h ** 2 / 2, q * h
            P = add(mm(mm(F, P), tr(F)), Q)
            Fs.append(F)
            Pps.append(P)
            if p.measured[k]:
                R = [[D(v) for v in row] for row in p.R[m]]
                m += 1
                K = mm(mm(P, tr(H)), inv(add(mm(mm(H, P), tr(H)), R)))
                IKH = add([[D(i == j) for j in range(4)] for i in range(4)], mm(K, H), -1)
                P = add(mm(mm(IKH, P), tr(IKH)), mm(mm(K, R), tr(K)))
            Pfs.append(P)
        Ps = [None] * len(p.ts)
        Ps[-1] = Pfs[-1]
        for k in range(len(p.ts) - 2, -1, -1):
            G = mm(mm(Pfs[k], tr(Fs[k + 1])), inv(Pps[k + 1]))
            Ps[k] = add(Pfs[k], mm(mm(G, add(Ps[k + 1], Pps[k + 1], -1)), tr(G)))
        return np.array([[[float(v) for v in r] for r in M] for M in Ps])


def test_filter_and_smoother_equal_filterpy(problems):
    """States as filterpy's. The smoothed covariances (kalman._rts: another form, equal in
    exact arithmetic) as the exact ones, where filterpy's float64 difference form is off
    by up to 60 % on these problems (a negative velocity variance on one)."""
    ours, ref = kalman.cv_rts(problems), kalman.cv_rts_filterpy(problems)
    worst_filterpy = 0.0
    for p, (x, P), (xr, Pr) in zip(problems, ours, ref):
        assert x.shape == (len(p.ts), 4) and P.shape == (len(p.ts), 4, 4)
        np.testing.assert_allclose(x[:, [0, 2]], xr[:, [0, 2]], rtol=0, atol=1e-9)   # px
        np.testing.assert_allclose(x[:, [1, 3]], xr[:, [1, 3]], rtol=0, atol=1e-7)   # px/s
        if len(p.ts) <= 40:
            exact, tol = _exact_and_tolerance(p)
            assert (np.abs(P - exact) <= tol).all()
            worst_filterpy = max(worst_filterpy, (np.abs(Pr - exact) / tol).max())
    assert worst_filterpy > 1                 # the cases that need the Joseph-like form


def _exact_and_tolerance(p):
    """_exact(p) and 1e-6 of σ_i σ_j per entry (σ: the exact per-step standard deviations)."""
    exact = _exact(p)
    scale = np.sqrt(np.einsum("nii->ni", exact))
    return exact, 1e-6 * scale[:, :, None] * scale[:, None, :] + 1e-12


def _ill_conditioned(seed):
    """A track as the crossings refit builds it (smoothing._along_track_problem): coasted
    steps first (no measurement, diffuse prior), centroids every 10 ms (two of them outliers,
    σ 1e4 px: weightless) and between them crossings, σ 0.02 px along the motion, 1e4 px
    across."""
    rng = np.random.default_rng(seed)
    u = np.array([np.cos(0.3), np.sin(0.3)])
    n = np.array([-u[1], u[0]])
    across = 0.02 ** 2 * np.outer(u, u) + 1e4 ** 2 * np.outer(n, n)
    steps = [(0.01 * j, None, None) for j in range(5)]           # (t, z, R); None: coasted
    for j in range(5, 20):
        t = 0.01 * j + rng.uniform(0, 2e-3)
        for k, tk in enumerate([t, *(t + rng.uniform(1e-4, 1e-3, 2))]):
            R = across if k else np.eye(2) * (1e4 if j in (5, 8) else 0.02) ** 2
            steps.append((tk, 300 * u * tk + rng.normal(0, 0.02, 2), R))
    steps.sort(key=lambda s: s[0])
    meas = [s for s in steps if s[1] is not None]
    return kalman.CVProblem(np.array([s[0] for s in steps]),
                            np.array([s[1] is not None for s in steps]),
                            np.array([s[1] for s in meas]), np.array([s[2] for s in meas]), 56.0)


def test_smoothed_variances_stay_positive_on_ill_conditioned_tracks():
    """filterpy's P + G (Pˢ − P⁻) Gᵀ cancels every digit on such tracks (negative variances:
    σ reported as 0 on the 50-star field; where its rounding comes out positive, the
    variances of the first steps are off by orders of magnitude — with numpy 2.4 on one
    seed of six); the Joseph-like form (kalman._rts) stays positive, and equals filterpy's
    on the same track made well conditioned (every covariance's eigenvalues capped at 1 px²)
    from its first measurement on (before it, the coasted steps' diffuse prior cancels
    digits in filterpy's form whatever R is: 0.13 % at the first step of one seed with
    filterpy 2.0.0)."""
    failed = 0
    for seed in range(6):
        p = _ill_conditioned(seed)
        [(x, P)], [(xr, Pr)] = kalman.cv_rts([p]), kalman.cv_rts_filterpy([p])
        var, var_r = P[:, [0, 2], [0, 2]], Pr[:, [0, 2], [0, 2]]
        assert (var > 0).all()
        np.testing.assert_allclose(x[:, [0, 2]], xr[:, [0, 2]], atol=1e-6)
        failed += not (var_r > 0).all()
        w, V = np.linalg.eigh(p.R)
        tame = p._replace(R=np.einsum("nij,nj,nkj->nik", V, np.minimum(w, 1.0), V))
        [(_, P)], [(_, Pr)] = kalman.cv_rts([tame]), kalman.cv_rts_filterpy([tame])
        seen = np.argmax(p.measured)
        np.testing.assert_allclose(P[seen:, [0, 2], [0, 2]], Pr[seen:, [0, 2], [0, 2]], rtol=1e-3)
    assert failed >= 3            # the case is the ill-conditioned one


def test_a_track_comes_out_the_same_alone_or_padded_in_a_batch(problems):
    alone = [kalman.cv_rts([p])[0] for p in problems]
    for (x, P), (xa, Pa) in zip(kalman.cv_rts(problems), alone):
        assert np.array_equal(x, xa) and np.array_equal(P, Pa)


@pytest.mark.parametrize("w", [0.0, 0.2])
@pytest.mark.parametrize("engine,rtol", [("numpy", 1e-12), ("taichi", 1e-9)])
def test_batched_likelihood_equals_the_per_track_one(problems, engine, rtol, w):
    """The numpy batch and the Taichi kernel (a thread per track and q) against the
    per-track reference, with and without a position random walk w."""
    rng = np.random.default_rng(4)
    tracks = [(p.ts[p.measured], p.z, rng.uniform(0.02, 0.5, len(p.z))) for p in problems
              if p.measured.sum() >= 4]
    run = kalman.innovation_loglik if engine == "numpy" else kalman.innovation_loglik_taichi
    for t, ll in zip(tracks, run(tracks, GRID, w)):
        ref = kalman.innovation_loglik_one(*t, GRID, w)
        np.testing.assert_allclose(ll, ref, rtol=rtol)
        assert np.argmax(ll) == np.argmax(ref)


def test_the_likelihood_finds_a_random_walk_in_the_positions():
    """A track wandering as a random walk of density 0.2 px²/s (a prior's gyro noise) is
    likelier with that w than with none, and the likelihood peaks near it on a w grid; a
    straight noisy track prefers none."""
    rng = np.random.default_rng(8)
    ts = np.arange(300) * 0.01
    walk = np.cumsum(rng.normal(0, np.sqrt(0.2 * 0.01), (300, 2)), 0)
    sigma = np.full(300, 0.02)
    wander = (ts, 50 + walk + rng.normal(0, 0.02, (300, 2)), sigma)
    straight = (ts, 50 + rng.normal(0, 0.02, (300, 2)), sigma)
    ws = [0.0, 0.02, 0.2, 2.0]
    best = [[float(kalman.innovation_loglik([t], GRID, w)[0].max()) for w in ws]
            for t in (wander, straight)]
    assert ws[int(np.argmax(best[0]))] == 0.2
    assert ws[int(np.argmax(best[1]))] == 0.0


@pytest.mark.parametrize("engine", ["numpy", "taichi"])
def test_a_straight_track_is_followed_exactly(engine):
    """No noise, no process noise: the smoother returns the line (a check that does not
    lean on filterpy)."""
    ts = np.linspace(0, 1, 50)
    z = np.column_stack([3 + 40 * ts, 7 - 12 * ts])
    p = kalman.CVProblem(ts, np.ones(50, bool), z, kalman.diagonal_covariances(np.full(50, 0.1)), 0.0)
    x, P = (kalman.cv_rts if engine == "numpy" else kalman.cv_rts_taichi)([p])[0]
    np.testing.assert_allclose(x[:, [0, 2]], z, atol=1e-6)
    np.testing.assert_allclose(x[:, [1, 3]], np.tile([40.0, -12.0], (50, 1)), atol=1e-5)
    assert np.all(P[:, 0, 0] > 0) and np.all(P[:, 0, 0] < 0.1 ** 2)


def test_tracks_split_into_several_batches_come_out_the_same(problems, monkeypatch):
    whole = kalman.cv_rts(problems)
    monkeypatch.setattr(kalman, "_MAX_CELLS", 300)                # a few tracks a batch
    assert len(kalman._groups([len(p.ts) for p in problems])) > 3
    for (x, P), (xs, Ps) in zip(kalman.cv_rts(problems), whole):
        assert np.array_equal(x, xs) and np.array_equal(P, Ps)


# -- the Taichi kernels against their numpy specification ---------------------------------
def test_taichi_filter_and_smoother_equal_the_numpy_batch(problems):
    """Not bit for bit (the kernel's 4×4 inverse is Gauss–Jordan, numpy's LAPACK's LU), but
    positions to 1e-7 px, and velocities and covariances wherever the state is known: the
    diffuse first steps (variance ~1e8) carry the rounding of ill-conditioned sums."""
    ours, ref = kalman.cv_rts_taichi(problems), kalman.cv_rts(problems)
    for p, (x, P), (xr, Pr) in zip(problems, ours, ref):
        assert x.shape == (len(p.ts), 4) and P.shape == (len(p.ts), 4, 4)
        np.testing.assert_allclose(x[:, [0, 2]], xr[:, [0, 2]], rtol=0, atol=1e-7)      # px
        known = Pr[:, 1, 1] < 1e4                            # velocity variance (px/s)²
        np.testing.assert_allclose(x[known][:, [1, 3]], xr[known][:, [1, 3]], rtol=0, atol=1e-3)
        # a covariance of the first steps is a difference of ~1e8 terms in both
        pos = np.ix_(np.flatnonzero(known), [0, 2], [0, 2])
        np.testing.assert_allclose(P[pos], Pr[pos], rtol=0.1)
        later = np.ix_(np.flatnonzero(known & (np.arange(len(p.ts)) >= 3)), [0, 2], [0, 2])
        np.testing.assert_allclose(P[later], Pr[later], rtol=1e-6, atol=1e-12)
        if len(p.ts) <= 40:
            exact, tol = _exact_and_tolerance(p)
            assert (np.abs(P[known] - exact[known]) <= tol[known]).all()



def test_taichi_launches_split_into_batches_come_out_the_same(problems, monkeypatch):
    from evstar_kernels.taichi import kalman_launch

    whole = kalman.cv_rts_taichi(problems)
    monkeypatch.setattr(kalman_launch, "MAX_STEPS", 150)
    for (x, P), (xs, Ps) in zip(kalman.cv_rts_taichi(problems), whole):
        assert np.array_equal(x, xs) and np.array_equal(P, Ps)
