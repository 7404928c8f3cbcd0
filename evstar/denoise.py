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
from .config import Config
from .errors import DataError, ParameterError, ParameterTypeError
from .events import Events, gather
from .frames import check_frame_count, check_grid
from evstar_kernels.reference import denoise as ref
from evstar_kernels.taichi.scratch import Scratch

BACKENDS = ("taichi", "reference")


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
    check_grid(events.width, events.height)
    return events


def _check_select(select, n, key="select"):
    """select as a contiguous bool array of n entries, or None."""
    if select is None:
        return None
    select = np.ascontiguousarray(select)
    if select.dtype != bool:
        raise ParameterTypeError(f"{key} must be a bool array (one per event), got "
                                 f"{select.dtype} values")
    if select.shape != (n,):
        raise ParameterError(f"{key} must hold one bool per event ({n}), got shape {select.shape}")
    return select


def _frame_offsets(t, dt_us, t0_us):
    """ref.frame_offsets, or DataError where t0_us is after the first event or the events
    span more than MAX_FRAMES frames."""
    if len(t):
        t0 = int(t[0]) if t0_us is None else t0_us
        if t[0] < t0:
            raise DataError(f"t0_us={t0} is after the first event ({int(t[0])} µs)")
        check_frame_count((int(t[-1]) - t0) // dt_us + 1, t0, int(t[-1]), dt_us)
    return ref.frame_offsets(t, dt_us, t0_us)


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
        return self._record(events, self._apply(events))

    def mask(self, events):
        """The keep mask alone (as apply; density filters count less for it)."""
        return self.apply(events)

    def _record(self, events, keep):
        self.n_events_ = len(events)
        self.n_kept_ = int(np.count_nonzero(keep))
        return keep

    def filter(self, events):
        """The kept events, in input order."""
        return events[self.apply(events)]

    def release(self):
        """Free the scratch memory the Taichi backend keeps for the next call."""
        _scratch_of(self).release()

    def sharing(self, scratch):
        """This filter, its Taichi calls using `scratch` (a Scratch): whoever makes a filter
        per call (the pipeline, per run) keeps the zeroed planes and mask tables between
        calls (~10 % of a 5 M-event MR-NDSEF mask to make afresh)."""
        self.__dict__["_scratch"] = scratch
        return self


# -- classical ---------------------------------------------------------------------------------
class ClassicalFilter(_Filter):
    """Spatio-temporal correlation (background-activity) filter; k=1 is dv-processing's.

    Per event in stream order: a neighbour (8-connected, not the pixel itself) supports it
    if the neighbour's last timestamp ts gives t − ts < dt_us (the timestamp map starts at
    0, as dv's does); keep if at least k neighbours support it. counts_ (int8) holds each
    event's number of supporting neighbours.
    """

    _param_names = ("dt_us", "k", "backend", "device", "schedule")

    def __init__(self, dt_us=G["dt_us"].default, k=D["k"].default, *, backend="taichi",
                 device="cpu", schedule="auto"):
        self.dt_us, self.device, _ = _check_common(dt_us, backend, device, None)
        self.k = D.check("k", k)
        self.backend = backend
        self.schedule = _check_schedule(schedule, self.device)

    def _apply(self, ev):
        if self.backend == "reference":
            support = ref.classical_support(ev.t, ev.x, ev.y, ev.width, ev.height, self.dt_us)
            keep = support >= self.k
        else:
            support, keep = _taichi_classical(self, ev)
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
            try:
                return ref.poisson_thresholds(rate, self.dt_us, self.radii, self.alpha)
            except ValueError as exc:
                raise ParameterError(f"auto thresholds at {rate:g} events/pixel/s in frames "
                                     f"of dt_us={self.dt_us}: {exc}") from None
        self.rate_hz_ = self.rate_hz
        return np.asarray(self.thresholds, np.int64)

    def apply(self, events, select=None):
        """Keep mask (bool, one entry per event, input order); sets counts_ and friends.
        select (bool per event): test only these events (every event still counts); the
        others are not kept and their counts are -1 (less work when few are asked)."""
        return self._run(events, select, full=True)

    def mask(self, events, select=None):
        """apply's mask, counting only what it needs: an event whose count at a radius
        already reaches every larger radius's threshold is kept without counting those
        (the disks are nested). counts_ is None (not kept)."""
        return self._run(events, select, full=False)

    def _run(self, events, select, full):
        events = _check_events(events)
        return self._record(events, self._apply(events, _check_select(select, len(events)), full))

    def _apply(self, ev, select=None, full=True):
        offsets = _frame_offsets(ev.t, self.dt_us, self.t0_us)
        th = self._resolve_thresholds(ev, offsets)
        self.thresholds_ = tuple(int(v) for v in th)
        if self.backend == "reference":
            frame = ref.frame_index(ev.t, self.dt_us, self.t0_us)
            keep, counts = ref.mr_ndsef(frame, ev.x, ev.y, ev.width, ev.height, self.radii, th,
                                        select, full)
            counts = counts.astype(np.int32) if full else None
        else:
            keep, counts = _taichi_counts(self, (ev.x, ev.y, ev.width, ev.height), offsets, th,
                                          select, full)
        self.counts_ = counts
        return keep

    def kept_among(self, events, among):
        """Indices of the events `among` (bool per event) selects that mask() keeps when they
        alone count and are tested: np.flatnonzero(among)[self.mask(events[among])], from
        their pixels and the frames' bounds in `events` (their times and polarities not
        gathered: the pooled look tests 3.7 M of a 5 M-event chunk). The Taichi backend with
        t0_us and a rate (or explicit thresholds); otherwise by that selection."""
        events = _check_events(events)
        idx = np.flatnonzero(_check_select(among, len(events), "among"))
        if (self.backend != "taichi" or self.t0_us is None or not len(idx)
                or (self.rate_hz is None and isinstance(self.thresholds, str))
                or events.t[0] < self.t0_us):
            return idx[self.mask(events[idx])]
        # the selection's frames: those of the whole stream up to its last event's
        bounds = _frame_offsets(events.t[:idx[-1] + 1], self.dt_us, self.t0_us)
        offsets = np.searchsorted(idx, bounds)
        th = self._resolve_thresholds(None, offsets)
        self.thresholds_ = tuple(int(v) for v in th)
        x, y = gather([events.x, events.y], idx)
        keep, self.counts_ = _taichi_counts(self, (x, y, events.width, events.height), offsets,
                                            th, None, False)
        self._record(x, keep)   # the selection's events
        return idx[keep]


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

    def __init__(self, dt_us=G["dt_us"].default, radius=D["radius"].default,
                 threshold=D["threshold"].default, *, alpha=D["alpha"].default, rate_hz=None,
                 t0_us=None, backend="taichi", device="cpu", strategy="auto",
                 schedule="auto"):
        self._set_common(dt_us, alpha, rate_hz, t0_us, backend, device, strategy, schedule)
        self.radius = D.check("radius", radius)
        self.threshold = D.check("threshold", threshold)

    radii = property(lambda self: (self.radius,))
    thresholds = property(lambda self: self.threshold if isinstance(self.threshold, str)
                          else (self.threshold,))
    threshold_ = property(lambda self: self.thresholds_[0])   # after a call: the one used

    def _apply(self, ev, select=None, full=True):
        keep = super()._apply(ev, select, full)
        if self.counts_ is not None:
            self.counts_ = self.counts_.reshape(-1)  # (n, 1) -> (n,): a view, no copy
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

    def __init__(self, dt_us=G["dt_us"].default, radii=tuple(D["radii"].default),
                 thresholds=D["thresholds"].default, *, alpha=D["alpha"].default,
                 rate_hz=None, t0_us=None, backend="taichi", device="cpu", strategy="auto",
                 schedule="auto"):
        self._set_common(dt_us, alpha, rate_hz, t0_us, backend, device, strategy, schedule)
        self.radii = tuple(D.check("radii", radii))
        thresholds = P.check_thresholds_per_radius(D.check("thresholds", thresholds), self.radii)
        self.thresholds = thresholds if thresholds == P.AUTO else tuple(thresholds)


def from_config(config, *, t0_us=None, rate_hz=None, backend="taichi", scratch=None):
    """The filter an :class:`evstar.Config` describes (None for method 'none'): the one
    factory of the pipeline and the command line. `rate_hz` (e.g. a calibration window's
    background rate) is used unless the configuration fixes denoise.rate_hz. scratch: a
    Scratch the filter shares (_Filter.sharing), None for its own."""
    if not isinstance(config, Config):
        raise ParameterTypeError(f"config must be an evstar.Config, got {type(config).__name__}")
    flt = _from_config(config, t0_us, rate_hz, backend)
    return flt if flt is None or scratch is None else flt.sharing(scratch)


def _from_config(config, t0_us, rate_hz, backend):
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


# -- Taichi launches ------------------------------------------------------------------------------


def _resolve_schedule(schedule, device):
    if schedule == "auto":
        return "lanes" if device == "cpu" else "events"
    return schedule


def _scratch_of(flt):
    """The filter's scratch owner, made on its first Taichi call (setdefault: one per filter
    even when two threads make the first call together)."""
    return flt.__dict__.setdefault("_scratch", Scratch())


def _taichi_counts(flt, pixels, offsets, thresholds, select=None, full=True):
    """count_density of the events' pixels = (x, y, width, height)."""
    from evstar_kernels.taichi import density_launch

    return density_launch.count_density(
        backends.taichi(flt.device), *pixels, offsets, flt.radii, thresholds,
        strategy=flt.strategy, schedule=_resolve_schedule(flt.schedule, flt.device),
        scratch=_scratch_of(flt), select=select, full=full)


def _taichi_classical(flt, ev):
    from evstar_kernels.taichi import classical_launch

    return classical_launch.classical_filter(
        backends.taichi(flt.device), ev.t, ev.x, ev.y, ev.width, ev.height, flt.dt_us, flt.k,
        schedule=_resolve_schedule(flt.schedule, flt.device), scratch=_scratch_of(flt))
