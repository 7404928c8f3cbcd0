"""IMU integration on SO(3): alignment, coverage errors, interpolation, slerp, accelerometer."""
import math

import numpy as np
import pytest

from evstar import DataError, Imu
from evstar.motion import AttitudeTrack, check_coverage, integrate_accel, interpolate
from evstar_kernels.reference import so3

DEG = math.pi / 180


def angle_between(qa, qb):
    return np.linalg.norm(so3.quat_log(so3.quat_mul(qa, so3.quat_conj(qb))), axis=-1)


def constant_rate_imu(omega_cam, *, rate_hz=1000, duration_s=1.0, R_cam_imu=None, offset_us=0):
    t = np.arange(0, int(duration_s * 1e6) + 1, int(1e6 / rate_hz))
    R = np.eye(3) if R_cam_imu is None else R_cam_imu
    gyro_imu = np.tile(R.T @ omega_cam, (len(t), 1))  # what an IMU turned by R_cam_imu reads
    return Imu(t, gyro_imu, R_cam_imu=R, time_offset_us=offset_us)


def test_constant_rate_track_with_extrinsics_and_time_offset():
    omega = np.array([0.1, -0.25, 0.05])
    R = so3.exp_so3([0.4, -1.2, 2.0])
    imu = constant_rate_imu(omega, R_cam_imu=R, offset_us=2500)
    q0 = so3.quat_exp([0.2, 0.1, 0.3])
    track = AttitudeTrack.from_imu(imu, q0=q0, t0_us=400_000)
    t = np.linspace(2500, 1_002_500, 997)  # camera clock = IMU clock + 2500 µs
    expect = so3.quat_mul(so3.quat_exp(-np.outer((t - 400_000) * 1e-6, omega)), q0)
    assert angle_between(track.at(t), expect).max() < 1e-12


def test_track_nodes_and_slerp_between_them():
    rng = np.random.default_rng(3)
    imu = Imu(np.arange(0, 50_000, 1000), rng.normal(size=(50, 3)))
    track = AttitudeTrack.from_imu(imu)
    np.testing.assert_allclose(np.abs(np.sum(track.at(track.t_us) * track.q_cw, 1)), 1, atol=1e-14)
    # halfway between two nodes the attitude is the mid-rotation of the step
    mid = track.at(track.t_us[:-1] + 500)
    half = so3.quat_mul(so3.quat_exp(-0.5e-3 * 0.5 * (imu.gyro[1:] + imu.gyro[:-1])), track.q_cw[:-1])
    assert angle_between(mid, half).max() < 1e-13


def test_sinusoidal_motion_integrates_to_the_analytic_angle():
    # rate about a fixed axis: ω(t) = A·2πf·cos(2πft)  =>  angle(t) = A·sin(2πft)
    amp, f = 10 * DEG, 1.0
    axis = np.array([0.0, -1.0, 0.0])
    t = np.arange(0, 2_000_001, 1000)
    w = amp * 2 * math.pi * f * np.cos(2 * math.pi * f * t * 1e-6)
    track = AttitudeTrack.from_imu(Imu(t, np.outer(w, axis)))
    t_ev = np.linspace(0, 2e6, 3331)
    expect = so3.quat_exp(-np.outer(amp * np.sin(2 * math.pi * f * t_ev * 1e-6), axis))
    # trapezoid rule on a 1 kHz grid: global error ~ A·(2πf)³·dt²/12 per second of motion,
    # ~2e-6 rad (0.0001°, a few thousandths of a pixel); the same with 10x fewer samples is ~100x worse
    err = angle_between(track.at(t_ev), expect).max()
    assert 1e-8 < err < 3e-6
    coarse = AttitudeTrack.from_imu(Imu(t[::10], np.outer(w[::10], axis)))
    assert 50 * err < angle_between(coarse.at(t_ev), expect).max() < 200 * err


def test_extrapolation_only_within_the_margin():
    omega = np.array([0.0, 0.3, 0.0])
    track = AttitudeTrack.from_imu(constant_rate_imu(omega, duration_s=0.1))
    with pytest.raises(DataError, match="covers 0..100000"):
        track.at([100_001])
    q = track.at([105_000], extrapolate_us=5000)
    expect = so3.quat_exp(-omega * 0.105)
    assert angle_between(q, expect[None]).max() < 1e-12


def test_interpolate_is_linear_in_camera_time():
    imu = Imu([0, 1000, 2000], [[0, 0, 0], [1, 2, 3], [1, 2, 3]], [[0, 0, 0], [0, 0, 10], [0, 0, 10]],
              time_offset_us=100)
    g, a = interpolate(imu, [100, 600, 1600])
    np.testing.assert_allclose(g, [[0, 0, 0], [0.5, 1, 1.5], [1, 2, 3]])
    np.testing.assert_allclose(a[:, 2], [0, 5, 10])


def test_coverage_errors_are_clear():
    imu = constant_rate_imu(np.zeros(3), duration_s=0.01)
    check_coverage(imu, 0, 10_000)
    with pytest.raises(DataError, match=r"IMU covers 0..10000 µs .* span 0..20000"):
        check_coverage(imu, 0, 20_000)
    with pytest.raises(DataError, match="at least 2"):
        check_coverage(Imu([0], [[0, 0, 0]]), 0, 0)
    imu.gyro[4, 1] = np.nan  # corrupted after validation
    with pytest.raises(DataError, match="non-finite value at sample 4"):
        check_coverage(imu, 0, 10_000)
    with pytest.raises(DataError, match="IMU timestamps repeat at sample 2"):
        Imu([0, 5, 5, 9], np.zeros((4, 3)))               # refused as it is made
    imu.gyro[4, 1] = 0.0
    imu.t[3] = imu.t[2]                                     # ... or corrupted after
    with pytest.raises(DataError, match="increase strictly"):
        check_coverage(imu, 0, 9_000)


def test_constant_acceleration_double_integration():
    t = np.arange(0, 1_000_001, 1000)
    acc = np.tile([0.5, -1.0, 2.0], (len(t), 1))
    kin = integrate_accel(Imu(t, np.zeros_like(acc), acc), v0=(1, 0, 0), p0=(0, 0, 5))
    ts = t * 1e-6
    np.testing.assert_allclose(kin.velocity, np.array([1, 0, 0]) + np.outer(ts, acc[0]), atol=1e-12)
    np.testing.assert_allclose(kin.position, np.array([0, 0, 5]) + np.outer(ts, [1, 0, 0])
                               + 0.5 * np.outer(ts ** 2, acc[0]), atol=1e-9)
    v, p = kin.at([500_000])
    np.testing.assert_allclose(v[0], [1.25, -0.5, 1.0])


def test_rotating_camera_at_rest_cancels_gravity_with_attitude():
    # the camera spins in place about its x axis; its accelerometer reads +g "up" (world +z)
    omega = np.array([1.0, 0.0, 0.0])
    t = np.arange(0, 2_000_001, 1000)
    q = so3.quat_exp(-np.outer(t * 1e-6, omega))
    accel_cam = so3.quat_rotate(q, np.array([0.0, 0.0, 9.81]))
    imu = Imu(t, np.tile(omega, (len(t), 1)), accel_cam)
    kin = integrate_accel(imu, AttitudeTrack.from_imu(imu), gravity_world=(0, 0, -9.81))
    assert np.abs(kin.velocity).max() < 1e-9 and np.abs(kin.position).max() < 1e-9
    # without the attitude the same data seem to accelerate: the paper's assumption matters
    assert np.abs(integrate_accel(imu, gravity_world=(0, 0, -9.81)).position).max() > 1e-3


def test_around_keeps_the_samples_bracketing_an_interval():
    imu = Imu(np.arange(0, 10_000, 1000), np.zeros((10, 3)), time_offset_us=500)   # camera 500..9500
    assert imu.around(2_000, 4_000).t_cam.tolist() == [1_500, 2_500, 3_500, 4_500]
    assert imu.around(2_500, 3_500).t_cam.tolist() == [2_500, 3_500]
    assert imu.around(-5_000, 0).t_cam.tolist() == [500, 1_500]          # before: the first two
    assert imu.around(20_000, 30_000).t_cam.tolist() == [8_500, 9_500]   # after: the last two


def test_a_long_gap_in_the_imu_is_warned_about():
    import warnings

    from evstar.errors import EvstarWarning

    imu = constant_rate_imu(np.zeros(3), duration_s=1.0)
    keep = (imu.t < 300_000) | (imu.t > 500_000)
    gap = Imu(imu.t[keep], imu.gyro[keep], imu.accel[keep])
    with pytest.warns(EvstarWarning, match=r"no sample for 0\.2.* s \(299000\.\.501000 µs\)"):
        check_coverage(gap, 0, 1_000_000)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_coverage(imu, 0, 1_000_000)          # a regular IMU: nothing to say
        check_coverage(gap, 600_000, 900_000)      # the gap outside the span: nothing either
