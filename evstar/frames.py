"""Pseudo-frames: frame k holds events with t in [t0 + k·dt, t0 + (k+1)·dt)."""
from __future__ import annotations

import numpy as np


def check_dt(dt_us):
    """dt_us as the declaration in evstar.parameters accepts it (ParameterError otherwise)."""
    from .parameters import GLOBAL

    return GLOBAL.check("dt_us", dt_us)


def frame_ids(t, dt_us, t_origin_us=None):
    """Frame index of each timestamp (int64); the origin defaults to the first timestamp."""
    from evstar_kernels.reference.denoise import frame_index

    return frame_index(t, check_dt(dt_us), t_origin_us)


def frame_bounds(frames):
    """(unique frame ids, start index, stop index) of a sorted frame-id array."""
    if len(frames) == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    starts = np.flatnonzero(np.r_[True, frames[1:] != frames[:-1]])
    stops = np.r_[starts[1:], len(frames)]
    return frames[starts], starts, stops


def accumulated(events):
    """Event counts per pixel as a (height, width) int64 image."""
    img = np.bincount(events.y.astype(np.int64) * events.width + events.x,
                      minlength=events.width * events.height)
    return img.reshape(events.height, events.width)
