"""The whole chain: motion compensation -> denoise -> extract -> track -> metrics.

    import evstar
    from evstar import sim
    run = sim.simulate(sim.paper_preset(20.0), seed=1)
    result = evstar.Pipeline(evstar.Config()).run(run.events, run.imu, run.camera, truth=run.truth)
    result.centroids, result.metrics

Every stage is also callable alone (evstar.motion.compensate, evstar.denoise, evstar.extract,
evstar.tracking). A recording larger than memory goes through :meth:`Pipeline.run_file`,
chunk by chunk of ``config.chunk_frames`` frames, with results identical to :meth:`run`:
both take the background rate for ``auto`` thresholds from the first ``chunk_frames``
frames (the calibration window) and from any block of frames where it moved
(evstar.background; blocks divide chunks), frames never straddle chunks, the classical
filter gets the previous chunk's last ``dt`` of events as context, and tracks are linked at
the end.
"""
from __future__ import annotations

import functools
import time
import warnings
from dataclasses import asdict, dataclass, field

import numpy as np

from . import accuracy
from .background import Background, windows
from .bursts import flashes
from .config import Config
from .errors import DataError, EvstarWarning, ParameterTypeError
from .events import Events, time_lattice_us
from .extract import CENTROID_DTYPE, Extractor
from .frames import (accumulated, check_frame_count, frame_offsets, images, on_pixels,
                     stall_starts, stalled_us, stalls)
from .gyro_repair import repaired
from .parameters import AUTO, MAX_PIXEL_RATE_HZ
from .pixel_order import PixelOrder
from .recording import check_parts
from .tracking import Tracker
from evstar_kernels.taichi.scratch import Scratch


@dataclass
class Result:
    centroids: np.ndarray                     # CENTROID_DTYPE rows, tracks linked
    metrics: dict                             # deterministic for given inputs and seed
    timings_s: dict                           # seconds per stage (varies run to run)
    keep: np.ndarray | None = None            # keep mask per input event (None when streamed)
    compensation: object = None               # evstar.motion.Compensation (whole runs)
    frame_counts: dict = field(default_factory=dict)   # per-frame event counts, for plots
    # (events per pixel, kept events per pixel), or a call counting them when first asked
    images: object = field(default=None, repr=False)

    @property
    def image_before(self):
        """Accumulated events per pixel (height, width) int64."""
        return self._images()[0]

    @property
    def image_after(self):
        """The same, kept events only."""
        return self._images()[1]

    def _images(self):
        # whole runs count them only for whoever looks (plots): one pass over every event
        if callable(self.images):
            self.images = self.images()
        return (None, None) if self.images is None else self.images


class Pipeline:
    """Runs the configured stages; see the module docstring."""

    def __init__(self, config=None):
        self.config = Config() if config is None else config
        if not isinstance(self.config, Config):
            raise ParameterTypeError(f"config must be an evstar.Config, got {type(config).__name__}")
        self.config.validate()
        from .estimation import pixel_lag

        pixel_lag(self.config.estimate.pixel_lag_file)   # a bad file fails here, before any work
        # the filters' scratch: a run makes its filters anew, their planes and tables stay
        # (one per pipeline: two pipelines in two threads must not share them)
        self._scratch = {"frames": Scratch(), "pooled": Scratch()}

    # -- stage factories ----------------------------------------------------------------
    def make_filter(self, t0_us, rate_hz):
        """The configured denoiser with a fixed frame origin and background rate (its
        scratch kept from run to run)."""
        from . import denoise

        return denoise.from_config(self.config, t0_us=t0_us, rate_hz=rate_hz,
                                   scratch=self._scratch["frames"])

    def make_extractor(self, t0_us, compensated=False):
        """Compensated coordinates are positions at the frame mid-time, so their centroids
        carry that time whatever extract.time_ref says."""
        params = {**asdict(self.config.extract), **({"time_ref": "mid"} if compensated else {})}
        params.pop("pool_frames")       # the pipeline's second look (evstar.pooling)
        return Extractor(dt_us=self.config.dt_us, t_origin_us=t0_us, device=self.config.device,
                         **params)

    def make_tracker(self):
        """A faint star's pooled centroids (evstar.pooling) can come up to 2·pool_frames − 1
        frames apart: its track survives that long without a centroid."""
        params, k = asdict(self.config.track), self.config.extract.pool_frames
        if k > 1:
            params["max_gap"] = max(params["max_gap"], 2 * k - 1)
        return Tracker(**params)

    def calibration(self, events, t0_us):
        """(calibration_rate, calibration_hot_pixels) from one count image of the window;
        an EvstarWarning where the window's timestamps lie on a coarse lattice."""
        w = self._calibration_window(events, t0_us)
        counts = accumulated(w)
        _warn_lattice(w.t)
        return self._rate(w, counts), self._hot_pixels(counts)

    def calibration_rate(self, events, t0_us):
        """Background rate (events/pixel/s) of the first chunk_frames frames."""
        w = self._calibration_window(events, t0_us)
        return self._rate(w, accumulated(w))

    def calibration_hot_pixels(self, events, t0_us):
        """Hot-pixel mask (height, width) from the counts of the first chunk_frames frames
        (the calibration window, as for the background rate), or None when switched off."""
        return self._hot_pixels(accumulated(self._calibration_window(events, t0_us)))

    def _background(self, t0_us, rate):
        """The run's evstar.background.Background: the calibration window's (µs from t0_us)
        rate `rate`."""
        return Background(rate, (t0_us, t0_us + self.config.chunk_frames * self.config.dt_us))

    def _calibration_window(self, events, t0_us):
        """The events of the first chunk_frames frames, less a flash's (evstar.bursts). A
        run's first kernels count them, on whatever Taichi runs on (frames.images): Taichi is
        started on the run's device here, else it started on the CPU and a cuda run's filters
        could not switch to the GPU."""
        from .backends import taichi

        taichi(self.config.device)
        w = events.time_window(t0_us, t0_us + self.config.chunk_frames * self.config.dt_us)
        flash = flashes(w.t, t0_us, self.config.dt_us, w.width * w.height)
        return w[~flash] if flash.any() else w      # a flash is no background, no hot pixel

    def _rate(self, window, counts):
        """The window's background rate, over at least one frame: events that all share a
        timestamp (a recording shorter than a frame) measured 1.6 MHz a pixel over the 1 µs
        floor, which the filter refused as its rate_hz; and no pixel fires faster than
        MAX_PIXEL_RATE_HZ."""
        from evstar_kernels.reference.denoise import background_rate

        dt = self.config.dt_us
        # less its stalls: a readout that stalled for 300 ms of a 1 s window had put the rate
        # at 0.7 of the background's and the paper's sinusoid 0.018 -> 0.086 px
        span_us = int(window.t[-1]) - int(window.t[0]) - stalled_us(window.t, dt) if len(window) else 0
        rate = background_rate(window.t, window.x, window.y, window.width, window.height,
                               counts=counts, duration_s=max(span_us, dt) * 1e-6)
        return min(rate, MAX_PIXEL_RATE_HZ)

    def _hot_pixels(self, counts):
        h = self.config.hotpixels
        if not h.remove:
            return None
        from .hotpixels import hot_pixels

        return hot_pixels(counts, h.alpha, h.neighbour_ratio)

    # -- one chunk ----------------------------------------------------------------------
    def _compensate(self, events, imu, camera, t0_us, mode, filter_result=None):
        from .motion import compensate

        # always the Taichi warp (every core; ~1.9x the one-thread Warp launch on 2 cores):
        # chunks and whole runs must round identically
        return compensate(events, imu, camera, self.config.dt_us, mode, t0_us=t0_us,
                          filter_result=filter_result, causal=self.config.motion.causal,
                          extrapolate_us=self.config.motion.extrapolate_us, backend="taichi",
                          device=self.config.device)

    def _chunk(self, events, imu, camera, t0_us, rate, mode, filter_result, context=None,
               state=None):
        """(keep mask, centroids, timings, compensation) of one chunk; `context` are earlier
        events the classical filter needs (their own outputs are dropped). With a `state`
        (_RunState), hot pixels' events are dropped and the chunk's crossings collected. A
        flash's events (evstar.bursts.flashes) are taken as lost: the chunk runs without
        them, and they are not kept."""
        flash = flashes(events.t, t0_us, self.config.dt_us, events.width * events.height)
        if flash.any():
            keep, cents, timings, comp = self._chunk(events[~flash], imu, camera, t0_us, rate,
                                                     mode, filter_result, context, state)
            whole = np.zeros(len(events), bool)
            whole[~flash] = keep
            return whole, cents, timings, comp
        timings = {}
        t = time.perf_counter()
        comp = self._compensate(events, imu, camera, t0_us, mode, filter_result)
        # mode none: the events themselves (idx None: no index array of the whole stream)
        ev_f, idx = (events, None) if mode == "none" else comp.events()
        timings["compensate"] = time.perf_counter() - t
        t = time.perf_counter()
        flt = self.make_filter(t0_us, rate)
        rates = [(None, None, rate)]   # runs of blocks of one background rate
        if flt is None:
            keep_f = np.ones(len(ev_f), bool)
        elif context is not None and len(context) and self.config.denoise.method == "classical":
            both = Events.concatenate([context, ev_f])
            keep_f = flt.apply(both)[len(context):]
        else:
            keep_f = flt.mask(ev_f) if len(ev_f) else np.zeros(0, bool)
            if (state is not None and state.background is not None
                    and getattr(flt, "thresholds", None) == AUTO):
                # auto thresholds follow the background block by block (evstar.background)
                keep_f, rates = state.background.followed(
                    ev_f.t, keep_f, t0_us, self.config, events.width * events.height,
                    lambda part, hz: self.make_filter(t0_us, hz).mask(ev_f[part]))
        whole = idx is None or len(idx) == len(events)   # every event stayed: idx = 0 .. n-1
        hot = None                          # per event: on a hot pixel (no star's)
        if state is not None and state.hot is not None:
            hot = on_pixels(events, state.hot)
            keep_f &= ~(hot if whole else hot[comp.inside])   # = hot[idx]; a mask: faster
        timings["denoise"] = time.perf_counter() - t
        t = time.perf_counter()
        # the kept events' indices into ev_f and into `events`, found once (whole: the
        # same; else indices: ~2x a mask's selection of idx)
        kept_f = np.flatnonzero(keep_f)
        kept = kept_f if whole else idx[kept_f]
        # uncompensated coordinates are the kept events' own pixels
        xy = None if mode == "none" else comp.coordinates(kept)
        cents, members = self.make_extractor(t0_us, mode != "none").centroids_and_members(
            ev_f.at_sorted(kept_f), xy=xy)
        timings["extract"] = time.perf_counter() - t
        keep = keep_f
        if not whole:
            keep = np.zeros(len(events), bool)
            keep[kept] = True
        if state is not None:
            t = time.perf_counter()
            # the pooled look takes every event no frame centroid used: those the filter
            # dropped, and those it kept that no reported cluster holds (a faint star's
            # sparse events on a quiet sensor pass the filter but not DBSCAN): marked from
            # the dropped ones (nearly every kept event is a member: a few to unmark)
            unused = ~keep
            unused[kept[~members]] = True
            if hot is not None:
                unused &= ~hot
            cents = self._with_pooled(cents, events, unused, t0_us, rates)
            timings["extract"] += time.perf_counter() - t
            t = time.perf_counter()
            state.add_chunk(events, kept, cents)
            timings["estimate"] = time.perf_counter() - t
        return keep, cents, timings, comp

    def _with_pooled(self, cents, events, unused, t0_us, rates):
        """The frame centroids and the pooled ones of the events neither in a frame
        centroid's cluster nor on a hot pixel (`unused`: a mask of those; evstar.pooling),
        in time order; each run of blocks of one background rate (`rates`:
        Background.followed) looked at with its own."""
        from .pooling import pooled_centroids

        pooled = [pooled_centroids(self.config, events[part], unused[part], t0_us, hz, cents,
                                   self._scratch["pooled"]) for part, hz in windows(events, rates)]
        pooled = np.concatenate(pooled) if pooled else np.zeros(0, CENTROID_DTYPE)
        if not len(pooled):
            return cents
        out = np.concatenate([cents, pooled])
        return out[np.lexsort((out["x"], out["t"]))]

    # -- whole recordings in memory -----------------------------------------------------
    def run(self, events, imu=None, camera=None, truth=None):
        """Run every stage on events held in memory."""
        mode = self.config.motion.compensate
        if not isinstance(events, Events):   # check_parts lets None through (run_file's)
            raise ParameterTypeError(f"events must be an evstar.Events, got {type(events).__name__}")
        check_parts(events, imu, camera, mode)
        imu = self._repaired(imu)
        if truth is not None:
            accuracy.check_truth(truth, len(events), events.width, events.height,
                        events.t[[0, -1]] if len(events) else None)
        t0 = int(events.t[0]) if len(events) else 0
        span = (t0, int(events.t[-1])) if len(events) else None   # the recording's first, last µs
        if span is not None:
            check_frame_count((span[1] - t0) // self.config.dt_us + 1, *span, self.config.dt_us)
        rate, hot = self.calibration(events, t0)
        timings = {}
        state = _RunState(self.config, events.width, events.height, t0, hot,
                          self._background(t0, rate))
        keep, cents, chunk_t, comp = self._chunk(events, imu, camera, t0, rate, _warp(mode), None,
                                                 state=state)
        _add(timings, chunk_t)
        filter_result = None
        if mode == "pf":
            filter_result, timings["particle_filter"] = self._particle_filter(cents, imu, camera)
            comp = comp.with_filter(filter_result, self._held(imu, span), self.config.motion.causal)
        acc = _Summary(events.width, events.height, self.config.dt_us, t0, images=False)
        acc.add(events, keep, truth, 0)
        result = self._finish(cents, timings, len(events), truth, acc, filter_result,
                              *self._estimator(state, t0, imu, camera, filter_result, span, rate),
                              span_us=span)
        _report_background(result, state)
        result.keep, result.compensation = keep, comp
        result.images = functools.partial(images, events, keep)   # a Result stays picklable
        return result

    def _repaired(self, imu):
        """The run's IMU, repaired (evstar.gyro_repair) where the run compensates with it and
        motion.repair_gyro is on."""
        m = self.config.motion
        return repaired(imu) if m.compensate != "none" and m.repair_gyro else imu

    def _particle_filter(self, centroids, imu, camera):
        """(FilterResult, seconds): the particle filter on the run's tracked frame centroids
        (its gyro-warped pass: within a frame a gyro bias b moves an event by at most
        f·b·dt/2, 0.06 px at 1 °/s, 10 ms, f 870 px; a second pass warped with the filter's
        attitude moved centroids by 0.0002 px median on the EVK4 fields,
        perf/study_pf_passes.py)."""
        from .estimation import no_star_tracks
        from .motion import ParticleFilter

        tracked = self.make_tracker().link(centroids[centroids["source"] != "pooled"])
        # stars cut by the sensor edge give centroids biased by up to ~3 px, and a trail of
        # OFF lobes or a still track (a hot pixel) is no star: leave them out
        obs = tracked[(tracked["track"] >= 0) & ~tracked["border"]
                      & ~np.isin(tracked["track"], no_star_tracks(tracked))]
        # a track joined where one ended as another began (tracking._join: a turn, two stars
        # side by side) can hold two centroids at one time: which is the star's is unknown
        _, where, count = np.unique(np.column_stack([obs["track"], obs["t"]]), axis=0,
                                    return_inverse=True, return_counts=True)
        obs = obs[count[where.ravel()] == 1]
        if not len(obs):
            raise DataError("the particle filter needs a tracked star to correct the gyro with, "
                            "and none was tracked (motion.compensate = 'imu' uses the gyro alone)")
        # a last frame's centroid can sit past the IMU's end, as events may
        imu = self._held(imu, (int(obs["t"].min()), int(obs["t"].max())))
        t = time.perf_counter()
        pf = ParticleFilter(self.config.motion.n_particles, seed=self.config.seed,
                            device=self.config.device)
        result = pf.run(imu, {"t": obs["t"], "track": obs["track"], "x": obs["x"], "y": obs["y"]},
                        camera)
        return result, time.perf_counter() - t

    def _held(self, imu, span):
        """The IMU as compensation saw it: its ends held over the recording's span."""
        from .motion import hold_ends

        return hold_ends(imu, span[0], span[1], self.config.motion.extrapolate_us)

    def _estimator(self, state, t0, imu, camera, filter_result, span, rate):
        """(linked centroids -> star positions (evstar.estimation), the motion prior): with
        the run's crossings and, when the run compensates with the IMU, the gyro's image
        velocity as the motion prior (an IMU that only came along in the file is not
        trusted with that; the tracker joins tracks with it too); span: the recording's
        (first, last) event µs, None when it has none; rate: the measured background rate
        (events/pixel/s)."""
        from . import estimation
        from .clock import on_camera_clock

        prior = estimation.velocity_prior(self.config, imu, camera, span or (), filter_result)
        e = self.config.estimate

        def highest():   # the background where it was highest: clusters must beat that
            return rate if state.background is None else state.background.highest_hz

        def positions(cents):
            lag = state.measured_lag(cents)
            crossings = state.crossings(lag)
            delay_us = state.depth_delay_us()
            moved, positions.clock_offset_us = on_camera_clock(
                self.config, prior, imu, camera, span or (), crossings, cents, lag, filter_result,
                delay_us, state.slow_decay())
            positions.report = dict(state.pixel_order(cents))   # evstar.pixel_order
            used = estimation.used_lag(e, lag)
            if used is not None:   # the pixels' lag the crossings are moved back by
                positions.report["pixel_lag"] = used.summary()
            elif e.estimator == "crossings":
                _note_unmeasured_lag(positions.report, delay_us)
            rows = estimation.estimate(cents, self.config, t0, crossings, moved, span,
                                       state.sensor, lag, highest(), state.near_events(),
                                       positions.report, state.stalls(), delay_us)
            if camera is None or e.field_min_stars == 0 or e.estimator == "mean":
                return rows
            from . import field

            return field.refine(rows, camera, e.field_min_stars,
                                estimation.largest_lag_us(e, lag))

        return positions, prior

    def _finish(self, centroids, timings, n_events, truth, acc, filter_result, estimator=None,
                prior=None, span_us=None):
        from .pooling import kept

        stats = acc.stats
        t = time.perf_counter()
        cents = self.make_tracker().link(centroids[kept(centroids, self.config)], prior)
        timings["track"] = time.perf_counter() - t
        if estimator is not None:
            t = time.perf_counter()
            cents = estimator(cents)
            timings["estimate"] = timings.get("estimate", 0.0) + time.perf_counter() - t
        metrics = {"events": n_events, "events_kept": stats["kept"],
                   "centroids": int(len(cents)),
                   "tracks": int(len(np.unique(cents["track"][cents["track"] >= 0])))}
        if span_us is not None:  # the recording's time span: throughput as x real time
            metrics["duration_s"] = (int(span_us[1]) - int(span_us[0])) / 1e6
        if getattr(estimator, "clock_offset_us", None) is not None:
            # as evstar.Imu's time_offset_us counts it: t_camera = t_imu + offset
            metrics["imu_time_offset_us"] = -estimator.clock_offset_us
        # PixelLag.summary, evstar.vibration.summary, evstar.pixel_order's notes
        for key in ("pixel_lag", "vibration", "polarity", "repeated"):
            if getattr(estimator, "report", {}).get(key):
                metrics[key] = estimator.report[key]
        if filter_result is not None and len(filter_result.bias):
            metrics["pf_final_bias_dps"] = np.degrees(filter_result.bias[-1]).tolist()
        if truth is not None:
            metrics.update(self._truth_metrics(cents, stats, truth))
        return Result(cents, metrics, dict(timings), frame_counts=acc.frame_counts(),
                      images=acc.images)

    def _truth_metrics(self, cents, stats, truth):
        from .metrics import snr_db

        s0, n0, s1, n1 = stats["signal"], stats["noise"], stats["signal_kept"], stats["noise_kept"]
        out = {"snr_before_db": snr_db(s0, n0), "snr_after_db": snr_db(s1, n1),
               "signal_retained": s1 / s0 if s0 else float("nan"),
               "noise_removed": 1 - n1 / n0 if n0 else float("nan")}
        out["snr_gain_db"] = out["snr_after_db"] - out["snr_before_db"]
        star, err = accuracy.match(cents, truth.star_position)
        out["centroid_error_px"] = accuracy.summary(err[star >= 0])
        out["centroids_matched"] = int((star >= 0).sum())
        return out

    # -- recordings larger than memory ---------------------------------------------------
    def run_file(self, path, imu=None, camera=None, truth=None, progress=True, format=None,
                 sensor_size=None):
        """Stream a file chunk by chunk (bounded memory); same results as run()."""
        from . import io

        mode = self.config.motion.compensate
        check_parts(None, imu, camera, mode)
        imu = self._repaired(imu)
        span = chunk_span_us(self.config)
        first = next(io.windows(path, span, format=format, sensor_size=sensor_size), None)
        if first is None:   # no events: as a whole run of them (nothing to hold in memory)
            rec = io.read(path, format=format, sensor_size=sensor_size)
            return self.run(rec.events, imu, camera, truth)
        check_parts(first[1], imu, camera, mode)
        if truth is not None:  # the event count is known only at the end (checked there)
            accuracy.check_truth(truth, None, first[1].width, first[1].height, first[1].t[[0]])
        t0 = int(first[1].t[0])
        rate, hot = self.calibration(first[1], t0)
        # the size the first look found (or inferred, warning once): not inferred again
        sensor_size = (first[1].width, first[1].height)

        total = io.event_count(path, format) if progress else None

        def chunks(desc):
            return _with_context(io.windows(path, span, format=format, sensor_size=sensor_size,
                                            t_origin_us=t0), self.config.dt_us, desc, progress,
                                 total)
        timings, filter_result = {}, None
        parts, offset, first_last = [], 0, [t0, t0]
        acc = _Summary(first[1].width, first[1].height, self.config.dt_us, t0)
        state = _RunState(self.config, first[1].width, first[1].height, t0, hot,
                          self._background(t0, rate))
        for events, context in chunks("evstar run"):
            keep, cents, chunk_t, _ = self._chunk(events, imu, camera, t0, rate, _warp(mode),
                                                  None, context, state)
            _add(timings, chunk_t)
            parts.append(cents)
            acc.add(events, keep, truth, offset)
            offset += len(events)
            first_last[1] = int(events.t[-1])
        if truth is not None:
            accuracy.check_truth(truth, offset, first[1].width, first[1].height, None)
        if mode == "pf":
            filter_result, timings["particle_filter"] = self._particle_filter(_cat(parts), imu, camera)
        result = self._finish(_cat(parts), timings, offset, truth, acc, filter_result,
                              *self._estimator(state, t0, imu, camera, filter_result,
                                               first_last, rate),
                              span_us=first_last)
        return _report_background(result, state)


def chunk_span_us(config):
    """µs of a streamed chunk, and of the spans a whole run gathers its crossings in (the
    same, so both gather the same): chunk_frames rounded up to whole pooled frames
    (extract.pool_frames), which must not straddle chunks (with --chunk-frames 5 and
    pool_frames 4 a real recording's streamed run found 147 centroids, the whole run 148)."""
    pool = config.extract.pool_frames
    return -(-config.chunk_frames // pool) * pool * config.dt_us


def _report_background(result, state):
    """result, its metrics["background_hz"] set where a block's background rate moved
    (evstar.background.Background.summary)."""
    moved = state.background.summary() if state.background is not None else None
    if moved:
        result.metrics["background_hz"] = moved
    return result


def _note_unmeasured_lag(report, delay_us):
    """Report (metrics' pixel_lag) and warn of a delay of the crossings' deepest levels
    behind their top (µs) that no lag file or measured lag accounts for, from
    estimation.UNMEASURED_LAG_NOTE_US: its size is in the rows' σ, not in their positions."""
    from .estimation import UNMEASURED_LAG_NOTE_US

    if delay_us < UNMEASURED_LAG_NOTE_US:
        return
    report["pixel_lag"] = {"source": "not measured", "depth_delay_ms": round(delay_us / 1e3, 2)}
    warnings.warn(EvstarWarning(
        f"the crossings' deepest levels pass {delay_us / 1e3:.2f} ms after their top (a pixel "
        f"low-pass, or a long refractory period) and this run could not measure the lag: where "
        f"no gyro speed change tells it, stars trail by up to their speed times that delay, "
        f"which their sigma holds; a lag file from `evstar calibrate` (estimate.pixel_lag_file) "
        f"or the sensor's refractory period (estimate.refractory_us) removes it"), stacklevel=4)


def _warn_lattice(t):
    """Warn where timestamps lie on a coarse lattice (events.time_lattice_us): positions are
    for the stamped times, and a stamp for the start of its step reports each star where it
    was half a step later — speed × step/2 ahead along its motion (20 °/s, 1 ms: 0.12 px,
    perf/study_time_quantization.py); with a gyro on a changing rate, the clock measurement takes
    it up (motion.measure_clock)."""
    step = time_lattice_us(t)
    if step:
        warnings.warn(EvstarWarning(
            f"the timestamps lie on a {step} µs lattice: positions are for the stamped times "
            f"(where a stamp marks the start of its {step} µs, stars are reported on average "
            f"{step / 2:g} µs of their motion ahead)"), stacklevel=3)


def _warp(mode):
    """How a run's events are warped: 'pf' as 'imu' (the filter corrects the attitude the
    run reports and the estimator's prior, not the warp within a frame: _particle_filter)."""
    return "imu" if mode == "pf" else mode


# -- helpers -----------------------------------------------------------------------------
class _RunState:
    """What a run carries chunk to chunk: the hot-pixel mask of its calibration window (their
    events are dropped before extraction) and the pixel crossings it gathers for its
    estimator, span by span of a streamed chunk's length (chunk_span_us; a crossing whose
    flanks fall in two spans is lost), the sensor's OFF/ON threshold ratio
    measured on the first span unless configured, and the
    crossings' level profiles for the lag estimate (evstar.level_lag), and the events about
    each span's frame centroids for the across step (evstar.across: 12 bytes an event, kept
    for the run), and the background's rate block by block (evstar.background). A streamed
    run's chunks are those spans, so it gathers the same crossings and events as a run in
    memory."""

    def __init__(self, config, width, height, t0_us, hot=None, background=None):
        # no hot pixel found: no mask (a pass over every event finds none on it)
        hot = hot if hot is not None and hot.any() else None
        self.config, self._crossings, self.sensor, self.hot = config, [], (width, height), hot
        self.background = background
        self._near = []
        self._stalls, self._last_us = [], None      # the readout's stalls (frames.stalls)
        self.t0_us, self.span_us = t0_us, chunk_span_us(config)
        e = config.estimate
        self.threshold_ratio = None if e.threshold_ratio == AUTO else e.threshold_ratio
        # with a refractory period: the crossings paired as without it, and their ratio
        self._plain, self._plain_ratio = [], self.threshold_ratio
        # where too few changes measure it: the calibration recording's (a bright moving
        # field, pixel_lag_file), else 1
        self.fallback_ratio = 1.0
        if self.threshold_ratio is None and e.pixel_lag_file is not None:
            from .estimation import pixel_lag

            self.fallback_ratio = pixel_lag(e.pixel_lag_file).threshold_ratio or 1.0
        self.order, self._notes = PixelOrder(), None   # evstar.pixel_order; None: unread
        self.profiles = None
        if e.estimator == "crossings" and e.measure_lag and e.pixel_lag_file is None:
            from .level_lag import LevelProfiles

            self.profiles = LevelProfiles()

    def add_chunk(self, events, kept, centroids):
        """Gather a chunk's crossings (estimator crossings) of its `kept` events (ascending
        indices) and the events near its `centroids` (evstar.across; time-ordered, as the
        extractor gives them), span by span."""
        from .across import near_centroids

        if not len(events):
            return
        f0, bounds = frame_offsets(events.t, self.span_us, self.t0_us)
        spans = list(zip(bounds[:-1], bounds[1:]))
        # the readout's stalls, found span by span: the slices a streamed run's chunks are
        starts = [stall_starts(events.t[a:b], self.config.dt_us) for a, b in spans]
        for (a, b), s in zip(spans, starts):
            if b > a:
                self._stalls.append(stalls(events.t[a:b], s, self.config.dt_us, self._last_us))
                self._last_us = int(events.t[b - 1])
        e = self.config.estimate
        with_crossings = e.estimator == "crossings"
        across = e.estimator != "mean" and e.across_kernel_px > 0
        if not (with_crossings or across):
            return
        # each span's centroids: one search, not a scan of all of them per span
        cuts = np.searchsorted(centroids["t"],
                               self.t0_us + np.arange(f0, f0 + len(bounds)) * self.span_us)
        for k, (a, b) in enumerate(spans):
            if across:
                self._near.append(near_centroids(events[a:b], centroids[cuts[k]:cuts[k + 1]],
                                                 self.hot))
            if not with_crossings:
                continue
            # a pixel's events across a stall are no passage: an ON before a 300 ms stall
            # and an OFF after it made a crossing 100 px off its star
            edges = np.r_[a, a + starts[k], b]
            for a2, b2 in zip(edges[:-1], edges[1:]):
                piece = kept[np.searchsorted(kept, a2):np.searchsorted(kept, b2)]
                self._add_crossings(events[a2:b2], piece - a2)

    def _add_crossings(self, events, mine):
        """Gather the crossings of `events` (a span, or its part between stalls) near their
        kept events `mine` (ascending indices into them)."""
        from .estimation import chunk_crossings, chunk_crossings_both

        e = self.config.estimate
        order = self.order if self.order.wanted else None
        both = e.refractory_us > 0 and self.profiles is not None     # a low-pass may show
        # the background of the span that measures the ratio (the calibration window's
        # rate): a measured ratio discounts its events in the runs
        measuring = self.threshold_ratio is None or (both and self._plain_ratio is None)
        rates = self.background.hz if measuring and self.background is not None else None
        if both:
            (crossings, r), (plain, r_plain) = chunk_crossings_both(
                events, mine, e.crossing_radius_px, e.refractory_us,
                (self._ratio(self.threshold_ratio), self._ratio(self._plain_ratio)),
                self.profiles, self.fallback_ratio, order, rates)
            if self._plain_ratio is None:
                self._plain_ratio = self.fallback_ratio if r_plain is None else r_plain
            self._plain.append(plain)
        else:
            crossings, r = chunk_crossings(
                events, mine, e.crossing_radius_px, self._ratio(self.threshold_ratio),
                with_ratio=True, refractory_us=e.refractory_us, profiles=self.profiles,
                fallback_ratio=self.fallback_ratio, order=order, background_hz=rates)
        if self.threshold_ratio is None:   # the first span's: the calibration window
            self.threshold_ratio = self.fallback_ratio if r is None else r
        self._crossings.append(crossings)

    def pixel_order(self, centroids):
        """{"polarity": note, "repeated": note} of what the order of the events near the
        stars says (evstar.pixel_order; each warned once, None where it says nothing) — and
        nothing where the linked `centroids` hold no track: a scene without stars may run
        OFF before ON (the EVT2 sample)."""
        if self._notes is None:
            tracked = bool(np.any(centroids["track"] >= 0))
            self._notes = {"polarity": self.order.reversed() if tracked else None,
                           "repeated": self.order.repeated() if tracked else None}
            for note in filter(None, self._notes.values()):
                warnings.warn(EvstarWarning(note), stacklevel=3)
        return self._notes

    @staticmethod
    def _ratio(ratio):
        """A ratio for chunk_crossings: "auto" (measured) until the first span set it."""
        return AUTO if ratio is None else ratio

    def crossings(self, lag=None):
        """The run's crossings; where the pixels' low-pass `lag` was measured (not None) and
        the run pairs levels with a refractory period, those a run told no period finds:
        behind a low-pass the refractory pairing took dark-sky positions 0.109 -> 0.192 and
        0.155 -> 0.341 px (1 Hz sinusoids, 100 µs told; fresh-37 of perf/study_accuracy.py)
        and a Cygnus EVK4 16 mm pan at 20 °/s 0.33 -> 1.89, where on fast pixels it takes
        them 0.041 -> 0.013 (the lag model holds on the plain pairs; with the plain pairs
        and the ratio the refractory levels measure, the pan was still 0.72)."""
        chosen = self._plain if lag is not None and self._plain else self._crossings
        return np.concatenate(chosen) if chosen else None

    def stalls(self):
        """(n, 2) µs of the run's readout stalls so far (frames.stalls)."""
        return np.concatenate(self._stalls) if self._stalls else np.zeros((0, 2), np.int64)

    def near_events(self):
        """(t, x, y) of the events near a centroid (across.near_centroids), hot pixels out."""
        if not self._near:
            return np.zeros(0, np.int64), np.zeros(0, np.uint16), np.zeros(0, np.uint16)
        return tuple(np.concatenate(c) for c in zip(*self._near))

    def depth_delay_us(self):
        """How much later the crossings' deepest levels pass than their top (µs; 0 where
        the run gathers no level profiles: evstar.level_lag.LevelProfiles.depth_delay_us)."""
        return 0.0 if self.profiles is None else self.profiles.depth_delay_us()

    def slow_decay(self):
        """Whether the stars' pixels relax slower than they rise (False where the run gathers
        no level profiles: evstar.level_lag.LevelProfiles.slow_decay)."""
        return self.profiles is not None and self.profiles.slow_decay()

    def measured_lag(self, centroids=None):
        """The pixels' lag measured from the crossings' level profiles (None: not measured,
        or no low-pass found), their midpoints moved for the speed changes of the tracks of
        the linked `centroids` (evstar.level_lag.speed_changes) where given."""
        if self.profiles is None:
            return None
        from .level_lag import speed_changes

        return self.profiles.lag(None if centroids is None else speed_changes(centroids))


def _with_context(windows, dt_us, desc, progress, total=None):
    """(events, context) per chunk: context = the previous chunk's events of its last dt.
    total: the recording's events where known (the bar then shows how far along it is)."""
    from tqdm import tqdm

    # disable=None: no bar where stderr is no terminal (a log)
    bar = tqdm(desc=desc, total=total, unit="ev", unit_scale=True,
               disable=None if progress else True, leave=False)
    prev = None
    for _, events in windows:
        context = None if prev is None else prev.time_window(int(events.t[0]) - dt_us, int(events.t[0]))
        yield events, context
        bar.update(len(events))
        prev = events
    bar.close()


class _Summary:
    """Counts accumulated chunk by chunk: kept/signal/noise totals, per-frame counts and,
    with `images`, per-pixel images (bounded memory: one image per sensor, one row per
    frame); `.images` is (before, after) or None."""

    def __init__(self, width, height, dt_us, t0, images=True):
        self.dt_us, self.t0 = dt_us, t0
        self.images = (np.zeros((height, width), np.int64),
                       np.zeros((height, width), np.int64)) if images else None
        self.stats, self.frames = {}, []    # frames: (first frame, {series: counts}) per chunk

    def add(self, events, keep, truth, offset):
        if self.images is not None:
            for total, part in zip(self.images, images(events, keep)):
                total += part
        series = {"before": None, "after": keep}                 # None: every event
        new = {"kept": int(np.count_nonzero(keep))}
        if truth is not None:
            if offset + len(events) > len(truth.labels):
                raise DataError(f"the truth labels {len(truth.labels):,} events but the recording "
                                f"has more: a truth file of another recording")
            sig = truth.labels[offset:offset + len(events)] >= 0
            series.update(signal_before=sig, signal_after=sig & keep, noise_before=~sig,
                          noise_after=~sig & keep)
            new.update(signal=int(sig.sum()), noise=int((~sig).sum()),
                       signal_kept=int((sig & keep).sum()), noise_kept=int((~sig & keep).sum()))
        _add(self.stats, new)
        if len(events):
            # events are time-sorted: a frame's events are one run, found by its bounds
            lo, bounds = frame_offsets(events.t, self.dt_us, self.t0)
            self.frames.append((lo, {name: _per_frame(m, bounds) for name, m in series.items()}))

    def frame_counts(self):
        if not self.frames:
            return {}
        n = max(lo + len(c["before"]) for lo, c in self.frames)
        out = {"t_s": (np.arange(n) + 0.5) * self.dt_us * 1e-6}
        for name in self.frames[0][1]:
            out[name] = np.zeros(n, np.int64)
            for lo, counts in self.frames:   # a later chunk's count of a frame replaces it
                out[name][lo:lo + len(counts[name])] = counts[name]
        return out


def _per_frame(mask, bounds):
    """The events `mask` selects (None: all) in each frame of `bounds`: a count per frame
    that holds events (a two-event file spanning 11 days has 99 M frames, two of them not
    empty; a running sum of a 5 M-event mask took 43 ms where 400 counts take 0.7)."""
    sizes = np.diff(bounds)
    if mask is None:
        return sizes
    out = np.zeros(len(sizes), np.int64)
    for j in np.flatnonzero(sizes):
        out[j] = np.count_nonzero(mask[bounds[j]:bounds[j + 1]])
    return out


def _add(acc, new):
    for k, v in new.items():
        acc[k] = acc.get(k, 0) + v


def _cat(parts):
    parts = [p for p in parts if len(p)]
    return np.concatenate(parts) if parts else np.zeros(0, CENTROID_DTYPE)
