"""IMU on SO(3): time alignment and coverage checks, interpolation to event times, gyro
integration with the exponential map (attitude at any time by slerp), and the paper's
accelerometer double integration.

Conventions (docs/design.md): times are camera-clock µs (`Imu.t_cam`); rates and accelerations are
in the camera frame (`Imu.gyro_cam`, `Imu.accel_cam`); R_cw maps world vectors into the
camera and dR_cw/dt = −[ω]× R_cw. Between two samples the rate is taken as their mean (the
rate is linear in time between samples, so this is the exact mean rate of each interval).
"""
from __future__ import annotations

import numpy as np

from evstar_kernels.reference import so3

from ..errors import DataError, ParameterError, ParameterTypeError
from ..imu import Imu


#: a gap between IMU samples longer than this many median sample intervals (and than
#: GAP_MIN_US) inside the span is warned about: the rotation across it is interpolated from
#: its two ends, which a real turn need not follow (a 5 s gap passed silently)
GAP_INTERVALS = 10
GAP_MIN_US = 50_000


def warn_gaps(imu, t_start_us, t_stop_us):
    """An EvstarWarning naming the IMU's longest gap within [t_start_us, t_stop_us] where it
    exceeds GAP_INTERVALS median intervals and GAP_MIN_US."""
    import warnings

    from ..errors import EvstarWarning

    tc = imu.t_cam
    if len(tc) < 3:
        return
    step = np.diff(tc)
    inside = (tc[1:] > t_start_us) & (tc[:-1] < t_stop_us)
    if not inside.any():
        return
    i = int(np.flatnonzero(inside)[np.argmax(step[inside])])
    if step[i] > max(GAP_INTERVALS * float(np.median(step)), GAP_MIN_US):
        warnings.warn(f"the IMU has no sample for {step[i] / 1e6:.3g} s ({tc[i]}..{tc[i + 1]} µs); "
                      "the rotation across that gap is interpolated", EvstarWarning)   # once per run


def check_coverage(imu, t_start_us, t_stop_us, what="the events"):
    """Raise DataError unless the IMU (camera clock) spans [t_start_us, t_stop_us] with finite
    data; warn of a long gap inside the span (warn_gaps)."""
    if not isinstance(imu, Imu):
        raise ParameterTypeError(f"imu must be an evstar.Imu, got {type(imu).__name__}")
    if len(imu) < 2:
        raise DataError(f"IMU has {len(imu)} sample(s); motion compensation needs at least 2")
    if not imu.covers(int(np.floor(t_start_us)), int(np.ceil(t_stop_us))):
        raise DataError(f"IMU covers {imu.t_cam[0]}..{imu.t_cam[-1]} µs (camera clock) but "
                        f"{what} span {t_start_us:.0f}..{t_stop_us:.0f} µs")
    for name in ("gyro", "accel"):
        bad = ~np.all(np.isfinite(getattr(imu, name)), axis=1)
        if bad.any():
            raise DataError(f"IMU {name} holds a non-finite value at sample {np.flatnonzero(bad)[0]}")
    if np.any(np.diff(imu.t) <= 0):
        i = int(np.flatnonzero(np.diff(imu.t) <= 0)[0]) + 1
        raise DataError(f"IMU timestamps must increase strictly; sample {i} repeats {imu.t[i]} µs")
    warn_gaps(imu, t_start_us, t_stop_us)


def hold_ends(imu, t_start_us, t_stop_us, extrapolate_us):
    """The IMU extended to cover [t_start_us, t_stop_us] by holding its first and last sample
    (the nearest sample's rate) for up to `extrapolate_us` µs beyond either end; DataError
    naming the gap when the events reach further. Sensors often start the IMU a little
    after the events (the DAVIS346 of the E-MLB sample: 0.7 ms)."""
    if not isinstance(imu, Imu):
        raise ParameterTypeError(f"imu must be an evstar.Imu, got {type(imu).__name__}")
    if not (np.isfinite(extrapolate_us) and extrapolate_us >= 0):
        raise ParameterError(f"extrapolate_us must be finite and >= 0, got {extrapolate_us!r}")
    if len(imu) == 0:
        return imu
    tc = imu.t_cam
    before, after = int(tc[0]) - int(np.floor(t_start_us)), int(np.ceil(t_stop_us)) - int(tc[-1])
    for gap, where in ((before, "starts {} µs after the first"), (after, "ends {} µs before the last")):
        if gap > extrapolate_us:
            raise DataError(f"the IMU {where.format(gap)} event, more than extrapolate_us = {extrapolate_us:g} µs "
                            f"(IMU {tc[0]}..{tc[-1]} µs, events {t_start_us:.0f}..{t_stop_us:.0f} µs)")
    head = [0] if before > 0 else []
    tail = [len(imu) - 1] if after > 0 else []
    if not head and not tail:
        return imu
    rows = np.r_[head, np.arange(len(imu)), tail].astype(np.int64)
    t = imu.t[rows].copy()
    if head:
        t[0] -= before
    if tail:
        t[-1] += after
    return Imu(t, imu.gyro[rows], imu.accel[rows], R_cam_imu=imu.R_cam_imu,
               time_offset_us=imu.time_offset_us)


def interpolate(imu, t_us):
    """Gyro and accelerometer (camera frame) linearly interpolated at camera times t_us: (N, 3) x2."""
    tc = imu.t_cam.astype(np.float64)
    return interp_rows(t_us, tc, imu.gyro_cam), interp_rows(t_us, tc, imu.accel_cam)


def gyro_at(imu):
    """t_us -> interpolate(imu, t_us)[0], the camera-frame samples prepared once (for many
    calls)."""
    tc, g = imu.t_cam.astype(np.float64), imu.gyro_cam
    return lambda t_us: interp_rows(t_us, tc, g)


def interp_rows(t_us, tc, v):
    """(n, 3) rows v (at the increasing times tc) linearly interpolated at t_us, column by
    column (held beyond the ends)."""
    t = np.asarray(t_us, dtype=np.float64)
    return np.stack([np.interp(t, tc, v[:, k]) for k in range(3)], 1)


class AttitudeTrack:
    """Attitude quaternions q_cw (x, y, z, w) at increasing camera times t_us (float64 µs).

    Build it with :meth:`from_imu`; :meth:`at` gives the attitude at any time by slerp
    between the two neighbouring nodes, and, within `extrapolate_us` beyond either end, by
    continuing the end rate.
    """

    def __init__(self, t_us, q_cw):
        self.t_us = np.ascontiguousarray(t_us, dtype=np.float64)
        self.q_cw = np.ascontiguousarray(q_cw, dtype=np.float64)
        if self.q_cw.shape != (len(self.t_us), 4) or len(self.t_us) < 2:
            raise DataError("an attitude track needs >= 2 times and one quaternion (4,) per time")
        if np.any(np.diff(self.t_us) <= 0):
            raise DataError("attitude track times must increase strictly")
        self._phi = so3.quat_log(so3.quat_mul(self.q_cw[1:], so3.quat_conj(self.q_cw[:-1])))

    @classmethod
    def from_imu(cls, imu, *, q0=None, t0_us=None, bias=None):
        """Integrate the gyro minus `bias` (rad/s, camera frame: (3,) or one row per sample).

        The track has one node per IMU sample; q0 (default identity) is the attitude at
        t0_us (default the first sample; it must lie within the samples).
        """
        check_coverage(imu, imu.t_cam[0], imu.t_cam[-1], what="the IMU samples")
        t = imu.t_cam.astype(np.float64)
        g = imu.gyro_cam - (0.0 if bias is None else np.broadcast_to(bias, imu.gyro.shape))
        q0 = so3.quat_identity() if q0 is None else so3.quat_normalize(np.asarray(q0, np.float64))
        q = so3.integrate_rates(so3.quat_identity(), 0.5 * (g[1:] + g[:-1]), np.diff(t) * 1e-6)
        track = cls(t, q)
        if t0_us is not None:  # re-anchor: q(t) <- q(t) ⊗ q(t0)⁻¹ ⊗ q0 (world-side gauge)
            t0 = float(t0_us)
            if not t[0] <= t0 <= t[-1]:
                raise DataError(f"t0_us = {t0_us} lies outside the IMU samples {t[0]:.0f}..{t[-1]:.0f}")
            q0 = so3.quat_mul(so3.quat_conj(track.at([t0])[0]), q0)
        return cls(t, so3.quat_normalize(so3.quat_mul(track.q_cw, q0)))

    def at(self, t_us, extrapolate_us=0.0):
        """Attitudes (N, 4) at times t_us; DataError beyond the track by more than extrapolate_us."""
        t = self.check_times(t_us, extrapolate_us)
        T = self.t_us
        k = np.clip(np.searchsorted(T, t, side="right") - 1, 0, len(T) - 2)
        s = (t - T[k]) / (T[k + 1] - T[k])  # outside [0, 1] only when extrapolating
        # slerp(q_k, q_k+1, s) = Exp(s·φ_k) ⊗ q_k with φ_k = Log(q_k+1 ⊗ q_k⁻¹): one exp per time
        return so3.quat_mul(so3.quat_exp(s[:, None] * self._phi[k]), self.q_cw[k])

    @property
    def steps(self):
        """φ_k = Log(q_k+1 ⊗ q_k⁻¹), (N − 1, 3): the rotation of each interval."""
        return self._phi

    def check_times(self, t_us, extrapolate_us=0.0):
        """t_us as float64 (1-D); DataError if any lies beyond the track by more than extrapolate_us."""
        t = np.atleast_1d(np.asarray(t_us, dtype=np.float64))
        self.check_span(t, extrapolate_us)
        return t

    def check_span(self, t_us, extrapolate_us=0.0):
        """check_times on times of any numeric dtype, without converting them."""
        t, T = np.atleast_1d(np.asarray(t_us)), self.t_us
        if len(t) and (t.min() < T[0] - extrapolate_us or t.max() > T[-1] + extrapolate_us):
            raise DataError(f"attitude requested at {t.min():.0f}..{t.max():.0f} µs but the IMU "
                            f"track covers {T[0]:.0f}..{T[-1]:.0f} µs")

    def relative(self, t_ref_us, t_us, extrapolate_us=0.0):
        """q(t_ref ← t) = q_cw(t_ref) ⊗ q_cw(t)⁻¹: rotates camera rays at t into the camera at t_ref."""
        q_ref = self.at(t_ref_us, extrapolate_us)
        q_t = self.at(t_us, extrapolate_us)
        return so3.quat_mul(q_ref, so3.quat_conj(q_t))


class Kinematics:
    """Velocity and position (world frame, m/s and m) at camera times t_us, from the accelerometer."""

    def __init__(self, t_us, velocity, position):
        self.t_us = np.asarray(t_us, dtype=np.float64)
        self.velocity = np.asarray(velocity, dtype=np.float64)
        self.position = np.asarray(position, dtype=np.float64)

    def at(self, t_us):
        """(velocity, position) linearly interpolated at t_us."""
        t = np.asarray(t_us, dtype=np.float64)
        lerp = lambda a: np.stack([np.interp(t, self.t_us, a[:, k]) for k in range(3)], 1)  # noqa: E731
        return lerp(self.velocity), lerp(self.position)


def integrate_accel(imu, attitude=None, *, v0=(0.0, 0.0, 0.0), p0=(0.0, 0.0, 0.0),
                    gravity_world=None):
    """The paper's double integration, v(t) = v0 + ∫a, P(t) = P0 + ∫v (trapezoidal rule).

    a is the accelerometer rotated into the world frame by the attitude track
    (a_w = R_cwᵀ·a_cam; without a track the camera frame is taken as the world frame, as the
    paper does) plus `gravity_world`, the gravity vector in world coordinates (e.g. (0, 0,
    −9.81) for a z-up world: an accelerometer at rest reads +g upwards, and adding gravity
    cancels it). By default no gravity is added, i.e. the accelerometer is assumed
    gravity-compensated. Stars are at infinity, so compensation never needs this; it serves
    near targets of known depth.
    """
    check_coverage(imu, imu.t_cam[0], imu.t_cam[-1], what="the IMU samples")
    t = imu.t_cam.astype(np.float64)
    a = imu.accel_cam
    if attitude is not None:
        a = so3.quat_rotate(so3.quat_conj(attitude.at(t)), a)
    if gravity_world is not None:
        a = a + np.asarray(gravity_world, dtype=np.float64)
    dt = np.diff(t)[:, None] * 1e-6
    v = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (a[1:] + a[:-1]) * dt, axis=0)])
    v += np.asarray(v0, dtype=np.float64)
    p = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)])
    p += np.asarray(p0, dtype=np.float64)
    return Kinematics(t, v, p)
