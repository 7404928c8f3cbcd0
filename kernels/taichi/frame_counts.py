"""Multi-radius disk counts per pseudo-frame, lane-parallel for CPUs (no per-event atomics).

Specification: `evstar_kernels.reference.denoise.mr_ndsef` (bit-exact masks and counts).

Each busy iteration of the parallel loop owns a run of whole frames and a private scratch
slot: it bins a frame, counts radius 1 for every event, then the larger radii for the
survivors only (hierarchical screening), and un-bins the frame. Frame layouts:

- SPARSE (work grows with events): a plane of occupancy bit tiles (bit_tiles) holds which
  pixels have an event, and the cell grid holds only the *extras* (count − 1) of pixels
  with repeated events, listed as they appear and marked in a second tile plane (the
  repeat bits). A disk's count is a few popcounts of tile & mask, plus — only where the
  repeat bits say the disk holds repeats — the extras in its cells, read from the grid.
- FULL: the grid holds the counts, and a disk's cells are read directly (SWAR words).
- PREFIX (work grows with pixels, once per frame): FULL plus row prefix sums; each disk
  row costs two reads.

A frame of >= dense_min events starts in PREFIX, the others in SPARSE (FULL for disks too
small for tiles to pay). After radius 1 the survivors' pixels decide whether the larger
radii stay as they are or fold the bits into full counts (FULL), with prefix sums on top
if cheaper (frame_costs). docs/kernels.md explains the layouts and the cost model.

Every step below is a ti.func inlined into the one kernel, and each way of counting a
radius appears there once, which keeps the compile time down. Cell layouts: frame_grids
("u16x4" for launches whose frames hold <= frame_grids.MAX_EVENTS events, "i32" otherwise).

Outputs: counts[e, k] = events of e's frame in disk k around e (e included), -1 where e
was rejected at an earlier radius (or, counting for the mask alone, kept at an earlier
radius whose count reached every larger threshold); keep[e] = 1 iff counts[e, k] >=
thresholds[k] for all k.
"""
import functools
from dataclasses import dataclass

import taichi as ti

from . import bit_tiles
from . import frame_grids as fg
from . import slots
from .disk_reads import annulus_segments, disk_padding, make_direct_count, make_prefix_count
from .frame_costs import Costs, disk_costs
from .arrays import i32_1d, i32_2d, u16_1d, u64_1d, u8_1d


#: layouts of a frame (see the module doc)
SPARSE, FULL, PREFIX = 0, 1, 2
#: a sparse frame's tile plane is cleared whole once its events number more than the
#: plane's words / CLEAR_STORES (a sequential store costs a fraction of a scattered one)
CLEAR_STORES = 4
#: keep[e] of a radius-1 survivor the larger radii still have to decide (final keep is 0 or 1)
UNDECIDED = 2


def tile_masks(disks, width, height):
    """The mask table count_frames_kernel(disks, width, height, ...) takes (uint64)."""
    geo = fg.Geometry(width, height, disk_padding(disks))
    return bit_tiles.mask_table(bit_tiles.plan(geo, disks), annulus_segments(disks))


def scratch_sizes(disks, width, height):
    """Elements per slot of the kernel's scratch: (grid cells, prefix, tiles and repeat bits)."""
    geo = fg.Geometry(width, height, disk_padding(disks))
    return geo.plane, geo.prefix_plane, bit_tiles.plan(geo, disks).plane


@dataclass(frozen=True)
class _Plan:
    """What one compiled kernel is specialised on (compile-time constants)."""
    n_radii: int
    geo: fg.Geometry
    tp: bit_tiles.TilePlan
    costs: Costs
    cell: str
    selective: bool  # only the events `ask` marks are tested
    stored: int      # radii whose counts are stored (n_radii, or 1 for the mask alone)


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
def clear_owners(owners: ti.template(), owned: ti.template(), r0: ti.i32, n_owned: ti.i32):
    """Forget the frame's pixel owners (only the pixels listed in owned)."""
    for i in range(n_owned):
        owners[owned[r0 + i]] = 0


def make_tile_and_bit(plan):
    """ti.func (tile, bit) of a pixel in the slot's bit tiles."""
    geo, tp = plan.geo, plan.tp

    @ti.func
    def tile_and_bit(xe: ti.i32, ye: ti.i32):
        return bit_tiles.tile_of(tp, xe + geo.pad, ye + geo.pad), bit_tiles.bit_of(xe + geo.pad, ye + geo.pad)

    return tile_and_bit


def make_start_layout(plan):
    """ti.func the layout a frame of n events starts in (radius 1)."""
    costs = plan.costs

    @ti.func
    def start_layout(n: ti.i32, first_dense: ti.i32) -> ti.i32:
        layout = SPARSE
        if ti.static(not costs.tiles):
            layout = FULL
        if n >= first_dense:
            layout = PREFIX
        return layout

    return start_layout


def make_survivor_layout(plan):
    """ti.func the cheapest layout for the larger radii, given radius 1's survivors."""
    costs = plan.costs

    @ti.func
    def survivor_layout(layout: ti.i32, n: ti.i32, survivors: ti.i32, prefix_allowed: ti.i32) -> ti.i32:
        """For a frame of n events now in `layout` whose survivors sit on `survivors` pixels
        (each pixel is counted once)."""
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

    return survivor_layout


def make_bin_frame(plan):
    """ti.func binning a frame's events in its layout (SPARSE: bits, extras, repeat bits)."""
    geo = plan.geo
    _, bin_cell, _, read_cell = fg.LAYOUTS[plan.cell]
    tile_and_bit = make_tile_and_bit(plan)

    @ti.func
    def bin_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, layout: ti.i32,
                  grid: ti.template(), tiles: ti.template(), repeated: ti.template(),
                  repeats: ti.template(), g0: ti.i32, t0: ti.i32, r0: ti.i32) -> ti.i32:
        """Returns how many pixels it listed in repeats."""
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

    return bin_frame


def make_fold_frame(plan):
    """ti.func turning a sparse frame's bits + extras into full counts (bits cleared)."""
    geo = plan.geo
    bin_cell = fg.LAYOUTS[plan.cell][1]
    tile_and_bit = make_tile_and_bit(plan)

    @ti.func
    def fold_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, grid: ti.template(),
                   tiles: ti.template(), g0: ti.i32, t0: ti.i32):
        for e in range(e0, e1):
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            t, b = tile_and_bit(xe, ye)
            if tiles[t0 + t] & b != ti.u64(0):
                bin_cell(grid, g0 + fg.cell_index(geo, xe, ye))
                tiles[t0 + t] = tiles[t0 + t] & ~b

    return fold_frame


def make_unbin_frame(plan):
    """ti.func leaving the frame's scratch all zero again."""
    geo, tp = plan.geo, plan.tp
    unbin_cell = fg.LAYOUTS[plan.cell][2]

    @ti.func
    def unbin_frame(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, layout: ti.i32,
                    grid: ti.template(), tiles: ti.template(), repeated: ti.template(),
                    repeats: ti.template(), n_rep: ti.i32, g0: ti.i32, t0: ti.i32, r0: ti.i32):
        if layout == SPARSE and (e1 - e0) * CLEAR_STORES > tp.plane:
            for i in range(tp.plane):  # many events: sequential stores beat scattered ones
                tiles[t0 + i] = ti.u64(0)
        else:
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

    return unbin_frame


def make_count_radius1(plan, disks):
    """ti.func counting radius 1 for every event of a frame; returns (n_owned, n_alive)."""
    geo, n_radii = plan.geo, plan.n_radii
    prefix_count = make_prefix_count(disks, geo)
    direct_count = make_direct_count(disks, geo, plan.cell)
    box_count = bit_tiles.make_box_count(plan.tp, 0)

    @ti.func
    def count_radius1(x: ti.template(), y: ti.template(), ask: ti.template(), e0: ti.i32,
                      e1: ti.i32, layout: ti.i32, thresholds: ti.template(), enough: ti.template(),
                      grid: ti.template(), prefix: ti.template(), tiles: ti.template(),
                      repeated: ti.template(), masks: ti.template(), owners: ti.template(),
                      owned: ti.template(), g0: ti.i32, p0: ti.i32, t0: ti.i32, r0: ti.i32,
                      counts: ti.template(), keep: ti.template()):
        """Pixels of the frame get an owner (the first asked event to count them) where
        counting is dear (beside repeats) or an event survives undecided (its count below
        enough[0]); n_alive: those survivors' owners. Events not asked (selective plans)
        get counts -1 and keep 0."""
        n_owned = 0
        n_alive = 0
        for e in range(e0, e1):
            if ti.static(plan.selective):
                if ask[e] == 0:
                    for k in ti.static(range(plan.stored)):
                        counts[e, k] = -1
                    keep[e] = ti.u8(0)
                    continue
            xe = ti.cast(x[e], ti.i32)
            ye = ti.cast(y[e], ti.i32)
            at = g0 + fg.cell_index(geo, xe, ye)
            owner = -1
            c = 0
            direct = ti.cast(layout == FULL, ti.i32)
            if layout == PREFIX:
                c = prefix_count(prefix, p0 + fg.prefix_index(geo, xe, ye), 0)
            elif layout == SPARSE:
                occupied, near = box_count(tiles, repeated, masks, t0, xe + geo.pad, ye + geo.pad)
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
            for k in ti.static(range(1, plan.stored)):
                counts[e, k] = -1
            alive = ti.cast(c >= thresholds[0], ti.i32)
            keep[e] = ti.cast(alive, ti.u8)
            if ti.static(n_radii > 1):
                if alive == 1 and c < enough[0]:  # the larger radii decide
                    keep[e] = ti.u8(UNDECIDED)
                    if owner < 0:
                        owner, n_owned = owner_of(owners, owned, at, e, r0, n_owned)
                    if owner == e:
                        n_alive += 1
        return n_owned, n_alive

    return count_radius1


def make_count_annulus(plan, disks):
    """ti.func disk k's count around (xe, ye) for k >= 1, given disk k−1's count c."""
    geo = plan.geo
    prefix_count = make_prefix_count(disks, geo)
    direct_count = make_direct_count(disks, geo, plan.cell)
    box_counts = [bit_tiles.make_box_count(plan.tp, k) for k in range(plan.n_radii)]

    @ti.func
    def count_annulus(grid: ti.template(), prefix: ti.template(), tiles: ti.template(),
                      repeated: ti.template(), masks: ti.template(), g0: ti.i32, p0: ti.i32,
                      t0: ti.i32, xe: ti.i32, ye: ti.i32, k: ti.template(), layout: ti.i32,
                      c: ti.i32) -> ti.i32:
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

    return count_annulus


def make_count_larger_radii(plan, disks):
    """ti.func counting radii 2..K for radius 1's undecided survivors, once per pixel (its
    owner), each until its fate is decided: below a threshold, or at enough[k]."""
    geo, n_radii = plan.geo, plan.n_radii
    count_annulus = make_count_annulus(plan, disks)

    @ti.func
    def count_larger_radii(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32,
                           layout: ti.i32, thresholds: ti.template(), enough: ti.template(),
                           grid: ti.template(), prefix: ti.template(), tiles: ti.template(),
                           repeated: ti.template(), masks: ti.template(), owners: ti.template(),
                           g0: ti.i32, p0: ti.i32, t0: ti.i32, counts: ti.template(),
                           keep: ti.template()):
        for e in range(e0, e1):
            if keep[e] == UNDECIDED:
                xe = ti.cast(x[e], ti.i32)
                ye = ti.cast(y[e], ti.i32)
                owner = owners[g0 + fg.cell_index(geo, xe, ye)] - 1
                if owner != e:  # the owner came first: same counts
                    for k in ti.static(range(1, plan.stored)):
                        counts[e, k] = counts[owner, k]
                    keep[e] = keep[owner]
                else:
                    c = counts[e, 0]
                    going = 1
                    kept = 1
                    for k in ti.static(range(1, n_radii)):
                        if going == 1:
                            c = count_annulus(grid, prefix, tiles, repeated, masks, g0, p0, t0,
                                              xe, ye, k, layout, c)
                            if ti.static(k < plan.stored):
                                counts[e, k] = c
                            if c < thresholds[k]:
                                going, kept = 0, 0
                            elif c >= enough[k]:
                                going = 0
                    keep[e] = ti.cast(kept, ti.u8)

    return count_larger_radii


def make_relayout(plan):
    """ti.func moving a frame to the layout its survivors count cheapest in."""
    geo = plan.geo
    read_cell = fg.LAYOUTS[plan.cell][3]
    survivor_layout = make_survivor_layout(plan)
    fold_frame = make_fold_frame(plan)

    @ti.func
    def relayout(x: ti.template(), y: ti.template(), e0: ti.i32, e1: ti.i32, layout: ti.i32,
                 n_alive: ti.i32, prefix_allowed: ti.i32, grid: ti.template(), prefix: ti.template(),
                 tiles: ti.template(), g0: ti.i32, p0: ti.i32, t0: ti.i32) -> ti.i32:
        """Returns the new layout (fold the bits for FULL, row prefix sums for PREFIX)."""
        out = survivor_layout(layout, e1 - e0, n_alive, prefix_allowed)
        if layout == SPARSE and out != SPARSE:
            fold_frame(x, y, e0, e1, grid, tiles, g0, t0)
        if out == PREFIX:
            fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
        return out

    return relayout


@functools.lru_cache(maxsize=None)
def count_frames_kernel(disks, width, height, cell="i32", selective=False, stored=None):
    """Kernel counting events in the nested `disks` (see module doc) for every frame.

    Specification: `evstar_kernels.reference.denoise.mr_ndsef`.

    Call as kernel(x, y, ask, offsets, unit_lo, unit_hi, thresholds, enough, dense_min, grid,
    prefix, tiles, repeated, masks, repeats, owners, owned, busy, counts, keep); an event
    whose count at radius k reaches enough[k] is kept without counting the larger radii
    (the mask-only form: enough[k] = the largest threshold after k; int32 max counts all
    the radii the mask reaches); counts holds `stored` columns (default every radius; 1:
    radius 1's only, which the kernel needs, for the mask alone); `selective` kernels
    test only the events with ask[e] != 0 (every event still counts), others read no `ask`
    (any array); dense_min < 0 uses the
    built-in cost model, 0 forces prefix sums, a huge value forces direct reads (sparse,
    then full counts for the survivors where cheaper). grid, prefix, tiles, repeated and owners
    hold busy.shape[0] slots (scratch_sizes; owners as many cells as grid), all zero between
    calls; masks is tile_masks(disks, width, height); repeats and owned hold busy.shape[0]
    equal parts of room for a frame's distinct pixels (min(its events, width · height)).

    Events at one pixel have the same counts, so where counting is dear (radius 1 beside
    repeated pixels, and the larger radii) the pixel's first event counts — it becomes the
    pixel's owner — and the others copy its counts.
    """
    geo = fg.Geometry(width, height, disk_padding(disks))
    plan = _Plan(len(disks), geo, bit_tiles.plan(geo, disks), disk_costs(disks, geo, cell), cell,
                 selective, len(disks) if stored is None else stored)
    n_radii = plan.n_radii
    grid_1d = ti.types.ndarray(dtype=fg.LAYOUTS[cell][0], ndim=1)
    read_cell = fg.LAYOUTS[cell][3]
    start_layout, bin_frame, unbin_frame = make_start_layout(plan), make_bin_frame(plan), make_unbin_frame(plan)
    count_radius1, relayout = make_count_radius1(plan, disks), make_relayout(plan)
    count_larger_radii = make_count_larger_radii(plan, disks)

    @ti.kernel
    def count_frames(x: u16_1d, y: u16_1d, ask: u8_1d, offsets: i32_1d, unit_lo: i32_1d,
                     unit_hi: i32_1d, thresholds: i32_1d, enough: i32_1d, dense_min: ti.i32,
                     grid: grid_1d, prefix: i32_1d, tiles: u64_1d, repeated: u64_1d,
                     masks: u64_1d, repeats: i32_1d, owners: i32_1d, owned: i32_1d,
                     busy: i32_1d, counts: i32_2d, keep: u8_1d):
        first_dense = dense_min
        if first_dense < 0:
            first_dense = plan.costs.dense_min
        room = owned.shape[0] // busy.shape[0]
        for u in range(unit_lo.shape[0]):
            if unit_hi[u] > unit_lo[u]:
                slot = slots.claim(busy, busy.shape[0])
                g0, p0, t0, r0 = slot * geo.plane, slot * geo.prefix_plane, slot * plan.tp.plane, slot * room
                for f in range(unit_lo[u], unit_hi[u]):
                    e0 = offsets[f]
                    e1 = offsets[f + 1]
                    layout = start_layout(e1 - e0, first_dense)
                    n_rep = bin_frame(x, y, e0, e1, layout, grid, tiles, repeated, repeats, g0, t0, r0)
                    if layout == PREFIX:
                        fg.row_prefix_sums(grid, g0, prefix, p0, geo, read_cell)
                    n_owned, n_alive = count_radius1(x, y, ask, e0, e1, layout, thresholds,
                                                     enough, grid, prefix, tiles, repeated, masks,
                                                     owners, owned, g0, p0, t0, r0, counts, keep)
                    if ti.static(n_radii > 1):
                        if n_alive > 0:
                            if layout != PREFIX:
                                layout = relayout(x, y, e0, e1, layout, n_alive, dense_min < 0, grid,
                                                  prefix, tiles, g0, p0, t0)
                            count_larger_radii(x, y, e0, e1, layout, thresholds, enough, grid,
                                               prefix, tiles, repeated, masks, owners, g0, p0, t0,
                                               counts, keep)
                    unbin_frame(x, y, e0, e1, layout, grid, tiles, repeated, repeats, n_rep, g0, t0, r0)
                    clear_owners(owners, owned, r0, n_owned)
                slots.release(busy, slot)

    return count_frames
