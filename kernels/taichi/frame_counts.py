"""Multi-radius disk counts per pseudo-frame, lane-parallel for CPUs (no per-event atomics).

Each busy iteration of the parallel loop owns a run of whole frames and a private grid
slot: it bins a frame, counts radius 1 for every event, then the larger radii for the
survivors only (hierarchical screening), and un-bins the frame. Sparse frames read the
disk cells directly, radius k adding only its annulus to the count of radius k−1 (work
grows with events); dense frames build row prefix sums and read two cells per disk row
(work grows with pixels, once per frame). A frame is dense when it holds >= dense_min
events, or — after radius 1 — when its survivors would read more cells than a prefix
pass costs (disk_costs).

`count_frames_kernel(disks, width, height, cell)` builds (and caches) a kernel for one
sensor size and one set of disks: the disks and the grid's row stride are compile-time
constants, so every cell read is unrolled at a constant offset. `disks[k]` is a tuple of
(dy, w) rows, w the half-width of row dy. Cell layouts: see frame_grids ("u16x4" for
launches whose frames hold <= frame_grids.MAX_EVENTS events, "i32" otherwise).

Outputs: counts[e, k] = events of e's frame in disk k around e (e included), -1 where e
was rejected at an earlier radius; keep[e] = 1 iff counts[e, k] >= thresholds[k] for all k.
"""
import functools

import taichi as ti

from . import frame_grids as fg
from . import slots

u16_1d = ti.types.ndarray(dtype=ti.u16, ndim=1)
i32_1d = ti.types.ndarray(dtype=ti.i32, ndim=1)
i32_2d = ti.types.ndarray(dtype=ti.i32, ndim=2)
u8_1d = ti.types.ndarray(dtype=ti.u8, ndim=1)

#: cost of one row-prefix cell relative to one direct cell read (sequential vs scattered)
PREFIX_CELL_COST = 0.75


def disk_padding(disks):
    return max(max(abs(dy), w) for rows in disks for dy, w in rows)


def annulus_segments(disks):
    """Per radius, the rows (dy, ((dx_lo, dx_hi), ...)) of disk k not in disk k−1."""
    out, prev = [], {}
    for rows in disks:
        segs = []
        for dy, w in rows:
            wp = prev.get(dy, -1)
            if wp < 0:
                segs.append((dy, ((-w, w),)))
            elif w > wp:
                segs.append((dy, ((-w, -wp - 1), (wp + 1, w))))
        out.append(tuple(segs))
        prev = dict(rows)
    return tuple(out)


def direct_costs(disks, geo, cell):
    """Reads per event of each radius's direct count: annulus cells, or SWAR words."""
    segments = annulus_segments(disks)
    if cell == "u16x4":  # words loaded, mean over the four alignments
        return [sum(len(g) for terms in fg.swar_terms(seg, geo.stride) for g in terms) / fg.LANES
                for seg in segments]
    return [sum(b - a + 1 for _, pieces in seg for a, b in pieces) for seg in segments]


def disk_costs(disks, geo, cell="i32"):
    """Compile-time costs (in reads) that steer the sparse/dense choice.

    Returns (dense_min, rest_gain, plane_cost): radius 1 uses prefix sums when a frame holds
    at least dense_min events; after radius 1, the survivors use prefix sums for the other
    radii when survivors * rest_gain > plane_cost.
    """
    direct = direct_costs(disks, geo, cell)
    plane_cost = int(PREFIX_CELL_COST * geo.prefix_plane)
    gain1 = max(direct[0] - 2 * len(disks[0]), 1)
    rest_gain = max(sum(direct[1:]) - 2 * sum(len(rows) for rows in disks[1:]), 1)
    return max(1, int(plane_cost // gain1)), max(1, int(rest_gain)), plane_cost


def make_disk_count(disks, geo, cell):
    """ti.func counting disk k around a cell: from row prefix sums (dense) or, sparse, the
    count c of disk k−1 plus the annulus cells read directly (all offsets constant)."""
    segments = annulus_segments(disks)
    stride, pstride = geo.stride, geo.prefix_stride
    sums = [fg.make_swar_sum(fg.swar_terms(seg, stride)) for seg in segments] if cell == "u16x4" else []

    @ti.func
    def disk_count(grid: ti.template(), prefix: ti.template(), at: ti.i32, pat: ti.i32,
                   k: ti.template(), dense: ti.i32, c: ti.i32) -> ti.i32:
        out = c
        if dense:
            out = 0
            for dy, w in ti.static(disks[k]):
                out += prefix[pat + dy * pstride + w + 1] - prefix[pat + dy * pstride - w]
        else:
            if ti.static(cell == "u16x4"):
                out += ti.static(sums[k])(grid, at)
            else:
                for dy, pieces in ti.static(segments[k]):
                    for a, b in ti.static(pieces):
                        for dx in ti.static(range(a, b + 1)):
                            out += grid[at + dy * stride + dx]
        return out

    return disk_count


@functools.lru_cache(maxsize=None)
def count_frames_kernel(disks, width, height, cell="i32"):
    """Kernel counting events in the nested `disks` (see module doc) for every frame.

    Call as kernel(x, y, offsets, unit_lo, unit_hi, thresholds, dense_min, grid, prefix,
    busy, counts, keep); dense_min < 0 uses the built-in cost model, 0 forces prefix sums,
    a huge value forces direct reads. grid holds busy.shape[0] planes of `cell` layout.
    """
    n_radii = len(disks)
    geo = fg.Geometry(width, height, disk_padding(disks))
    model_min, rest_gain, plane_cost = disk_costs(disks, geo, cell)
    dtype, bin_cell, unbin_cell, read_cell = fg.LAYOUTS[cell]
    grid_1d = ti.types.ndarray(dtype=dtype, ndim=1)
    disk_count = make_disk_count(disks, geo, cell)

    @ti.kernel
    def count_frames(x: u16_1d, y: u16_1d, offsets: i32_1d, unit_lo: i32_1d, unit_hi: i32_1d,
                     thresholds: i32_1d, dense_min: ti.i32, grid: grid_1d, prefix: i32_1d,
                     busy: i32_1d, counts: i32_2d, keep: u8_1d):
        first_dense = dense_min
        if first_dense < 0:
            first_dense = model_min
        for u in range(unit_lo.shape[0]):
            if unit_hi[u] > unit_lo[u]:
                slot = slots.claim(busy, busy.shape[0])
                g0 = slot * geo.plane
                p0 = slot * geo.prefix_plane
                for f in range(unit_lo[u], unit_hi[u]):
                    e0 = offsets[f]
                    e1 = offsets[f + 1]
                    for e in range(e0, e1):
                        bin_cell(grid, g0 + fg.cell_index(geo, ti.cast(x[e], ti.i32), ti.cast(y[e], ti.i32)))
                    dense = e1 - e0 >= first_dense
                    if dense:
                        fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
                    survivors = 0
                    for e in range(e0, e1):  # radius 1: every event
                        xe = ti.cast(x[e], ti.i32)
                        ye = ti.cast(y[e], ti.i32)
                        c = disk_count(grid, prefix, g0 + fg.cell_index(geo, xe, ye),
                                       p0 + fg.prefix_index(geo, xe, ye), 0, dense, 0)
                        counts[e, 0] = c
                        for k in ti.static(range(1, n_radii)):
                            counts[e, k] = -1
                        alive = ti.cast(c >= thresholds[0], ti.i32)
                        survivors += alive
                        keep[e] = ti.cast(alive, ti.u8)
                    if ti.static(n_radii > 1):
                        if survivors > 0 and not dense and dense_min < 0 and survivors * rest_gain > plane_cost:
                            fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
                            dense = True
                        if survivors > 0:
                            for e in range(e0, e1):  # larger radii: survivors only
                                if keep[e] == 1:
                                    c = counts[e, 0]
                                    alive = 1
                                    xe = ti.cast(x[e], ti.i32)
                                    ye = ti.cast(y[e], ti.i32)
                                    at = g0 + fg.cell_index(geo, xe, ye)
                                    pat = p0 + fg.prefix_index(geo, xe, ye)
                                    for k in ti.static(range(1, n_radii)):
                                        if alive == 1:
                                            c = disk_count(grid, prefix, at, pat, k, dense, c)
                                            counts[e, k] = c
                                            if c < thresholds[k]:
                                                alive = 0
                                    keep[e] = ti.cast(alive, ti.u8)
                    for e in range(e0, e1):
                        unbin_cell(grid, g0 + fg.cell_index(geo, ti.cast(x[e], ti.i32), ti.cast(y[e], ti.i32)))
                slots.release(busy, slot)

    return count_frames
