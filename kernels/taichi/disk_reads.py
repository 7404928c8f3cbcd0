"""A disk's count from a frame's grid: annuli, direct cell reads and row prefix sums.

`disks[k]` is a tuple of (dy, w) rows, w the half-width of row dy (compile-time constants,
so every read is unrolled at a constant offset). Radius k adds its annulus (disk k minus
disk k−1) to the count of radius k−1.
"""
import taichi as ti

from . import bit_tiles
from . import frame_grids as fg


def disk_padding(disks):
    """The grid border the largest disk needs (the tiles' extent covers the rows)."""
    return max(bit_tiles.extent(rows) for rows in disks)


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


def make_prefix_count(disks, geo):
    """ti.func disk k's count around a prefix cell: two reads per disk row."""
    pstride = geo.prefix_stride

    @ti.func
    def prefix_count(prefix: ti.template(), pat: ti.i32, k: ti.template()) -> ti.i32:
        out = 0
        for dy, w in ti.static(disks[k]):
            out += prefix[pat + dy * pstride + w + 1] - prefix[pat + dy * pstride - w]
        return out

    return prefix_count


def make_direct_count(disks, geo, cell):
    """ti.func adding the grid cells of disk k's annulus around a cell to c, read directly
    (SWAR words for u16x4; all offsets constant)."""
    segments = annulus_segments(disks)
    stride = geo.stride
    sums = [fg.make_swar_sum(fg.swar_terms(seg, stride)) for seg in segments] if cell == "u16x4" else []

    @ti.func
    def direct_count(grid: ti.template(), at: ti.i32, k: ti.template(), c: ti.i32) -> ti.i32:
        out = c
        if ti.static(cell == "u16x4"):
            out += ti.static(sums[k])(grid, at)
        else:
            for dy, pieces in ti.static(segments[k]):
                for a, b in ti.static(pieces):
                    for dx in ti.static(range(a, b + 1)):
                        out += grid[at + dy * stride + dx]
        return out

    return direct_count


def make_disk_count(disks, geo, cell):
    """ti.func adding disk k's annulus around a cell to the count c of disk k−1: from row
    prefix sums (dense) or the annulus cells read directly."""
    prefix_count = make_prefix_count(disks, geo)
    direct_count = make_direct_count(disks, geo, cell)

    @ti.func
    def disk_count(grid: ti.template(), prefix: ti.template(), at: ti.i32, pat: ti.i32,
                   k: ti.template(), dense: ti.i32, c: ti.i32) -> ti.i32:
        out = 0
        if dense:
            out = prefix_count(prefix, pat, k)
        else:
            out = direct_count(grid, at, k, c)
        return out

    return disk_count
