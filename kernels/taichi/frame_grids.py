"""Per-frame dense grids: geometry and cell layouts (binning, un-binning, reading) for Taichi.

A grid slot is a flat plane of (H + 2·pad) rows x `stride` cells (stride >= W + 2·pad, a
multiple of 4) whose border of width `pad` (>= the largest disk half-width) stays zero, so
disk reads need no bounds checks. Grids are cleared by un-binning the frame's events,
never by touching every pixel. The row prefix plane has one more column:
prefix[r, c] = sum(grid[r, :c]). All sizes are Python constants baked into the kernels.

Two cell layouts:
- "i32": one int32 per cell; any count.
- "u16x4": four 16-bit cells per uint64 word (cell i is lane i % 4 of word i // 4). A disk
  row is summed word-wise (SWAR): add the words lane by lane, drop the lanes outside the
  row, and fold the four lanes with one multiply. Exact when no frame holds more than
  MAX_EVENTS events: then no lane, partial or final sum can carry. The grid array needs
  one spare word at its end (a row piece may read one word past its last cell).
"""
from dataclasses import dataclass

import taichi as ti

LANES = 4
LANE_BITS = 16
MAX_EVENTS = (1 << LANE_BITS) // 4 - 1  # per frame, for u16x4 cells (a cell is read <= 4 times)
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


def swar_plan(segments, stride):
    """Static plan of a SWAR disk sum: per row piece (dy, (dx_lo, dx_hi)) the row's word
    offset, dx_lo, its length, the words to load and whether the unwanted trailing lanes
    can reach into a second word. Pieces are read from the word of their first cell."""
    plan = []
    for dy, pieces in segments:
        for a, b in pieces:
            n = b - a + 1
            words = (n + 2) // LANES + 1             # most words n cells can span
            plan.append((dy * stride // LANES, a, n, words, LANES * words - n > LANES))
    return tuple(plan[i:i + 32] for i in range(0, len(plan), 32))  # unroll <= 32 at a time


@ti.func
def low_lanes(q: ti.u64) -> ti.u64:
    """Mask of the lanes below lane q (0..3)."""
    return (ti.u64(1) << (ti.u64(LANE_BITS) * q)) - ti.u64(1)


@ti.func
def top_lanes(m: ti.u64) -> ti.u64:
    """Mask of the top m lanes (0..4), without shifting by 64."""
    half = ti.u64(LANE_BITS // 2) * m
    return ~((ti.u64(FULL) >> half) >> half)


def make_swar_sum(plan):
    """ti.func: the count of the cells of `plan` (see swar_plan) around cell `at`.

    Branch-free: each piece adds all the words it may span, then subtracts the lanes
    before its first cell and after its last. The subtracted lanes were added just
    before, so no lane borrows; no lane carries while a cell is loaded at most 4 times
    and the frame holds at most MAX_EVENTS events.
    """

    @ti.func
    def swar_sum(words: ti.template(), at: ti.i32) -> ti.i32:
        acc = ti.u64(0)
        for group in ti.static(plan):
            for row, a, n, n_words, two in ti.static(group):
                s = at + a
                q = ti.cast(s & 3, ti.u64)
                base = (s >> 2) + row
                for j in ti.static(range(n_words)):
                    acc += words[base + j]
                acc -= words[base] & low_lanes(q)
                r = ti.u64(LANES * n_words - n) - q     # unwanted lanes after the last cell
                acc -= words[base + n_words - 1] & top_lanes(ti.min(r, ti.u64(LANES)))
                if ti.static(two):
                    acc -= words[base + n_words - 2] & top_lanes(ti.max(r, ti.u64(LANES)) - ti.u64(LANES))
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
