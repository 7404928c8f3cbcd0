"""A star's position across its motion from every event about its path.

The crossings time a star's passage along its motion; across it, positions come from the
centroids of the events the density filter kept. A faint or slow star's flank events are
kept unevenly (a threshold on local counts turns a slightly busier flank row — the pixels'
threshold mismatch — into a much busier one), so its rows sit at a constant offset across
the motion that no averaging along the track removes (perf/study_across.py,
perf/study_mismatch.py). Here each track takes the across offset of *all* events near its
path (noise included, hot pixels out), pooled over the whole track: the fixed point of a
mean-shift with Gaussian weights of σ `kernel_px` — a symmetric profile on a uniform
background has it at the star — and its rows move across the motion by it.

Events find their track through coarse cells the track's path touches (CELL_PX), then their
frame's row of that track (moved to the event's time along the track's velocity).
"""
from __future__ import annotations

import numpy as np

from .field import _velocities

#: cells (px) that index which tracks pass where
CELL_PX = 8
#: events within this of the star's position at their time along the motion (px)
ALONG_PX = 3.0
#: histogram bin of the across offsets (px): the weights are taken at bin centres
BIN_PX = 0.02
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


def refine(rows, t, x, y, t0_us, dt_us, sensor, kernel_px):
    """Rows (CENTROID_DTYPE) with each track moved across its motion onto the mean-shift
    fixed point of its events' across offsets (module doc); a new array. t, x, y: the events
    near the stars (µs, px); sensor: (width, height)."""
    out = rows.copy()
    sel = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    if kernel_px <= 0 or len(sel) < 2 or not len(t):
        return out
    sel = sel[np.lexsort((rows["t"][sel], rows["track"][sel]))]
    tracks, g = np.unique(rows["track"][sel], return_inverse=True)
    p = np.stack([rows["x"][sel], rows["y"][sel]], axis=1)
    tr = rows["t"][sel].astype(np.float64)
    u = _directions(p, g)
    v = _velocities(tr, p, g)
    ev, row = _pairs(rows["frame"][sel], g, p, v, dt_us, t, x, y, t0_us, sensor, kernel_px)
    d = (np.stack([x[ev], y[ev]], axis=1).astype(np.float64) - p[row]
         - v[row] * (t[ev] - tr[row])[:, None])
    along = np.einsum("ij,ij->i", d, u[row])
    across = d[:, 1] * u[row, 0] - d[:, 0] * u[row, 1]
    ok = np.abs(along) <= ALONG_PX
    shift = mean_shift(g[row[ok]], across[ok], len(tracks), kernel_px)
    s = shift[g]
    out["x"][sel] -= s * u[:, 1]
    out["y"][sel] += s * u[:, 0]
    return out


def mean_shift(group, a, n_groups, kernel_px):
    """Per group, the fixed point d = Σ a·K(a − d) / Σ K(a − d) of Gaussian weights K of σ
    `kernel_px`, from d = 0 (0 where the weights sum to fewer than MIN_EVENTS or d leaves
    ±MAX_SHIFT_PX). A smooth window: a hard one locks onto the pixel grid (rows enter and
    leave it whole; ~0.1 px for a star moving along a pixel row). Offsets are binned (BIN_PX,
    exact sums within each bin), so each step costs O(groups x bins)."""
    reach = REACH_PX + MAX_SHIFT_PX
    nb = int(np.ceil(2 * reach / BIN_PX))
    inside = np.flatnonzero(np.abs(a) < reach)
    key = group[inside] * nb + ((a[inside] + reach) / BIN_PX).astype(np.int64).clip(0, nb - 1)
    count = np.bincount(key, minlength=n_groups * nb).reshape(n_groups, nb)
    total = np.bincount(key, a[inside], n_groups * nb).reshape(n_groups, nb)
    centre = (np.arange(nb) + 0.5) * BIN_PX - reach
    # a first pass measures the profile's width (the kernel-weighted variance is
    # σ²h²/(σ² + h²) for a Gaussian profile of σ), the second weighs with a kernel matched to
    # it: a bright star's events spread wide and flat-topped (log response), and a narrow
    # kernel there locks onto pixel rows
    d, n = _fixed_point(count, total, centre, np.full(n_groups, float(kernel_px)))
    w = np.exp(-0.5 * ((centre - d[:, None]) / kernel_px) ** 2)
    v = (w * count * (centre - d[:, None]) ** 2).sum(axis=1) / np.maximum(n, 1e-12)
    h2 = kernel_px ** 2
    sigma = np.sqrt(np.where(v < 0.9 * h2, v * h2 / np.maximum(h2 - v, 1e-12), np.inf))
    h = np.clip(PROFILE_FACTOR * sigma, KERNEL_MIN_PX, KERNEL_MAX_PX)
    d, n = _fixed_point(count, total, centre, h)
    w = np.exp(-0.5 * ((centre - d[:, None]) / h[:, None]) ** 2)
    se = np.sqrt((w ** 2 * count * (centre - d[:, None]) ** 2).sum(axis=1)) / np.maximum(n, 1e-12)
    d = d * np.clip(1 - (SHRINK * se) ** 2 / np.maximum(d ** 2, 1e-24), 0, 1)
    return np.where((n >= MIN_EVENTS) & (np.abs(d) < MAX_SHIFT_PX), d, 0.0)


SHRINK = 0.0


def _fixed_point(count, total, centre, h):
    """(d, weight sum) per group: the mean-shift fixed point from 0 with kernel σ h."""
    d, n = np.zeros(len(h)), np.zeros(len(h))
    active = np.arange(len(h))
    for _ in range(100):
        w = np.exp(-0.5 * ((centre - d[active, None]) / h[active, None]) ** 2)
        n[active] = (w * count[active]).sum(axis=1)
        new = np.clip(np.divide((w * total[active]).sum(axis=1), n[active],
                                out=np.zeros(len(active)), where=n[active] > 0),
                      -MAX_SHIFT_PX, MAX_SHIFT_PX)
        moving = np.abs(new - d[active]) >= 1e-4
        d[active] = new
        active = active[moving]
        if not len(active):
            break
    return d, n


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


def _pairs(frame, g, p, v, dt_us, t, x, y, t0_us, sensor, kernel_px):
    """(event index, row index) of every event in a cell its frame's row of a track passes
    (those cells dilated by one), the row's track having a row in the event's frame, the row
    away from the sensor's edge (an edge cuts one flank)."""
    width, height = sensor
    wc, hc = -(-width // CELL_PX), -(-height // CELL_PX)
    # the path of each row's frame, sampled every half cell, and the cells about it
    reach = np.linalg.norm(v, axis=1) * dt_us / 2
    n_s = (2 * np.ceil(reach / (CELL_PX / 2))).astype(np.int64) + 1
    r = np.repeat(np.arange(len(p)), n_s)
    frac = np.arange(len(r)) - np.repeat(np.cumsum(n_s) - n_s, n_s)
    at = p[r] + v[r] * ((frac / np.maximum(n_s[r] - 1, 1) - 0.5) * dt_us)[:, None]
    cx = np.clip(at[:, 0] // CELL_PX, 0, wc - 1).astype(np.int64)
    cy = np.clip(at[:, 1] // CELL_PX, 0, hc - 1).astype(np.int64)
    off = np.arange(-1, 2)
    cell = ((cy[:, None, None] + off[:, None]).clip(0, hc - 1) * wc
            + (cx[:, None, None] + off).clip(0, wc - 1)).reshape(len(r), 9)
    pair = np.unique(np.column_stack([cell.ravel(), np.repeat(g[r], 9)]), axis=0)
    start = np.searchsorted(pair[:, 0], np.arange(wc * hc + 1))
    # each event to every track of its cell
    ec = (y // CELL_PX).astype(np.int64) * wc + x // CELL_PX
    n_e = start[ec + 1] - start[ec]
    ev = np.repeat(np.arange(len(t)), n_e)
    k = start[ec][ev] + np.arange(len(ev)) - np.repeat(np.cumsum(n_e) - n_e, n_e)
    track = pair[k, 1]
    # its frame's row of that track (a dense table per track from its first frame)
    f0 = np.full(g.max() + 1, np.iinfo(np.int64).max)
    np.minimum.at(f0, g, frame)
    f1 = np.zeros(g.max() + 1, np.int64)
    np.maximum.at(f1, g, frame)
    base = np.r_[0, np.cumsum(f1 - f0 + 1)]
    table = np.full(base[-1], -1)
    table[(base[g] + frame - f0[g])[::-1]] = np.arange(len(g))[::-1]   # the first row of a frame
    ef = (t[ev] - t0_us) // dt_us
    inside = (ef >= f0[track]) & (ef <= f1[track])
    ev, track, ef = ev[inside], track[inside], ef[inside]
    row = table[base[track] + ef - f0[track]]
    ev, row = ev[row >= 0], row[row >= 0]
    margin = EDGE_SIGMAS * kernel_px + 1
    away = ((p[row, 0] >= margin - 0.5) & (p[row, 0] <= width - 0.5 - margin)
            & (p[row, 1] >= margin - 0.5) & (p[row, 1] <= height - 0.5 - margin))
    return ev[away], row[away]
