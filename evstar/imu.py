"""Imu: gyroscope and accelerometer samples with their extrinsic calibration to the camera."""
from __future__ import annotations

import warnings

import numpy as np

from .errors import DataError, EvstarWarning
from .events import SORT_HINT, T_LIMIT_US, as_int_array, check_time_range, is_integer_value


#: the largest angular rate (rad/s) a gyro sample may hold: 100 rad/s ≈ 5700 °/s, well beyond
#: any star sensor's slew and MEMS gyros' ±2000 °/s ranges; larger values are corrupt data
#: (rotating by them makes cos/sin of huge angles: warnings and garbage attitudes)
MAX_RATE_RAD_S = 100.0


def first_excess_rate(gyro):
    """(sample, axis) of the first value of an (N, 3) gyro array beyond ±MAX_RATE_RAD_S, or None."""
    bad = np.abs(gyro) > MAX_RATE_RAD_S
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad.any(axis=1))[0])
    return i, int(np.argmax(bad[i]))


def _vec3(name, values, n, finite=True):
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:  # ragged lists and the like
        raise DataError(f"IMU field '{name}' is not a numeric array ({exc})") from None
    # real numbers only: casting complex drops the imaginary part (numpy warns), strings would parse
    if arr.dtype.kind not in "biuf":
        raise DataError(f"IMU field '{name}' must hold real numbers, got dtype {arr.dtype}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    if arr.shape != (n, 3):
        raise DataError(f"IMU field '{name}' must have shape ({n}, 3), got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        i = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
        raise DataError(f"IMU field '{name}' holds a non-finite value at sample {i}: {arr[i]}")
    return arr


class Imu:
    """IMU samples: t int64 µs (IMU clock), gyro rad/s and accel m/s² as (N, 3) in the IMU frame.

    ``R_cam_imu`` rotates IMU-frame vectors into the camera frame (identity by default) and
    ``time_offset_us`` maps IMU time to camera time: t_camera = t + time_offset_us.
    :meth:`t_cam`, :meth:`gyro_cam` and :meth:`accel_cam` give the samples in the camera
    frame and clock, which is what motion compensation uses.
    """

    __slots__ = ("t", "gyro", "accel", "R_cam_imu", "time_offset_us")

    def __init__(self, t, gyro, accel=None, *, R_cam_imu=None, time_offset_us=0, sort=False):
        t = as_int_array("t", t, kind="IMU")   # Events' checks: whole, finite, 1-D numbers
        n = len(t)
        i = check_time_range(t)
        if i is not None:
            raise DataError(f"IMU field 't' = {t[i]} at sample {i} is outside the valid range ±{T_LIMIT_US} µs")
        self.t = np.ascontiguousarray(t, dtype=np.int64)
        self.gyro = _vec3("gyro", gyro, n)
        bad = first_excess_rate(self.gyro)
        if bad is not None:
            i, k = bad
            raise DataError(f"IMU field 'gyro' axis {'xyz'[k]} = {self.gyro[i, k]:g} rad/s at sample {i} "
                            f"is beyond ±{MAX_RATE_RAD_S:g} rad/s (≈5700 °/s), not a real rotation rate")
        self.accel = _vec3("accel", np.zeros((n, 3)) if accel is None else accel, n)
        R = np.eye(3) if R_cam_imu is None else _vec3("R_cam_imu", R_cam_imu, 3, finite=False)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) \
                or np.linalg.det(R) < 0:
            raise DataError(f"R_cam_imu must be a 3x3 rotation matrix, got {R.tolist()}")
        self.R_cam_imu = R
        if not is_integer_value(time_offset_us):   # 1.7 or "5" is no clock offset in µs
            raise DataError(f"IMU time_offset_us must be an integer, got {time_offset_us!r}")
        self.time_offset_us = int(time_offset_us)
        if abs(self.time_offset_us) > T_LIMIT_US:
            raise DataError(f"IMU time_offset_us = {self.time_offset_us} is outside ±{T_LIMIT_US} µs")
        if n > 1 and np.any(np.diff(self.t) < 0):
            if not sort:
                i = int(np.flatnonzero(np.diff(self.t) < 0)[0])
                raise DataError(f"IMU timestamps decrease at sample {i + 1}; {SORT_HINT}")
            order = np.argsort(self.t, kind="stable")
            self.t, self.gyro, self.accel = self.t[order], self.gyro[order], self.accel[order]
        if n > 1 and np.any(np.diff(self.t) == 0):   # integration needs a time between samples
            i = int(np.flatnonzero(np.diff(self.t) == 0)[0]) + 1
            raise DataError(f"IMU timestamps repeat at sample {i} ({self.t[i]} µs): each sample "
                            "needs its own time")

    def __len__(self):
        return len(self.t)

    @property
    def t_cam(self):
        return self.t + self.time_offset_us

    @property
    def gyro_cam(self):
        return self.gyro @ self.R_cam_imu.T

    @property
    def accel_cam(self):
        return self.accel @ self.R_cam_imu.T

    @property
    def rate_hz(self):
        if len(self) < 2 or self.t[-1] == self.t[0]:
            return 0.0
        return (len(self) - 1) / ((self.t[-1] - self.t[0]) * 1e-6)

    def time_window(self, t_start_us, t_stop_us):
        """Samples with camera time in [t_start_us, t_stop_us)."""
        i0, i1 = np.searchsorted(self.t_cam, [t_start_us, t_stop_us], side="left")
        return self._samples(i0, i1)

    def around(self, t_start_us, t_stop_us):
        """Samples with camera time in [t_start_us, t_stop_us] and the nearest one beyond
        each end (at least two): all that interpolating the gyro over the interval reads."""
        tc, n = self.t_cam, len(self)
        i0 = min(max(int(np.searchsorted(tc, t_start_us, side="right")) - 1, 0), max(n - 2, 0))
        i1 = min(max(int(np.searchsorted(tc, t_stop_us, side="left")) + 1, i0 + 2), n)
        return self._samples(i0, i1)

    def _samples(self, i0, i1):
        """Samples i0 .. i1 − 1, the same mounting and clock offset."""
        return Imu(self.t[i0:i1], self.gyro[i0:i1], self.accel[i0:i1],
                   R_cam_imu=self.R_cam_imu, time_offset_us=self.time_offset_us)

    def covers(self, t_start_us, t_stop_us):
        return len(self) > 0 and self.t_cam[0] <= t_start_us and self.t_cam[-1] >= t_stop_us

    def warn_if_not_covering(self, events, source="IMU"):
        """Warn when the samples do not span the events' time range (compensation would extrapolate)."""
        if len(events) and not self.covers(int(events.t[0]), int(events.t[-1])):
            span = f"{self.t_cam[0]}..{self.t_cam[-1]}" if len(self) else "nothing"
            warnings.warn(f"{source}: IMU covers {span} µs but the events span "
                          f"{events.t[0]}..{events.t[-1]} µs", EvstarWarning, stacklevel=2)

    def __eq__(self, other):
        if not isinstance(other, Imu):
            return NotImplemented
        return (np.array_equal(self.t, other.t) and np.array_equal(self.gyro, other.gyro)
                and np.array_equal(self.accel, other.accel)
                and np.array_equal(self.R_cam_imu, other.R_cam_imu)
                and self.time_offset_us == other.time_offset_us)

    __hash__ = None

    def __repr__(self):
        return f"Imu(n={len(self)}, {self.rate_hz:.0f} Hz)"
