"""Multi-radius disk counts, event-parallel (the GPU form; also runs on CPU).

For a batch of frames [f0, f1): every event adds itself to its frame's grid plane with an
atomic add, dense frames (>= dense_min events) get row prefix sums (one thread per row),
every event then counts its disks hierarchically, and the events clear the planes again
(un-binning: concurrent writes of 0 are benign). Planes are indexed f − f0; the caller sizes
the batch to the memory it grants. Counts and masks are the same as frame_counts'.
"""
import functools

import taichi as ti

from . import frame_grids as fg
from .disk_reads import disk_padding, make_disk_count
from .arrays import i32_1d, i32_2d, u16_1d, u8_1d


@ti.func
def frame_of(offsets: ti.template(), f0: ti.i32, f1: ti.i32, e: ti.i32) -> ti.i32:
    """The frame f in [f0, f1) with offsets[f] <= e < offsets[f + 1] (binary search)."""
    lo, hi = f0, f1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if offsets[mid] <= e:
            lo = mid
        else:
            hi = mid
    return lo


@functools.lru_cache(maxsize=None)
def count_events_kernels(disks, width, height):
    """(bin, prefix_rows, count, unbin) kernels for one sensor size and set of disks.

    Specification: `evstar_kernels.reference.denoise.mr_ndsef` (bit-exact masks and counts)."""
    n_radii = len(disks)
    geo = fg.Geometry(width, height, disk_padding(disks))
    disk_count = make_disk_count(disks, geo, "i32")

    @ti.kernel
    def bin_frames(x: u16_1d, y: u16_1d, offsets: i32_1d, f0: ti.i32, f1: ti.i32, grid: i32_1d):
        for e in range(offsets[f0], offsets[f1]):
            f = frame_of(offsets, f0, f1, e)
            at = (f - f0) * geo.plane + fg.cell_index(geo, ti.cast(x[e], ti.i32), ti.cast(y[e], ti.i32))
            ti.atomic_add(grid[at], 1)

    @ti.kernel
    def prefix_rows(offsets: i32_1d, f0: ti.i32, f1: ti.i32, dense_min: ti.i32, grid: i32_1d,
                    prefix: i32_1d):
        for f, r in ti.ndrange((f0, f1), (geo.pad, geo.pad + geo.height)):
            if offsets[f + 1] - offsets[f] >= dense_min:
                g = (f - f0) * geo.plane + r * geo.stride
                p = (f - f0) * geo.prefix_plane + r * geo.prefix_stride
                s = 0
                prefix[p] = 0
                for c in range(geo.stride):
                    s += grid[g + c]
                    prefix[p + c + 1] = s

    @ti.kernel
    def count(x: u16_1d, y: u16_1d, offsets: i32_1d, f0: ti.i32, f1: ti.i32, thresholds: i32_1d,
              enough: i32_1d, dense_min: ti.i32, grid: i32_1d, prefix: i32_1d, counts: i32_2d,
              keep: u8_1d):
        for e in range(offsets[f0], offsets[f1]):
            f = frame_of(offsets, f0, f1, e)
            dense = ti.cast(offsets[f + 1] - offsets[f] >= dense_min, ti.i32)
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            at = (f - f0) * geo.plane + fg.cell_index(geo, xe, ye)
            pat = (f - f0) * geo.prefix_plane + fg.prefix_index(geo, xe, ye)
            going = 1  # until decided: below a threshold, or at enough[k] (kept)
            kept = 1
            c = 0
            for k in ti.static(range(n_radii)):
                if going == 1:
                    c = disk_count(grid, prefix, at, pat, k, dense, c)
                    counts[e, k] = c
                    if c < thresholds[k]:
                        going, kept = 0, 0
                    elif c >= enough[k]:
                        going = 0
                else:
                    counts[e, k] = -1
            keep[e] = ti.cast(kept, ti.u8)

    @ti.kernel
    def unbin_frames(x: u16_1d, y: u16_1d, offsets: i32_1d, f0: ti.i32, f1: ti.i32, grid: i32_1d):
        for e in range(offsets[f0], offsets[f1]):
            f = frame_of(offsets, f0, f1, e)
            grid[(f - f0) * geo.plane + fg.cell_index(geo, ti.cast(x[e], ti.i32), ti.cast(y[e], ti.i32))] = 0

    return bin_frames, prefix_rows, count, unbin_frames
