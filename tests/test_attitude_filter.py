"""The attitude MEKF (evstar.attitude.filter) and the estimator around it.

Scenes are Hipparcos stars seen along simulator trajectories with centroids from the
simulator's true positions plus noise (evstar.attitude.oracle.synthetic_run), identified
by the truth (the simulator's world frame is ICRS): fast, and with exact ground truth.
"""
import math
import warnings

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter, rts_smoother
from scipy.spatial.transform import Rotation

import evstar
from evstar import Imu, sim
from evstar.errors import EvstarWarning
from evstar.attitude import AttitudeEstimator, Fix, Mekf, estimate, ra_dec_roll, rotation
from evstar.attitude.filter import exp_so3, log_so3, smooth
from evstar.attitude.oracle import synthetic_run, truth_identifier

CAM = sim.camera_preset("davis346", 16.0)          # f ≈ 865 px
R0 = sim.attitude_from_radec(83.8, -5.4, 20.0)     # Orion


@pytest.fixture(scope="module")
def pan():
    return synthetic_run(sim.ConstantRate(20.0, R0=R0), CAM, 0.3, sigma_px=0.05, mag_limit=4.5)


def errors_px(rows, truth):
    """Cross-boresight (x focal length) and about-boresight (x half diagonal) errors, px."""
    R = rotation(np.stack([rows["qw"], rows["qx"], rows["qy"], rows["qz"]], 1))
    rv = Rotation.from_matrix(truth.rotation_at(rows["t"]) @ R).as_rotvec()   # R_cw · R_ic
    cam = truth.camera
    return np.hypot(rv[:, 0], rv[:, 1]) * cam.fx, np.abs(rv[:, 2]) * math.hypot(cam.width, cam.height) / 2


# -- the filter steps against references -----------------------------------------------------
def star_dirs(R, n, rng):
    d = (R @ np.c_[rng.uniform(-0.2, 0.2, (n, 2)), np.ones(n)].T).T
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def state(mode, scale, rng):
    """(s, P) of a filter: [ω, α] in rate mode, the bias in imu mode."""
    n = 6 if mode == "rate" else 3
    return scale * rng.normal(size=n), np.eye(n + 3)


@pytest.mark.parametrize("mode", ["rate", "imu"])
def test_jacobian_is_the_derivative_of_the_prediction(mode):
    rng = np.random.default_rng(1)
    f = Mekf(exp_so3(rng.normal(size=3)), *state(mode, 0.3, rng), mode)
    gyro = rng.normal(size=3)
    d, dt, z = star_dirs(f.R, 4, rng), np.array([-3e-3, -1e-3, 0.0, 2e-3]), np.zeros((4, 2))

    def rates(filt):
        return None if mode == "rate" else np.tile(gyro - filt.s, (4, 1))

    r0, H = f.residuals(z, d, dt, rates(f))
    numeric = np.zeros_like(H)
    for k in range(len(f.P)):
        g, e = f.copy(), np.eye(len(f.P))[k] * 1e-7
        g.R, g.s = f.R @ exp_so3(e[:3]), f.s + e[3:]
        numeric[:, :, k] = -(g.residuals(z, d, dt, rates(g))[0] - r0) / 1e-7
    np.testing.assert_allclose(H, numeric, atol=2e-5)


@pytest.mark.parametrize("mode", ["rate", "imu"])
def test_covariance_prediction_is_the_linearised_error_propagation(mode):
    """Without process noise P' = F P Fᵀ, F from finite differences of the error after one
    step (to the first order in ω·dt the filter keeps); with it, P' grows by a PSD Q."""
    rng = np.random.default_rng(2)
    f = Mekf(exp_so3(rng.normal(size=3)), *state(mode, 0.5, rng), mode)
    gyro, dt, n = rng.normal(size=3), 0.01, len(f.P)
    ref = f.copy()
    ref.predict(dt, gyro)
    F = np.zeros((n, n))
    for k in range(n):
        g, e = f.copy(), np.eye(n)[k] * 1e-7
        g.R, g.s = f.R @ exp_so3(e[:3]), f.s + e[3:]
        g.predict(dt, gyro)
        F[:3, k] = Rotation.from_matrix(ref.R.T @ g.R).as_rotvec() / 1e-7
        F[3:, k] = (g.s - ref.s) / 1e-7
    P0 = np.diag(rng.uniform(0.1, 1.0, n))
    f.P = P0.copy()
    f.predict(dt, gyro)
    np.testing.assert_allclose(f.P, F @ P0 @ F.T, atol=np.abs(f.rate(gyro)).max() * dt * dt)
    noisy = Mekf(f.R, f.s, P0, mode, gyro_noise=1e-3, bias_walk=1e-4, jerk_noise=10.0)
    noisy.predict(dt, gyro)
    f.P = P0.copy()
    f.predict(dt, gyro)
    Q = noisy.P - f.P
    assert np.allclose(Q, Q.T) and np.linalg.eigvalsh(Q)[0] >= -1e-15 and np.trace(Q) > 0


def test_joint_update_is_filterpys_kalman_update():
    rng = np.random.default_rng(3)
    f = Mekf(exp_so3(rng.normal(size=3)), 0.1 * rng.normal(size=3), np.diag([1e-6] * 3 + [1e-2] * 3), "imu")
    d = star_dirs(f.R, 5, rng)
    z = f.residuals(np.zeros((5, 2)), d)[0] * -1 + rng.normal(0, 1e-4, (5, 2))   # predicted + noise
    sigma = np.full((5, 2), 1e-4)
    r, H = f.residuals(z, d)
    kf = KalmanFilter(dim_x=6, dim_z=10)
    kf.x, kf.P, kf.H, kf.R = np.zeros(6), f.P.copy(), H.reshape(10, 6), np.eye(10) * 1e-8
    kf.update(r.reshape(10))
    s0, R0_ = f.s.copy(), f.R.copy()
    assert f.update(z, d, sigma).all()
    np.testing.assert_allclose(f.s - s0, kf.x[3:], atol=1e-12)
    np.testing.assert_allclose(Rotation.from_matrix(R0_.T @ f.R).as_rotvec(), kf.x[:3], atol=1e-12)
    np.testing.assert_allclose(f.P, kf.P, rtol=1e-6, atol=1e-18)


def test_gate_leaves_out_an_outlier():
    rng = np.random.default_rng(4)
    f = Mekf(np.eye(3), np.zeros(6), np.diag([1e-6] * 3 + [1e-2] * 6), "rate")
    d = star_dirs(f.R, 6, rng)
    z = -f.residuals(np.zeros((6, 2)), d)[0]
    z[2] += 0.01                                         # ~9 px off at f = 865
    used = f.update(z, d, np.full((6, 2), 1e-4), gate=5.0)
    assert used.tolist() == [True, True, False, True, True, True]


def test_log_is_the_inverse_of_exp():
    rng = np.random.default_rng(7)
    for phi in rng.normal(0, 1, (20, 3)):
        np.testing.assert_allclose(log_so3(exp_so3(phi)), phi, atol=1e-9)
    np.testing.assert_allclose(log_so3(exp_so3(np.array([1e-9, 0, 0]))), [1e-9, 0, 0], atol=1e-15)


def test_smoother_is_filterpys_rts_on_the_error_state():
    """Attitudes fixed at R0 and no coupling of the state into them: the pass is the linear
    RTS smoother of the rest (filterpy's), and the attitude stays put."""
    rng = np.random.default_rng(8)
    n = 3
    A = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    F = np.eye(n + 3)
    F[3:, 3:] = A
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.F, kf.Q, kf.H, kf.R = A, 0.01 * np.eye(n), rng.normal(size=(1, n)), np.eye(1) * 0.1
    kf.x, kf.P = rng.normal(size=n), np.eye(n)
    nodes, Xs, Ps = [], [], []
    for k in range(12):
        if k:
            kf.predict()
        x_pred, P_pred = kf.x.copy(), kf.P.copy()
        kf.update(rng.normal(size=1))
        block = lambda P: np.block([[np.eye(3) * 1e-3, np.zeros((3, n))], [np.zeros((n, 3)), P]])
        nodes.append(dict(F=F, R_pred=R0, s_pred=x_pred, P_pred=block(P_pred), R=R0,
                          s=kf.x.copy(), P=block(kf.P), row=k))
        Xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
    xs, Pss, _, _ = rts_smoother(np.array(Xs), np.array(Ps), [A] * 12, [kf.Q] * 12)
    out = smooth(nodes)
    np.testing.assert_allclose([s for _, s, _ in out], xs, atol=1e-12)
    np.testing.assert_allclose([P[3:, 3:] for _, _, P in out], Pss, atol=1e-12)
    assert all(np.allclose(R, R0, atol=1e-12) for R, _, _ in out)


def test_smoothed_rows_beat_the_causal_filter_and_end_equal(pan):
    """The gyro's noise between frames and the constant-acceleration model's lag are what
    the causal rows carry; the smoothed rows are nearer the truth, and the last row, which
    has no later data, is the causal one."""
    c, truth, imu = pan
    for use in (None, imu):
        smooth_rows, causal = (estimate(c, CAM, use, identifier=truth_identifier(truth), smooth=on)
                               for on in (True, False))
        assert len(smooth_rows) == len(causal)
        e_s, e_c = (np.sqrt(np.mean(errors_px(r, truth)[0][5:] ** 2)) for r in (smooth_rows, causal))
        assert e_s < 0.9 * e_c
        last = [smooth_rows[-1][k] for k in ("qw", "qx", "qy", "qz")]
        np.testing.assert_allclose(last, [causal[-1][k] for k in ("qw", "qx", "qy", "qz")], atol=1e-12)


# -- convergence on simulated truth -------------------------------------------------------
def test_attitude_error_small_after_updates_without_imu(pan):
    c, truth, _ = pan
    rows = estimate(c, CAM, identifier=truth_identifier(truth))
    cross, about = errors_px(rows, truth)
    assert rows["t"][0] < 25_000 and len(rows) >= 27
    assert np.sqrt(np.mean(cross[5:] ** 2)) < 0.05 and np.sqrt(np.mean(about[5:] ** 2)) < 0.1
    w = np.stack([rows["wx"], rows["wy"], rows["wz"]], 1)
    err = np.abs(w[5:] - truth.omega_cam[0]).max(0)
    assert err[:2].max() < math.radians(0.5) and err[2] < math.radians(2)   # roll rate: weakest


def test_gyro_bias_is_estimated_with_an_imu(pan):
    c, truth, imu = pan
    est = AttitudeEstimator(CAM, imu, identifier=truth_identifier(truth))
    rows = est.run(c)
    cross, about = errors_px(rows, truth)
    assert np.sqrt(np.mean(cross[5:] ** 2)) < 0.05 and np.sqrt(np.mean(about[5:] ** 2)) < 0.1
    bias = truth.gyro_bias[-1] @ truth.R_cam_imu.T
    assert np.linalg.norm(est.filt.s - bias) < 0.2 * np.linalg.norm(bias)


def test_a_gyro_record_with_spikes_is_repaired_first(pan):
    """Ten samples at 50x their rate (evstar.gyro_repair removes them): the same attitude."""
    c, truth, imu = pan
    g = imu.gyro.copy()
    g[100:110] *= 50
    spiked = Imu(imu.t, g, imu.accel, R_cam_imu=imu.R_cam_imu, time_offset_us=imu.time_offset_us)
    with pytest.warns(EvstarWarning, match="10 spike sample"):
        rows = AttitudeEstimator(CAM, spiked, identifier=truth_identifier(truth)).run(c)
    cross, _ = errors_px(rows, truth)
    assert np.sqrt(np.mean(cross[5:] ** 2)) < 0.05
    # motion.repair_gyro off (Config.attitude_options carries it): the record as it is
    options = evstar.Config().replace(**{"motion.repair_gyro": False}).attitude_options()
    with warnings.catch_warnings():
        warnings.simplefilter("error", EvstarWarning)
        rows = AttitudeEstimator(CAM, spiked, identifier=truth_identifier(truth), **options).run(c)
    assert np.sqrt(np.mean(errors_px(rows, truth)[0][5:] ** 2)) > 1.0


def test_sinusoid_is_followed_without_imu():
    c, truth, _ = synthetic_run(sim.Sinusoid(10.0, 1.0, R0=R0), CAM, 0.4, sigma_px=0.05, mag_limit=4.5)
    rows = estimate(c, CAM, identifier=truth_identifier(truth))
    cross, about = errors_px(rows, truth)
    assert np.sqrt(np.mean(cross ** 2)) < 0.1 and cross.max() < 0.5 and about.max() < 0.5


# -- conventions ----------------------------------------------------------------------------
def test_catalogue_star_projected_with_the_output_lands_on_its_centroid(pan):
    c, truth, _ = pan
    rows = estimate(c, CAM, identifier=truth_identifier(truth))
    r = rows[10]
    R_ic = rotation([[r["qw"], r["qx"], r["qy"], r["qz"]]])[0]
    near = c[np.abs(c["t"] - r["t"]) <= 0]
    assert len(near) >= 3
    xy = CAM.project(truth.stars.directions[near["track"]] @ R_ic)    # d in camera: R_icᵀ d
    np.testing.assert_allclose(xy, np.stack([near["x"], near["y"]], 1), atol=0.25)


def test_quaternion_is_unit_scalar_first_and_roll_matches_attitude_from_radec():
    rng = np.random.default_rng(6)
    for _ in range(20):
        ra, dec, roll = rng.uniform(0, 360), rng.uniform(-85, 85), rng.uniform(-179, 179)
        R_ic = sim.attitude_from_radec(ra, dec, roll).T
        q = evstar.attitude.quaternion(R_ic)
        assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-12
        np.testing.assert_allclose(rotation([q])[0], R_ic, atol=1e-12)
        got = ra_dec_roll(R_ic)
        np.testing.assert_allclose(got, (ra, dec, roll), atol=1e-8)


def test_rate_hz_1000_gives_rows_every_millisecond(pan):
    c, truth, imu = pan
    for use_imu in (None, imu):
        rows = estimate(c, CAM, use_imu, rate_hz=1000, identifier=truth_identifier(truth))
        assert np.all(np.diff(rows["t"]) == 1000) and len(rows) > 250
        cross, _ = errors_px(rows, truth)
        assert np.sqrt(np.mean(cross[50:] ** 2)) < 0.05     # predictions between updates


# -- bad inputs -----------------------------------------------------------------------------
def test_no_camera_is_a_parameter_error(pan):
    with pytest.raises(evstar.ParameterError, match="camera"):
        estimate(pan[0], None, identifier=truth_identifier(pan[1]))


def test_too_few_stars_gives_no_rows_and_says_why(pan):
    c, truth, _ = pan
    est = AttitudeEstimator(CAM, identifier=truth_identifier(truth, min_stars=1000))
    rows = est.run(c)
    assert len(rows) == 0 and est.fixes and {s for _, s, _ in est.fixes} == {"too_few_stars"}


def test_no_solution_gives_no_rows(pan):
    def never(xy, t_us, weight=None):
        return Fix(t_us, False, "no_solution", np.full(4, np.nan))

    est = AttitudeEstimator(CAM, identifier=never)
    assert len(est.run(pan[0])) == 0 and est.fixes[0][1] == "no_solution"
    assert len(est.fixes) == 30         # 300 ms: while lost, every 10 ms frame is searched
    est = AttitudeEstimator(CAM, identifier=never, lost_retry_ms=100)
    assert len(est.run(pan[0])) == 0
    assert len(est.fixes) == 3          # a failed search retried every 100 ms


def test_bad_options_and_inputs_are_evstar_errors(pan):
    with pytest.raises(evstar.ParameterError, match="rate_hz"):
        estimate(pan[0], CAM, rate_hz=0, identifier=truth_identifier(pan[1]))
    with pytest.raises(evstar.ParameterError, match="unknown attitude option"):
        estimate(pan[0], CAM, rate=3, identifier=truth_identifier(pan[1]))
    with pytest.raises(evstar.ParameterTypeError, match="centroids"):
        estimate(np.zeros(3), CAM, identifier=truth_identifier(pan[1]))
    assert len(estimate(pan[0][:0], CAM, identifier=truth_identifier(pan[1]))) == 0


def test_a_gap_is_coasted_and_new_tracks_are_identified_again(pan):
    """No centroids for 60 ms, then the stars come back under new track ids: rows go on
    (coasting), the new tracks are identified and the error stays small after the gap."""
    c, truth, imu = pan
    c = c[(c["t"] < 100_000) | (c["t"] > 160_000)].copy()
    c["track"][c["t"] > 160_000] += 1000
    for use in (None, imu):
        est = AttitudeEstimator(CAM, use, identifier=truth_identifier(truth))
        rows = est.run(c)
        assert np.all(np.diff(rows["t"]) == 10_000)                 # no frame without a row
        gap = (rows["t"] > 110_000) & (rows["t"] < 160_000)
        assert set(rows["status"][gap]) == {"coasting"} and np.all(rows["n_stars"][gap] == 0)
        assert len(est.fixes) >= 2 and est.fixes[-1][0] > 160_000
        cross, about = errors_px(rows, truth)
        after = rows["t"] > 200_000
        assert rows["status"][after].tolist() == ["tracking"] * after.sum()
        assert cross[after].max() < 0.1 and about[after].max() < 0.2


def test_centroid_delay_moves_the_centroid_times(pan):
    """Centroids stamped 2 ms before the star was where they say: a 20 °/s pan then lags by
    2 ms (~0.6 px); centroid_delay_us = 2000 puts the times right."""
    c, truth, _ = pan
    early = c.copy()
    early["t"] -= 2000
    late = estimate(early, CAM, identifier=truth_identifier(truth))
    fixed = estimate(early, CAM, identifier=truth_identifier(truth), centroid_delay_us=2000)
    lag = np.sqrt(np.mean(errors_px(late, truth)[0][5:] ** 2))
    assert lag > 0.3 and np.sqrt(np.mean(errors_px(fixed, truth)[0][5:] ** 2)) < 0.05


def test_pooled_centroids_identify_but_update_only_when_asked(pan):
    """The pipeline's pooled centroids (a mean over several frames, biased under an
    acceleration) are left out of the updates by default: shifted by 1 px they move the
    attitude only with pooled_centroids on."""
    c, truth, _ = pan
    c = c.copy()
    pooled = c["track"] % 2 == 1
    c["source"][pooled] = "pooled"
    c["x"][pooled] += 1.0
    err = {on: errors_px(estimate(c, CAM, identifier=truth_identifier(truth), pooled_centroids=on),
                         truth)[0] for on in (False, True)}
    assert np.sqrt(np.mean(err[False] ** 2)) < 0.05 < 0.3 < np.sqrt(np.mean(err[True] ** 2))


def test_an_imu_that_does_not_reach_the_centroids_is_refused(pan):
    """An IMU 10 s late (or with a repeated timestamp) is a DataError naming the spans, not
    a run driven by its end samples' rate; one that misses the centroids' ends by less than
    motion.extrapolate_us is held there, as the pipeline holds it."""
    c, truth, imu = pan
    ident = truth_identifier(truth)
    late = evstar.Imu(imu.t + 10_000_000, imu.gyro, imu.accel, R_cam_imu=imu.R_cam_imu)
    with pytest.raises(evstar.DataError, match="IMU .*centroids|the IMU starts"):
        estimate(c, CAM, late, identifier=ident)
    t = imu.t.copy()
    t[5] = t[4]
    with pytest.raises(evstar.DataError, match="IMU timestamps repeat at sample 5"):
        evstar.Imu(t, imu.gyro, imu.accel, R_cam_imu=imu.R_cam_imu)   # refused as it is made
    inside = (imu.t >= c["t"].min() + 2000) & (imu.t <= c["t"].max() - 2000)
    short = evstar.Imu(imu.t[inside], imu.gyro[inside], imu.accel[inside], R_cam_imu=imu.R_cam_imu)
    assert len(estimate(c, CAM, short, identifier=ident)) > 0
