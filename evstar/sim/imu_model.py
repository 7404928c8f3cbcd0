"""IMU model: gyroscope and accelerometer on the camera, with noise, bias and calibration.

Truth first, in the camera frame and clock (docs/design.md): the gyro reads the body rate ω with
dR_cw/dt = −[ω]× R_cw; the accelerometer reads the specific force f = a − g, where a is the
acceleration of a point `lever_arm_m` away from the rotation centre (ω̇ × r + ω × (ω × r)) and
g is gravity, fixed in the world frame. Then the sensor: readings are rotated into the IMU
frame (R_cam_imu maps IMU vectors into the camera), a constant bias, a bias random walk and
white noise are added, and the timestamps are written in the IMU clock,
t_imu = t_camera − time_offset_us — the inverse of what :class:`evstar.Imu` undoes.

Noise is given as densities: white noise of density n per √Hz becomes n·√rate per sample, a
bias walk of density w becomes steps of w·√(1/rate).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..imu import Imu
from ..errors import ParameterError

STANDARD_GRAVITY = 9.80665


def _vec(name, v):
    a = np.asarray(v, np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ParameterError(f"ImuSpec.{name} must be a finite 3-vector, got {v!r}")
    return tuple(float(x) for x in a)


@dataclass(frozen=True)
class ImuSpec:
    """A MEMS IMU (BMI160-class noise by default) rigidly mounted with the camera."""

    rate_hz: float = 1000.0
    gyro_noise_density: float = 1.2e-4              # rad/s/√Hz (≈ 0.007 °/s/√Hz)
    gyro_bias: tuple = (2e-3, -1e-3, 1.5e-3)        # rad/s, IMU frame (≈ 0.1 °/s)
    gyro_bias_walk: float = 2e-5                    # rad/s²/√Hz
    accel_noise_density: float = 1.8e-3             # m/s²/√Hz (≈ 180 µg/√Hz)
    accel_bias: tuple = (0.05, -0.03, 0.04)         # m/s², IMU frame
    accel_bias_walk: float = 1e-4                   # m/s³/√Hz
    R_cam_imu: tuple | None = None                  # IMU -> camera rotation (identity if None)
    time_offset_us: int = 0                         # t_camera = t_imu + offset
    lever_arm_m: tuple = (0.0, 0.0, 0.0)            # camera from the rotation centre, camera frame
    # gravity in the scenario's world frame: the paper presets' world is the camera at t = 0
    # (y down); star fields use the celestial frame, where the local vertical must be given
    gravity_world: tuple = (0.0, STANDARD_GRAVITY, 0.0)

    def __post_init__(self):
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ParameterError(f"ImuSpec.rate_hz must be positive, got {self.rate_hz!r}")
        for name in ("gyro_noise_density", "gyro_bias_walk", "accel_noise_density", "accel_bias_walk"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"ImuSpec.{name} must be >= 0, got {v!r}")
        for name in ("gyro_bias", "accel_bias", "lever_arm_m", "gravity_world"):
            object.__setattr__(self, name, _vec(name, getattr(self, name)))
        if self.R_cam_imu is not None:
            R = np.asarray(self.R_cam_imu, np.float64)
            if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
                raise ParameterError("ImuSpec.R_cam_imu must be a 3x3 rotation matrix")
            object.__setattr__(self, "R_cam_imu", tuple(map(tuple, R.tolist())))
        if int(self.time_offset_us) != self.time_offset_us:
            raise ParameterError(f"ImuSpec.time_offset_us must be an integer, got {self.time_offset_us!r}")

    @classmethod
    def ideal(cls, **overrides):
        """Noise- and bias-free readings (for tests and ground truth)."""
        base = dict(gyro_noise_density=0.0, gyro_bias=(0, 0, 0), gyro_bias_walk=0.0,
                    accel_noise_density=0.0, accel_bias=(0, 0, 0), accel_bias_walk=0.0)
        base.update(overrides)
        return cls(**base)

    @property
    def rotation(self):
        return np.eye(3) if self.R_cam_imu is None else np.array(self.R_cam_imu)


def true_motion(trajectory, t_s, spec):
    """(ω, specific force) in the camera frame at camera times t_s, without sensor errors."""
    w = trajectory.omega(t_s)
    r = np.array(spec.lever_arm_m)
    acc = np.cross(trajectory.omega_dot(t_s), r) + np.cross(w, np.cross(w, r))
    g_cam = trajectory.rotation(t_s) @ np.array(spec.gravity_world)
    return w, acc - g_cam


def _bias_series(rng, bias, walk_density, n, rate_hz):
    steps = rng.standard_normal((n, 3)) * (walk_density * math.sqrt(1.0 / rate_hz))
    steps[0] = 0.0
    return np.asarray(bias) + np.cumsum(steps, axis=0)


def simulate_imu(trajectory, spec, duration_s, t_start_us, rng):
    """Imu covering camera times [t_start, t_start + duration] (inclusive), and the true
    biases (gyro, accel) in the IMU frame at each sample."""
    n = int(math.ceil(duration_s * spec.rate_hz)) + 1
    t_cam_us = t_start_us + np.rint(np.arange(n) * (1e6 / spec.rate_hz)).astype(np.int64)
    t_s = (t_cam_us - t_start_us) * 1e-6
    w_cam, f_cam = true_motion(trajectory, t_s, spec)
    R = spec.rotation
    sigma_g = spec.gyro_noise_density * math.sqrt(spec.rate_hz)
    sigma_a = spec.accel_noise_density * math.sqrt(spec.rate_hz)
    b_g = _bias_series(rng, spec.gyro_bias, spec.gyro_bias_walk, n, spec.rate_hz)
    b_a = _bias_series(rng, spec.accel_bias, spec.accel_bias_walk, n, spec.rate_hz)
    gyro = w_cam @ R + b_g + sigma_g * rng.standard_normal((n, 3))      # row form of Rᵀ·ω
    accel = f_cam @ R + b_a + sigma_a * rng.standard_normal((n, 3))
    imu = Imu(t_cam_us - int(spec.time_offset_us), gyro, accel, R_cam_imu=R,
              time_offset_us=int(spec.time_offset_us))
    return imu, b_g, b_a
