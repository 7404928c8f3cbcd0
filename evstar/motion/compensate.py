"""Motion compensation of an event stream: modes 'none' | 'imu' | 'pf'.

Every event moves to its pseudo-frame's reference time (float coordinates for centroids);
the rounded coordinates (pixel i covers [i − ½, i + ½)) are what the filters bin.

- 'none': coordinates unchanged.
- 'imu':  rotation from the raw gyro integrated on SO(3).
- 'pf':   rotation from the gyro corrected by the particle filter's bias estimate, which
          needs star observations (t, track, x, y centroids, e.g. from a first extraction
          pass with 'imu') or a FilterResult from an earlier run.
"""
from __future__ import annotations

import copy
import functools

import numpy as np

from evstar_kernels.reference.pixels import rounded_pixels

from .. import parameters as P
from ..errors import DataError, ParameterError, ParameterTypeError
from ..events import Events
from ..frames import check_dt
from ..recording import check_parts
from .imu_integration import AttitudeTrack, check_coverage, hold_ends
from .particle_filter import ParticleFilter
from .warping import frame_reference_times, frame_references, warp_indexed

MODES = P.COMPENSATIONS
EXTRAPOLATE_US = P.MOTION["extrapolate_us"].default


class Compensation:
    """Per-event result: x, y float64 (warped), xi, yi int64 (rounded; made when read), inside
    (rounded pixel on the sensor), frame int64, t_ref_us float64, plus the attitude track and,
    for 'pf', the FilterResult used. Mode 'none' (:meth:`identity`) computes these arrays only
    when read."""

    def __init__(self, events, mode, x, y, frame, t_ref_us, attitude=None, filter_result=None):
        self.frame, self.t_ref_us = frame, t_ref_us
        xy = np.column_stack([np.asarray(x, np.float64), np.asarray(y, np.float64)])
        self._warped(events, mode, xy, attitude, filter_result)

    @classmethod
    def warped(cls, events, mode, xy, frames, attitude, filter_result=None, pixels=None):
        """Modes 'imu', 'pf' from the warped (n, 2) xy: frame and t_ref_us are made when read,
        from frames = (dt_us, t0_us, reference) (a run reads neither); pixels: (px, py,
        inside) of xy when the warp gave them (reference.pixels.rounded_pixels)."""
        self = cls.__new__(cls)
        self._frames = frames
        self._warped(events, mode, xy, attitude, filter_result, pixels)
        return self

    def _warped(self, events, mode, xy, attitude, filter_result, pixels=None):
        self.mode = mode
        self._xy = xy   # rows: coordinates() gathers both axes at once
        self.x, self.y = xy[:, 0], xy[:, 1]
        self.attitude, self.filter_result = attitude, filter_result
        # uint16 pixels of the events on the sensor (NaN, behind the camera, is outside)
        self._px, self._py, self.inside = (
            rounded_pixels(self.x, self.y, events.width, events.height) if pixels is None
            else pixels)
        self._events = events

    @classmethod
    def identity(cls, events, dt_us, t0_us=None, reference="mid"):
        """Mode 'none': every event stays at its pixel (a run reads none of the per-event
        arrays: they are made, as __init__ would, on first access)."""
        self = cls.__new__(cls)
        self.mode, self.attitude, self.filter_result, self._events = "none", None, None, events
        self._frames = (dt_us, t0_us, reference)
        frame_reference_times(events.t[:1], dt_us, t0_us, reference)   # arguments checked now
        return self

    # made on first access: x, y, inside for identity() only (__init__ sets them: they shadow
    # these), frame and t_ref_us unless __init__ set them; xi, yi in every mode
    x = functools.cached_property(lambda self: np.asarray(self._events.x, np.float64))
    y = functools.cached_property(lambda self: np.asarray(self._events.y, np.float64))
    xi = functools.cached_property(lambda self: self._pixels("x"))
    yi = functools.cached_property(lambda self: self._pixels("y"))
    inside = functools.cached_property(lambda self: np.ones(len(self._events), bool))
    frame = functools.cached_property(lambda self: self._reference_times[0])
    t_ref_us = functools.cached_property(lambda self: self._reference_times[1])
    _reference_times = functools.cached_property(
        lambda self: frame_reference_times(self._events.t, *self._frames))

    def __len__(self):
        return len(self._events)

    def _pixels(self, axis):
        """Rounded coordinates, int64; -1 where the ray turned behind the camera."""
        if self.mode == "none":
            return getattr(self._events, axis).astype(np.int64)
        r = np.floor(getattr(self, axis) + 0.5)
        return np.where(np.isnan(r), -1.0, r).astype(np.int64)

    def with_filter(self, filter_result, imu, causal=True):
        """This gyro-warped compensation as mode 'pf': the attitude the particle filter
        corrected (FilterResult.attitude_track of `imu`) and its result, the events where the
        gyro put them (a bias moves them by at most f·b·dt/2 within a frame)."""
        out = copy.copy(self)
        out.mode, out.filter_result = "pf", filter_result
        out.attitude = filter_result.attitude_track(imu, causal=causal)
        return out

    def coordinates(self, index):
        """(len(index), 2) float64 (x, y) of the events `index` (as x[index], y[index])."""
        if "_xy" in self.__dict__:
            return np.take(self._xy, index, axis=0)   # ~7x the speed of _xy[index]
        ev = self._events
        return np.column_stack([ev.x[index], ev.y[index]]).astype(np.float64)

    def events(self):
        """(Events at the rounded warped pixels of the events that stay on the sensor, their
        indices in the input stream). Time order is kept."""
        ev = self._events
        if self.mode == "none":
            return ev, np.arange(len(ev))
        idx = np.flatnonzero(self.inside)
        if len(idx) == len(ev):
            return Events._trusted(ev.t, self._px, self._py, ev.p, ev.width, ev.height), idx
        m = self.inside   # a mask selects ~2x faster than the indices gather
        return Events._trusted(ev.t[m], self._px[m], self._py[m], ev.p[m], ev.width,
                               ev.height), idx

    def __repr__(self):
        return f"Compensation(mode={self.mode!r}, n={len(self)}, inside={int(self.inside.sum())})"


def compensate(events, imu=None, camera=None, dt_us=10_000, mode="imu", *, observations=None,
               particle_filter=None, filter_result=None, causal=True, t0_us=None, reference="mid",
               extrapolate_us=EXTRAPOLATE_US, backend="reference", device="cpu"):
    """Warp `events` to their frames' reference times.

    events: evstar.Events; imu: evstar.Imu covering the events (modes 'imu', 'pf');
    camera: evstar.Camera; dt_us: pseudo-frame length (µs); t0_us: frame origin (default the
    first event); reference: 'mid' (frame mid-time) or 'start'. For mode 'pf', either
    `observations` (see evstar.motion.StarObservations) with an optional `particle_filter`
    (a ParticleFilter; default ParticleFilter()), or a `filter_result` from an earlier run;
    causal: use at each time the bias estimated up to then (True, online) or the final
    estimate throughout (False, offline). extrapolate_us: events up to this many µs before
    the first or after the last IMU sample use that sample's rate (held); further, a
    DataError. backend 'reference' (numpy) | 'warp' and device 'cpu' | 'cuda'
    choose where the warping runs (the particle filter has its own device setting).
    """
    mode = P.MOTION.check("compensate", mode, "mode")
    extrapolate_us = P.MOTION.check("extrapolate_us", extrapolate_us)
    dt_us = check_dt(dt_us)
    if not isinstance(events, Events):
        raise ParameterTypeError(f"events must be an evstar.Events, got {type(events).__name__}")
    if mode == "none":
        return Compensation.identity(events, dt_us, t0_us, reference)
    # their types, the IMU and camera the mode needs, the camera's size against the events'
    check_parts(events, imu, camera, mode)
    if len(imu) < 2:
        raise DataError(f"the IMU has {len(imu)} sample(s); compensation needs at least 2")
    refs, ref_index = frame_references(events.t, dt_us, t0_us, reference)
    if len(events):
        imu = hold_ends(imu, events.t[0], events.t[-1], extrapolate_us)
        check_coverage(imu, events.t[0], events.t[-1])
    result = None
    if mode == "pf":
        result = filter_result or _run_filter(particle_filter, imu, observations, camera)
        attitude = result.attitude_track(imu, causal=causal)
    else:
        attitude = AttitudeTrack.from_imu(imu)
    xy, *pixels = warp_indexed(events.t, events.x, events.y, refs, ref_index, attitude, camera,
                               extrapolate_us=float(dt_us), sensor=(events.width, events.height),
                               backend=backend, device=device)
    return Compensation.warped(events, mode, xy, (dt_us, t0_us, reference), attitude, result,
                               pixels)


def _run_filter(particle_filter, imu, observations, camera):
    if observations is None:
        raise ParameterError("mode='pf' needs observations (star centroids t, track, x, y) "
                             "or a filter_result")
    pf = ParticleFilter() if particle_filter is None else particle_filter
    if not isinstance(pf, ParticleFilter):
        raise ParameterTypeError(f"particle_filter must be a ParticleFilter, got {type(pf).__name__}")
    return pf.run(imu, observations, camera)
