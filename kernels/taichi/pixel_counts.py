"""Events per pixel, all and kept, in one pass; a per-pixel flag per event; the pixels of
kept events; the ranks of flagged pixels and packed times of their events.

Specification: `evstar_kernels.reference.pixels.pixel_counts` (bit-exact). A cell packs
both counts in one int64 — all events in the low 32 bits, the kept ones in the high 32 —
so an event is one add to one cell; a launch of at most 2³¹ − 1 events cannot carry from
the low half into the high one. On the CPU the loop runs serially (Taichi then demotes
the atomic adds: ~5 ns an event, where numpy's two bincounts took ~14 and contended
atomics over two threads ~7); on a GPU it runs in parallel. The kept events' pixels and
the flagged events' pixel ranks run in parallel at the selected events (np.flatnonzero).
"""
import functools

import taichi as ti

from .arrays import i8_1d, i32_1d, i64_1d, u16_1d, u32_1d, u8_1d


@ti.func
def _flag(bits: ti.template(), k: ti.i32):
    """Bit k of flags packed 8 a byte, little-endian (np.packbits(..., bitorder="little"))."""
    return (bits[k >> 3] >> ti.cast(k & 7, ti.u8)) & ti.u8(1)


@ti.kernel
def pixel_flags(x: u16_1d, y: u16_1d, bits: u8_1d, width: ti.i32, out: u8_1d):
    """out[e] = bit k = y·width + x of the flags packed 8 a byte, little-endian
    (np.packbits(flags, bitorder="little"); reference: flags[y, x]): a megapixel sensor's
    flags in 115 kB, where its byte image's random reads missed the cache (~1.6x slower)."""
    for e in range(x.shape[0]):
        out[e] = _flag(bits, ti.cast(y[e], ti.i32) * width + ti.cast(x[e], ti.i32))


@ti.func
def _pixel(x: ti.template(), y: ti.template(), e: ti.i32, width: ti.i32) -> ti.i32:
    return ti.cast(y[e], ti.i32) * width + ti.cast(x[e], ti.i32)


@ti.kernel
def flagged_ids(t: i64_1d, x: u16_1d, y: u16_1d, p: i8_1d, at: i64_1d, words: u32_1d,
                before: i32_1d, width: ti.i32, id_out: u32_1d, tp_out: i64_1d):
    """Of the events at[j] (those at flagged pixels: pixel_flags, np.flatnonzero), in
    parallel: the pixel's id, its rank among the flagged pixels by key y·width + x, and
    2t + p (p 0 or 1: one value for a sort to move). `before` holds the count of flags in
    the words before each: a rank is that count and a popcount, from 230 kB of a megapixel
    sensor's tables where an int32 rank image would miss the cache. (A copy in lanes of
    runs of events, each written at its lane's next free place, took ~1.3x as long.)"""
    for j in range(at.shape[0]):
        e = ti.cast(at[j], ti.i32)
        k = _pixel(x, y, e, width)
        w, b = words[k >> 5], ti.cast(k & 31, ti.u32)
        id_out[j] = ti.cast(before[k >> 5] + ti.math.popcnt(w & ((ti.u32(1) << b) - 1)), ti.u32)
        tp_out[j] = t[e] * 2 + ti.cast(p[e], ti.i64)


@ti.kernel
def mark_pixels(x: u16_1d, y: u16_1d, at: i64_1d, width: ti.i32, flags: u8_1d):
    """flags[y·width + x] = 1 at the events at[j] (those a keep mask selects: np.flatnonzero),
    in parallel; two events of one pixel store the same 1. (A branch-free pass over every
    event in lanes, each ORing keep into a plane of its thread's, took ~1.7x as long where
    a third of the events were kept, ~3x where a tenth were.)"""
    for j in range(at.shape[0]):
        flags[_pixel(x, y, ti.cast(at[j], ti.i32), width)] = ti.u8(1)


@functools.lru_cache(maxsize=None)
def count_pixels_kernel(serial):
    """kernel(x, y, keep, width, cells): cells[y·width + x] += 1 (+ 2³² where keep) for
    every event."""

    @ti.kernel
    def count_pixels(x: u16_1d, y: u16_1d, keep: u8_1d, width: ti.i32, cells: i64_1d):
        ti.loop_config(serialize=serial)
        for e in range(x.shape[0]):
            add = ti.i64(1) + (ti.cast(keep[e], ti.i64) << 32)
            ti.atomic_add(cells[ti.cast(y[e], ti.i32) * width + ti.cast(x[e], ti.i32)], add)

    return count_pixels


@functools.lru_cache(maxsize=None)
def count_all_kernel(serial):
    """kernel(x, y, width, cells): cells[y·width + x] += 1 for every event, int32 cells (half
    the packed cells' memory: scattered adds ~4x faster on a megapixel sensor, 14 vs 63 ms
    for 2.9 M events; a launch of at most 2³¹ − 1 events cannot overflow them)."""

    @ti.kernel
    def count_all(x: u16_1d, y: u16_1d, width: ti.i32, cells: i32_1d):
        ti.loop_config(serialize=serial)
        for e in range(x.shape[0]):
            ti.atomic_add(cells[ti.cast(y[e], ti.i32) * width + ti.cast(x[e], ti.i32)], 1)

    return count_all
