"""Launch of the Taichi level-pair kernels: events in the pixel-then-time order in, per
ON→OFF change its position in that order, run lengths and pair sums out."""
import numpy as np

from . import launch
from .crossings import pair_sums as _pair_sums, refractory_pair_sums as _refractory_sums
from .crossings import changes as _changes_kernel, run_lengths as _run_lengths
from .crossings import without_strays as _without_strays


class LevelPairs:
    """The kernels' arrays for one input, kept between the two launches (the pair counts
    are decided on the host from the run lengths)."""

    def __init__(self, ti, ts, keys, ps, cap):
        """ts, keys, ps: the events' times (int64), pixel keys and polarities in the
        pixel-then-time order."""
        ps = np.asarray(ps)
        ps = ps.view(np.uint8) if ps.dtype == bool else ps      # no bool arrays in Taichi kernels
        self.arrays = arrays = launch.Arrays(ti)
        self.ts = arrays.put(np.asarray(ts, np.int64))
        #: positions c in the order of every ON→OFF change (pixel-major, then time) and the
        #: ON run before / OFF run after each
        self.change, self.on_before, self.off_after = _changes(
            arrays, arrays.put(np.asarray(keys, np.uint32)), arrays.put(ps), int(cap))

    def without_strays(self, change, on_before, off_after, factor):
        """(on_before, off_after) of the changes at positions `change` less their runs'
        stray outermost events (evstar.crossings.without_strays)."""
        arrays = self.arrays
        on, off = arrays.put(np.array(on_before, np.int32)), arrays.put(np.array(off_after, np.int32))
        if len(change):
            with launch.RUNTIME_LOCK:
                _without_strays(self.ts, arrays.put(np.asarray(change, np.int64)),
                                int(factor), on, off)
        return (on, off) if not arrays.on_device else (on.to_numpy(), off.to_numpy())

    def sums(self, change, pairs, ratio, on_before):
        """(sums of pair midpoints, of their squares, of their squared half-widths) of the
        changes at positions `change` with `pairs` pairs each (> 0) and `on_before` ON events
        before each."""
        arrays = self.arrays
        sums, sq, h2 = (arrays.empty(len(change), np.float64) for _ in range(3))
        if len(change):
            with launch.RUNTIME_LOCK:
                _pair_sums(self.ts, arrays.put(np.asarray(change, np.int64)),
                           arrays.put(np.asarray(pairs, np.int32)),
                           arrays.put(np.asarray(on_before, np.int32)), float(ratio), sums, sq, h2)
        if arrays.on_device:
            sums, sq, h2 = sums.to_numpy(), sq.to_numpy(), h2.to_numpy()
        return sums, sq, h2

    def refractory_sums(self, change, on_before, off_after, ratio, refractory_us, max_step,
                        max_pairs):
        """(pairs, sums of pair midpoints, of their squares, of their squared half-widths) of
        the changes at positions `change`, of a sensor with a refractory period."""
        arrays, n = self.arrays, len(change)
        pairs = arrays.empty(n, np.int32)
        sums, sq, h2 = (arrays.empty(n, np.float64) for _ in range(3))
        if n:
            with launch.RUNTIME_LOCK:
                _refractory_sums(self.ts, arrays.put(np.asarray(change, np.int64)),
                                 arrays.put(np.asarray(on_before, np.int32)),
                                 arrays.put(np.asarray(off_after, np.int32)), float(ratio),
                                 float(refractory_us), float(max_step), int(max_pairs), pairs,
                                 sums, sq, h2)
        if arrays.on_device:
            pairs, sums, sq, h2 = pairs.to_numpy(), sums.to_numpy(), sq.to_numpy(), h2.to_numpy()
        return pairs.astype(np.int64), sums, sq, h2


def _changes(arrays, keys, ps, cap):
    """(positions of the changes, their ON runs before, OFF runs after): on the CPU in one
    serial pass over the runs, on a device from the parallel run lengths at every event."""
    n = keys.shape[0]
    if arrays.on_device:
        on, off = arrays.empty(n, np.int32), arrays.empty(n, np.int32)
        with launch.RUNTIME_LOCK:
            _run_lengths(keys, ps, cap, on, off)
        on, off = on.to_numpy(), off.to_numpy()
        change = np.flatnonzero(off)
        return change, on.take(change), off.take(change)
    size = n // 2 + 1                         # a change is an ON and an OFF of its own
    out = np.empty(size, np.int64), np.empty(size, np.int32), np.empty(size, np.int32)
    with launch.RUNTIME_LOCK:
        m = _changes_kernel(keys, ps, cap, *out)
    for a in out:
        a.resize(m, refcheck=False)
    return out
