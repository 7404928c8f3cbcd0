"""Occupancy bit tiles of sparse frames: which pixels of a frame hold at least one event.

A tile is one uint64 holding an 8 x 8 block of the padded grid (bit 8·row + column), so
the few tiles under a disk's bounding box answer "how many occupied pixels in the disk"
with one popcount of tile & mask each, from a plane small enough to stay in L1 (40 KB for
640 x 480). The masks depend only on where the box starts inside its first tile: `masks`
holds, per radius and for each of the 64 start offsets, one mask per covered tile
(span x span tiles). Repeated events at one pixel are not in the bits; frame_counts keeps
them apart ("extras", count − 1 per pixel), and marks their pixels in a second plane of
tiles (the repeat bits) so that a disk learns from the same masks whether it holds any.

Coordinates are the cell grid's (frame_grids.Geometry, padding included), so a disk of
radius k around the event at padded (X, Y) has its box at (X − e_k, Y − e_k), e_k the
disk's extent (largest |dx| or |dy|).
"""
from dataclasses import dataclass

import numpy as np
import taichi as ti

TILE = 8
SHIFT = 3  # log2(TILE)
UNROLL_SPAN = 4  # boxes of at most 4 x 4 tiles are unrolled; larger ones loop


@dataclass(frozen=True)
class TilePlan:
    """Tile plane geometry and mask-table layout for one grid geometry and set of disks."""
    cols: int
    rows: int
    extents: tuple  # e_k per radius
    spans: tuple    # tiles per side of radius k's box
    bases: tuple    # where radius k's masks start in the mask table

    @property
    def plane(self):
        return self.cols * self.rows


def extent(rows):
    """The largest |dx| or |dy| of a disk given as (dy, half-width) rows."""
    return max(max(abs(dy), w) for dy, w in rows)


def plan(geo, disks):
    """Tile plane covering the padded grid and every disk box; mask-table offsets."""
    extents = tuple(extent(rows) for rows in disks)
    spans = tuple((2 * e + 2 * TILE - 1) // TILE for e in extents)
    # the last tile any box reads, and the last tile of a padded row / column
    cols = max([((geo.width - 1 + geo.pad - e) >> SHIFT) + s for e, s in zip(extents, spans)]
               + [-(-geo.stride // TILE)])
    rows = max([((geo.height - 1 + geo.pad - e) >> SHIFT) + s for e, s in zip(extents, spans)]
               + [-(-geo.rows // TILE)])
    bases = tuple(int(v) for v in np.cumsum([0] + [TILE * TILE * s * s for s in spans])[:-1])
    return TilePlan(cols, rows, extents, spans, bases)


def mask_table(tp, segments):
    """uint64 masks: radius k, box start (oy, ox) in its tile, tile (j, i) of the box ->
    the bits of that tile inside radius k's cells `segments[k]` ((dy, ((a, b), ...)) rows)."""
    out = []
    for k, seg in enumerate(segments):
        e, s = tp.extents[k], tp.spans[k]
        inside = np.zeros((s * TILE, s * TILE), bool)  # box-relative, with room for the offset
        for dy, pieces in seg:
            for a, b in pieces:
                inside[dy + e, a + e:b + e + 1] = True
        bit = np.left_shift(np.uint64(1), np.arange(TILE * TILE, dtype=np.uint64)).reshape(TILE, TILE)
        table = np.zeros((TILE, TILE, s, s), np.uint64)
        for oy in range(TILE):
            for ox in range(TILE):
                shifted = np.zeros((s * TILE, s * TILE), bool)
                shifted[oy:, ox:] = inside[:s * TILE - oy, :s * TILE - ox]
                blocks = shifted.reshape(s, TILE, s, TILE).transpose(0, 2, 1, 3)
                table[oy, ox] = np.bitwise_or.reduce(np.where(blocks, bit, np.uint64(0)), axis=(2, 3))
        out.append(table.reshape(-1))
    return np.concatenate(out)


@ti.func
def tile_of(tp: ti.template(), X: ti.i32, Y: ti.i32) -> ti.i32:
    return (Y >> SHIFT) * tp.cols + (X >> SHIFT)


@ti.func
def bit_of(X: ti.i32, Y: ti.i32) -> ti.u64:
    return ti.u64(1) << ti.cast(((Y & (TILE - 1)) << SHIFT) | (X & (TILE - 1)), ti.u64)


def make_box_count(tp, k):
    """ti.func (tiles, repeated, masks, t0, X, Y) -> (occupied pixels of radius k's cells
    around padded (X, Y), nonzero iff any of those cells holds repeated events)."""
    e, s, base = tp.extents[k], tp.spans[k], tp.bases[k]
    unrolled = s <= UNROLL_SPAN

    @ti.func
    def box_count(tiles: ti.template(), repeated: ti.template(), masks: ti.template(), t0: ti.i32,
                  X: ti.i32, Y: ti.i32):
        bx, by = X - e, Y - e
        first = t0 + tile_of(tp, bx, by)
        m0 = base + (((by & (TILE - 1)) << SHIFT) | (bx & (TILE - 1))) * (s * s)
        n = 0
        near = ti.u64(0)
        if ti.static(unrolled):
            for j in ti.static(range(s)):
                for i in ti.static(range(s)):
                    m = masks[m0 + j * s + i]
                    n += ti.cast(ti.math.popcnt(tiles[first + j * tp.cols + i] & m), ti.i32)
                    near |= repeated[first + j * tp.cols + i] & m
        else:
            for j in range(s):
                for i in range(s):
                    m = masks[m0 + j * s + i]
                    n += ti.cast(ti.math.popcnt(tiles[first + j * tp.cols + i] & m), ti.i32)
                    near |= repeated[first + j * tp.cols + i] & m
        return n, near

    return box_count
