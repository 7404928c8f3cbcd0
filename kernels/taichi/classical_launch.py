"""Launch of the classical filter: lane ranges (the CPU form) or time buckets (the GPU form).

`classical_filter` returns the support and keep mask of
`evstar_kernels.reference.denoise.classical_support` (keep: support >= k).
"""
import numpy as np

from . import classical, classical_buckets as cb
from . import launch


def classical_filter(ti, t, x, y, width, height, dt_us, k, *, schedule, scratch, on_launch=None):
    """(support int8 (n,), keep bool (n,)); schedule "lanes" or "events"; scratch: the
    caller's Scratch; on_launch() is called after every kernel launch."""
    n = len(t)
    support = np.empty(n, np.int8)
    keep = np.empty(n, np.uint8)
    if n:
        run = _classical_lanes if schedule == "lanes" else _classical_events
        with launch.RUNTIME_LOCK, scratch:
            run(ti, (t, x, y, width, height), dt_us, k, scratch, on_launch, support, keep)
    return support, keep.view(bool)


def _classical_lanes(ti, stream, dt_us, k, scratch, on_launch, support, keep):
    t, x, y, width, height = stream
    threads = launch.cpu_threads(ti)
    shape = (threads, height + 2, width + 2)

    def make_maps():
        maps = np.full(shape, classical.BORDER, np.int64)
        maps[:, 1:-1, 1:-1] = 0
        return maps

    maps = scratch.array("maps", shape, make_maps)
    busy = np.zeros(threads, np.int32)
    n = len(t)
    for a, b in launch.pieces(n):
        # one range per thread: every range but the first replays ~rate·dt events
        cuts = np.unique(np.linspace(a, b, threads + 1).astype(np.int64))
        lb = _lookback(t, cuts[:-1], dt_us)
        base = int(lb[0])
        lb_u, lo, hi = launch.units(cuts - base, threads, lb - base)
        classical.classical_ranges(t[base:b], x[base:b], y[base:b], lb_u, lo, hi,
                                   dt_us, k, maps, busy, support[base:b], keep[base:b])
        launch.launched(on_launch)


def _lookback(t, starts, dt_us):
    """First event that can still support the event at each start: t > t_start − dt.

    Where t_start < dt the zero-initialised map of dv matters, so replay from the start.
    """
    t_start = t[starts]
    lb = np.searchsorted(t, t_start - dt_us, side="right")
    lb[t_start < dt_us] = 0
    return lb


def _compact_buckets(t, dt_us):
    """Bucket of width dt per event, renumbered so ids stay small: a gap of empty buckets
    becomes a single empty id, which keeps "the previous bucket" meaningful."""
    b = (t - t[0]) // dt_us
    step = np.minimum(np.diff(b, prepend=b[:1]), 2)
    return np.cumsum(step).astype(np.int64)


def _classical_events(ti, stream, dt_us, k, scratch, on_launch, support, keep):
    t, x, y, width, height = stream
    fill, evaluate, clear = cb.classical_bucket_kernels(width, height)
    arrays = launch.Arrays(ti)
    stride, n = width + 2, len(t)
    plane = (height + 2) * stride
    bucket = _compact_buckets(t, dt_us)
    planes = int(max(2, min(launch.EVENT_GRID_BYTES // (12 * plane), bucket[-1] + 2)))

    def fresh_planes():
        first = np.full(planes * plane, cb.NONE, np.int32)
        return arrays.put(first), arrays.put(np.full(planes * plane, cb.BORDER, np.int64))

    first, last_t = scratch.array("buckets", (plane, stride, planes, arrays.on_device), fresh_planes)
    early = np.flatnonzero(t < dt_us)  # only these can see dv's initial zeros
    pix_early = (y[early].astype(np.int64) + 1) * stride + x[early] + 1
    first_any = np.full(plane, -1, np.int32)
    first_any.reshape(height + 2, stride)[1:-1, 1:-1] = cb.NONE
    starts = np.unique(np.searchsorted(bucket, bucket[np.arange(0, n, launch.MAX_LAUNCH_EVENTS)],
                                       side="left"))
    for a, b in zip(starts, np.append(starts[1:], n)):
        base = int(np.searchsorted(bucket, bucket[a] - 1, side="left"))
        fa = first_any.copy()
        if len(early):
            u, i = np.unique(pix_early, return_index=True)
            fa[u] = early[i] - base
        sl = slice(base, b)
        t_d, x_d, y_d = arrays.put(t[sl]), arrays.put(x[sl]), arrays.put(y[sl])
        b_d, fa_d = arrays.put((bucket[sl] - bucket[base]).astype(np.int32)), arrays.put(fa)
        s_d, k_d = arrays.empty(b - base, np.int8), arrays.empty(b - base, np.uint8)
        local = bucket[sl] - bucket[base]
        for b0 in range(int(local[a - base]), int(local[-1]) + 1, planes - 1):
            b1 = b0 + planes - 1
            f0, e0, e1 = np.searchsorted(local, [b0 - 1, b0, b1], side="left")
            fill(x_d, y_d, b_d, f0, e1, b0 - 1, t_d, first, last_t)
            launch.launched(on_launch)
            evaluate(x_d, y_d, t_d, b_d, e0, e1, b0 - 1, dt_us, k, first, last_t, fa_d, s_d, k_d)
            clear(x_d, y_d, b_d, f0, e1, b0 - 1, first, last_t)
            launch.launched(on_launch)
        arrays.get(s_d, support[a:b], skip=a - base)  # [base, a) belong to the launch before
        arrays.get(k_d, keep[a:b], skip=a - base)
