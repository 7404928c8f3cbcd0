"""Attitude from tracked centroids: identification, then the MEKF of :mod:`.filter`.

    rows = evstar.attitude.estimate(result.centroids, camera, imu=None, rate_hz=100)

Frame by frame (the pipeline's `frame` field, else ``frame_us`` bins): while the filter has
no attitude — and at most every ``reidentify_ms`` while fewer than ``min_stars``
identified tracks are seen or confirmed tracks are unnamed — the centroids of the frame's
confirmed tracks, moved to the frame's last centroid time with their tracks' image
velocities (a fast pan would distort the pattern), are identified; a full search that
fails is retried ``lost_retry_ms`` later while the attitude is lost (0: the next frame, a
quicker first fix), ``reidentify_ms`` later while tracking (a noisy recording would spend
the solver's timeout on each frame). When no frame has identified for ``pooled_window_ms`` while
the attitude is lost (or fewer than ``min_stars`` identified tracks are seen and some
confirmed ones are unnamed) and the events are given, the
window's events pooled into one image are identified (:func:`.identify_events`, warped by
the gyro when there is an IMU; at most every max(``pooled_window_ms``, ``lost_retry_ms``)
while lost, max(``pooled_window_ms``, ``reidentify_ms``) while tracking, that wait doubling
after each failed pooled search in a row up to ``pooled_max_wait_ms``):
its stars name the tracks whose position at the fix's time is within the solver's
``match_radius_px`` of them. A fix names the stars of its tracks: every later
centroid of such a track measures that star. A fix starts a filter that has no attitude;
then each frame is one prediction (gyro, or the constant-acceleration model) to its last
centroid time and one joint update with its identified stars, and each output time
(``rate_hz``) a prediction and a row. The attitude is lost when its 1-σ exceeds
``lost_sigma_deg`` or every star is rejected ``max_misses`` frames in a row; rows stop
until the next fix. With ``smooth`` (default) an RTS pass over each filter run then
replaces every row by the smoothed attitude (filter.smooth): each row uses the centroids
after it too. docs/attitude.md ("Filter") has the model and the measurements.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import parameters as P
from ..camera import Camera
from ..errors import DataError, ParameterError, ParameterTypeError
from ..events import Events
from ..frames import run_neighbours
from ..imu import Imu
from .filter import Mekf, hat, smooth
from .output import ATTITUDE_DTYPE, rotation, rows

A = P.ATTITUDE_FILTER
ARCSEC = math.pi / 180 / 3600


def estimate(centroids, camera, imu=None, rate_hz=A["rate_hz"].default, events=None, **options):
    """ATTITUDE_DTYPE rows (evstar.attitude.output) from CENTROID_DTYPE `centroids` (fields
    t, x, y, track, sigma and, optionally, source, frame) and, optionally, the events they
    came from (for the pooled-window fallback); see :class:`AttitudeEstimator`."""
    return AttitudeEstimator(camera, imu, rate_hz=rate_hz, **options).run(centroids, events)


class AttitudeEstimator:
    """Options are the [attitude_filter] parameters (evstar.parameters) plus
    identifier: a callable (xy (n, 2) px, t_us, weight (n,) or None) -> evstar.attitude.Fix;
    default: evstar.attitude.identify with `solver` and `epoch` (weight: the centroids'
    event counts, brightest patterns first); solver: the evstar.attitude.Solver of identify
    and identify_events (default: Solver.for_camera(camera), cached per process).
    After run(): .fixes, a list of (t_us, status, stars matched) — status "pooled ..." for
    an identification of the pooled events (evstar.attitude.identify_events) — and
    .searches, (Fix, pixel positions (n, 2) of its matched stars, their times (n,), "frame"
    or "pooled") of each identification searched, verified (Fix.ok) or not."""

    def __init__(self, camera, imu=None, *, identifier=None, epoch=None, solver=None,
                 frame_us=P.GLOBAL["dt_us"].default,
                 repair_gyro=P.MOTION["repair_gyro"].default, **options):
        if camera is None:
            raise ParameterError("the attitude needs the camera's intrinsics (--camera camera.json)")
        if not isinstance(camera, Camera):
            raise ParameterTypeError(f"camera must be an evstar.Camera, got {type(camera).__name__}")
        if imu is not None and not isinstance(imu, Imu):
            raise ParameterTypeError(f"imu must be an evstar.Imu, got {type(imu).__name__}")
        if imu is not None and len(imu) < 2:
            raise DataError(f"the IMU has {len(imu)} sample(s); the attitude filter needs >= 2")
        unknown = set(options) - set(A)
        if unknown:
            raise ParameterError(f"unknown attitude option(s) {sorted(unknown)}; known: {sorted(A)}")
        self.o = {k: A.check(k, options.get(k, p.default)) for k, p in A.items()}
        self.camera, self.imu = camera, imu
        self.frame_us = P.GLOBAL.check("dt_us", frame_us, "frame_us")
        self.repair_gyro = P.MOTION.check("repair_gyro", repair_gyro, "repair_gyro")
        self.epoch, self._solver = epoch, solver
        if identifier is not None and not callable(identifier):
            raise ParameterTypeError("identifier must be a function (xy, t_us, weight=None) -> "
                                     f"Fix, got {type(identifier).__name__}")
        self.identifier = identifier or self._default_identifier
        self.fixes, self.searches = [], []

    @property
    def solver(self):
        """The given Solver, or the camera's cached one (created on first use)."""
        from .solver import Solver

        self._solver = Solver.of(self._solver, self.camera)
        return self._solver

    def _default_identifier(self, xy, t_us, weight=None):
        from .identify import identify

        return identify(xy, self.camera, t_us, epoch=self.epoch, solver=self.solver, weight=weight)

    # -- the run ----------------------------------------------------------------------------
    def run(self, centroids, events=None):
        """Attitude rows from `centroids`; `events` (evstar.Events, the recording the
        centroids came from) enable the pooled-window fallback."""
        if events is not None and not isinstance(events, Events):
            raise ParameterTypeError(f"events must be evstar.Events, got {type(events).__name__}")
        c = _delayed(_measured(centroids), self.o["centroid_delay_us"])
        self.fixes, self.searches, self._out = [], [], []
        pooled = events is not None and len(events) and self.o["pooled_window_ms"] > 0
        if not len(c) and not pooled:
            return np.zeros(0, ATTITUDE_DTYPE)
        self._events = events if pooled else None
        self._ev_t0 = int(events.t[0]) if pooled else 0
        self._pool_from, self._pooled_at = self._ev_t0, -math.inf
        self._pool_fails = 0          # failed pooled searches in a row
        # frames without centroids count too (the pipeline's frames start at the first event)
        empty = pooled and "frame" in c.dtype.names and np.all(c["frame"] >= 0)
        self._next_frame = 0
        self._gyro = None if self.imu is None else _GyroIntegral(
            _checked_imu(self.imu, c["t"], events if pooled else None, self.repair_gyro))
        self._c, self._xy_dt = c, _track_velocity(c)
        # a pooled centroid averages pool_frames frames: biased along an acceleration
        self._updates = np.ones(len(c), bool) if self.o["pooled_centroids"] or \
            "source" not in c.dtype.names else c["source"] != "pooled"
        self._z, self._sig = self._normalised(c)
        self._stars, self._misses = {}, {}          # track -> ICRS direction, rejections
        self.filt, self._t_f, self._last_id, self._retry_at = None, None, -math.inf, -math.inf
        self._last_used, self._n_used, self._bad = -math.inf, 0, 0
        step = 1e6 / self.o["rate_hz"]
        t0, t_end = (int(c["t"][0]), int(c["t"][-1])) if len(c) else (0, -1)
        n_out = int((t_end - t0) / step) + 1
        if n_out > P.MAX_FRAMES:   # one output time each: a corrupt centroid time
            raise DataError(f"the centroids span {t0} to {t_end} µs: {n_out} outputs at "
                            f"{self.o['rate_hz']:g} Hz, more than {P.MAX_FRAMES:_}")
        self._out_t = t0 + np.rint(np.arange(n_out) * step).astype(np.int64)
        self._next_out = 0
        self._chains = []      # per filter run: its nodes (updates and rows) for the smoother
        for idx in _frames(c, self.frame_us) if len(c) else []:
            t_ref = int(c["t"][idx[-1]])               # every centroid of the frame is <= t_ref
            if empty:
                self._empty_frames_until(int(c["frame"][idx[-1]]))
            self._emit_until(t_ref)
            self._maybe_identify(idx, t_ref)
            if self.filt is not None:      # after a (re)start too: the fix's prior is loose
                self._predict_to(t_ref)
                self._update(idx, t_ref)
        if empty:      # acquisition only: rows need centroids to follow (none after the last)
            self._empty_frames_until(-(-(int(events.t[-1]) + 1 - self._ev_t0) // self.frame_us))
        self._emit_until(t_end + 1)
        if not self._out:
            return np.zeros(0, ATTITUDE_DTYPE)
        if self.o["smooth"]:
            for chain in self._chains:
                self._smooth_rows(chain)
        return rows(*(np.array(col) for col in zip(*self._out)))

    def _maybe_identify(self, idx, t_ref):
        """Identify the frame when needed; a fix names its tracks' stars and (re)starts a
        filter that has no attitude."""
        t_end = self._frame_end(idx, t_ref)
        idx = idx[self._c["track"][idx] >= 0]      # confirmed tracks: noise clusters are not
        c = self._c[idx]
        tracks = c["track"]
        known = np.array([k in self._stars for k in tracks.tolist()], bool)
        lost = self.filt is None
        few = known.sum() < self.o["min_stars"]
        # lost: retry once a failed search's wait has passed; tracking: every reidentify_ms
        due = t_ref >= self._retry_at if lost else t_ref - self._last_id >= self.o["reidentify_ms"] * 1000
        if not (lost or few):
            self._pool_from = t_end       # the pooled window waits only while lost or few
        if not (lost or few or not known.all()):
            return
        if due and self._identify_frame(idx, c, t_ref, lost):
            self._pool_from = t_end
            return
        if lost or few and not known.all():    # tracking: only unnamed tracks can be named
            self._maybe_pool(t_end, t_ref, lost)

    def _empty_frames_until(self, frame):
        """The frames before `frame` that had no centroid: while the attitude is lost, their
        ends may still be due for the pooled window."""
        for k in range(self._next_frame, frame):
            t_end = self._ev_t0 + (k + 1) * self.frame_us
            self._emit_until(t_end)
            if self.filt is None:
                self._maybe_pool(t_end, t_end, True)
        self._next_frame = max(self._next_frame, frame + 1)

    def _maybe_pool(self, t_end, t_ref, lost):
        """The pooled window ending at t_end, when no frame has identified for that long."""
        window_us = int(round(self.o["pooled_window_ms"] * 1000))
        every_us = max(window_us, self.o["lost_retry_ms" if lost else "reidentify_ms"] * 1000)
        if self._pool_fails:      # failing again and again: a window without stars, back off
            every_us = max(every_us, min(every_us * 2.0 ** self._pool_fails,
                                         self.o["pooled_max_wait_ms"] * 1000))
        if (self._events is not None and t_end - self._pool_from >= window_us
                and t_end - self._pooled_at >= every_us):
            self._pooled_at = t_end
            if self._identify_pooled(t_end - window_us, t_end, t_ref, lost):
                self._pool_from, self._pool_fails = t_end, 0
            else:
                self._pool_fails += 1

    def _identify_frame(self, idx, c, t_ref, lost):
        """Identify the frame's confirmed tracks (idx, their centroids c); True for a fix."""
        tracks = c["track"]
        if len(c) < 4:                              # no pattern to search: say so, cheaply
            self.fixes.append((t_ref, "too_few_stars", 0))
            return False
        self._last_id = t_ref
        shift = np.nan_to_num(self._xy_dt[idx]) * (t_ref - c["t"])[:, None] * 1e-6
        xy = np.stack([c["x"], c["y"]], 1) + shift
        fix = self.identifier(xy, t_ref, c["n_events"] if "n_events" in c.dtype.names else None)
        self._record(fix, t_ref, "frame", xy, t_ref)
        if not fix.ok:
            if fix.status != "too_few_stars":        # a full search failed: not every frame
                wait = self.o["lost_retry_ms"] if lost else self.o["reidentify_ms"]
                self._retry_at = t_ref + wait * 1000
            return False
        self._name(fix, tracks)
        if lost:
            self._start(fix, t_ref, idx, xy)
        return True

    def _identify_pooled(self, t_start, t_stop, t_ref, lost):
        """Identify the events of [t_start, t_stop) pooled (identify_events); its stars name
        the confirmed tracks seen in the window (by their position at the fix's time), and
        it (re)starts a filter that has no attitude. True for a fix."""
        from .acquire import identify_events

        fix, found = identify_events(self._events, self.camera, t_start, t_stop, imu=self.imu,
                                     solver=self.solver, epoch=self.epoch)
        ci = self._record(fix, t_ref, "pooled", found, fix.t_us)
        if not fix.ok:
            return False
        idx, xy = self._tracks_at(t_start, t_ref, fix.t_us)
        star, track = _pairs(found[ci], xy, self.solver.settings["match_radius_px"])
        named = dataclasses.replace(fix, centroid_index=track, hip=np.asarray(fix.hip)[star],
                                    dir_icrs=np.asarray(fix.dir_icrs)[star])
        self._name(named, self._c["track"][idx])
        if lost:
            self._start(named, fix.t_us, idx, xy)
            self._t_start = t_ref       # rows say "fix" from the frame that found it
        return True

    def _record(self, fix, t_ref, kind, xy, t_us):
        """A search ("frame" or "pooled", of positions xy at t_us) in .fixes as (t_ref, its
        status, its stars) and in .searches with its matched positions; their indices."""
        self.fixes.append((t_ref, fix.status if kind == "frame" else f"{kind} {fix.status}",
                           len(fix.hip) if fix.ok else 0))
        ci = np.asarray(fix.centroid_index, int)
        self.searches.append((fix, xy[ci], np.full(len(ci), t_us), kind))
        return ci

    def _tracks_at(self, t_start, t_stop, t_us):
        """Confirmed tracks with centroids in [t_start, t_stop]: for each, the index of its
        centroid nearest t_us (n,) and its position then, moved to t_us along the track (n, 2)."""
        c = self._c
        i = np.arange(np.searchsorted(c["t"], t_start, "left"), np.searchsorted(c["t"], t_stop, "right"))
        i = i[c["track"][i] >= 0]
        i = i[np.lexsort((np.abs(c["t"][i] - t_us), c["track"][i]))]
        i = i[np.r_[True, np.diff(c["track"][i]) != 0]] if len(i) else i
        xy = np.stack([c["x"][i], c["y"][i]], 1) + np.nan_to_num(self._xy_dt[i]) * (
            (t_us - c["t"][i]) * 1e-6)[:, None]
        return i, xy

    def _name(self, fix, tracks):
        """A verified fix names the stars of its centroids' tracks."""
        for i, d in zip(np.asarray(fix.centroid_index, int), np.asarray(fix.dir_icrs, float)):
            self._stars[int(tracks[i])] = d / np.linalg.norm(d)
            self._misses[int(tracks[i])] = 0

    def _frame_end(self, idx, t_ref):
        """The end of the frame of centroids idx: from the pipeline's frame field and the
        first event's time (the pipeline's frames start there), else its last centroid."""
        c = self._c
        if self._events is None or "frame" not in c.dtype.names or c["frame"][idx[-1]] < 0:
            return t_ref
        end = self._ev_t0 + (int(c["frame"][idx[-1]]) + 1) * self.frame_us
        return int(min(max(end, t_ref), t_ref + self.frame_us))

    def _start(self, fix, t_ref, idx, xy):
        o = self.o
        R = rotation(fix.q_icrs_cam)[0]
        if self.imu is not None:
            s, priors = np.zeros(3), [o["bias_prior"]] * 3
        else:
            w = _rate_from_motion(self.camera, xy, self._xy_dt[idx], np.asarray(fix.centroid_index, int))
            prior = o["rate_prior"] if w is None else o["rate_prior_tracks"]
            s = np.r_[np.zeros(3) if w is None else w, np.zeros(3)]
            priors = [prior] * 3 + [o["accel_prior"]] * 3
        P0 = np.diag([(o["init_sigma_arcsec"] * ARCSEC) ** 2] * 3 + [p * p for p in priors])
        self.filt = Mekf(R, s, P0, "imu" if self.imu is not None else "rate",
                         gyro_noise=o["gyro_noise"], bias_walk=o["bias_walk"],
                         jerk_noise=o["jerk_noise"])
        self._t_f, self._t_start, self._bad = t_ref, t_ref, 0
        self._n_used, self._last_used = len(fix.hip), t_ref
        self._chains.append([])
        self._F = np.eye(len(P0))

    def _update(self, idx, t_ref):
        """One joint update with the frame's centroids of identified tracks."""
        tracks = self._c["track"][idx]
        keep = np.array([k in self._stars for k in tracks.tolist()], bool) & self._updates[idx]
        if not keep.any():
            return
        idx, tracks = idx[keep], tracks[keep]
        dirs = np.stack([self._stars[int(k)] for k in tracks])
        dt = (self._c["t"][idx] - t_ref) * 1e-6
        rates = None if self.imu is None else self._gyro.mean(self._c["t"][idx], t_ref) - self.filt.s
        pred = (self.filt.R.copy(), self.filt.s.copy(), self.filt.P.copy())
        used = self.filt.update(self._z[idx], dirs, self._sig[idx], dt, rates, gate=self.o["gate"])
        self._node(pred)
        for k, u in zip(tracks.tolist(), used.tolist()):
            # an identity the measurements keep contradicting is forgotten
            self._misses[k] = 0 if u else self._misses.get(k, 0) + 1
            if self._misses[k] >= self.o["max_misses"]:
                self._stars.pop(k, None)
        if used.any():
            self._n_used, self._last_used, self._bad = int(used.sum()), t_ref, 0
        else:
            self._bad += 1
        if self._bad >= self.o["max_misses"]:
            self.filt = None     # every star rejected frame after frame: the attitude is lost

    def _emit_until(self, t_stop):
        """Rows at the output times before t_stop (predictions from the last update)."""
        out_t = self._out_t
        while self._next_out < len(out_t) and out_t[self._next_out] < t_stop:
            t = int(out_t[self._next_out])
            self._next_out += 1
            if self.filt is None or t < self._t_f:
                continue
            self._predict_to(t)
            if self.filt.attitude_sigma > math.radians(self.o["lost_sigma_deg"]):
                self.filt = None  # lost: rows stop until the next fix
                continue
            gyro = self._gyro.at(t) if self.imu is not None else None
            recent = t - self._last_used < self.frame_us
            status = "fix" if t - self._t_start < self.frame_us else "tracking" if recent else "coasting"
            self._node(None, row=len(self._out))
            self._out.append((t, self.filt.R.copy(), self.filt.rate(gyro),
                              self._n_used if recent else 0, status))

    def _predict_to(self, t):
        if self.imu is None:
            self._F = self.filt.predict((t - self._t_f) * 1e-6) @ self._F
        else:
            for dt, g in self._gyro.steps(self._t_f, t):
                self._F = self.filt.predict(dt, g) @ self._F
        self._t_f = t

    def _node(self, pred, row=None):
        """Record the filter's state for the smoother: `pred` (R, s, P) before an update, or
        None at a row (no update); the transition since the previous node restarts."""
        f = self.filt
        R_pred, s_pred, P_pred = pred if pred is not None else (f.R.copy(), f.s.copy(), f.P.copy())
        self._chains[-1].append(dict(F=self._F, R_pred=R_pred, s_pred=s_pred, P_pred=P_pred,
                                     R=f.R.copy(), s=f.s.copy(), P=f.P.copy(), row=row))
        self._F = np.eye(len(f.P))

    def _smooth_rows(self, chain):
        """Rows of one filter run replaced by their smoothed attitude and rate."""
        if not chain:
            return
        for node, (R, s, _) in zip(chain, smooth(chain)):
            if node["row"] is None:
                continue
            t, _, _, n, status = self._out[node["row"]]
            rate = s[:3] if self.imu is None else self._gyro.at(t) - s
            self._out[node["row"]] = (t, R, rate, n, status)

    def _normalised(self, c):
        """Pinhole-normalised coordinates (n, 2) and their per-axis sigma (n, 2)."""
        cam = self.camera
        r = cam.unproject(np.stack([c["x"], c["y"]], 1))
        z = r[:, :2] / r[:, 2:]
        s = c["sigma"] if "sigma" in c.dtype.names else np.full(len(c), np.nan)
        s = np.where(np.isfinite(s), s, self.o["sigma_px"])
        s = np.maximum(s, self.o["sigma_floor_px"]) * self.o["sigma_scale"]
        return z, np.stack([s / cam.fx, s / cam.fy], 1)


# -- helpers ------------------------------------------------------------------------------------
def _measured(centroids):
    """Measured rows (a smoother's coasted rows are predictions, not data), time-sorted."""
    names = getattr(getattr(centroids, "dtype", None), "names", None) or ()
    missing = [f for f in ("t", "x", "y", "track") if f not in names]
    if missing:
        raise ParameterTypeError(f"centroids must be a structured array with fields t, x, y, track "
                                 f"(CENTROID_DTYPE); missing {missing}")
    c = _numeric_fields(centroids)
    c = c[c["source"] != "coasted"] if "source" in names else c
    c = c[np.isfinite(c["x"]) & np.isfinite(c["y"])]
    return c[np.argsort(c["t"], kind="stable")]


def _numeric_fields(centroids):
    """A copy of `centroids` whose t and track are int64 and x, y (and sigma, frame where
    present) numeric: a table read by hand (floats with NaN, strings) fails here with the
    field and value named, not deep in the filter."""
    from ..events import T_LIMIT_US

    names = centroids.dtype.names
    kinds = {"t": "i", "track": "i", "frame": "i", "x": "f", "y": "f", "sigma": "f"}
    cols = {}
    for name, kind in kinds.items():
        if name not in names:
            continue
        col = np.asarray(centroids[name])
        if col.dtype.kind not in "biuf":
            raise DataError(f"centroids field '{name}' must hold numbers, got dtype {col.dtype}")
        if kind == "i" and col.dtype.kind == "f":
            bad = ~np.isfinite(col) | (col != np.round(col)) if len(col) else np.zeros(0, bool)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise DataError(f"centroids field '{name}' = {col[i].item()!r} at row {i} is not a whole "
                                f"number")
        if name == "t" and len(col) and np.any(np.abs(col) > T_LIMIT_US):
            i = int(np.flatnonzero(np.abs(col) > T_LIMIT_US)[0])
            raise DataError(f"centroids field 't' = {col[i].item()!r} at row {i} is outside the valid "
                            f"range ±{T_LIMIT_US} µs")
        cols[name] = col.astype(np.int64 if kind == "i" else np.float64)
    dtype = [(n, cols[n].dtype if n in cols else centroids.dtype[n]) for n in names]
    out = np.empty(len(centroids), dtype)
    for n in names:
        out[n] = cols[n] if n in cols else centroids[n]
    return out


def _delayed(c, delay_us):
    """Centroids with their times moved to when their positions were the star's."""
    if delay_us:
        c = c.copy()
        c["t"] += int(round(delay_us))
    return c


def _track_velocity(c):
    """Image velocity (px/s) of each centroid from its track's neighbours (NaN when the
    centroid has none, e.g. unconfirmed: track −1)."""
    v = np.full((len(c), 2), np.nan)
    order = np.lexsort((c["t"], c["track"]))
    tr, t = c["track"][order], c["t"][order].astype(float)
    xy = np.stack([c["x"], c["y"]], 1)[order]
    a, b = run_neighbours(tr)
    i = np.arange(len(c))
    a, b = np.where(tr >= 0, a, i), np.where(tr >= 0, b, i)     # unconfirmed: none
    dt = (t[b] - t[a]) * 1e-6
    ok = dt > 0
    v[order[ok]] = (xy[b[ok]] - xy[a[ok]]) / dt[ok, None]
    return v


def _rate_from_motion(camera, xy, xy_dt, matched):
    """Body rate (rad/s) by least squares from the image velocities of the identified
    centroids: a fixed star's normalised coordinates move as ż = ∂π/∂v · [v]× ω. None
    with fewer than two identified centroids whose track gives a velocity."""
    good = matched[np.all(np.isfinite(xy_dt[matched]), axis=1)]
    if len(good) < 2:
        return None
    lhs, rhs = [], []
    for i in good:
        x, y = (xy[i, 0] - camera.cx) / camera.fx, (xy[i, 1] - camera.cy) / camera.fy
        D = np.array([[1.0, 0.0, -x], [0.0, 1.0, -y]])
        lhs.append(D @ hat(np.array([x, y, 1.0])))
        rhs.append(xy_dt[i] / [camera.fx, camera.fy])
    return np.linalg.lstsq(np.vstack(lhs), np.concatenate(rhs), rcond=None)[0]


def _frames(c, frame_us):
    """Index arrays of the centroids of each frame (the pipeline's `frame` field, else
    frame_us bins from the first centroid), in time order."""
    if "frame" in c.dtype.names and np.all(c["frame"] >= 0):
        key = c["frame"]
    else:
        key = (c["t"] - c["t"][0]) // frame_us
    order = np.lexsort((c["t"], key))
    cuts = np.flatnonzero(np.diff(key[order])) + 1
    groups = np.split(order, cuts)
    return sorted(groups, key=lambda g: c["t"][g[-1]])


def _checked_imu(imu, t_us, events=None, repair=True):
    """The IMU repaired (evstar.gyro_repair, where `repair`: motion.repair_gyro) and held
    over the span of the centroid times `t_us` (and of `events`, where the pooled search
    reads them) as the pipeline's compensation holds it, or DataError: an IMU that does not
    reach the data drove the filter with its end samples' rate for the whole run (an IMU
    10 s late: half the true rate, the attitude 0.4° off, no error)."""
    from ..gyro_repair import repaired
    from ..motion.imu_integration import check_coverage, hold_ends

    imu = repaired(imu) if repair else imu
    ends = [float(np.min(t_us)), float(np.max(t_us))] if len(t_us) else []
    if events is not None and len(events):
        ends += [float(events.t[0]), float(events.t[-1])]
    if not ends:
        return imu
    t0, t1 = min(ends), max(ends)
    held = hold_ends(imu, t0, t1, P.MOTION["extrapolate_us"].default)
    check_coverage(held, t0, t1, what="the centroids")    # finite, strictly increasing
    return held


class _GyroIntegral:
    """The gyro (camera frame and clock) as a piecewise-linear rate: its value, its mean
    over an interval (from the exact integral) and the pieces between samples."""

    def __init__(self, imu):
        from ..motion.imu_integration import gyro_at

        self.t = imu.t_cam.astype(float)
        self.g = imu.gyro_cam
        self._at = gyro_at(imu)
        dt = np.diff(self.t) * 1e-6
        self.G = np.r_[np.zeros((1, 3)), np.cumsum(0.5 * (self.g[1:] + self.g[:-1]) * dt[:, None], 0)]

    def at(self, t):
        """Readings (n, 3) at times (n,), or (3,) at one time (held beyond the ends)."""
        out = self._at(np.atleast_1d(np.asarray(t, float)))
        return out[0] if np.ndim(t) == 0 else out

    def integral(self, t):
        """∫ gyro dt (rad) from the first sample to each t (n,)."""
        t = np.asarray(t, float)
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 1)
        h = (t - self.t[k]) * 1e-6
        return self.G[k] + 0.5 * (self.g[k] + self.at(t)) * h[:, None]

    def mean(self, t, t_ref):
        """Mean reading over [t, t_ref] for each t (n,) (the reading at t_ref where equal)."""
        t = np.asarray(t, float)
        span = (t_ref - t) * 1e-6
        ok = span != 0
        out = np.tile(self.at(float(t_ref)), (len(t), 1))
        if ok.any():
            ref = self.integral(np.full(int(ok.sum()), float(t_ref)))
            out[ok] = (ref - self.integral(t[ok])) / span[ok, None]
        return out

    def steps(self, ta, tb):
        """(dt s, mean reading) of each piece of [ta, tb] between samples."""
        i0, i1 = np.searchsorted(self.t, [ta, tb], side="right")
        pts = np.r_[ta, self.t[i0:i1], tb].astype(float)
        pts = pts[np.r_[True, np.diff(pts) > 0]]
        if len(pts) < 2:
            return []
        gp = self.at(pts)
        return list(zip((np.diff(pts) * 1e-6).tolist(), 0.5 * (gp[1:] + gp[:-1])))


def _pairs(a, b, radius):
    """One-to-one pairs (ia, ib) of points a (n, 2) and b (m, 2) within `radius`, nearest
    first."""
    if not len(a) or not len(b):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    d = np.hypot(*(a[:, None] - b[None]).transpose(2, 0, 1))
    ia, ib = np.nonzero(d <= radius)
    used_a, used_b, pa, pb = set(), set(), [], []
    for k in np.argsort(d[ia, ib], kind="stable"):
        if ia[k] not in used_a and ib[k] not in used_b:
            used_a.add(ia[k]), used_b.add(ib[k])
            pa.append(ia[k]), pb.append(ib[k])
    return np.array(pa, np.int64), np.array(pb, np.int64)
