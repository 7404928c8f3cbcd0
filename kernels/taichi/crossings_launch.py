"""Launch of the Taichi level-pair kernels: events and their pixel-then-time order in, per
ON→OFF change with pairs its position in the order, its pair count and pair sums out."""
import numpy as np

from . import launch
from .crossings import pair_counts as _pair_counts, pair_sums as _pair_sums


def level_pairs(ti, order, key, t, p, max_pairs):
    """(positions c in `order` of the changes with k > 0 pairs, ascending; k; the sums of
    their pair midpoints; the sums of their squares) — evstar.crossings' changes in its
    order (pixel-major, then time). p: ON where > 0 (bool or numbers)."""
    n, p = len(order), np.asarray(p)
    p = p.view(np.uint8) if p.dtype == bool else p      # no bool arrays in Taichi kernels
    arrays = launch.Arrays(ti)
    order, t = arrays.put(np.asarray(order, np.int64)), arrays.put(np.asarray(t, np.int64))
    key, p = arrays.put(np.asarray(key, np.uint32)), arrays.put(p)
    # a thread per event counts, then (the changes picked out on the host) one per change sums
    pairs = arrays.empty(n, np.int32)
    with launch.RUNTIME_LOCK:
        _pair_counts(order, key, p, int(max_pairs), pairs)
    k = pairs if not arrays.on_device else pairs.to_numpy()
    change = np.flatnonzero(k)
    sums, sq = arrays.empty(len(change), np.float64), arrays.empty(len(change), np.float64)
    if len(change):
        with launch.RUNTIME_LOCK:
            _pair_sums(order, t, arrays.put(change), pairs, sums, sq)
    if arrays.on_device:
        sums, sq = sums.to_numpy(), sq.to_numpy()
    return change, k.take(change), sums, sq
