"""Pseudo-frames: frame k holds events with t in [t0 + k·dt, t0 + (k+1)·dt)."""
from __future__ import annotations

import numpy as np


def check_dt(dt_us):
    if not (isinstance(dt_us, (int, np.integer)) and dt_us > 0):
        raise ValueError(f"dt_us must be a positive integer number of microseconds, got {dt_us!r}")
    return int(dt_us)


def frame_ids(t, dt_us, t_origin_us=None):
    """Frame index of each timestamp (int64); the origin defaults to the first timestamp."""
    t = np.asarray(t, dtype=np.int64)
    t0 = (int(t[0]) if len(t) else 0) if t_origin_us is None else int(t_origin_us)
    return (t - t0) // check_dt(dt_us)


def frame_bounds(frames):
    """(unique frame ids, start index, stop index) of a sorted frame-id array."""
    if len(frames) == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    starts = np.flatnonzero(np.r_[True, frames[1:] != frames[:-1]])
    stops = np.r_[starts[1:], len(frames)]
    return frames[starts], starts, stops
