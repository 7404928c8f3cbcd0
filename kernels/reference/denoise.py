"""Denoising filters in plain numpy: the executable specification (docs/kernels.md).

Every accelerated backend is tested against these functions, bit-exact for masks and counts.
They are written for clarity and independence from the accelerated kernels (sorting and
binary search instead of dense grids), not for speed.

Conventions: `t` int64 µs (non-decreasing), `x`, `y` integer pixel indices on a
`width` x `height` sensor; frames are half-open time intervals [t0 + k·dt, t0 + (k+1)·dt).
"""
from __future__ import annotations

import math

import numpy as np
from . import poisson

#: The 8 neighbours of a pixel, in (dx, dy) order; the pixel itself is never a neighbour.
NEIGHBOURS_8 = tuple((dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dx, dy) != (0, 0))


# -- pseudo-frames ------------------------------------------------------------------------
def frame_index(t, dt_us, t0_us=None):
    """Frame of each event: floor((t - t0) / dt), t0 the first timestamp unless given."""
    t = np.asarray(t, dtype=np.int64)
    if len(t) == 0:
        return np.zeros(0, np.int64)
    t0 = int(t[0]) if t0_us is None else int(t0_us)
    return (t - t0) // int(dt_us)


def frame_offsets(t, dt_us, t0_us=None):
    """Event index where each frame starts (length n_frames + 1), frames 0..last non-empty one.

    Frame k holds events offsets[k]:offsets[k+1]; empty frames have equal offsets.
    Events before t0 are not allowed (they would have a negative frame index).
    """
    t = np.asarray(t, dtype=np.int64)
    if len(t) == 0:
        return np.zeros(1, np.int64)
    t0 = int(t[0]) if t0_us is None else int(t0_us)
    if t[0] < t0:
        raise ValueError(f"t0_us={t0} is after the first event ({int(t[0])} µs)")
    n_frames = int((t[-1] - t0) // int(dt_us)) + 1
    edges = t0 + np.arange(n_frames + 1, dtype=np.int64) * int(dt_us)
    return np.searchsorted(t, edges, side="left").astype(np.int64)


# -- disks on the pixel lattice ------------------------------------------------------------
def disk_rows(radius):
    """Rows of the lattice disk {(dx, dy): dx² + dy² < r²} as (dy, half_width) arrays.

    The half-width of row dy is the largest integer w with w² < r² − dy² (strict, so a
    pixel exactly at distance r is outside: ⌊√(r² − dy² − ε)⌋, docs/kernels.md).
    """
    r2 = float(radius) ** 2
    dys, ws = [], []
    for dy in range(-math.ceil(radius), math.ceil(radius) + 1):
        rest = r2 - dy * dy
        if rest <= 0:
            continue
        w = math.isqrt(max(int(math.ceil(rest)) - 1, 0))  # largest w with w² < rest
        while (w + 1) ** 2 < rest:
            w += 1
        while w > 0 and w * w >= rest:
            w -= 1
        dys.append(dy)
        ws.append(w)
    return np.array(dys, np.int64), np.array(ws, np.int64)


def disk_area(radius):
    """Exact number of lattice pixels in the disk of `radius` (strict inequality)."""
    _, ws = disk_rows(radius)
    return int(np.sum(2 * ws + 1))


# -- classical spatio-temporal correlation filter -------------------------------------------
def classical_support(t, x, y, width, height, dt_us):
    """Number of the 8 neighbours that support each event (0..8), dv-processing semantics.

    A neighbour supports event i if its last timestamp ts (the latest event at that pixel
    with stream index < i; 0 if there is none, as dv's time surface starts at 0) satisfies
    t_i − ts < dt. Parallel exact form: sort the events by (pixel, index) and binary-search
    the latest earlier event of every neighbour — no sequential loop.
    """
    t = np.asarray(t, np.int64)
    x = np.asarray(x, np.int64)
    y = np.asarray(y, np.int64)
    n = len(t)
    support = np.zeros(n, np.int8)
    if n == 0:
        return support
    pix = y * width + x
    order = np.argsort(pix, kind="stable")          # by (pixel, index)
    keys = pix[order] * n + order                    # strictly increasing
    idx = np.arange(n, dtype=np.int64)
    for dx, dy in NEIGHBOURS_8:
        nx, ny = x + dx, y + dy
        inside = (nx >= 0) & (nx < width) & (ny >= 0) & (ny < height)
        npix = ny * width + nx
        pos = np.searchsorted(keys, npix * n + idx, side="left") - 1
        found = inside & (pos >= 0)
        found[found] = pix[order[pos[found]]] == npix[found]
        ts = np.zeros(n, np.int64)
        ts[found] = t[order[pos[found]]]
        support += (inside & (t - ts < dt_us)).astype(np.int8)
    return support


def classical_mask(t, x, y, width, height, dt_us, k=1):
    """Keep mask of the classical filter: at least `k` supporting neighbours (k=1: dv's filter)."""
    return classical_support(t, x, y, width, height, dt_us) >= k


# -- NDSEF / MR-NDSEF ------------------------------------------------------------------------
def _sorted_frame_keys(frame, x, y, width, height):
    key = (frame * height + y) * width + x
    return np.sort(key), key


def disk_counts(frame, x, y, width, height, radius, select=None):
    """p(e) = events of the same frame in the disk of `radius` around e (e itself included).

    Computed by binary search in the events sorted by (frame, y, x): for every row of the
    disk, count the keys between the row segment's two ends. `select` (bool mask) limits
    the events evaluated; others get -1.
    """
    frame = np.asarray(frame, np.int64)
    x = np.asarray(x, np.int64)
    y = np.asarray(y, np.int64)
    keys, _ = _sorted_frame_keys(frame, x, y, width, height)
    out = np.full(len(x), -1, np.int64)
    sel = np.ones(len(x), bool) if select is None else np.asarray(select, bool)
    f, xs, ys = frame[sel], x[sel], y[sel]
    total = np.zeros(len(xs), np.int64)
    for dy, w in zip(*disk_rows(radius)):
        yy = ys + dy
        ok = (yy >= 0) & (yy < height)
        lo = np.clip(xs - w, 0, width - 1)
        hi = np.clip(xs + w, 0, width - 1)
        base = (f * height + yy) * width
        c = (np.searchsorted(keys, base + hi, side="right")
             - np.searchsorted(keys, base + lo, side="left"))
        total += np.where(ok, c, 0)
    out[sel] = total
    return out


def mr_ndsef(frame, x, y, width, height, radii, thresholds, select=None, full=True):
    """MR-NDSEF with per-radius thresholds and hierarchical screening.

    Keep iff p_k(e) >= th_k for every radius k. Radius k is evaluated only for events that
    passed radii 1..k-1 (same mask as evaluating all, less work); counts[i, k] is -1 where
    event i was rejected before radius k. `select` (bool mask) limits the events tested:
    the others count (every event of a frame does) but are not kept, their counts all -1.
    full=False (the mask alone) also stops, kept, at radius k an event whose p_k already
    reaches every larger radius's threshold: the disks are nested, so p_(k+1), ... >= p_k
    (same mask; its larger counts are -1).
    Returns (keep mask, counts (n, K) int64).
    """
    n = len(np.asarray(x))
    counts = np.full((n, len(radii)), -1, np.int64)
    alive = np.ones(n, bool) if select is None else np.array(select, bool)
    kept = np.zeros(n, bool)    # decided early (full=False)
    for k, (r, th) in enumerate(zip(radii, thresholds)):
        if not alive.any():
            break
        counts[:, k] = disk_counts(frame, x, y, width, height, r, select=alive)
        alive &= counts[:, k] >= th
        if not full and k + 1 < len(radii):
            done = alive & (counts[:, k] >= max(thresholds[k + 1:]))
            kept |= done
            alive &= ~done
    return alive | kept, counts


# -- auto thresholds --------------------------------------------------------------------------
def poisson_thresholds(rate_hz, dt_us, radii, alpha):
    """th_k = smallest n with P[Poisson(λ·dt·A_k) >= n] <= α, A_k the disk's lattice area.
    ValueError where a threshold would not fit the kernels' int32 counts, or the quantile
    is not computed (NaN: α below ~1e-16, where 1 − α rounds to 1, or λ·dt·A_k above ~1e11)."""
    mu = np.array([float(rate_hz) * float(dt_us) * 1e-6 * disk_area(r) for r in radii])
    out = np.ones(len(mu), np.int64)
    busy = mu > 0
    # P[X >= n] = sf(n - 1); isf gives the smallest m with sf(m) <= alpha, so n = m + 1
    # (one vectorised call: scipy's per-call overhead dominates on short streams)
    m = poisson.isf(alpha, mu[busy])
    if not np.all(m + 1 <= np.iinfo(np.int32).max):     # NaN fails too
        raise ValueError(f"alpha={alpha} at {mu.max():g} background events per disk gives no "
                         f"threshold below 2**31 (Poisson quantile {np.max(m)})")
    out[busy] = m.astype(np.int64) + 1
    return out


def background_rate(t, x, y, width, height, outlier_p=1e-6, chunk=1 << 20, duration_s=None,
                    counts=None):
    """Robust background rate λ (events / pixel / s) of a stream.

    Pixels whose event count is improbably high for a Poisson process of the plain mean
    rate (upper tail < `outlier_p`: hot pixels, the target's track) are left out, and the
    rate is re-measured on the remaining pixels over the stream's duration (its time span
    unless `duration_s` is given, e.g. for a sample of time windows). Pixel counts are
    accumulated in chunks so the temporary memory stays small for long streams, unless
    the caller has them (`counts`: the events per pixel, width · height int64, row-major).
    """
    t = np.asarray(t)
    if len(t) == 0:
        return 0.0
    if duration_s is None:
        duration_s = max(int(t[-1]) - int(t[0]), 1) * 1e-6
    for i in range(0, len(t) if counts is None else 0, chunk):
        pix = np.asarray(y[i:i + chunk], np.int32) * np.int32(width) + np.asarray(x[i:i + chunk], np.int32)
        part = np.bincount(pix, minlength=width * height)
        counts = part if counts is None else counts + part
    counts = np.asarray(counts).reshape(-1)
    cut = poisson.isf(outlier_p, counts.mean())
    outliers = np.flatnonzero(counts > cut)  # few: sum them rather than copy the inliers
    n_inliers = counts.size - len(outliers)
    return float((int(counts.sum()) - int(counts[outliers].sum())) / max(n_inliers, 1) / duration_s)
