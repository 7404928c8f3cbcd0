"""Taichi kernels of the level pairs of evstar.crossings: per ON→OFF polarity change of a
pixel, the number of pairs and the sums of their midpoint times and of their squares.

Specification: evstar.crossings.key_crossings with engine "numpy", which sums the pairs of
all changes together, j = 1, 2, ... in turn; here one thread per change sums its pairs in
the same order j = 1 .. k, with the same operations (an int64 sum of the two times, then
× 0.5), so the floats are the same bits. The events are read through the pixel-then-time
order, not gathered into sorted copies: those random reads are most of the time.
"""
import taichi as ti

from .arrays import any_1d, f64_1d, i32_1d, i64_1d, u32_1d


@ti.kernel
def pair_counts(order: i64_1d, key: u32_1d, p: any_1d, max_pairs: ti.i32, pairs: i32_1d):
    """Events key, p (ON: p > 0) read in `order`. pairs[c]: the number k <= max_pairs of
    level pairs (c − j, c + j), j = 1 .. k, of position c: c and c − j ON, c + j OFF, all of
    c's pixel (0 where c is not the last ON before an OFF of its pixel, or has no ON before
    it in its run)."""
    n = order.shape[0]
    for c in range(n):
        a = order[c]
        k = 0
        if p[a] > 0:
            # c ± j were read by this thread's neighbouring iterations: mostly cached
            while k < max_pairs and c - k - 1 >= 0 and c + k + 1 < n:
                on = order[c - k - 1]
                off = order[c + k + 1]
                if key[on] != key[a] or p[on] <= 0 or key[off] != key[a] or p[off] > 0:
                    break
                k += 1
        pairs[c] = k


@ti.kernel
def pair_sums(order: i64_1d, t: i64_1d, change: i64_1d, pairs: i32_1d, sums: f64_1d,
              sq: f64_1d):
    """Per change c = change[i] (a position in `order` with pairs[c] = k > 0): the sums of
    its pair midpoints 0.5·(t[c − j] + t[c + j]) and of their squares, j = 1 .. k in turn."""
    for i in range(change.shape[0]):
        c = change[i]
        s = ti.f64(0.0)
        s2 = ti.f64(0.0)
        for j in range(1, pairs[c] + 1):
            mid = 0.5 * ti.cast(t[order[c - j]] + t[order[c + j]], ti.f64)
            s += mid
            s2 += mid * mid
        sums[i] = s
        sq[i] = s2
