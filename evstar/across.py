"""A star's position across its motion from every event about its path.

The crossings time a star's passage along its motion; across it, positions come from the
centroids of the events the density filter kept. A faint or slow star's flank events are
kept unevenly (a threshold on local counts turns a slightly busier flank row — the pixels'
threshold mismatch — into a much busier one), so its rows sit at a constant offset across
the motion that no averaging along the track removes (perf/study_across.py,
perf/study_mismatch.py); a neighbour's events pull a close pair's centroids together. Here
each track takes the across offset of *all* events near its path (noise included, hot pixels
out), pooled over the whole track: the mode a mean-shift with Gaussian weights finds — a
symmetric profile on a uniform background has it at the star — and its rows move across the
motion by it. A track that reverses (a sinusoid's turns) has two frames: its offset may turn
with the motion or stay on one side of its path in the image; the one whose profile is
narrower is taken (_image_frame).

Events find their track through coarse cells its path touches (CELL_PX), then their frame's
row of that track, moved to the event's time along the track's velocity; the histogram of
their offsets across the motion is a kernel (evstar_kernels.taichi.across).
"""
from __future__ import annotations

import numpy as np

from .crossings import dilate
from .field import _velocities

#: cells (px, a power of two) that index which tracks pass where
CELL_PX = 8
#: events within this of the star's position at their time along the motion (px)
ALONG_PX = 3.0
#: histogram bin of the across offsets (px): an event's offset is its bin's centre
BIN_PX = 0.01
#: offsets beyond this (px) from the path weigh nothing
REACH_PX = 8.0
#: the second pass's kernel σ: this x the profile's σ the first measured, within the bounds
PROFILE_FACTOR = 1.2
KERNEL_MIN_PX, KERNEL_MAX_PX = 1.0, 4.0
#: a track needs at least this much weight (events) in its window
MIN_EVENTS = 100
#: rows closer to the sensor's edge than this many kernel σ (+1 px) give no events (an edge
#: cuts one flank; weights there are ~1 %)
EDGE_SIGMAS = 3.0
#: a shift beyond this (px) is no offset of the star's own profile (a neighbour, a blend)
MAX_SHIFT_PX = 1.0
#: the direction of the motion at a row: its track's displacement over at least this (px)
DIRECTION_SPAN_PX = 4.0
#: events within this (px, square) of a frame centroid are kept for the histograms: a
#: region symmetric about the star, wider than its profile (those near *kept* events are
#: not: a faint star's kept events can lie on one flank, and its events on the other were
#: missed — 0.4 px shifts on a dark-sky field)
STORE_RADIUS_PX = 6


def near_centroids(events, centroids, hot=None, radius_px=STORE_RADIUS_PX):
    """(t, x, y) of the events within `radius_px` (square) of a centroid's pixel, none on
    a pixel `hot` flags (a bool image, or None)."""
    from .events import gather
    from .frames import on_pixels

    if not len(centroids) or not len(events):
        return events.t[:0], events.x[:0], events.y[:0]
    near = np.zeros((events.height, events.width), bool)
    x = np.clip(np.rint(centroids["x"]), 0, events.width - 1).astype(np.intp)
    y = np.clip(np.rint(centroids["y"]), 0, events.height - 1).astype(np.intp)
    near[y, x] = True
    near = dilate(near, radius_px)
    if hot is not None:
        near &= ~hot
    # their polarities are not gathered: the histograms do not need them
    return tuple(gather([events.t, events.x, events.y], np.flatnonzero(on_pixels(events, near))))


def refine(rows, t, x, y, t0_us, dt_us, sensor, kernel_px, engine="taichi"):
    """Rows (CENTROID_DTYPE) with each track moved across its motion onto the mode of its
    events' across offsets (module doc); a new array. t, x, y: the events near the stars
    (µs, px); sensor: (width, height); kernel_px: the first pass's kernel σ (0: off);
    engine "taichi" or "numpy" (the histogram's specification; the same counts)."""
    out = rows.copy()
    sel = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    if kernel_px <= 0 or len(sel) < 2 or not len(t):
        return out
    sel = sel[np.lexsort((rows["t"][sel], rows["track"][sel]))]
    _, g = np.unique(rows["track"][sel], return_inverse=True)
    p = np.stack([rows["x"][sel], rows["y"][sel]], axis=1)
    tr = rows["t"][sel].astype(np.float64)
    u, v = _directions(p, g), _velocities(tr, p, g)
    margin = EDGE_SIGMAS * kernel_px + 1
    counts = offset_counts(t, x, y, t0_us, dt_us, sensor, rows["frame"][sel], g, p, v, u, tr,
                           margin, engine)
    s, width = _mode(counts, kernel_px)
    # a track that reverses: its offset is one side of the motion (as above) or one side of
    # its path in the image (a pixel row's threshold, the PSF), which its passes' motion
    # frames cancel; the frame whose profile is narrower is the offset's
    image_u = _image_frame(u, g)
    back = (image_u * u).sum(1) < 0
    reversing = (np.bincount(g, back) > 0) & (np.bincount(g, ~back) > 0)
    if reversing.any():
        s_img, width_img = _mode(offset_counts(t, x, y, t0_us, dt_us, sensor,
                                               rows["frame"][sel], g, p, v, image_u, tr,
                                               margin, engine), kernel_px)
        image = reversing & (width_img < width)
        s = np.where(image, s_img, s)
        u = np.where(image[g][:, None], image_u, u)
    s = s[g]
    out["x"][sel] -= s * u[:, 1]
    out["y"][sel] += s * u[:, 0]
    return out


def offset_counts(t, x, y, t0_us, dt_us, sensor, frame, g, p, v, u, tr, margin_px, engine):
    """(tracks, bins) histogram of the events' offsets across their track's motion
    (BIN_PX bins from -(REACH_PX + MAX_SHIFT_PX)); rows within margin_px of the sensor's
    edge give none."""
    width, height = sensor
    cells_w = -(-width // CELL_PX)
    start, pair_track = _cells(p, v, g, dt_us, cells_w, -(-height // CELL_PX))
    tracks, table = _frame_table(frame, g)
    away = ((p[:, 0] >= margin_px - 0.5) & (p[:, 0] <= width - 0.5 - margin_px)
            & (p[:, 1] >= margin_px - 0.5) & (p[:, 1] <= height - 0.5 - margin_px))
    table_rows = np.column_stack([p, v, u, tr, away])
    reach = REACH_PX + MAX_SHIFT_PX
    args = (t, x, y, t0_us, dt_us, CELL_PX.bit_length() - 1, cells_w, start, pair_track,
            tracks, table, table_rows, ALONG_PX, reach, BIN_PX, int(round(2 * reach / BIN_PX)))
    if engine == "numpy":
        from evstar_kernels.reference.across import across_counts

        return across_counts(*args)
    from evstar_kernels.taichi.across_launch import across_counts

    from .backends import taichi_running

    return across_counts(taichi_running(), *args)


def mean_shift(counts, kernel_px):
    """Per track (a row of `counts`, the histogram offset_counts makes), the mean-shift
    fixed point from 0 of its offsets with Gaussian weights; 0 where the weights sum to
    fewer than MIN_EVENTS or the point leaves ±MAX_SHIFT_PX. A first pass with σ `kernel_px`
    measures the profile's width (the kernel-weighted variance is σ²h²/(σ² + h²) for a
    Gaussian profile of σ); the second weighs with a kernel matched to it: a bright star's
    events spread wide and flat-topped (log response), where a narrow kernel locks onto
    pixel rows. Smooth weights: a hard window locks too (rows enter and leave it whole)."""
    return _mode(counts, kernel_px)[0]


def _mode(counts, kernel_px):
    """(mean_shift's shift, the profile's σ its first pass measured; inf where too wide to
    tell) per row of `counts`."""
    reach = REACH_PX + MAX_SHIFT_PX
    centre = (np.arange(counts.shape[1]) + 0.5) * BIN_PX - reach
    counts = counts.astype(np.float64)
    d, n = _fixed_point(counts, centre, np.full(len(counts), float(kernel_px)))
    w = np.exp(-0.5 * ((centre - d[:, None]) / kernel_px) ** 2)
    var = (w * counts * (centre - d[:, None]) ** 2).sum(axis=1) / np.maximum(n, 1e-12)
    h2 = kernel_px ** 2
    sigma = np.sqrt(np.where(var < 0.9 * h2, var * h2 / np.maximum(h2 - var, 1e-12), np.inf))
    d, n = _fixed_point(counts, centre, np.clip(PROFILE_FACTOR * sigma, KERNEL_MIN_PX,
                                                KERNEL_MAX_PX))
    return np.where((n >= MIN_EVENTS) & (np.abs(d) < MAX_SHIFT_PX), d, 0.0), sigma


def _fixed_point(counts, centre, h):
    """(d, weight sum) per row of `counts`: the mean-shift fixed point from 0, kernel σ h."""
    d, n = np.zeros(len(h)), np.zeros(len(h))
    active = np.arange(len(h))
    for _ in range(100):
        w = np.exp(-0.5 * ((centre - d[active, None]) / h[active, None]) ** 2) * counts[active]
        n[active] = w.sum(axis=1)
        new = np.clip(np.divide(w @ centre, n[active], out=np.zeros(len(active)),
                                where=n[active] > 0), -MAX_SHIFT_PX, MAX_SHIFT_PX)
        moving = np.abs(new - d[active]) >= 1e-4
        d[active] = new
        active = active[moving]
        if not len(active):
            break
    return d, n


def _image_frame(u, g):
    """u with each row turned to its track's principal axis of direction (the dominant
    eigenvector of Σ u uᵀ, sign-free): a reversing track's rows moving back flipped, so that
    across is one side of its path in the image."""
    n_tr = int(g.max()) + 1 if len(g) else 0
    xx, xy, yy = (np.bincount(g, a * b, n_tr) for a, b in ((u[:, 0], u[:, 0]), (u[:, 0], u[:, 1]),
                                                           (u[:, 1], u[:, 1])))
    M = np.stack([np.stack([xx, xy], -1), np.stack([xy, yy], -1)], -2)
    axis = np.linalg.eigh(M)[1][:, :, -1][g]
    return np.where(((u * axis).sum(1) < 0)[:, None], -u, u)


def _directions(p, g):
    """Per row (sorted by track, time), the unit direction of its track's motion: the
    displacement between the rows k before and after it, k per track so that the track
    moves DIRECTION_SPAN_PX over 2k rows (its whole length where it moves less)."""
    n = len(p)
    first = np.r_[0, np.flatnonzero(np.diff(g)) + 1]
    last = np.r_[first[1:], n] - 1
    length = np.linalg.norm(p[last] - p[first], axis=1)
    rows_of = last - first + 1
    k = np.ceil(DIRECTION_SPAN_PX / 2 / np.maximum(length / np.maximum(rows_of - 1, 1), 1e-9))
    k = np.minimum(k, rows_of).astype(np.int64)[g]
    i = np.arange(n)
    step = p[np.minimum(i + k, last[g])] - p[np.maximum(i - k, first[g])]
    norm = np.linalg.norm(step, axis=1, keepdims=True)
    return np.divide(step, norm, out=np.zeros_like(step), where=norm > 0)


def _cells(p, v, g, dt_us, cells_w, cells_h):
    """(start, track): the tracks whose path passes each cell or a neighbour of it, cell c's
    at track[start[c]:start[c + 1]]; a row's path spans its frame (sampled every half cell)."""
    n_s = (2 * np.ceil(np.linalg.norm(v, axis=1) * dt_us / CELL_PX)).astype(np.int64) + 1
    r = np.repeat(np.arange(len(p)), n_s)
    frac = np.arange(len(r)) - np.repeat(np.cumsum(n_s) - n_s, n_s)
    at = p[r] + v[r] * ((frac / np.maximum(n_s[r] - 1, 1) - 0.5) * dt_us)[:, None]
    cx = np.clip(at[:, 0] // CELL_PX, 0, cells_w - 1).astype(np.int64)
    cy = np.clip(at[:, 1] // CELL_PX, 0, cells_h - 1).astype(np.int64)
    off = np.arange(-1, 2)
    cell = ((cy[:, None, None] + off[:, None]).clip(0, cells_h - 1) * cells_w
            + (cx[:, None, None] + off).clip(0, cells_w - 1)).reshape(-1)
    n_tracks = int(g.max()) + 1
    # the distinct (cell, track) keys in order, by a presence table: no sort of the samples
    present = np.zeros(cells_w * cells_h * n_tracks, bool)
    present[cell * n_tracks + np.repeat(g[r], 9)] = True
    key = np.flatnonzero(present)
    start = np.searchsorted(key // n_tracks, np.arange(cells_w * cells_h + 1))
    return start, key % n_tracks


def _frame_table(frame, g):
    """(tracks, table): per track its first and last frame and the start of its slots in
    `table`, which holds its first row in each frame (-1: none)."""
    n_tracks = int(g.max()) + 1
    first = np.r_[0, np.flatnonzero(np.diff(g)) + 1]     # rows sorted by track, time
    f0 = np.minimum.reduceat(frame, first)
    f1 = np.maximum.reduceat(frame, first)
    base = np.r_[0, np.cumsum(f1 - f0 + 1)][:n_tracks]
    table = np.full(int((f1 - f0 + 1).sum()), -1, np.int64)
    slot, row = np.unique(base[g] + frame - f0[g], return_index=True)   # a frame's first row
    table[slot] = row
    return np.column_stack([f0, f1, base]), table
