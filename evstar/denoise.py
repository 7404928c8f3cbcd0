"""Event denoising filters: classical (dv-compatible), NDSEF and MR-NDSEF.

Every filter is a small estimator in the scikit-learn manner: the constructor only stores
and validates its parameters (a bad one raises ValueError naming it), `apply(events)`
returns the keep mask (one bool per input event, input order) and records per-event
counts in `counts_`, and `filter(events)` returns the kept events.

`backend="taichi"` (default) runs the Taichi kernels of `evstar_kernels.taichi` on
`device="cpu"|"cuda"`; `backend="reference"` runs the numpy specification of
`evstar_kernels.reference.denoise`. Both give bit-identical masks and counts.

Why MR-NDSEF does not fuse with the literal min of raw counts
---------------------------------------------------------------
Liu et al. (2025) fuse the radii with M(e0) = min_k p_k(e0) and one threshold. The disks
are nested (r1 < r2 < ...), so p_1 <= p_2 <= ... for every event and the minimum is always
p_1: the larger radii would never matter and MR-NDSEF would collapse to NDSEF at r1.
evstar keeps the paper's intent — an event must be dense at *every* scale — by giving
each radius its own threshold: keep iff p_k(e0) >= th_k for all k. The thresholds are
explicit or `auto`: th_k is the smallest n with P[Poisson(λ·dt·A_k) >= n] <= α, A_k the
exact lattice area of disk k and λ the measured background rate, so each scale rejects
background at the same false-alarm probability α. Radii are evaluated hierarchically
(r1 for all events, r_k only for survivors of r_(k-1)): same mask, less work.
"""
from __future__ import annotations

import numpy as np

from . import backends, parameters as P
from .errors import ParameterError, ParameterTypeError
from .events import Events
from evstar_kernels.reference import denoise as ref

BACKENDS = ("taichi", "reference")
_MAX_LAUNCH_EVENTS = 1 << 30  # Taichi loop bounds are i32: launch at most this many events


# -- parameter validation: the declarations of evstar.parameters, plus the kernel options --
D, G, K = P.DENOISE, P.GLOBAL, P.KERNEL
BACKENDS, STRATEGIES, SCHEDULES = P.DENOISE_BACKENDS, P.STRATEGIES, P.SCHEDULES


def _check_common(dt_us, backend, device, t0_us):
    dt_us, device = G.check("dt_us", dt_us), G.check("device", device)
    backend = K.check("backend", backend)
    if backend == "reference" and device != "cpu":
        raise ParameterError(f"device must be 'cpu' with backend='reference', got {device!r}")
    return dt_us, device, K.check("t0_us", t0_us)


def _check_events(events):
    if not isinstance(events, Events):
        raise ParameterTypeError(f"events must be evstar.Events, got {type(events).__name__}")
    return events


def _check_schedule(schedule, device):
    schedule = K.check("schedule", schedule)
    if schedule == "lanes" and device != "cpu":
        raise ParameterError("schedule='lanes' is the CPU form; use 'events' (or 'auto') on CUDA")
    return schedule


# -- base class ------------------------------------------------------------------------------
class _Filter:
    """apply() -> keep mask, filter() -> kept Events; subclasses implement _apply()."""

    _param_names: tuple = ()

    def get_params(self):
        return {k: getattr(self, k) for k in self._param_names}

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def apply(self, events):
        """Keep mask (bool, one entry per event, input order); sets counts_ and friends."""
        events = _check_events(events)
        keep = self._apply(events)
        self.n_events_ = len(events)
        self.n_kept_ = int(np.count_nonzero(keep))
        return keep

    def filter(self, events):
        """The kept events, in input order."""
        return events[self.apply(events)]


# -- classical ---------------------------------------------------------------------------------
class ClassicalFilter(_Filter):
    """Spatio-temporal correlation (background-activity) filter; k=1 is dv-processing's.

    Per event in stream order: a neighbour (8-connected, not the pixel itself) supports it
    if the neighbour's last timestamp ts gives t − ts < dt_us (the timestamp map starts at
    0, as dv's does); keep if at least k neighbours support it. counts_ (int8) holds each
    event's number of supporting neighbours.
    """

    _param_names = ("dt_us", "k", "backend", "device", "schedule")

    def __init__(self, dt_us=10_000, k=1, *, backend="taichi", device="cpu", schedule="auto"):
        self.dt_us, self.device, _ = _check_common(dt_us, backend, device, None)
        self.k = D.check("k", k)
        self.backend = backend
        self.schedule = _check_schedule(schedule, self.device)

    def _apply(self, ev):
        if self.backend == "reference":
            support = ref.classical_support(ev.t, ev.x, ev.y, ev.width, ev.height, self.dt_us)
            keep = support >= self.k
        else:
            support, keep = _taichi_classical(ev, self.dt_us, self.k, self.device, self.schedule)
        self.counts_ = support
        return keep


# -- NDSEF / MR-NDSEF -------------------------------------------------------------------------
class _DensityFilter(_Filter):
    """Shared machinery: pseudo-frames, thresholds (explicit or auto), counting backends."""

    def _set_common(self, dt_us, alpha, rate_hz, t0_us, backend, device, strategy, schedule):
        """Validate and store the parameters NDSEF and MR-NDSEF share."""
        self.dt_us, self.device, self.t0_us = _check_common(dt_us, backend, device, t0_us)
        self.alpha = D.check("alpha", alpha)
        self.rate_hz = D.check("rate_hz", rate_hz)
        self.backend = backend
        self.strategy = K.check("strategy", strategy)
        self.schedule = _check_schedule(schedule, self.device)

    def _resolve_thresholds(self, ev, offsets):
        if isinstance(self.thresholds, str):
            rate = self.rate_hz if self.rate_hz is not None else _background_rate(ev, offsets, self.dt_us)
            self.rate_hz_ = rate
            return ref.poisson_thresholds(rate, self.dt_us, self.radii, self.alpha)
        self.rate_hz_ = self.rate_hz
        return np.asarray(self.thresholds, np.int64)

    def _apply(self, ev):
        offsets = ref.frame_offsets(ev.t, self.dt_us, self.t0_us)
        th = self._resolve_thresholds(ev, offsets)
        self.thresholds_ = tuple(int(v) for v in th)
        self.n_frames_ = len(offsets) - 1
        if self.backend == "reference":
            frame = ref.frame_index(ev.t, self.dt_us, self.t0_us)
            keep, counts = ref.mr_ndsef(frame, ev.x, ev.y, ev.width, ev.height, self.radii, th)
            counts = counts.astype(np.int32)
        else:
            keep, counts = _taichi_counts(ev, offsets, self.radii, th, self.device, self.strategy,
                                          self.schedule)
        self.counts_ = counts
        return keep


_RATE_SAMPLE_EVENTS = 1 << 18  # λ within ~0.2 %, in a few ms


def _background_rate(ev, offsets, dt_us):
    """λ for auto thresholds: ref.background_rate on the whole stream, or on evenly spaced
    whole frames holding about _RATE_SAMPLE_EVENTS events when the stream is longer."""
    n_full = len(offsets) - 2  # the last frame may be cut short
    step = int(np.ceil(offsets[-1] / _RATE_SAMPLE_EVENTS))
    if step <= 1 or n_full < 2 * step:
        return ref.background_rate(ev.t, ev.x, ev.y, ev.width, ev.height)
    frames = np.arange(0, n_full, step)
    parts = [slice(offsets[f], offsets[f + 1]) for f in frames]
    xs = np.concatenate([ev.x[p] for p in parts])
    ys = np.concatenate([ev.y[p] for p in parts])
    ts = np.concatenate([ev.t[p] for p in parts])
    return ref.background_rate(ts, xs, ys, ev.width, ev.height, duration_s=len(frames) * dt_us * 1e-6)


class NDSEF(_DensityFilter):
    """Neighbourhood-density spatio-temporal event filter (single radius).

    In each pseudo-frame [t0 + k·dt, t0 + (k+1)·dt), p(e) = number of events of the frame
    with (x − x_e)² + (y − y_e)² < radius² (e itself and repeated events at a pixel
    included); keep iff p(e) >= threshold. threshold='auto' picks the smallest n with
    P[Poisson(λ·dt·A) >= n] <= alpha (A the disk's lattice area, λ the measured background
    rate unless rate_hz is given). counts_ (int32) holds p(e).
    """

    _param_names = ("dt_us", "radius", "threshold", "alpha", "rate_hz", "t0_us", "backend",
                    "device", "strategy", "schedule")

    def __init__(self, dt_us=10_000, radius=5, threshold="auto", *, alpha=1e-3, rate_hz=None,
                 t0_us=None, backend="taichi", device="cpu", strategy="auto",
                 schedule="auto"):
        self._set_common(dt_us, alpha, rate_hz, t0_us, backend, device, strategy, schedule)
        self.radius = D.check("radius", radius)
        self.threshold = D.check("threshold", threshold)

    radii = property(lambda self: (self.radius,))
    thresholds = property(lambda self: self.threshold if isinstance(self.threshold, str)
                          else (self.threshold,))

    def _apply(self, ev):
        keep = super()._apply(ev)
        self.counts_ = self.counts_.reshape(-1)  # (n, 1) -> (n,): a view, no copy
        self.threshold_ = self.thresholds_[0]
        return keep


class MRNDSEF(_DensityFilter):
    """Multi-radius NDSEF with per-radius thresholds and hierarchical screening.

    Keep iff p_k(e) >= th_k for every radius k (see the module docstring for why this
    replaces the paper's min over raw counts). thresholds='auto' derives th_k from the
    background rate and the false-alarm probability alpha; or pass one integer per radius.
    counts_ (int32, shape (n, K)) holds p_k(e), -1 where e was rejected at an earlier radius.
    After apply: thresholds_ (the integers used), rate_hz_ (λ used by 'auto').
    """

    _param_names = ("dt_us", "radii", "thresholds", "alpha", "rate_hz", "t0_us", "backend",
                    "device", "strategy", "schedule")

    def __init__(self, dt_us=10_000, radii=(3, 5, 7, 9, 11), thresholds="auto", *, alpha=1e-3,
                 rate_hz=None, t0_us=None, backend="taichi", device="cpu", strategy="auto",
                 schedule="auto"):
        self._set_common(dt_us, alpha, rate_hz, t0_us, backend, device, strategy, schedule)
        self.radii = tuple(D.check("radii", radii))
        thresholds = D.check("thresholds", thresholds)
        if thresholds != P.AUTO and len(thresholds) != len(self.radii):
            raise ParameterError(f"thresholds must be 'auto' or one integer per radius "
                                 f"({len(self.radii)}), got {thresholds!r}")
        self.thresholds = thresholds if thresholds == P.AUTO else tuple(thresholds)


def from_config(config, *, t0_us=None, rate_hz=None, backend="taichi"):
    """The filter an :class:`evstar.Config` describes (None for method 'none'): the one
    factory of the pipeline and the command line. `rate_hz` (e.g. a calibration window's
    background rate) is used unless the configuration fixes denoise.rate_hz."""
    d = config.denoise
    common = dict(dt_us=config.dt_us, device=config.device, backend=backend)
    density = dict(alpha=d.alpha, rate_hz=d.rate_hz if d.rate_hz is not None else rate_hz,
                   t0_us=t0_us, **common)
    if d.method == "classical":
        return ClassicalFilter(k=d.k, **common)
    if d.method == "ndsef":
        return NDSEF(radius=d.radius, threshold=d.threshold, **density)
    if d.method == "mr-ndsef":
        return MRNDSEF(radii=d.radii, thresholds=d.thresholds, **density)
    return None


# -- Taichi launch logic -------------------------------------------------------------------------
_EVENT_GRID_BYTES = 256 << 20   # scratch planes of the event-parallel form, per batch
_DEVICE_ARRAYS = False          # tests set True to run the CUDA data path (ti.ndarray) on CPU
_CELL_DTYPES = {"u16x4": (np.uint64, 4), "i32": (np.int32, 1)}  # dtype, cells per element
_scratch = {}  # reusable scratch grids, keyed by shape: the kernels always leave them cleared


def _scratch_array(key, make):
    arr = _scratch.get(key)
    if arr is None:
        arr = _scratch[key] = make()
    return arr


def _resolve_schedule(schedule, device):
    if schedule == "auto":
        return "lanes" if device == "cpu" else "events"
    return schedule


class _Arrays:
    """Numpy arrays as the kernels take them: as they are on the CPU (no copy), copied into
    Taichi ndarrays on a GPU — once per launch, so the data stay resident across kernels."""

    def __init__(self, ti, device):
        self.ti = ti
        self.on_device = device != "cpu" or _DEVICE_ARRAYS

    def put(self, arr):
        arr = np.ascontiguousarray(arr)
        if not self.on_device:
            return arr
        dev = self.ti.ndarray(dtype=self.ti.lang.util.to_taichi_type(arr.dtype), shape=arr.shape)
        dev.from_numpy(arr)
        return dev

    def empty(self, shape, dtype):
        if not self.on_device:
            return np.empty(shape, dtype)
        return self.ti.ndarray(dtype=self.ti.lang.util.to_taichi_type(np.dtype(dtype)), shape=shape)

    def get(self, dev, out, skip=0):
        """Copy dev[skip:] into out."""
        out[...] = (dev if not self.on_device else dev.to_numpy())[skip:]


def _cpu_threads(ti):
    return max(1, int(ti.lang.impl.current_cfg().cpu_max_num_threads))


def _units(bounds, n_threads, *per_piece):
    """Spread work pieces (bounds[j]..bounds[j+1]) over the iterations of a lane loop.

    Taichi's CPU loops give each thread a contiguous block of >= 512 iterations, so the
    loop has 512 iterations per thread and piece j sits at iteration j·U/n_pieces; the
    other iterations are empty (lo == hi). Extra per-piece arrays are spread the same way
    and returned first.
    """
    n_pieces = len(bounds) - 1
    n_iter = max(512 * n_threads, n_pieces)
    at = (np.arange(n_pieces, dtype=np.int64) * n_iter) // max(n_pieces, 1)
    out = []
    for values in (*per_piece, bounds[:-1], bounds[1:]):
        arr = np.zeros(n_iter, np.int32)
        arr[at] = values
        out.append(arr)
    return out


def _balanced_cuts(cum, n_pieces):
    """Indices into `cum` (non-decreasing work prefix) cutting it into ~equal pieces."""
    targets = np.linspace(cum[0], cum[-1], n_pieces + 1)
    cuts = np.searchsorted(cum, targets, side="left")
    cuts[0], cuts[-1] = 0, len(cum) - 1
    return np.unique(cuts)


def _frame_launches(offsets, max_events=None):
    """Runs of whole frames holding at most max_events events (a bigger frame goes alone)."""
    max_events = _MAX_LAUNCH_EVENTS if max_events is None else max_events
    n_frames = len(offsets) - 1
    f0 = 0
    while f0 < n_frames:
        f1 = int(np.searchsorted(offsets, offsets[f0] + max_events, side="right")) - 1
        f1 = min(max(f1, f0 + 1), n_frames)
        yield f0, f1
        f0 = f1


def _disks(radii):
    """Nested lattice disks as compile-time tuples of (dy, half-width) rows."""
    return tuple(tuple(zip(*(v.tolist() for v in ref.disk_rows(r)))) for r in radii)


def _taichi_counts(ev, offsets, radii, thresholds, device, strategy, schedule):
    ti = backends.taichi(device)
    n = len(ev)
    counts = np.empty((n, len(radii)), np.int32)
    keep = np.empty(n, np.uint8)
    if n == 0:
        return keep.view(bool), counts
    run = _counts_lanes if _resolve_schedule(schedule, device) == "lanes" else _counts_events
    run(ti, ev, offsets, _disks(radii), np.asarray(thresholds, np.int32), strategy, device, counts, keep)
    return keep.view(bool), counts


def _counts_lanes(ti, ev, offsets, disks, th, strategy, device, counts, keep):
    from evstar_kernels.taichi import frame_counts, frame_grids

    dense_min = {"auto": -1, "sparse": np.iinfo(np.int32).max, "dense": 0}[strategy]
    threads = _cpu_threads(ti)
    size = (ev.width, ev.height)
    cells, prefix_cells, tile_cells = frame_counts.scratch_sizes(disks, *size)

    def slots_of(name, n, dtype):  # one zeroed part per thread, kept for the next call
        return _scratch_array((name, disks, size, threads), lambda: np.zeros(threads * n, dtype))

    prefix = slots_of("prefix", prefix_cells, np.int32)
    tiles, repeated = slots_of("tiles", tile_cells, np.uint64), slots_of("repeated", tile_cells, np.uint64)
    owners = slots_of("owners", cells, np.int32)
    masks = _scratch_array(("masks", disks, size), lambda: frame_counts.tile_masks(disks, *size))
    busy = np.zeros(threads, np.int32)
    for f0, f1 in _frame_launches(offsets):
        e0, e1 = int(offsets[f0]), int(offsets[f1])
        local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
        biggest = int(np.diff(local).max())
        # packed 16-bit cells are exact while no frame holds more than MAX_EVENTS events
        cell = "u16x4" if biggest <= frame_grids.MAX_EVENTS else "i32"
        dtype, per_element = _CELL_DTYPES[cell]
        grid = slots_of(f"grid-{cell}", cells // per_element, dtype)
        room = min(biggest, ev.width * ev.height)  # a frame's pixels, each listed at most once
        repeats, owned = (np.empty(threads * room, np.int32) for _ in range(2))
        lo, hi = _units(_balanced_cuts(local, 8 * threads), threads)
        kernel = frame_counts.count_frames_kernel(disks, ev.width, ev.height, cell)
        kernel(ev.x[e0:e1], ev.y[e0:e1], local, lo, hi, th, dense_min, grid, prefix, tiles, repeated,
               masks, repeats, owners, owned, busy, counts[e0:e1], keep[e0:e1])


def _counts_events(ti, ev, offsets, disks, th, strategy, device, counts, keep):
    from evstar_kernels.taichi import event_counts, frame_counts, frame_grids

    geo = frame_grids.Geometry(ev.width, ev.height, frame_counts.disk_padding(disks))
    direct = frame_counts.direct_costs(disks, geo, "i32")
    dense_min = {"auto": frame_counts.prefix_break_even(direct, disks, geo),
                 "sparse": np.iinfo(np.int32).max, "dense": 0}[strategy]
    bin_frames, prefix_rows, count, unbin_frames = event_counts.count_events_kernels(
        disks, ev.width, ev.height)
    arrays = _Arrays(ti, device)
    planes = max(1, _EVENT_GRID_BYTES // (4 * (geo.plane + geo.prefix_plane)))
    planes = min(planes, len(offsets) - 1)
    grid = _scratch_array(("ev-grid", geo, planes, arrays.on_device),
                          lambda: arrays.put(np.zeros(planes * geo.plane, np.int32)))
    prefix = _scratch_array(("ev-prefix", geo, planes, arrays.on_device),
                            lambda: arrays.put(np.zeros(planes * geo.prefix_plane, np.int32)))
    th_d = arrays.put(th)
    for f0, f1 in _frame_launches(offsets):
        e0, e1 = int(offsets[f0]), int(offsets[f1])
        local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
        x, y, off = arrays.put(ev.x[e0:e1]), arrays.put(ev.y[e0:e1]), arrays.put(local)
        c_d, k_d = arrays.empty((e1 - e0, len(disks)), np.int32), arrays.empty(e1 - e0, np.uint8)
        sizes = np.diff(local)
        for b0 in range(0, f1 - f0, planes):
            b1 = min(b0 + planes, f1 - f0)
            bin_frames(x, y, off, b0, b1, grid)
            if np.any(sizes[b0:b1] >= dense_min):
                prefix_rows(off, b0, b1, dense_min, grid, prefix)
            count(x, y, off, b0, b1, th_d, dense_min, grid, prefix, c_d, k_d)
            unbin_frames(x, y, off, b0, b1, grid)
        arrays.get(c_d, counts[e0:e1])
        arrays.get(k_d, keep[e0:e1])


def _taichi_classical(ev, dt_us, k, device, schedule):
    ti = backends.taichi(device)
    n = len(ev)
    support = np.empty(n, np.int8)
    keep = np.empty(n, np.uint8)
    if n:
        run = _classical_lanes if _resolve_schedule(schedule, device) == "lanes" else _classical_events
        run(ti, ev, dt_us, k, device, support, keep)
    return support, keep.view(bool)


def _classical_lanes(ti, ev, dt_us, k, device, support, keep):
    from evstar_kernels.taichi import classical

    threads = _cpu_threads(ti)
    shape = (threads, ev.height + 2, ev.width + 2)

    def make_maps():
        maps = np.full(shape, classical.BORDER, np.int64)
        maps[:, 1:-1, 1:-1] = 0
        return maps

    maps = _scratch_array(("maps",) + shape, make_maps)
    busy = np.zeros(threads, np.int32)
    n = len(ev)
    for a in range(0, n, _MAX_LAUNCH_EVENTS):
        b = min(n, a + _MAX_LAUNCH_EVENTS)
        # one range per thread: every range but the first replays ~rate·dt events
        cuts = np.unique(np.linspace(a, b, threads + 1).astype(np.int64))
        lb = _lookback(ev.t, cuts[:-1], dt_us)
        base = int(lb[0])
        lb_u, lo, hi = _units(cuts - base, threads, lb - base)
        classical.classical_ranges(ev.t[base:b], ev.x[base:b], ev.y[base:b], lb_u, lo, hi,
                                   dt_us, k, maps, busy, support[base:b], keep[base:b])


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


def _classical_events(ti, ev, dt_us, k, device, support, keep):
    from evstar_kernels.taichi import classical_buckets as cb

    fill, evaluate, clear = cb.classical_bucket_kernels(ev.width, ev.height)
    arrays = _Arrays(ti, device)
    stride, n = ev.width + 2, len(ev)
    plane = (ev.height + 2) * stride
    bucket = _compact_buckets(ev.t, dt_us)
    planes = int(max(2, min(_EVENT_GRID_BYTES // (12 * plane), bucket[-1] + 2)))

    def fresh_planes():
        first = np.full(planes * plane, cb.NONE, np.int32)
        return arrays.put(first), arrays.put(np.full(planes * plane, cb.BORDER, np.int64))

    first, last_t = _scratch_array(("buckets", plane, stride, planes, arrays.on_device), fresh_planes)
    early = np.flatnonzero(ev.t < dt_us)  # only these can see dv's initial zeros
    pix_early = (ev.y[early].astype(np.int64) + 1) * stride + ev.x[early] + 1
    first_any = np.full(plane, -1, np.int32)
    first_any.reshape(ev.height + 2, stride)[1:-1, 1:-1] = cb.NONE
    starts = np.unique(np.searchsorted(bucket, bucket[np.arange(0, n, _MAX_LAUNCH_EVENTS)], side="left"))
    for a, b in zip(starts, np.append(starts[1:], n)):
        base = int(np.searchsorted(bucket, bucket[a] - 1, side="left"))
        fa = first_any.copy()
        if len(early):
            u, i = np.unique(pix_early, return_index=True)
            fa[u] = early[i] - base
        sl = slice(base, b)
        t_d, x_d, y_d = arrays.put(ev.t[sl]), arrays.put(ev.x[sl]), arrays.put(ev.y[sl])
        b_d, fa_d = arrays.put((bucket[sl] - bucket[base]).astype(np.int32)), arrays.put(fa)
        s_d, k_d = arrays.empty(b - base, np.int8), arrays.empty(b - base, np.uint8)
        local = bucket[sl] - bucket[base]
        for b0 in range(int(local[a - base]), int(local[-1]) + 1, planes - 1):
            b1 = b0 + planes - 1
            f0, e0, e1 = np.searchsorted(local, [b0 - 1, b0, b1], side="left")
            fill(x_d, y_d, b_d, f0, e1, b0 - 1, t_d, first, last_t)
            evaluate(x_d, y_d, t_d, b_d, e0, e1, b0 - 1, dt_us, k, first, last_t, fa_d, s_d, k_d)
            clear(x_d, y_d, b_d, f0, e1, b0 - 1, first, last_t)
        arrays.get(s_d, support[a:b], skip=a - base)  # [base, a) belong to the launch before
        arrays.get(k_d, keep[a:b], skip=a - base)
