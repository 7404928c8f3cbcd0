"""Pseudo-frames: frame k holds events with t in [t0 + k·dt, t0 + (k+1)·dt)."""
from __future__ import annotations

import numpy as np

from .errors import DataError
from .parameters import MAX_FRAMES, MAX_GRID_PIXELS

#: frames are kept apart in one spatial search by a coordinate this far apart (>> any px)
FRAME_GAP = 1e6


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


def stable_order(key):
    """np.argsort(key, kind="stable") of integers, by numpy's 16-bit radix sort where they
    fit: one pass for keys in [0, 2¹⁶), two (low half, then high) in [0, 2³²) — 2-8x quicker
    than its sort of wider integers (the same permutation: stable sorts agree)."""
    key = np.asarray(key)
    if (not len(key) or key.dtype.kind not in "iu" or key.min() < 0
            or key.max() >= 1 << 32):
        return np.argsort(key, kind="stable")
    if key.max() < 1 << 16:
        return np.argsort(key.astype(np.uint16), kind="stable")
    low = np.argsort((key & 0xFFFF).astype(np.uint16), kind="stable")
    return low[np.argsort((key[low] >> 16).astype(np.uint16), kind="stable")]


def groups(ids):
    """(distinct ids ascending, the indices of each, in their order)."""
    order = stable_order(ids)
    cut = np.flatnonzero(np.diff(ids[order])) + 1
    return (ids[order][np.r_[0, cut]] if len(ids) else ids[:0]), np.split(order, cut)


def run_neighbours(ids):
    """(previous, next): per element of `ids` (equal ids adjacent, e.g. rows sorted by track
    then time), the index of the element before and after it in its run; its own index at
    the run's ends."""
    i = np.arange(len(ids))
    same = ids[1:] == ids[:-1]
    return np.where(np.r_[False, same], i - 1, i), np.where(np.r_[same, False], i + 1, i)


def ranks(counts, starts=0):
    """s, s + 1, ..., s + c − 1 for each count c and start s, concatenated (one repeat):
    e.g. each member's place in its group, or (starts) its index in the sorted whole."""
    counts = np.asarray(counts, np.int64)
    return np.arange(counts.sum()) + np.repeat(starts - (np.cumsum(counts) - counts), counts)


def check_frame_count(n_frames, first_us, last_us, dt_us):
    """DataError where the n_frames frames of dt_us from first_us to last_us (the first
    event or frame origin, the last event) are more than MAX_FRAMES (per-frame arrays would
    not fit in memory)."""
    if n_frames > MAX_FRAMES:
        raise DataError(f"{first_us} to {last_us} µs spans {n_frames} frames of dt_us={dt_us}, "
                        f"more than {MAX_FRAMES:_} (a corrupt timestamp or frame origin?)")


def check_grid(width, height):
    """DataError where a width x height sensor has more than MAX_GRID_PIXELS pixels (the
    dense kernels' per-pixel grids would not fit in memory)."""
    if width * height > MAX_GRID_PIXELS:
        raise DataError(f"the sensor is {width}x{height} px, {width * height:,} pixels: evstar's "
                        f"per-pixel grids take at most {MAX_GRID_PIXELS:,} (8192x8192; a "
                        "corrupt header's size?)")


def frame_offsets(t, dt_us, t0):
    """(first frame id, index where each frame from it to the last starts, then len(t)) of
    time-sorted t in frames of dt_us from t0 (DataError beyond MAX_FRAMES frames)."""
    if len(t) == 0:
        return 0, np.zeros(1, np.int64)
    f0, f1 = (int(t[0]) - t0) // dt_us, (int(t[-1]) - t0) // dt_us
    check_frame_count(f1 - f0 + 1, int(t[0]), int(t[-1]), dt_us)
    return f0, np.searchsorted(t, t0 + np.arange(f0, f1 + 2, dtype=np.int64) * dt_us)


#: a stall is a gap in which at least this many events were due at the stream's mean rate
#: (a Poisson stream leaves one such gap in e^20 ≈ 5·10⁸): on a quiet small sensor (90
#: events a second) gaps of over a frame are the rule, no stall
STALL_EVENTS = 20


def stall_starts(t, dt_us):
    """Indices i of the sorted times `t` that follow a stall: t[i] − t[i − 1] > dt_us (a
    gap of more than a frame) and > STALL_EVENTS mean intervals, in which the sensor sent
    nothing (a readout that stalled; a sensor's background alone sends an event every few
    µs). Such a gap holds a whole empty window of a grid of half-frames, found by a search
    per window (a pass over a 4 s run's 5 M gaps took ~10 ms); only those windows' gaps are
    measured."""
    t = np.asarray(t)
    if len(t) < 2:
        return np.zeros(0, np.int64)
    dt_us = stall_gap_us(t, dt_us)
    half = max(int(dt_us) // 2, 1)
    edges = int(t[0]) + half * np.arange((int(t[-1]) - int(t[0])) // half + 2, dtype=np.int64)
    at = np.searchsorted(t, edges)
    empty = at[:-1] == at[1:]
    i = np.unique(at[:-1][empty])
    i = i[(i > 0) & (i < len(t))]
    return i[t[i] - t[i - 1] > dt_us]


def stall_gap_us(t, dt_us):
    """The shortest gap of the sorted times `t` that is a stall (stall_starts): over a frame
    and over STALL_EVENTS mean intervals."""
    if len(t) < 2:
        return int(dt_us)
    return max(int(dt_us), STALL_EVENTS * (int(t[-1]) - int(t[0])) // (len(t) - 1))


def stalled_us(t, dt_us, start_us=None):
    """µs of the sorted times `t` (from start_us where given) in stalls (stall_starts): of
    each gap between events, what exceeds a frame."""
    i = stall_starts(t, dt_us)
    lost = int(np.sum(t[i] - t[i - 1] - dt_us)) if len(i) else 0
    if start_us is not None and len(t) and int(t[0]) - int(start_us) > stall_gap_us(t, dt_us):
        lost += int(t[0]) - int(start_us) - int(dt_us)
    return lost


def stalls(t, starts, dt_us, before_us=None):
    """(n, 2) int64 (last event before, first after) of each stall among the sorted times
    `t` (`starts`: their stall_starts), one before t[0] included where before_us (an earlier
    chunk's last event time) is given."""
    t = np.asarray(t, np.int64)
    out = np.column_stack([t[starts - 1], t[starts]])
    if before_us is not None and len(t) and int(t[0]) - int(before_us) > stall_gap_us(t, dt_us):
        out = np.vstack([[[int(before_us), int(t[0])]], out])
    return out


def nearest_in_frame(ref_xy, ref_frame, xy, frame, max_px):
    """(distance, index into ref) of the nearest reference point of the same frame to each
    point within max_px (inf and len(ref) where none is), as scipy's cKDTree.query."""
    from scipy.spatial import cKDTree

    def pts(p, f):
        return np.column_stack([np.asarray(p, float), np.asarray(f, float) * FRAME_GAP])

    return cKDTree(pts(ref_xy, ref_frame)).query(pts(xy, frame), distance_upper_bound=max_px)


def accumulated(events, keep=None):
    """Event counts per pixel as a (height, width) int64 image (of the events `keep`
    selects, when given)."""
    every, kept = images(events, keep)
    return every if keep is None else kept


def images(events, keep=None):
    """(events per pixel, the kept ones' or None) as (height, width) int64 images, in one
    pass over the events (a Taichi kernel wherever the run's kernels run)."""
    from evstar_kernels.taichi.pixel_counts_launch import pixel_counts

    from .backends import taichi_running

    return pixel_counts(taichi_running(), events.x, events.y, events.width, events.height, keep)


def kept_pixels(events, keep):
    """(height, width) bool image: the pixels of the events `keep` (bool (n,)) selects, or
    of the events at the ascending indices `keep` (kept_indices)."""
    from evstar_kernels.taichi.pixel_counts_launch import marked_pixels

    from .backends import taichi_running

    return marked_pixels(taichi_running(), events.x, events.y, keep, events.width, events.height)


def kept_indices(keep):
    """The ascending indices of the events a keep mask (bool) selects; indices as they are
    (a caller that has them spares a pass over the mask)."""
    keep = np.asarray(keep)
    return np.flatnonzero(keep) if keep.dtype == bool else keep


def events_on_pixels(events, flags):
    """(t, x, y, p) of the events at pixels flags (a (height, width) bool image) sets, in
    order (a Taichi kernel's flags, wherever the run's kernels run, and numpy's gathers)."""
    from evstar_kernels.taichi.pixel_counts_launch import on_flagged_pixels

    from .backends import taichi_running

    return tuple(on_flagged_pixels(taichi_running(), events.t, events.x, events.y, events.p,
                                   flags))


def events_by_pixel(events, flags):
    """(t, pixel key y·width + x (uint32), p) of the events (evstar.Events: time-sorted, p 0
    or 1) at pixels flags (a (height, width) bool image) sets, in the pixel-then-time order
    (Taichi kernels wherever the run's kernels run)."""
    from evstar_kernels.taichi.pixel_counts_launch import events_by_pixel as by_pixel

    from .backends import taichi_running

    return by_pixel(taichi_running(), events.t, events.x, events.y, events.p, flags)


def on_pixels(events, flags):
    """flags[y, x] of every event (bool (n,)), flags a (height, width) bool image."""
    from evstar_kernels.taichi.pixel_counts_launch import pixel_flags

    from .backends import taichi_running

    return pixel_flags(taichi_running(), events.x, events.y, flags)
