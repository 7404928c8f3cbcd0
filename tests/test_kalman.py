"""The batched constant-velocity Kalman filter + RTS smoother equals filterpy's, and the
batched innovation likelihood the per-track one, on random tracks: missing measurements,
repeated times, diagonal and full covariances, process noise from 0 to 10⁶ px²/s³."""
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
    return kalman.CVProblem(ts, measured, z, R, q)


@pytest.fixture(scope="module")
def problems():
    rng = np.random.default_rng(3)
    return [problem(rng, int(n), i % 2) for i, n in enumerate([1, 2, 3, *rng.integers(4, 120, 13)])]


def test_filter_and_smoother_equal_filterpy(problems):
    ours, ref = kalman.cv_rts(problems), kalman.cv_rts_filterpy(problems)
    for p, (x, P), (xr, Pr) in zip(problems, ours, ref):
        assert x.shape == (len(p.ts), 4) and P.shape == (len(p.ts), 4, 4)
        np.testing.assert_allclose(x[:, [0, 2]], xr[:, [0, 2]], rtol=0, atol=1e-9)   # px
        np.testing.assert_allclose(x[:, [1, 3]], xr[:, [1, 3]], rtol=0, atol=1e-7)   # px/s
        np.testing.assert_allclose(P, Pr, rtol=1e-9, atol=1e-9 * np.abs(Pr).max())


def test_a_track_comes_out_the_same_alone_or_padded_in_a_batch(problems):
    alone = [kalman.cv_rts([p])[0] for p in problems]
    for (x, P), (xa, Pa) in zip(kalman.cv_rts(problems), alone):
        assert np.array_equal(x, xa) and np.array_equal(P, Pa)


@pytest.mark.parametrize("engine,rtol", [("numpy", 1e-12), ("taichi", 1e-9)])
def test_batched_likelihood_equals_the_per_track_one(problems, engine, rtol):
    """The numpy batch and the Taichi kernel (a thread per track and q) against the
    per-track reference."""
    rng = np.random.default_rng(4)
    tracks = [(p.ts[p.measured], p.z, rng.uniform(0.02, 0.5, len(p.z))) for p in problems
              if p.measured.sum() >= 4]
    run = kalman.innovation_loglik if engine == "numpy" else kalman.innovation_loglik_taichi
    for t, ll in zip(tracks, run(tracks, GRID)):
        ref = kalman.innovation_loglik_one(*t, GRID)
        np.testing.assert_allclose(ll, ref, rtol=rtol)
        assert np.argmax(ll) == np.argmax(ref)


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



def test_taichi_launches_split_into_batches_come_out_the_same(problems, monkeypatch):
    from evstar_kernels.taichi import kalman_launch

    whole = kalman.cv_rts_taichi(problems)
    monkeypatch.setattr(kalman_launch, "MAX_STEPS", 150)
    for (x, P), (xs, Ps) in zip(kalman.cv_rts_taichi(problems), whole):
        assert np.array_equal(x, xs) and np.array_equal(P, Ps)
