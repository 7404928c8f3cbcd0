"""Per-frame dense grids: geometry and cell layouts (binning, un-binning, reading) for Taichi.

A grid slot is a flat plane of (H + 2·pad) rows x `stride` cells (stride >= W + 2·pad, a
multiple of 4) whose border of width `pad` (>= the largest disk half-width) stays zero, so
disk reads need no bounds checks. Grids are cleared by un-binning the frame's events,
never by touching every pixel. The row prefix plane has one more column:
prefix[r, c] = sum(grid[r, :c]). All sizes are Python constants baked into the kernels.

Two cell layouts:
- "i32": one int32 per cell; any count.
- "u16x4": four 16-bit cells per uint64 word (cell i is lane i % 4 of word i // 4). A disk
  is summed word-wise (SWAR): mask the lanes outside it, add the words lane by lane, and
  fold the four lanes with one multiply. Which words and masks depends on the centre's
  alignment (cell % 4).
  Exact when no frame holds more than MAX_EVENTS events: then no lane, partial or final
  sum can carry.
"""
from dataclasses import dataclass

import taichi as ti

LANES = 4
LANE_BITS = 16
MAX_EVENTS = (1 << LANE_BITS) - 1  # per frame, for u16x4 cells
FULL = (1 << 64) - 1
FOLD = 0x0001000100010001  # x * FOLD >> 48 = sum of the four 16-bit lanes of x


@dataclass(frozen=True)
class Geometry:
    width: int
    height: int
    pad: int

    @property
    def stride(self):
        return -(-(self.width + 2 * self.pad) // LANES) * LANES

    @property
    def rows(self):
        return self.height + 2 * self.pad

    @property
    def plane(self):
        return self.rows * self.stride

    @property
    def prefix_stride(self):
        return self.stride + 1

    @property
    def prefix_plane(self):
        return self.rows * self.prefix_stride


@ti.func
def cell_index(geo: ti.template(), x: ti.i32, y: ti.i32) -> ti.i32:
    return (y + geo.pad) * geo.stride + x + geo.pad


@ti.func
def prefix_index(geo: ti.template(), x: ti.i32, y: ti.i32) -> ti.i32:
    return (y + geo.pad) * geo.prefix_stride + x + geo.pad


# -- i32 cells ---------------------------------------------------------------------------
@ti.func
def i32_bin(grid: ti.template(), at: ti.i32):
    grid[at] = grid[at] + 1  # serial inside a lane: plain read-modify-write, no atomics


@ti.func
def i32_unbin(grid: ti.template(), at: ti.i32):
    grid[at] = 0


@ti.func
def i32_cell(grid: ti.template(), i: ti.i32) -> ti.i32:
    return grid[i]


# -- u16x4 cells -------------------------------------------------------------------------
@ti.func
def u16x4_bin(words: ti.template(), at: ti.i32):
    w = at >> 2
    words[w] = words[w] + (ti.u64(1) << ti.cast(LANE_BITS * (at & 3), ti.u64))


@ti.func
def u16x4_unbin(words: ti.template(), at: ti.i32):
    w = at >> 2
    words[w] = words[w] & ~(ti.u64(0xFFFF) << ti.cast(LANE_BITS * (at & 3), ti.u64))


@ti.func
def u16x4_cell(words: ti.template(), i: ti.i32) -> ti.i32:
    return ti.cast((words[i >> 2] >> ti.cast(LANE_BITS * (i & 3), ti.u64)) & ti.u64(0xFFFF), ti.i32)


def swar_terms(segments, stride):
    """For each alignment o = (centre cell) % 4: the (word offset, lane mask) pairs whose
    masked sum is the count of `segments` (rows (dy, ((dx_lo, dx_hi), ...))) around the
    centre. Offsets are relative to the centre's word; pieces of one row sharing a word
    have their masks merged (they are disjoint)."""
    out = []
    for o in range(LANES):
        terms = {}
        for dy, pieces in segments:
            for a, b in pieces:
                s, e = o + a, o + b
                for j in range(s // LANES, e // LANES + 1):
                    lo, hi = max(s - LANES * j, 0), min(e - LANES * j, LANES - 1)
                    mask = sum(0xFFFF << (LANE_BITS * lane) for lane in range(lo, hi + 1))
                    key = dy * stride // LANES + j
                    terms[key] = terms.get(key, 0) | mask
        items = sorted(terms.items())
        out.append(tuple(tuple(items[i:i + 32]) for i in range(0, len(items), 32)))  # unroll <= 32 at a time
    return tuple(out)


def make_swar_sum(terms):
    """ti.func swar_sum(words, at): the count of the cells `terms` (see swar_terms)
    describes around cell `at`, each alignment at % 4 with its own unrolled words and masks.

    (Measured on the 2-core CPU: one branch on the alignment costs about what picking the
    masks with conditional moves costs, or grouping a frame's events by alignment first.)"""

    @ti.func
    def swar_sum(words: ti.template(), at: ti.i32) -> ti.i32:
        w0 = at >> 2
        o = at & 3
        acc = ti.u64(0)
        for ov in ti.static(range(LANES)):
            if o == ov:
                for group in ti.static(terms[ov]):
                    for off, mask in ti.static(group):
                        if ti.static(mask == FULL):
                            acc += words[w0 + off]
                        else:
                            acc += words[w0 + off] & ti.u64(mask)
        return ti.cast((acc * ti.u64(FOLD)) >> ti.u64(48), ti.i32)

    return swar_sum


LAYOUTS = {
    "i32": (ti.i32, i32_bin, i32_unbin, i32_cell),
    "u16x4": (ti.u64, u16x4_bin, u16x4_unbin, u16x4_cell),
}


@ti.func
def row_prefix_sums(grid: ti.template(), g0: ti.i32, prefix: ti.template(), p0: ti.i32,
                    geo: ti.template(), cell: ti.template()):
    for r in range(geo.pad, geo.pad + geo.height):
        s = 0
        prefix[p0 + r * geo.prefix_stride] = 0
        for c in range(geo.stride):
            s += cell(grid, g0 + r * geo.stride + c)
            prefix[p0 + r * geo.prefix_stride + c + 1] = s
