"""The cost model (in memory reads) that picks how the lane kernel lays out a frame.

See docs/kernels.md ("Cost model"): radius 1 of a frame is counted from bit tiles (SPARSE),
direct cell reads (FULL) or row prefix sums (PREFIX), whichever reads least; after radius
1 the survivors' pixels decide again for the larger radii.
"""
import math
from dataclasses import dataclass

from . import bit_tiles
from . import frame_grids as fg
from .disk_reads import annulus_segments

#: cost of one row-prefix cell relative to one direct cell read (sequential vs scattered)
PREFIX_CELL_COST = 0.75
#: reads per tile under a sparse disk's box (the tile, its repeat bits; the masks come in
#: one vector load): measured, a radius-3 disk's 2 x 2 tiles beat its 10 SWAR words
TILE_READS = 2
#: reads per event to fold a sparse frame into full counts (and un-bin cells later)
FOLD_READS = 3


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

    return Costs(tiles=tiles, dense_min=_first_above(gain1, plane), plane=plane, fold=FOLD_READS,
                 rest_sparse=sum(TILE_READS * s * s + d for s, d in zip(tp.spans[1:], direct[1:])),
                 rest_direct=sum(direct[1:]), rest_prefix=sum(2 * len(rows) for rows in disks[1:]))


def _first_above(gain, plane):
    """The first n with n · gain(n) > plane (doubling, then bisection)."""
    n = 1
    while n < (1 << 30) and n * gain(n) <= plane:
        n *= 2
    lo = n // 2
    while n - lo > 1:
        mid = (lo + n) // 2
        lo, n = (mid, n) if mid * gain(mid) <= plane else (lo, mid)
    return n
