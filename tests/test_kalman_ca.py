"""The constant-acceleration filter + smoother (evstar.kalman_ca) against filterpy's, and
what the model buys: a steady acceleration followed to the track's ends."""
import numpy as np
import pytest

from evstar import kalman, kalman_ca


def _problem(rng, n=120, accel=300.0, noise=0.05, q=1e5, jerk=0.0):
    """Positions x = 10 + 20t + a·t²/2 (+ a jerk's t³/6), y = 5 − 3t at random times over
    0.6 s, two steps unmeasured, per-axis noise σ `noise`."""
    ts = np.sort(rng.uniform(0, 0.6, n))
    ts[0] = 0.0
    x = 10 + 20 * ts + accel * ts**2 / 2 + jerk * ts**3 / 6
    y = 5 - 3 * ts
    meas = np.ones(n, bool)
    meas[[5, 17]] = False
    z = np.column_stack([x, y])[meas] + noise * rng.standard_normal((meas.sum(), 2))
    R = kalman.diagonal_covariances(np.full(meas.sum(), noise))
    return kalman.CVProblem(ts, meas, z, R, q), x, y


def _filterpy(p):
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=6, dim_z=2)
    kf.H = np.zeros((2, 6))
    kf.H[0, 0] = kf.H[1, 3] = 1.0
    kf.x = np.array([p.z[0, 0], 0, 0, p.z[0, 1], 0, 0.0])
    kf.P = np.eye(6) * kalman.DIFFUSE
    h = np.r_[0.0, np.diff(p.ts)]
    F, Q = kalman_ca._transitions(h[:, None], np.full((len(h), 1, 2), p.q))
    zs, Rs = [None] * len(h), [kf.R] * len(h)
    for k, i in enumerate(np.flatnonzero(p.measured)):
        zs[i], Rs[i] = p.z[k], p.R[k]
    mu, cov, _, _ = kf.batch_filter(zs, Fs=list(F[:, 0]), Qs=list(Q[:, 0]), Rs=Rs)
    x, P, _, _ = kf.rts_smoother(mu, cov, Fs=list(F[:, 0]), Qs=list(Q[:, 0]))
    cv = [0, 1, 3, 4]
    return x[:, cv], P[:, cv][:, :, cv]


def test_smoother_equals_filterpy():
    rng = np.random.default_rng(1)
    for q in (1e2, 1e5, 1e9):
        p, _, _ = _problem(rng, q=q)
        (x, P), = kalman_ca.ca_rts([p])
        x_ref, P_ref = _filterpy(p)
        np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-9)
        for i in (0, 2):   # the positions' variances (filterpy's differences lose digits elsewhere)
            np.testing.assert_allclose(P[:, i, i], P_ref[:, i, i], rtol=1e-6)


def test_tracks_batched_come_out_as_alone():
    rng = np.random.default_rng(2)
    problems = [_problem(rng, n=n)[0] for n in (40, 120, 75)]
    together = kalman_ca.ca_rts(problems)
    for p, (x, P) in zip(problems, together):
        (x1, P1), = kalman_ca.ca_rts([p])
        np.testing.assert_allclose(x, x1, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(P, P1, rtol=1e-9, atol=1e-12)
    lls = kalman_ca.loglik(problems)
    for p, ll in zip(problems, lls):
        np.testing.assert_allclose(ll, kalman_ca.loglik([p])[0], rtol=1e-12)


def test_a_steady_acceleration_is_followed_to_the_ends():
    """A star speeding up at 300 px/s²: the constant-acceleration smoother's positions and
    velocities are within the noise at both ends, where the constant-velocity one, with the
    q its own likelihood picks, bends the track straight."""
    rng = np.random.default_rng(3)
    p, x, y = _problem(rng, noise=0.03)
    q = kalman_ca.best([p])[0][0]
    (xa, _), = kalman_ca.ca_rts([p._replace(q=q)])
    ends = np.r_[0:8, len(x) - 8:len(x)]
    v_true = 20 + 300.0 * p.ts
    assert np.abs(xa[ends, 0] - x[ends]).max() < 0.06
    assert np.abs(xa[:, 1] - v_true).max() < 3.0
    grid = np.r_[0.0, np.logspace(-2, 9, 45)]
    zc = np.column_stack([np.interp(p.ts[p.measured], p.ts, x), np.interp(p.ts[p.measured], p.ts, y)])
    ll = kalman.innovation_loglik([(p.ts[p.measured], p.z, np.full(len(zc), 0.03))], grid)[0]
    (xc, _), = kalman.cv_rts([p._replace(q=max(grid[np.argmax(ll)], 1.0))])
    assert np.abs(xc[ends, 0] - x[ends]).max() > 2 * np.abs(xa[ends, 0] - x[ends]).max()


@pytest.mark.parametrize("jerk, low", [(0.0, True), (2e4, False)])
def test_the_likelihood_picks_no_jerk_for_a_steady_acceleration(jerk, low):
    """A steady acceleration needs no jerk noise: the grid's least q; a changing one more."""
    rng = np.random.default_rng(4)
    p, _, _ = _problem(rng, noise=0.02, jerk=jerk)
    q = kalman_ca.best([p])[0][0]
    assert (q == kalman_ca.Q_GRID[0]) == low


def test_each_axis_takes_its_own_process_noise():
    """q = (along, across) scales each axis's block alone; equal values are the scalar q."""
    rng = np.random.default_rng(5)
    p, _, _ = _problem(rng)
    h = np.array([[0.0], [0.01]])
    F, Q = kalman_ca._transitions(h, np.array([[[1e6, 1e2]], [[1e6, 1e2]]]))
    _, Q1 = kalman_ca._transitions(h, np.full((2, 1, 2), 1e6))
    np.testing.assert_allclose(Q[1, 0, :3, :3], Q1[1, 0, :3, :3])
    np.testing.assert_allclose(Q[1, 0, 3:, 3:], Q1[1, 0, 3:, 3:] * 1e-4)
    (x2, _), = kalman_ca.ca_rts([p._replace(q=(1e5, 1e5))])
    (x1, _), = kalman_ca.ca_rts([p._replace(q=1e5)])
    np.testing.assert_array_equal(x1, x2)
    # the grid over the first axis alone, the second fixed
    ll = kalman_ca.loglik([p], second=1e2)[0]
    assert ll.shape == kalman_ca.Q_GRID.shape and np.isfinite(ll).all()
    assert not np.allclose(ll, kalman_ca.loglik([p])[0])


def test_a_track_smoothed_in_its_own_frame_and_turned_back_is_the_same_track():
    """evstar.smoothing fits a speeding track in its frame (along, across its motion); with
    the same q on both axes the model is isotropic, so turning there and back changes
    nothing but rounding."""
    from evstar.smoothing import _turned, _unturned

    rng = np.random.default_rng(6)
    p, _, _ = _problem(rng)
    R = p.R.copy()
    R[:, 0, 1] = R[:, 1, 0] = 0.5 * p.R[:, 0, 0]     # correlated axes, as crossings give
    p = p._replace(R=R)
    u = np.array([np.cos(0.7), np.sin(0.7)])
    (x, P), = kalman_ca.ca_rts([p])
    (xt, Pt), = kalman_ca.ca_rts([_turned(p, u)])
    xb, Pb = _unturned(xt, Pt, u)
    np.testing.assert_allclose(xb, x, rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(Pb[:, [0, 2], [0, 2]], P[:, [0, 2], [0, 2]], rtol=1e-6)
