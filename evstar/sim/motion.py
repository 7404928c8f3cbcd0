"""Camera attitude trajectories: turntable at a constant rate, sinusoid, user-supplied.

Conventions (docs/design.md): R_cw(t) maps world vectors into the camera frame (x right, y down,
z along the optical axis); ω(t) is the body rate in the camera frame, what an ideal gyro
aligned with the camera reads, and dR_cw/dt = −[ω]× R_cw. Times are seconds from the start
of the simulation.

The turntable axis defaults to the camera's "up" (−y): a positive rate pans the camera to
the left, seen from above counter-clockwise, so stars drift towards +x in the image.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation
from ..errors import ParameterError

UP = (0.0, -1.0, 0.0)


def _exp(rotvec):
    return Rotation.from_rotvec(np.asarray(rotvec, np.float64).reshape(-1, 3)).as_matrix()


def _log(R):
    return Rotation.from_matrix(np.asarray(R, np.float64).reshape(-1, 3, 3)).as_rotvec()


def _unit_axis(axis):
    a = np.asarray(axis, np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise ParameterError(f"axis must be a non-zero 3-vector, got {axis!r}")
    return a / np.linalg.norm(a)


def _rotation_matrix(R, name="R0"):
    R = np.eye(3) if R is None else np.asarray(R, np.float64)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
        raise ParameterError(f"{name} must be a 3x3 rotation matrix")
    return R


def attitude_from_radec(ra_deg, dec_deg, roll_deg=0.0):
    """R_cw pointing the optical axis at (ra, dec) of the celestial (ICRS) frame.

    With roll 0 the image's up (−y) points to the north celestial pole and east lies to the
    left, as the sky is seen from inside; roll turns the camera about its optical axis.
    """
    ra, dec = math.radians(ra_deg), math.radians(dec_deg)
    z = np.array([math.cos(dec) * math.cos(ra), math.cos(dec) * math.sin(ra), math.sin(dec)])
    east = np.array([-math.sin(ra), math.cos(ra), 0.0])
    north = np.cross(z, east)
    R = np.stack([-east, -north, z])  # rows: camera axes x (west), y (south), z in world coordinates
    return _exp([0.0, 0.0, math.radians(roll_deg)])[0] @ R


def random_pointing(seed=None):
    """(ra_deg, dec_deg, roll_deg): a boresight uniform over the sphere and a uniform roll,
    drawn from `seed` (an int, a numpy Generator, or None for fresh entropy)."""
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    ra, z, roll = rng.uniform(0, 360), rng.uniform(-1, 1), rng.uniform(0, 360)
    return float(ra), math.degrees(math.asin(z)), float(roll)


class Trajectory:
    """Base class: subclasses give rotation(t) and omega(t); omega_dot defaults to a
    central difference of omega."""

    def rotation(self, t_s):
        """R_cw at times t_s (seconds): (n, 3, 3)."""
        raise NotImplementedError

    def omega(self, t_s):
        """Body rate in the camera frame, rad/s: (n, 3)."""
        raise NotImplementedError

    def omega_dot(self, t_s, h=1e-4):
        t = np.atleast_1d(np.asarray(t_s, np.float64))
        return (self.omega(t + h) - self.omega(t - h)) / (2 * h)

    def max_rate(self, t0_s, t1_s, n=2001):
        """Largest |ω| on [t0, t1] (rad/s), sampled."""
        return float(np.linalg.norm(self.omega(np.linspace(t0_s, t1_s, n)), axis=1).max())


class AxisRotation(Trajectory):
    """Rotation about a fixed camera-frame axis by angle θ(t): R_cw = Exp(−axis·θ) · R0."""

    def __init__(self, axis=UP, R0=None):
        self.axis = _unit_axis(axis)
        self.R0 = _rotation_matrix(R0)

    def angle(self, t_s):
        raise NotImplementedError

    def angle_rate(self, t_s):
        raise NotImplementedError

    def angle_accel(self, t_s):
        raise NotImplementedError

    def rotation(self, t_s):
        theta = np.atleast_1d(np.asarray(self.angle(t_s), np.float64))
        return _exp(-theta[:, None] * self.axis) @ self.R0

    def omega(self, t_s):
        return np.atleast_1d(np.asarray(self.angle_rate(t_s), np.float64))[:, None] * self.axis

    def omega_dot(self, t_s, h=None):
        return np.atleast_1d(np.asarray(self.angle_accel(t_s), np.float64))[:, None] * self.axis


class ConstantRate(AxisRotation):
    """Turntable: constant rate `rate_dps` (°/s) about `axis` (camera frame), starting at R0."""

    def __init__(self, rate_dps, axis=UP, R0=None):
        if not math.isfinite(rate_dps):
            raise ParameterError(f"rate_dps must be finite, got {rate_dps!r}")
        super().__init__(axis, R0)
        self.rate_dps = float(rate_dps)
        self._w = math.radians(self.rate_dps)

    def angle(self, t_s):
        return self._w * np.asarray(t_s, np.float64)

    def angle_rate(self, t_s):
        return np.full(np.shape(np.atleast_1d(t_s)), self._w)

    def angle_accel(self, t_s):
        return np.zeros(np.shape(np.atleast_1d(t_s)))

    def __repr__(self):
        return f"ConstantRate(rate_dps={self.rate_dps}, axis={self.axis.tolist()})"


class Sinusoid(AxisRotation):
    """θ(t) = A·sin(2π f t + φ) about `axis`: e.g. 10° amplitude at 1 Hz."""

    def __init__(self, amplitude_deg, freq_hz, axis=UP, phase_deg=0.0, R0=None):
        for name, v in (("amplitude_deg", amplitude_deg), ("freq_hz", freq_hz), ("phase_deg", phase_deg)):
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {v!r}")
        if freq_hz < 0:
            raise ParameterError(f"freq_hz must be >= 0, got {freq_hz!r}")
        super().__init__(axis, R0)
        self.amplitude_deg, self.freq_hz, self.phase_deg = float(amplitude_deg), float(freq_hz), float(phase_deg)
        self._a, self._w, self._phi = math.radians(amplitude_deg), 2 * math.pi * freq_hz, math.radians(phase_deg)

    def angle(self, t_s):
        return self._a * np.sin(self._w * np.asarray(t_s, np.float64) + self._phi)

    def angle_rate(self, t_s):
        return self._a * self._w * np.cos(self._w * np.asarray(t_s, np.float64) + self._phi)

    def angle_accel(self, t_s):
        return -self._a * self._w ** 2 * np.sin(self._w * np.asarray(t_s, np.float64) + self._phi)

    def __repr__(self):
        return (f"Sinusoid(amplitude_deg={self.amplitude_deg}, freq_hz={self.freq_hz}, "
                f"axis={self.axis.tolist()}, phase_deg={self.phase_deg})")


class Slew(AxisRotation):
    """A rest-to-rest slew about `axis`: constant acceleration to `peak_rate_dps` at
    `duration_s` / 2, constant deceleration back to rest at `duration_s` (held at rest
    after)."""

    def __init__(self, peak_rate_dps, duration_s, axis=UP, R0=None):
        for name, v in (("peak_rate_dps", peak_rate_dps), ("duration_s", duration_s)):
            if not math.isfinite(v):
                raise ParameterError(f"{name} must be finite, got {v!r}")
        if duration_s <= 0:
            raise ParameterError(f"duration_s must be > 0, got {duration_s!r}")
        super().__init__(axis, R0)
        self.peak_rate_dps, self.duration_s = float(peak_rate_dps), float(duration_s)
        self._w, self._half = math.radians(peak_rate_dps), 0.5 * float(duration_s)
        self._alpha = self._w / self._half

    def _phase(self, t_s):
        """(time since the slew's middle, clipped to ± half its duration)."""
        return np.clip(np.asarray(t_s, np.float64), 0.0, self.duration_s) - self._half

    def angle(self, t_s):
        d = self._phase(t_s)
        # θ at the middle is α·half²/2; from there ω·d less α·d²/2 on either side (d < 0 before)
        return self._alpha * self._half ** 2 / 2 + self._w * d - 0.5 * self._alpha * d * np.abs(d)

    def angle_rate(self, t_s):
        return self._w - self._alpha * np.abs(self._phase(t_s))

    def angle_accel(self, t_s):
        t = np.asarray(t_s, np.float64)
        return np.where((t > 0) & (t < self.duration_s), -self._alpha * np.sign(self._phase(t)), 0.0)

    def __repr__(self):
        return (f"Slew(peak_rate_dps={self.peak_rate_dps}, duration_s={self.duration_s}, "
                f"axis={self.axis.tolist()})")


class Jitter(Trajectory):
    """`base` with a platform's vibration: a sinusoidal turn of `amplitude_deg` at `freq_hz`
    about the camera-frame `axis`, R_cw = Exp(−axis·θ(t))·R_base(t) with θ = A·sin(2π f t + φ);
    ω = θ̇·axis + Exp(−axis·θ)·ω_base (dR/dt = −[ω]× R for the product)."""

    def __init__(self, base, amplitude_deg, freq_hz, axis, phase_deg=0.0):
        if not isinstance(base, Trajectory):
            raise ParameterError(f"base must be a Trajectory, got {type(base).__name__}")
        self.base, self.wave = base, Sinusoid(amplitude_deg, freq_hz, axis, phase_deg)

    def rotation(self, t_s):
        return self.wave.rotation(t_s) @ self.base.rotation(t_s)

    def omega(self, t_s):
        turn = self.wave.rotation(t_s)
        return self.wave.omega(t_s) + np.einsum("nij,nj->ni", turn, self.base.omega(t_s))

    def __repr__(self):
        return (f"Jitter({self.base!r}, amplitude_deg={self.wave.amplitude_deg}, "
                f"freq_hz={self.wave.freq_hz}, axis={self.wave.axis.tolist()})")


class SampledTrajectory(Trajectory):
    """A user-supplied attitude table R_cw(t_i), interpolated by slerp.

    Between samples the rate is constant, ω_i = −Log(R_{i+1} R_iᵀ) / Δt_i, so integrating the
    reported ω reproduces the interpolated attitude exactly. Outside the table the first /
    last rate is extrapolated.
    """

    def __init__(self, t_s, R_cw):
        t = np.asarray(t_s, np.float64)
        R = np.asarray(R_cw, np.float64)
        if t.ndim != 1 or len(t) < 2:
            raise ParameterError("t_s must be a 1-D array of at least two times")
        if R.shape != (len(t), 3, 3):
            raise ParameterError(f"R_cw must have shape ({len(t)}, 3, 3), got {R.shape}")
        if not np.all(np.diff(t) > 0):
            raise ParameterError("t_s must be strictly increasing")
        if not np.allclose(R @ R.transpose(0, 2, 1), np.eye(3), atol=1e-6):
            raise ParameterError("R_cw must hold rotation matrices")
        self.t = t
        self.R = Rotation.from_matrix(R).as_matrix()  # re-orthonormalised
        steps = _log(self.R[1:] @ self.R[:-1].transpose(0, 2, 1))
        self._w = -steps / np.diff(t)[:, None]

    def _interval(self, t):
        return np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2)

    def rotation(self, t_s):
        t = np.atleast_1d(np.asarray(t_s, np.float64))
        i = self._interval(t)
        return _exp(-self._w[i] * (t - self.t[i])[:, None]) @ self.R[i]

    def omega(self, t_s):
        return self._w[self._interval(np.atleast_1d(np.asarray(t_s, np.float64)))]

    def __repr__(self):
        return f"SampledTrajectory(n={len(self.t)}, {self.t[0]}..{self.t[-1]} s)"


class FunctionTrajectory(Trajectory):
    """Any callable t_s -> R_cw (n, 3, 3); ω by a central difference of the attitude."""

    def __init__(self, rotation_fn, h_s=1e-5):
        if not callable(rotation_fn):
            raise ParameterError("rotation_fn must be callable: t_s (n,) -> R_cw (n, 3, 3)")
        self.fn, self.h = rotation_fn, float(h_s)

    def rotation(self, t_s):
        t = np.atleast_1d(np.asarray(t_s, np.float64))
        R = np.asarray(self.fn(t), np.float64).reshape(len(t), 3, 3)
        return R

    def omega(self, t_s):
        t = np.atleast_1d(np.asarray(t_s, np.float64))
        step = self.rotation(t + self.h) @ self.rotation(t - self.h).transpose(0, 2, 1)
        return -_log(step) / (2 * self.h)

    def __repr__(self):
        return f"FunctionTrajectory({getattr(self.fn, '__name__', self.fn)!r})"
