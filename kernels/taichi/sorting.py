"""Taichi kernel of a stable counting sort by small integer keys (pixel indices).

Specification: numpy's stable argsort of the keys (``np.argsort(key, kind="stable")``):
the events of each key in their input order. The three passes (histogram, prefix sum,
scatter) run serially: they are a few ns per event on one core, where numpy's stable sort
of 32-bit keys (two 16-bit radix passes with their gathers) takes ~60 ns. Starts are int32
(a launch sorts < 2³¹ keys): half the int64 table's cache misses on a megapixel sensor's
keys (the random reads and adds are the sort's cost). Two 10-bit radix passes (1024 write
streams each) were slower than this one pass: 30 vs 24 ms on 1.4 M pixel keys.
"""
import taichi as ti

from .arrays import i32_1d, i64_1d, u32_1d


@ti.func
def _run_starts(key: ti.template(), start: ti.template()):
    """start[k] (zeros on entry, n_keys + 1 long): where key k's run begins in the stable
    order — the keys' histogram shifted by one, then its prefix sum."""
    ti.loop_config(serialize=True)
    for i in range(key.shape[0]):
        start[ti.cast(key[i], ti.i32) + 1] += 1
    ti.loop_config(serialize=True)
    for k in range(start.shape[0] - 1):
        start[k + 1] += start[k]


@ti.kernel
def stable_order(key: u32_1d, start: i32_1d, order: i64_1d):
    """order: the stable sorting permutation of key; start (n_keys + 1, zeros on entry):
    on return, start[k] is where key k's run begins in order."""
    n = key.shape[0]
    _run_starts(key, start)
    ti.loop_config(serialize=True)
    for i in range(n):
        k = ti.cast(key[i], ti.i32)
        order[start[k]] = i
        start[k] += 1
    # the scatter moved each start to the next run's: shift back
    ti.loop_config(serialize=True)
    for j in range(start.shape[0] - 1):
        k = start.shape[0] - 1 - j
        start[k] = start[k - 1]
    start[0] = 0


@ti.kernel
def sorted_values(key: u32_1d, value: i64_1d, start: i32_1d, out: i64_1d):
    """out: value in the stable order of key (value[np.argsort(key, kind="stable")]), moved
    by stable_order's passes (no permutation to gather through: that gather's random reads
    took longer than the sort). start (n_keys + 1, zeros on entry): on return, start[k] is
    where key k's run ends in out (k < n_keys)."""
    _run_starts(key, start)
    ti.loop_config(serialize=True)
    for i in range(key.shape[0]):
        k = ti.cast(key[i], ti.i32)
        out[start[k]] = value[i]
        start[k] += 1
