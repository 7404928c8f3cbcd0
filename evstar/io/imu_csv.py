"""IMU CSV `t,gx,gy,gz,ax,ay,az` (t µs, gyro rad/s, accel m/s²)."""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import DataError, EvstarWarning, FormatError, ParameterTypeError
from ..events import T_LIMIT_US, check_time_range
from ..imu import MAX_RATE_RAD_S, Imu, first_excess_rate
from .atomic import atomic_path
from .guard import check_no_implicit_index, check_readable, csv_parser_error, decoder_errors
from .text import first_row_line, looks_like_seconds

COLUMNS = ["t", "gx", "gy", "gz", "ax", "ay", "az"]


def read_imu(path, R_cam_imu=None, time_offset_us=0, sort=False):
    """IMU samples from CSV; sort=True orders unsorted timestamps (otherwise an error)."""
    check_readable(path)
    with decoder_errors(path, "IMU CSV"):
        try:  # utf-8-sig: a BOM is not part of the first column's name
            frame = pd.read_csv(path, dtype=str, skipinitialspace=True, comment="#",
                                keep_default_na=False, encoding="utf-8-sig")
        except pd.errors.EmptyDataError:
            raise FormatError(path, "file is empty") from None
        except pd.errors.ParserError as exc:
            raise csv_parser_error(path, exc, "IMU CSV") from None
        first = first_row_line(path)
        check_no_implicit_index(path, frame, first, frame.shape[1])
        return _imu(path, frame, R_cam_imu, time_offset_us, sort, first)


def _imu(path, frame, R_cam_imu, time_offset_us, sort, first):
    """Samples from the frame of strings; `first` is the file line of its first row."""
    frame.columns = [str(c).strip().lower() for c in frame.columns]
    dup = sorted({c for c in COLUMNS if f"{c}.1" in frame.columns})
    if dup:
        raise FormatError(path, f"IMU column(s) {dup} appear more than once in the header")
    missing = [c for c in COLUMNS if c not in frame.columns]
    if missing:
        raise FormatError(path, f"missing IMU column(s) {missing}; expected header {','.join(COLUMNS)}")
    data = {}
    for c in COLUMNS:
        v = pd.to_numeric(frame[c], errors="coerce").to_numpy(np.float64)
        bad = np.flatnonzero(np.isnan(v) & ~frame[c].str.strip().str.lower().isin(["nan", "inf", "-inf"]).to_numpy())
        if len(bad):
            i = int(bad[0])
            raise FormatError(path, f"line {first + i}: column '{c}' holds a non-numeric value {frame[c].iloc[i]!r}")
        if c == "t" and check_time_range(v) is not None:
            i = check_time_range(v)
            raise FormatError(path, f"line {first + i}: column 't' = {frame[c].iloc[i]} is outside the "
                                    f"valid time range ±{T_LIMIT_US} µs")
        if not np.all(np.isfinite(v)):
            i = int(np.flatnonzero(~np.isfinite(v))[0])
            raise FormatError(path, f"line {first + i}: column '{c}' is not finite ({frame[c].iloc[i]})")
        data[c] = v
    gyro = np.stack([data[c] for c in ("gx", "gy", "gz")], 1)
    bad = first_excess_rate(gyro)  # Imu checks this too; here the message names line and column
    if bad is not None:
        i, c = bad[0], ("gx", "gy", "gz")[bad[1]]
        raise FormatError(path, f"line {first + i}: column '{c}' = {frame[c].iloc[i]} rad/s is beyond "
                                f"±{MAX_RATE_RAD_S:g} rad/s (≈5700 °/s), not a real rotation rate")
    _check_time_unit(path, data["t"])
    try:
        return Imu(np.round(data["t"]).astype(np.int64), gyro,
                   np.stack([data[c] for c in ("ax", "ay", "az")], 1),
                   R_cam_imu=R_cam_imu, time_offset_us=time_offset_us, sort=sort)
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def _check_time_unit(path, t):
    """IMU CSV times are µs: fractional values all under 10⁴ are seconds (rounded to µs they
    collapse onto a few: a FormatError saying so), as are whole ones a median under
    _MIN_IMU_STEP_US apart (seconds or ms: no gyro samples at > 100 kHz); other fractional
    µs are rounded, warned."""
    if looks_like_seconds(t):
        raise FormatError(path, "column 't' holds fractional values all under 10⁴: IMU CSV times "
                                "are in µs; if these are seconds, multiply them by 10⁶")
    steps = np.diff(np.sort(t))
    if len(steps) >= 2 and 0 < np.median(steps) < _MIN_IMU_STEP_US:
        raise FormatError(path, f"column 't': samples lie a median {np.median(steps):g} µs apart "
                                "(no gyro samples that fast): IMU CSV times are in µs; if these "
                                "are seconds or ms, multiply them by 10⁶ or 10³")
    frac = t != np.round(t)
    if not frac.any():
        return
    warnings.warn(f"{path}: column 't' has {int(frac.sum())} value(s) with fractional µs, "
                  f"rounded to whole µs", EvstarWarning, stacklevel=4)


#: the shortest median step of IMU times taken as µs (100 kHz; MEMS gyros sample at ≤ 8 kHz)
_MIN_IMU_STEP_US = 10


def write_imu(path, imu):
    """Write the samples as measured (IMU frame and clock); calibration is not part of this format."""
    if not isinstance(imu, Imu):
        raise ParameterTypeError(f"imu must be an evstar.Imu, got {type(imu).__name__}")
    frame = pd.DataFrame(np.column_stack([imu.gyro, imu.accel]), columns=COLUMNS[1:])
    frame.insert(0, "t", imu.t)
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format="%.17g")
