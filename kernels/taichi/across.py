"""Histograms of events' offsets across their track's motion.

Specification: `evstar_kernels.reference.across.across_counts` (bit-exact: the same float
operations in the same order per event; the counts are integer adds, so their order does
not matter). The events come as runs of whole frames (`bounds`), so an event's frame needs
no 64-bit division (~40 % of an event's cost when it did). Lanes of frames: on the CPU a
lane per thread, each into its own histogram (plain adds: two threads' atomic adds into
one track's bins contended); on a GPU a lane per frame, atomic adds into one.
"""
import functools

import taichi as ti

from .arrays import f64_2d, i32_1d, i64_1d, i64_2d, u16_1d


@ti.func
def _add_event(t: ti.i64, xe: ti.i64, ye: ti.i64, f: ti.i64, cell_shift: ti.i64,
               cells_w: ti.i64, start: ti.template(), pair_track: ti.template(),
               tracks: ti.template(), slots: ti.template(), along_px: ti.f64,
               reach_px: ti.f64, bin_px: ti.f64, nb: ti.i64, counts: ti.template(),
               base: ti.i64, private: ti.template()):
    """One count per candidate track of the event's cell whose frame row it lies near.
    Counted behind a branch: a branch-free add of 0 or 1 (every candidate a store into its
    track's histogram) took ~10 % longer on the 100-star EVK4 field (6.5 M candidates,
    2.1 M near)."""
    c = (ye >> cell_shift) * cells_w + (xe >> cell_shift)
    for k in range(start[c], start[c + 1]):
        g = ti.cast(pair_track[k], ti.i64)
        if tracks[g, 0] <= f and f <= tracks[g, 1]:
            r = tracks[g, 2] + f - tracks[g, 0]
            if slots[r, 7] > 0:
                lag = ti.cast(t, ti.f64) - slots[r, 6]
                dx = (ti.cast(xe, ti.f64) - slots[r, 0]) - slots[r, 2] * lag
                dy = (ti.cast(ye, ti.f64) - slots[r, 1]) - slots[r, 3] * lag
                along = dx * slots[r, 4] + dy * slots[r, 5]
                across = dy * slots[r, 4] - dx * slots[r, 5]
                if ti.abs(along) <= along_px and ti.abs(across) < reach_px:
                    b = ti.min(ti.cast((across + reach_px) / bin_px, ti.i64), nb - 1)
                    i = base + g * nb + b
                    if ti.static(private):
                        counts[i] = counts[i] + 1
                    else:
                        ti.atomic_add(counts[i], 1)


@functools.lru_cache(maxsize=None)
def across_counts_kernel(private):
    """kernel(t, x, y, bounds, lane, lo, hi, f_first, ..., hist_size, counts), slots in
    place of the reference's (table, rows): each track's row of each of its frames (the
    table's slots), away = 0 where it has none (one read less per candidate: ~6 %
    quicker). Iteration i
    adds the events of frames f_first + j, j = lo[i] .. hi[i] − 1 (events bounds[j] ..
    bounds[j + 1]; i32, as Taichi's loop bounds are: a launch holds < 2³¹ events), into
    histogram lane[i] of `counts` (hist_size each); private: no two iterations share one
    (plain adds), else atomic adds."""

    @ti.kernel
    def across_counts(t: i64_1d, x: u16_1d, y: u16_1d, bounds: i32_1d, lane: i32_1d,
                      lo: i32_1d, hi: i32_1d, f_first: ti.i64, cell_shift: ti.i64,
                      cells_w: ti.i64, start: i32_1d, pair_track: i32_1d, tracks: i64_2d,
                      slots: f64_2d, along_px: ti.f64, reach_px: ti.f64,
                      bin_px: ti.f64, nb: ti.i64, hist_size: ti.i64, counts: i64_1d):
        for i in range(lo.shape[0]):
            base = ti.cast(lane[i], ti.i64) * hist_size
            for j in range(lo[i], hi[i]):
                for e in range(bounds[j], bounds[j + 1]):
                    _add_event(t[e], ti.cast(x[e], ti.i64), ti.cast(y[e], ti.i64), f_first + j,
                               cell_shift, cells_w, start, pair_track, tracks, slots,
                               along_px, reach_px, bin_px, nb, counts, base, private)

    return across_counts
