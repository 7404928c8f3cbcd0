"""Multi-radius disk counts per pseudo-frame, lane-parallel for CPUs (no per-event atomics).

Each busy iteration of the parallel loop owns a run of whole frames and a private scratch
slot: it bins a frame, counts radius 1 for every event, then the larger radii for the
survivors only (hierarchical screening), and un-bins the frame. Frame layouts:

- SPARSE (work grows with events): a plane of occupancy bit tiles (bit_tiles) holds which
  pixels have an event, and the cell grid holds only the *extras* (count − 1) of pixels
  with repeated events, listed as they appear and marked in a second tile plane (the
  repeat bits). A disk's count is a few popcounts of tile & mask, plus — only where the
  repeat bits say the disk holds repeats — the extras in its cells, read from the grid.
  The planes stay in L1/L2 where a cell grid would not, and no alignment branch is taken.
- FULL: the grid holds the counts, and a disk's cells are read directly (SWAR words).
- PREFIX (work grows with pixels, once per frame): FULL plus row prefix sums; each disk
  row costs two reads.

Radius k adds its annulus to the count of radius k−1. A frame of >= dense_min events
starts in PREFIX, the others in SPARSE (FULL for disks too small for tiles to pay). After
radius 1 the survivors' pixels decide whether the larger radii stay as they are or fold
the bits into full counts (FULL), with prefix sums on top if cheaper (disk_costs).

`count_frames_kernel(disks, width, height, cell)` builds (and caches) a kernel for one
sensor size and one set of disks: the disks and the grid's row stride are compile-time
constants, so every cell read is unrolled at a constant offset. `disks[k]` is a tuple of
(dy, w) rows, w the half-width of row dy. Cell layouts: see frame_grids ("u16x4" for
launches whose frames hold <= frame_grids.MAX_EVENTS events, "i32" otherwise).

Outputs: counts[e, k] = events of e's frame in disk k around e (e included), -1 where e
was rejected at an earlier radius; keep[e] = 1 iff counts[e, k] >= thresholds[k] for all k.
"""
import functools
import math
from dataclasses import dataclass

import taichi as ti

from . import bit_tiles
from . import frame_grids as fg
from . import slots

u16_1d = ti.types.ndarray(dtype=ti.u16, ndim=1)
u64_1d = ti.types.ndarray(dtype=ti.u64, ndim=1)
i32_1d = ti.types.ndarray(dtype=ti.i32, ndim=1)
i32_2d = ti.types.ndarray(dtype=ti.i32, ndim=2)
u8_1d = ti.types.ndarray(dtype=ti.u8, ndim=1)

#: cost of one row-prefix cell relative to one direct cell read (sequential vs scattered)
PREFIX_CELL_COST = 0.75
#: reads per tile under a sparse disk's box (the tile, its repeat bits; the masks come in
#: one vector load): measured, a radius-3 disk's 2 x 2 tiles beat its 10 SWAR words
TILE_READS = 2
#: reads per event to fold a sparse frame into full counts (and un-bin cells later)
FOLD_READS = 3
#: layouts of a frame for the survivors of radius 1 (see count_frames_kernel)
SPARSE, FULL, PREFIX = 0, 1, 2


def disk_padding(disks):
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


def direct_costs(disks, geo, cell):
    """Reads per event of each radius's direct count: annulus cells, or SWAR words."""
    segments = annulus_segments(disks)
    if cell == "u16x4":  # words loaded, mean over the four alignments
        return [sum(len(g) for terms in fg.swar_terms(seg, geo.stride) for g in terms) / fg.LANES
                for seg in segments]
    return [sum(b - a + 1 for _, pieces in seg for a, b in pieces) for seg in segments]


def prefix_break_even(direct, disks, geo):
    """Events from which a frame's radius-1 counts are cheaper from row prefix sums, when
    each event costs direct[0] reads otherwise (the event-parallel form's model)."""
    plane_cost = int(PREFIX_CELL_COST * geo.prefix_plane)
    return max(1, int(plane_cost // max(direct[0] - 2 * len(disks[0]), 1)))


def repeat_share(n_events, geo, cells):
    """Chance that `cells` pixels hold a repeated pixel, for n_events spread evenly over the
    sensor (Poisson per pixel)."""
    lam = n_events / (geo.width * geo.height)
    repeat = -math.expm1(-lam) - lam * math.exp(-lam)  # P[count >= 2]
    return -math.expm1(cells * math.log1p(-min(repeat, 1 - 1e-12)))


@dataclass(frozen=True)
class Costs:
    """Compile-time costs (in reads) that steer the lane kernel's layouts (see disk_costs)."""
    tiles: bool         # radius 1 of sparse frames from bit tiles (else direct reads)
    dense_min: int      # a frame of >= dense_min events is counted from prefix sums
    plane: int          # one row-prefix pass
    fold: int           # per event: folding the bits into full counts, un-binning cells
    rest_sparse: float  # per survivor, radii 2..K: tiles + extras (beside repeats)
    rest_direct: float  # ... direct reads of full counts
    rest_prefix: float  # ... prefix reads


def disk_costs(disks, geo, cell="i32"):
    """The Costs of `disks` on `geo`.

    Radius 1 of a frame costs, per event, its tiles' reads plus — when the disk holds
    repeats — the direct reads of the extras (sparse; small disks read their cells directly
    instead, when that is fewer reads than the tiles), or two reads per disk row after a
    prefix pass (dense). Survivors sit where events pile up, so they are costed as beside
    repeats.
    """
    direct = direct_costs(disks, geo, cell)
    tp = bit_tiles.plan(geo, disks)
    plane = int(PREFIX_CELL_COST * geo.prefix_plane)

    tiles = TILE_READS * tp.spans[0] ** 2 < direct[0]

    def gain1(n):  # per event, sparse minus dense, radius 1
        if not tiles:
            return max(direct[0] - 2 * len(disks[0]), 1)
        share = repeat_share(n, geo, sum(2 * w + 1 for _, w in disks[0]))
        return TILE_READS * tp.spans[0] ** 2 + share * direct[0] - 2 * len(disks[0])

    n = 1
    while n < (1 << 30) and n * gain1(n) <= plane:
        n *= 2
    lo = n // 2
    while n - lo > 1:  # the first n with n * gain1(n) > plane
        mid = (lo + n) // 2
        lo, n = (mid, n) if mid * gain1(mid) <= plane else (lo, mid)
    return Costs(tiles=tiles, dense_min=n, plane=plane, fold=FOLD_READS,
                 rest_sparse=sum(TILE_READS * s * s + d for s, d in zip(tp.spans[1:], direct[1:])),
                 rest_direct=sum(direct[1:]), rest_prefix=sum(2 * len(rows) for rows in disks[1:]))


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


def tile_masks(disks, width, height):
    """The mask table count_frames_kernel(disks, width, height, ...) takes (uint64)."""
    geo = fg.Geometry(width, height, disk_padding(disks))
    return bit_tiles.mask_table(bit_tiles.plan(geo, disks), annulus_segments(disks))


def scratch_sizes(disks, width, height):
    """Elements per slot of the kernel's scratch: (grid cells, prefix, tiles and repeat bits)."""
    geo = fg.Geometry(width, height, disk_padding(disks))
    return geo.plane, geo.prefix_plane, bit_tiles.plan(geo, disks).plane


@functools.lru_cache(maxsize=None)
def count_frames_kernel(disks, width, height, cell="i32"):
    """Kernel counting events in the nested `disks` (see module doc) for every frame.

    Call as kernel(x, y, offsets, unit_lo, unit_hi, thresholds, dense_min, grid, prefix,
    tiles, repeated, masks, repeats, owners, owned, busy, counts, keep); dense_min < 0 uses the
    built-in cost model, 0 forces prefix sums, a huge value forces direct reads (sparse,
    then full counts for the survivors where cheaper). grid, prefix, tiles, repeated and owners
    hold busy.shape[0] slots (scratch_sizes; owners as many cells as grid), all zero between
    calls; masks is tile_masks(disks, width, height); repeats and owned hold busy.shape[0]
    equal parts of room for a frame's distinct pixels (min(its events, width · height)).

    Events at one pixel have the same counts, so where counting is dear (radius 1 beside
    repeated pixels, and the larger radii) the pixel's first event counts — it becomes the
    pixel's owner — and the others copy its counts.
    """
    n_radii = len(disks)
    geo = fg.Geometry(width, height, disk_padding(disks))
    tp = bit_tiles.plan(geo, disks)
    costs = disk_costs(disks, geo, cell)
    dtype, bin_cell, unbin_cell, read_cell = fg.LAYOUTS[cell]
    grid_1d = ti.types.ndarray(dtype=dtype, ndim=1)
    prefix_count = make_prefix_count(disks, geo)
    direct_count = make_direct_count(disks, geo, cell)
    box_counts = [bit_tiles.make_box_count(tp, k) for k in range(n_radii)]

    @ti.func
    def count(grid: ti.template(), prefix: ti.template(), tiles: ti.template(), repeated: ti.template(),
              masks: ti.template(), g0: ti.i32, p0: ti.i32, t0: ti.i32, xe: ti.i32, ye: ti.i32,
              k: ti.template(), layout: ti.i32, c: ti.i32) -> ti.i32:
        """Disk k's count around (xe, ye) for k >= 1, given disk k−1's count c. (Radius 1
        has its own loop; each way of counting a radius appears once in the kernel, which
        keeps its compile time down.)"""
        out = c
        if layout == PREFIX:
            out = prefix_count(prefix, p0 + fg.prefix_index(geo, xe, ye), k)
        else:
            direct = 1
            if layout == SPARSE:
                occupied, near = ti.static(box_counts[k])(tiles, repeated, masks, t0, xe + geo.pad,
                                                             ye + geo.pad)
                out += occupied
                direct = ti.cast(near != ti.u64(0), ti.i32)  # repeats in the annulus: add their extras
            if direct:
                out = direct_count(grid, g0 + fg.cell_index(geo, xe, ye), k, out)
        return out

    @ti.func
    def tile_and_bit(xe: ti.i32, ye: ti.i32):
        return bit_tiles.tile_of(tp, xe + geo.pad, ye + geo.pad), bit_tiles.bit_of(xe + geo.pad, ye + geo.pad)

    @ti.func
    def survivor_layout(layout: ti.i32, n: ti.i32, survivors: ti.i32, prefix_allowed: ti.i32) -> ti.i32:
        """The cheapest layout for a frame of n events now in `layout` whose survivors sit
        on `survivors` pixels (each pixel is counted once)."""
        s = ti.cast(survivors, ti.f32)
        fold = 0.0
        cost = s * costs.rest_direct
        best = layout
        if layout == SPARSE:
            fold = ti.cast(costs.fold, ti.f32) * ti.cast(n, ti.f32)
            cost = s * costs.rest_sparse
            if fold + s * costs.rest_direct < cost:
                best = FULL
                cost = fold + s * costs.rest_direct
        if prefix_allowed and fold + costs.plane + s * costs.rest_prefix < cost:
            best = PREFIX
        return best

    @ti.func
    def bin_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, layout: ti.i32,
                  grid: ti.template(), tiles: ti.template(), repeated: ti.template(),
                  repeats: ti.template(), g0: ti.i32, t0: ti.i32, r0: ti.i32) -> ti.i32:
        """Bin the frame's events in `layout`; returns how many pixels it listed in repeats."""
        n_rep = 0
        for e in range(e0, e1):
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            at = fg.cell_index(geo, xe, ye)
            if layout != SPARSE:
                bin_cell(grid, g0 + at)
            else:  # a bit per pixel; a repeat goes to the extras (and to the repeat bits)
                t, b = tile_and_bit(xe, ye)
                word = tiles[t0 + t]
                if word & b != ti.u64(0):
                    if read_cell(grid, g0 + at) == 0:
                        repeats[r0 + n_rep] = at
                        n_rep += 1
                    bin_cell(grid, g0 + at)
                    repeated[t0 + t] = repeated[t0 + t] | b
                else:
                    tiles[t0 + t] = word | b
        return n_rep

    @ti.func
    def owner_of(owners: ti.template(), owned: ti.template(), at: ti.i32, e: ti.i32, r0: ti.i32,
                 n_owned: ti.i32):
        """The pixel's owner (its first event to ask); e becomes it if there is none yet."""
        owner = owners[at] - 1
        if owner < 0:
            owner = e
            owners[at] = e + 1
            owned[r0 + n_owned] = at
            n_owned += 1
        return owner, n_owned

    @ti.func
    def fold_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, grid: ti.template(),
                   tiles: ti.template(), g0: ti.i32, t0: ti.i32):
        """Turn a sparse frame's bits + extras into full counts in the grid (bits cleared)."""
        for e in range(e0, e1):
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            t, b = tile_and_bit(xe, ye)
            if tiles[t0 + t] & b != ti.u64(0):
                bin_cell(grid, g0 + fg.cell_index(geo, xe, ye))
                tiles[t0 + t] = tiles[t0 + t] & ~b

    @ti.func
    def unbin_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, layout: ti.i32,
                    grid: ti.template(), tiles: ti.template(), repeated: ti.template(),
                    repeats: ti.template(), n_rep: ti.i32, g0: ti.i32, t0: ti.i32, r0: ti.i32):
        """Leave the frame's scratch all zero again."""
        for e in range(e0, e1):
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            if layout == SPARSE:  # every bit of a tile is this frame's: clear it whole
                tiles[t0 + bit_tiles.tile_of(tp, xe + geo.pad, ye + geo.pad)] = ti.u64(0)
            else:
                unbin_cell(grid, g0 + fg.cell_index(geo, xe, ye))
        for i in range(n_rep):
            at = repeats[r0 + i]
            unbin_cell(grid, g0 + at)
            repeated[t0 + bit_tiles.tile_of(tp, at % geo.stride, at // geo.stride)] = ti.u64(0)

    @ti.kernel
    def count_frames(x: u16_1d, y: u16_1d, offsets: i32_1d, unit_lo: i32_1d, unit_hi: i32_1d,
                     thresholds: i32_1d, dense_min: ti.i32, grid: grid_1d, prefix: i32_1d,
                     tiles: u64_1d, repeated: u64_1d, masks: u64_1d, repeats: i32_1d,
                     owners: i32_1d, owned: i32_1d, busy: i32_1d, counts: i32_2d, keep: u8_1d):
        first_dense = dense_min
        if first_dense < 0:
            first_dense = costs.dense_min
        room = owned.shape[0] // busy.shape[0]
        for u in range(unit_lo.shape[0]):
            if unit_hi[u] > unit_lo[u]:
                slot = slots.claim(busy, busy.shape[0])
                g0 = slot * geo.plane
                p0 = slot * geo.prefix_plane
                t0 = slot * tp.plane
                r0 = slot * room
                for f in range(unit_lo[u], unit_hi[u]):
                    e0 = offsets[f]
                    e1 = offsets[f + 1]
                    layout = SPARSE
                    if ti.static(not costs.tiles):
                        layout = FULL
                    if e1 - e0 >= first_dense:
                        layout = PREFIX
                    n_rep = bin_frame(x, y, e0, e1, layout, grid, tiles, repeated, repeats, g0, t0, r0)
                    if layout == PREFIX:
                        fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
                    n_owned = 0  # pixels counted by their first event, the pixel's owner
                    n_alive = 0  # ... of them, pixels of survivors
                    for e in range(e0, e1):  # radius 1: every event
                        xe = ti.cast(x[e], ti.i32)
                        ye = ti.cast(y[e], ti.i32)
                        at = g0 + fg.cell_index(geo, xe, ye)
                        owner = -1
                        c = 0
                        direct = ti.cast(layout == FULL, ti.i32)
                        if layout == PREFIX:
                            c = prefix_count(prefix, p0 + fg.prefix_index(geo, xe, ye), 0)
                        elif layout == SPARSE:
                            occupied, near = ti.static(box_counts[0])(tiles, repeated, masks, t0,
                                                                      xe + geo.pad, ye + geo.pad)
                            c = occupied
                            if near != ti.u64(0):  # repeats in the disk: their extras, once per pixel
                                owner, n_owned = owner_of(owners, owned, at, e, r0, n_owned)
                                if owner == e:
                                    direct = 1
                                else:
                                    c = counts[owner, 0]
                        if direct:
                            c = direct_count(grid, at, 0, c)
                        counts[e, 0] = c
                        for k in ti.static(range(1, n_radii)):
                            counts[e, k] = -1
                        alive = ti.cast(c >= thresholds[0], ti.i32)
                        keep[e] = ti.cast(alive, ti.u8)
                        if ti.static(n_radii > 1):
                            if alive == 1:
                                if owner < 0:
                                    owner, n_owned = owner_of(owners, owned, at, e, r0, n_owned)
                                if owner == e:
                                    n_alive += 1
                    if ti.static(n_radii > 1):
                        if n_alive > 0 and layout != PREFIX:
                            was = layout
                            layout = survivor_layout(layout, e1 - e0, n_alive, dense_min < 0)
                            if was == SPARSE and layout != SPARSE:
                                fold_frame(x, y, e0, e1, grid, tiles, g0, t0)
                            if layout == PREFIX:
                                fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
                        for e in range(e0, e1):  # larger radii: survivors only, once per pixel
                            if n_alive > 0 and keep[e] == 1:
                                xe = ti.cast(x[e], ti.i32)
                                ye = ti.cast(y[e], ti.i32)
                                owner = owners[g0 + fg.cell_index(geo, xe, ye)] - 1
                                if owner != e:  # the owner came first: same counts
                                    for k in ti.static(range(1, n_radii)):
                                        counts[e, k] = counts[owner, k]
                                    keep[e] = keep[owner]
                                else:
                                    c = counts[e, 0]
                                    alive = 1
                                    for k in ti.static(range(1, n_radii)):
                                        if alive == 1:
                                            c = count(grid, prefix, tiles, repeated, masks, g0, p0, t0,
                                                      xe, ye, k, layout, c)
                                            counts[e, k] = c
                                            if c < thresholds[k]:
                                                alive = 0
                                    keep[e] = ti.cast(alive, ti.u8)
                    unbin_frame(x, y, e0, e1, layout, grid, tiles, repeated, repeats, n_rep, g0, t0, r0)
                    for i in range(n_owned):
                        owners[owned[r0 + i]] = 0
                slots.release(busy, slot)

    return count_frames
