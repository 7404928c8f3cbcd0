"""Taichi kernels of the level pairs of evstar.crossings: per ON→OFF polarity change of a
pixel, the lengths of the ON run before it and the OFF run after it, and the sums of its
pairs' midpoint times and of their squares.

Specification: evstar.crossings.key_crossings with engine "numpy", which handles all changes
together, pair i = 1, 2, ... in turn; here one thread per change sums its pairs in the same
order i = 1 .. k with the same operations (where the rising level falls on an ON event, an
int64 sum of the two times, then × 0.5; else the interpolated rising time); with a
refractory period or a threshold ratio the interpolation divides, and Taichi's fast math
may round those divisions' last bits otherwise (times within 1e-6 µs of the specification,
tests/test_crossings.py; the integer outputs are identical). The events come in the pixel-then-time order (times ts): a change's
reads are its neighbours in memory, where reads through an order missed the cache each.
"""
import taichi as ti

from .arrays import any_1d, f64_1d, i32_1d, i64_1d, u32_1d


@ti.kernel
def run_lengths(key: u32_1d, p: any_1d, cap: ti.i32, on_before: i32_1d, off_after: i32_1d):
    """Events key, p (ON: p > 0) in the pixel-then-time order. Where position c
    is an ON followed by an OFF of its pixel: on_before[c], the ON events of its pixel right
    before it, and off_after[c] >= 1, the OFF events right after it (each at most `cap`);
    elsewhere 0, 0."""
    n = key.shape[0]
    for c in range(n):
        before, after = 0, 0
        if p[c] > 0 and c + 1 < n:
            if key[c + 1] == key[c] and p[c + 1] <= 0:
                while after < cap and c + after + 1 < n:
                    e = c + after + 1
                    if key[e] != key[c] or p[e] > 0:
                        break
                    after += 1
                while before < cap and c - before - 1 >= 0:
                    e = c - before - 1
                    if key[e] != key[c] or p[e] <= 0:
                        break
                    before += 1
        on_before[c] = before
        off_after[c] = after


@ti.kernel
def changes(key: u32_1d, p: any_1d, cap: ti.i32, change: i64_1d, on_before: i32_1d,
            off_after: i32_1d) -> ti.i64:
    """The changes and their run lengths (run_lengths's, at the changes only) in one serial
    pass over the runs: the first n entries of the outputs (as long as half the events, or
    more) get each change's position c and its ON and OFF run lengths (at most `cap`);
    returns n. For the CPU: no per-event outputs to search for the changes afterwards."""
    n = key.shape[0]
    m = ti.i64(0)
    start = ti.i64(0)            # the current run's first event
    on_start = ti.i64(-1)        # the ON run's first event, where an OFF run of its pixel follows
    ti.loop_config(serialize=True)
    for i in range(n):
        if i + 1 == n or key[i + 1] != key[i] or (p[i + 1] > 0) != (p[i] > 0):   # a run ends
            if p[i] > 0:
                on_start = ti.select(i + 1 < n and key[i + 1] == key[i], start, -1)
            else:
                if on_start >= 0:
                    change[m] = start - 1
                    on_before[m] = ti.cast(ti.min(start - 1 - on_start, cap), ti.i32)
                    off_after[m] = ti.cast(ti.min(i + 1 - start, cap), ti.i32)
                    m += 1
                on_start = -1
            start = i + 1
    return m


@ti.kernel
def without_strays(ts: i64_1d, change: i64_1d, factor: ti.i64,
                   on_before: i32_1d, off_after: i32_1d):
    """Per change c = change[i] with ON events before it, in place: the ON run less its
    first event, the OFF run less its last, where that event's gap to its neighbour in the
    run exceeds `factor` times the largest gap between the passage's other events (from the
    ON run's second event to the OFF run's second last; c's own gap always among them). The
    inside gaps are read from c's own outwards only until they clear both outer ones (a
    star's passage: after one or two)."""
    for i in range(change.shape[0]):
        c = change[i]
        nb, na = ti.cast(on_before[i], ti.i64), ti.cast(off_after[i], ti.i64)
        if nb >= 1:
            first, last = c - nb, c + na
            g_on = ts[first + 1] - ts[first]
            g_off = ti.i64(0)
            if na >= 2:
                g_off = ts[last] - ts[last - 1]
            lo, hi = first + 1, ti.select(na >= 2, last - 1, last)
            inside = ts[c + 1] - ts[c]
            down, up = c - 1, c + 1          # the next inside gaps: down .. down + 1, up .. up + 1
            while factor * inside < ti.max(g_on, g_off) and (down >= lo or up < hi):
                if down >= lo:
                    inside = ti.max(inside, ts[down + 1] - ts[down])
                    down -= 1
                if up < hi:
                    inside = ti.max(inside, ts[up + 1] - ts[up])
                    up += 1
            if g_on > factor * inside:
                on_before[i] -= 1
            if g_off > factor * inside:
                off_after[i] -= 1


@ti.kernel
def pair_sums(ts: i64_1d, change: i64_1d, pairs: i32_1d, on_before: i32_1d,
              ratio: ti.f64, sums: f64_1d, sq: f64_1d, h2: f64_1d):
    """Per change c = change[i] with pairs[i] = k > 0: the sums of its pair midpoints, of
    their squares about c's time and of the pairs' squared half-widths (OFF time less
    midpoint), pair j = 1 .. k in turn. Pair j: the j-th OFF after c (level j·C_off below
    c's) and the rising time at the same level, j·ratio ON steps before c (ratio =
    C_off / C_on), interpolated between ON events where that is not whole, extrapolated from
    the run's first two ON events (on_before[i] precede c) where it lies below the first."""
    for i in range(change.shape[0]):
        c = change[i]
        nb = ti.cast(on_before[i], ti.i64)
        t_c = ti.cast(ts[c], ti.f64)
        s = ti.f64(0.0)
        s2 = ti.f64(0.0)
        w2 = ti.f64(0.0)
        for j in range(1, pairs[i] + 1):
            x = j * ratio
            j0 = ti.cast(ti.floor(x + 1e-9), ti.i64)
            f = x - j0
            mid = ti.f64(0.0)
            if x > nb + 1e-9:
                first = ti.cast(ts[c - nb], ti.f64)
                rise = first - (x - nb) * (ti.cast(ts[c - nb + 1], ti.f64) - first)
                mid = 0.5 * (rise + ti.cast(ts[c + j], ti.f64))
            elif f < 1e-9:
                mid = 0.5 * ti.cast(ts[c - j0] + ts[c + j], ti.f64)
            else:
                rise = (ti.cast(ts[c - j0], ti.f64) * (1 - f)
                        + ti.cast(ts[c - j0 - 1], ti.f64) * f)
                mid = 0.5 * (rise + ti.cast(ts[c + j], ti.f64))
            half = ti.cast(ts[c + j], ti.f64) - mid
            s += mid
            s2 += (mid - t_c) * (mid - t_c)
            w2 += half * half
        sums[i] = s
        sq[i] = s2
        h2[i] = w2


@ti.func
def _level_step(gap, refractory, max_step):
    """evstar.crossings.level_step of one gap (µs, float)."""
    out = max_step
    if gap > refractory:
        out = ti.min(gap / ti.max(gap - refractory, 1e-9), max_step)
    return out


@ti.kernel
def refractory_pair_sums(ts: i64_1d, change: i64_1d, on_before: i32_1d,
                         off_after: i32_1d, ratio: ti.f64, refractory: ti.f64, max_step: ti.f64,
                         max_pairs: ti.i32, pairs: i32_1d, sums: f64_1d, sq: f64_1d,
                         h2: f64_1d):
    """Per change c = change[i]: the level pairs of a sensor with a refractory period, their
    count and the sums of their midpoints, of their squares about c's time and of their
    squared half-widths (specification:
    evstar.crossings._refractory_pairs, one change per thread with the same operations).
    ON event c − m lies d_m levels below the last ON; d_next is the depth of the next one
    back (has_next false past the run's first); OFF j lies d_off below."""
    for i in range(change.shape[0]):
        c, nb, na = change[i], ti.cast(on_before[i], ti.i64), ti.cast(off_after[i], ti.i64)
        t_c = ti.cast(ts[c], ti.f64)
        m = ti.i64(0)
        d_m, d_next = ti.f64(0.0), ti.f64(0.0)
        has_next = nb > 0
        top = ti.f64(0.0)
        if has_next:
            d_next = _level_step(ti.cast(ts[c] - ts[c - 1], ti.f64), refractory, max_step)
            top = d_next - 1
        d_off = ratio - top
        k = 0
        s, s2, w2 = ti.f64(0.0), ti.f64(0.0), ti.f64(0.0)
        alive = na >= 1
        j = ti.i64(1)
        while alive:
            if j > 1:
                d_off = d_off + ratio * _level_step(
                    ti.cast(ts[c + j] - ts[c + j - 1], ti.f64), refractory, max_step)
            while has_next and d_next <= d_off + 1e-9:
                m += 1
                d_m = d_next
                has_next = m < nb
                if has_next:
                    d_next = d_m + _level_step(ti.cast(ts[c - m] - ts[c - m - 1], ti.f64),
                                               refractory, max_step)
            beyond = (m == nb) and (d_off > d_m + 1e-9)
            if not beyond and d_off >= -1e-9:
                f = ti.f64(0.0)
                if has_next:
                    f = (d_off - d_m) / (d_next - d_m)
                rise = ti.cast(ts[c - m], ti.f64)
                if f >= 1e-9:
                    rise = rise * (1 - f) + ti.cast(ts[c - m - 1], ti.f64) * f
                fall = ti.cast(ts[c + j], ti.f64)
                mid = 0.5 * (rise + fall)
                half = fall - mid
                s += mid
                s2 += (mid - t_c) * (mid - t_c)
                w2 += half * half
                k += 1
            alive = (not beyond) and j < na and k < max_pairs
            j += 1
        pairs[i] = k
        sums[i] = s
        sq[i] = s2
        h2[i] = w2
