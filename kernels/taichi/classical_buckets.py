"""Classical filter (dv's BackgroundActivityNoiseFilter), event-parallel: the GPU form.

Cut time into buckets of width dt from the first event: b(i) = (t_i − t_first) // dt. An
earlier event j can support event i (t_i − t_j < dt) only from bucket b(i) or b(i) − 1,
and every earlier event of bucket b(i) does. So neighbour n supports i iff
  first[b(i)][n] < i                 (an earlier event of i's bucket at n), or
  last_t[b(i) − 1][n] > t_i − dt     (the latest event of the previous bucket at n), or
  t_i < dt and first_any[n] > i      (no event at n before i: dv's map still holds 0).
Per batch of buckets [b0, b1) the planes of buckets b0 − 1 .. b1 − 1 are filled with atomic
min/max, evaluated, and cleared by un-binning. Planes have a one-pixel border that is never
written (first = NONE, last_t = BORDER never support). first_any (one plane, from the
caller: the first launch-local index of an event at each pixel among the events with
t < dt, NONE if none, negative if before the launch) has a border of -1. Indices are
launch-local i32.
"""
import functools

import taichi as ti

from .arrays import i8_1d, i32_1d, i64_1d, u8_1d, u16_1d
from .classical import BORDER

NONE = 2**31 - 1


@functools.lru_cache(maxsize=None)
def classical_bucket_kernels(width, height):
    """(fill, evaluate, clear) kernels for one sensor size.

    Specification: `evstar_kernels.reference.denoise.classical_support` (support; keep is
    support >= k_min)."""
    stride = width + 2
    plane = (height + 2) * stride

    @ti.func
    def cell(x: ti.template(), y: ti.template(), i: ti.i32) -> ti.i32:
        return (ti.cast(y[i], ti.i32) + 1) * stride + ti.cast(x[i], ti.i32) + 1

    @ti.kernel
    def fill(x: u16_1d, y: u16_1d, bucket: i32_1d, e0: ti.i32, e1: ti.i32, b_base: ti.i32,
             t: i64_1d, first: i32_1d, last_t: i64_1d):
        for i in range(e0, e1):
            at = (bucket[i] - b_base) * plane + cell(x, y, i)
            ti.atomic_min(first[at], i)
            ti.atomic_max(last_t[at], t[i])

    @ti.kernel
    def evaluate(x: u16_1d, y: u16_1d, t: i64_1d, bucket: i32_1d, e0: ti.i32, e1: ti.i32,
                 b_base: ti.i32, dt: ti.i64, k_min: ti.i32, first: i32_1d, last_t: i64_1d,
                 first_any: i32_1d, support: i8_1d, keep: u8_1d):
        for i in range(e0, e1):
            c = cell(x, y, i)
            here = (bucket[i] - b_base) * plane + c
            prev = here - plane
            ti_ = t[i]
            s = 0
            for dy in ti.static(range(-1, 2)):
                for dx in ti.static(range(-1, 2)):
                    if ti.static(dx != 0 or dy != 0):
                        o = dy * stride + dx
                        ok = first[here + o] < i or last_t[prev + o] > ti_ - dt
                        if not ok and ti_ < dt:
                            ok = first_any[c + o] > i
                        s += ti.cast(ok, ti.i32)
            support[i] = ti.cast(s, ti.i8)
            keep[i] = ti.cast(s >= k_min, ti.u8)

    @ti.kernel
    def clear(x: u16_1d, y: u16_1d, bucket: i32_1d, e0: ti.i32, e1: ti.i32, b_base: ti.i32,
              first: i32_1d, last_t: i64_1d):
        for i in range(e0, e1):
            at = (bucket[i] - b_base) * plane + cell(x, y, i)
            first[at] = NONE
            last_t[at] = ti.i64(BORDER)

    return fill, evaluate, clear
