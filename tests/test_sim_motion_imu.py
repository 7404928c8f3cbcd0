"""Trajectories and the IMU model: rates consistent with attitudes (dR_cw/dt = −[ω]× R_cw),
the gyro integrating to the true attitude, calibration, noise levels and accelerometer."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from evstar import sim


def numeric_omega(traj, t, h=1e-6):
    """ω from the attitude alone: R(t+h) R(t−h)ᵀ = Exp(−2h ω)."""
    step = traj.rotation([t + h])[0] @ traj.rotation([t - h])[0].T
    return -Rotation.from_matrix(step).as_rotvec() / (2 * h)


def integrate(omega, t_s, R0, midpoint=False):
    """R_cw by the exponential map, independent of evstar: the rate over step k is the mean of
    the samples k and k+1 (trapezoid) or, with midpoint=True, omega[k] itself."""
    R = [R0]
    for k in range(len(t_s) - 1):
        w = omega[k] if midpoint else 0.5 * (omega[k] + omega[k + 1])
        R.append(Rotation.from_rotvec(-w * (t_s[k + 1] - t_s[k])).as_matrix() @ R[-1])
    return np.array(R)


def angle_between(A, B):
    return np.linalg.norm(Rotation.from_matrix(A @ np.transpose(B, (0, 2, 1))).as_rotvec(), axis=-1)


R_TILT = Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix()
TRAJECTORIES = {
    "constant": sim.ConstantRate(15.0, axis=(0.3, -1.0, 0.2), R0=R_TILT),
    "sinusoid": sim.Sinusoid(10.0, 1.0, phase_deg=30.0),
    "sampled": sim.SampledTrajectory(np.linspace(0, 1, 11), Rotation.from_rotvec(
        np.outer(np.linspace(0, 1, 11) ** 2, [0.1, 0.4, -0.2])).as_matrix()),
    "slew": sim.Slew(20.0, 1.0, axis=(0.0, 1.0, 0.2), R0=R_TILT),
    "function": sim.FunctionTrajectory(lambda t: Rotation.from_rotvec(
        np.outer(np.sin(3 * t), [0.2, -0.1, 0.05])).as_matrix()),
    "jitter": sim.Jitter(sim.ConstantRate(15.0, axis=(0.3, -1.0, 0.2), R0=R_TILT), 0.2, 12.0,
                         (1.0, 0.0, 0.0), phase_deg=20.0),
}


@pytest.mark.parametrize("name", TRAJECTORIES)
def test_rates_match_the_attitude_derivative(name):
    traj = TRAJECTORIES[name]
    for t in (0.13, 0.47, 0.81):
        assert traj.omega([t])[0] == pytest.approx(numeric_omega(traj, t), abs=1e-6)


@pytest.mark.parametrize("name", ["constant", "sinusoid", "sampled", "slew", "jitter"])
def test_integrating_the_rate_reproduces_the_attitude(name):
    traj = TRAJECTORIES[name]
    t = np.linspace(0, 1, 2001)
    mid = traj.omega(0.5 * (t[1:] + t[:-1]))     # midpoint rule: exact for piecewise-constant rates
    R = integrate(mid, t, traj.rotation([0.0])[0], midpoint=True)
    assert angle_between(R, traj.rotation(t)).max() < 1e-6


def test_jitter_turns_its_base_about_a_camera_axis():
    """A platform's vibration: R_cw = Exp(−axis·A sin(2π f t))·R_base; a star on the optical
    axis swings across the image by A about the x axis while the base pans it along x."""
    base = sim.ConstantRate(5.0)
    jit = sim.Jitter(base, 0.1, 10.0, (1.0, 0.0, 0.0))
    t = np.array([0.0, 0.025, 0.075, 0.3])
    theta = np.radians(0.1) * np.sin(2 * np.pi * 10.0 * t)
    expect = Rotation.from_rotvec(-theta[:, None] * [1.0, 0.0, 0.0]).as_matrix() @ base.rotation(t)
    assert np.allclose(jit.rotation(t), expect, atol=1e-15)
    with pytest.raises(ValueError, match="base"):
        sim.Jitter("pan", 0.1, 10.0, (1.0, 0.0, 0.0))


def test_sampled_trajectory_passes_through_its_table():
    traj = TRAJECTORIES["sampled"]
    assert angle_between(traj.rotation(traj.t), traj.R).max() < 1e-12


def test_sinusoid_angle_and_rate():
    traj = sim.Sinusoid(10.0, 1.0)
    assert np.degrees(np.linalg.norm(Rotation.from_matrix(traj.rotation([0.25])[0]).as_rotvec())) \
        == pytest.approx(10.0)
    assert np.linalg.norm(traj.omega([0.0])[0]) == pytest.approx(math.radians(10.0) * 2 * math.pi)


def test_a_slew_goes_rest_to_rest_peaking_midway():
    traj = sim.Slew(20.0, 1.0)
    rate = np.degrees(np.linalg.norm(traj.omega([0.0, 0.25, 0.5, 0.75, 1.0, 1.5]), axis=1))
    np.testing.assert_allclose(rate, [0, 10, 20, 10, 0, 0], atol=1e-9)
    turned = np.degrees(np.linalg.norm(Rotation.from_matrix(traj.rotation([1.0, 2.0])).as_rotvec(), axis=1))
    np.testing.assert_allclose(turned, [10.0, 10.0])           # ½ · 20 °/s · 1 s, then at rest
    accel = np.degrees(traj.omega_dot([0.2, 0.8]) @ traj.axis)     # along the turn axis
    np.testing.assert_allclose(accel, [40.0, -40.0])


def test_attitude_from_radec_points_the_optical_axis_with_north_up():
    R = sim.attitude_from_radec(83.8, -5.4)
    ra, dec = math.radians(83.8), math.radians(-5.4)
    target = [math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)]
    assert R @ target == pytest.approx([0, 0, 1], abs=1e-12)
    assert (R @ [0, 0, 1])[1] < 0            # the north pole is up (−y) in the image
    assert np.linalg.det(R) == pytest.approx(1.0)


@pytest.mark.parametrize("motion", [sim.ConstantRate(12.0), sim.Sinusoid(10.0, 1.0)])
def test_integrating_the_true_gyro_reproduces_the_true_attitude(motion):
    """Through the IMU's calibration: a rotated IMU with a clock offset, read back in the
    camera frame and clock, integrates to the truth's attitude."""
    R_ci = Rotation.from_euler("zyx", [90, 5, -3], degrees=True).as_matrix()
    cam = sim.camera_preset("dvxplorer-lite")
    scn = sim.Scenario(cam, sim.single_star(), motion, 0.5, sensor=sim.SensorSpec.ideal(),
                       imu=sim.ImuSpec.ideal(R_cam_imu=R_ci, time_offset_us=-1500), t_start_us=10_000)
    run = sim.simulate(scn, seed=0)
    imu, truth = run.imu, run.truth
    assert imu.t[0] == 10_000 + 1500 and imu.t_cam[0] == 10_000 and imu.t_cam[-1] == 510_000
    assert not np.allclose(imu.gyro, imu.gyro_cam)         # the IMU frame is not the camera's
    t_s = imu.t_cam * 1e-6
    R = integrate(imu.gyro_cam, t_s, truth.rotation_at(imu.t_cam[:1])[0])
    assert angle_between(R, truth.rotation_at(imu.t_cam)).max() < 1e-6
    # the truth table's own rate integrates likewise
    R2 = integrate(truth.omega_cam, truth.t_us * 1e-6, truth.rotation_at(truth.t_us[:1])[0])
    assert angle_between(R2, truth.rotation_at(truth.t_us)).max() < 1e-6


def test_gyro_noise_bias_and_bias_walk_have_the_set_sizes():
    spec = sim.ImuSpec(rate_hz=800.0, gyro_noise_density=2e-4, gyro_bias=(0.01, -0.02, 0.03),
                       gyro_bias_walk=0.0, accel_noise_density=3e-3, accel_bias=(0.1, 0.2, -0.1),
                       accel_bias_walk=0.0)
    cam = sim.camera_preset("dvxplorer-lite")
    scn = sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(0.0), 10.0,
                       sensor=sim.SensorSpec.ideal(), imu=spec)
    run = sim.simulate(scn, seed=1)
    g, a = run.imu.gyro, run.imu.accel
    assert g.mean(0) == pytest.approx([0.01, -0.02, 0.03], abs=4 * 2e-4 * math.sqrt(800 / len(g)))
    assert g.std(0) == pytest.approx(np.full(3, 2e-4 * math.sqrt(800)), rel=0.05)
    # at rest the accelerometer reads the specific force −g: "up", −y in the camera frame
    assert a.mean(0) == pytest.approx([0.1, 0.2 - 9.80665, -0.1], abs=1e-3)
    assert a.std(0) == pytest.approx(np.full(3, 3e-3 * math.sqrt(800)), rel=0.05)
    walk = sim.simulate(scn.replace(imu=sim.ImuSpec.ideal(gyro_bias_walk=1e-3)), seed=1).truth.gyro_bias
    steps = np.diff(walk, axis=0)
    assert steps.std() == pytest.approx(1e-3 * math.sqrt(1 / 1000.0), rel=0.05)


def test_accelerometer_sees_the_centripetal_acceleration_of_a_lever_arm():
    w = math.radians(90.0)
    spec = sim.ImuSpec.ideal(lever_arm_m=(0.0, 0.0, 0.2), gravity_world=(0, 0, 0))
    scn = sim.Scenario(sim.camera_preset("davis346"), sim.StarField.empty(), sim.ConstantRate(90.0), 0.1,
                       sensor=sim.SensorSpec.ideal(), imu=spec)
    accel = sim.simulate(scn, seed=0).imu.accel_cam
    assert accel == pytest.approx(np.tile([0, 0, -w * w * 0.2], (len(accel), 1)), abs=1e-9)


def test_invalid_settings_name_the_parameter():
    with pytest.raises(ValueError, match="rate_hz"):
        sim.ImuSpec(rate_hz=0)
    with pytest.raises(ValueError, match="R_cam_imu"):
        sim.ImuSpec(R_cam_imu=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="axis"):
        sim.ConstantRate(10.0, axis=(0, 0, 0))
    with pytest.raises(ValueError, match="t_s"):
        sim.SampledTrajectory([0.0, 0.0], np.stack([np.eye(3)] * 2))
