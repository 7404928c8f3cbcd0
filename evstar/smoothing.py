"""Multi-frame position estimates along tracks: a Kalman filter + RTS smoother per track.

One frame's centroid of a star with N events cannot beat σ_PSF/√N; a track's centroids,
pooled by a motion model, can. Per confirmed track (``track >= 0``) this runs, in
continuous time (the centroids' own timestamps, irregular where frames are missed), a
constant-velocity model per image axis — state (position, velocity), process noise white
acceleration of spectral density q (px²/s³) — through filterpy's KalmanFilter and its
Rauch–Tung–Striebel smoother.

* q is estimated per track from the data (``process_noise="auto"``): the value on a log
  grid that maximises the likelihood of the track's innovation sequence (the filter is run
  for every grid value at once). A constant-rate slew is straight in the image (q ≈ 0,
  floored at ``process_noise_min``); a turnaround raises q and the smoother follows it
  more loosely.
  Constant-velocity rather than constant-acceleration: the paper's slews are constant-rate
  or sinusoidal, and a sinusoid's acceleration is not constant either — what it needs is
  the velocity prior below.
* An optional velocity prior, a callable ``(t_us, x, y) -> (n, 2)`` image velocity px/s
  (e.g. :func:`imu_velocity_prior` from gyro rates), is the model's control input: the
  filter runs on the positions minus the prior's integrated displacement, so its velocity
  state is only the prior's error (a gyro bias) and turnarounds cost nothing.
* A centroid farther than ``outlier_sigma`` × its σ from the smoothed track (half of a
  star the extractor cut in two, a noise cluster the tracker took) is flagged ``outlier``
  and the track refitted without it; its frame keeps the refitted position.
* Frames of a track's life without a centroid are "coasted": the smoothed position at the
  frame's mid-time, flagged, when it lies within ``coast_ms`` of a measurement on either
  side; farther from both, nothing is reported for that frame.

Output rows (:data:`ESTIMATE_DTYPE`) are sorted by track, then time.
"""
from __future__ import annotations

import numpy as np
from filterpy.kalman import KalmanFilter

from .parameters import AUTO, ESTIMATE
from .errors import ParameterError

ESTIMATE_DTYPE = np.dtype([
    ("t", "<i8"), ("frame", "<i8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
    ("vx", "<f8"), ("vy", "<f8"), ("sigma_x", "<f8"), ("sigma_y", "<f8"),
    ("n_events", "<i4"), ("centroid", "<i8"), ("coasted", "?"), ("outlier", "?"),
    ("source", "<U8")])
MEASURED, COASTED = "measured", "coasted"
_Q_GRID = np.r_[0.0, np.logspace(-2, 9, 45)]   # px²/s³ candidates for the q estimate
_V0_VAR = 1e8                          # (px/s)²: the first velocity is unknown
_DIFFUSE = 1e8                         # px², (px/s)²: the filter's prior knows nothing
_OUTLIER_PASSES = 4                    # fits per track at most (outliers dropped between)
_IGNORED_SIGMA = 1e4                   # px: the σ that makes an outlier weightless
_HUBER_C = 3.0                         # σ: innovations beyond it count linearly in the q fit
_PRIOR_STEP_S = 1e-3                   # s: the velocity prior is integrated on this grid
MIN_CROSSINGS = 8                      # a track's crossings needed to refit it with them
MIN_CROSSING_SPAN_PX = 3.0             # ... spread at least this far along the motion
LAG_MAX_SE_S = 0.2e-3                  # s: a pixel lag fitted less precisely is not applied


class TrackSmoother:
    """Smoothed positions per frame of every confirmed track; see the module docstring.

    dt_us: the pseudo-frame length of the centroids' frames (coasted rows sit at their
    mid-times). Parameters are those of ``evstar.parameters.ESTIMATE``.
    """

    def __init__(self, dt_us=10_000, *, process_noise=AUTO, process_noise_min=1.0,
                 coast_ms=30.0, sigma_floor_px=0.02, psf_sigma_px=None, min_events=8,
                 outlier_sigma=4.0, coast_ends=ESTIMATE["coast_ends"].default):
        from .frames import check_dt

        self.dt_us = check_dt(dt_us)
        self.process_noise = ESTIMATE.check("process_noise", process_noise)
        self.process_noise_min = ESTIMATE.check("process_noise_min", process_noise_min)
        self.coast_ms = ESTIMATE.check("coast_ms", coast_ms)
        self.sigma_floor_px = ESTIMATE.check("sigma_floor_px", sigma_floor_px)
        self.psf_sigma_px = ESTIMATE.check("psf_sigma_px", psf_sigma_px)
        self.min_events = ESTIMATE.check("min_events", min_events)
        self.outlier_sigma = ESTIMATE.check("outlier_sigma", outlier_sigma)
        self.coast_ends = ESTIMATE.check("coast_ends", coast_ends)

    # -- measurement noise --------------------------------------------------------------
    def measurement_sigma(self, centroids):
        """Per-axis σ (px) of each centroid: psf_sigma_px/√N when given, else spread/√(2N)
        (spread is the 2-D RMS radius, √2 × the per-axis σ), where a centroid of fewer than
        ``min_events`` events takes its track's median spread (a spread from a handful of
        events is itself noise); floored at ``sigma_floor_px``."""
        n = np.maximum(centroids["n_events"].astype(float), 1.0)
        if self.psf_sigma_px is not None:
            return np.maximum(self.psf_sigma_px / np.sqrt(n), self.sigma_floor_px)
        spread = centroids["spread"].astype(float).copy()
        few = centroids["n_events"] < self.min_events
        for tr in np.unique(centroids["track"][few]):
            rows = centroids["track"] == tr
            rich = rows & ~few
            pool = centroids["spread"][rich if rich.any() else rows]
            spread[rows & few] = np.median(pool)
        return np.maximum(spread / np.sqrt(2 * n), self.sigma_floor_px)

    # -- all tracks ---------------------------------------------------------------------
    def smooth(self, centroids, t0_us=None, velocity_prior=None, sigma=None):
        """ESTIMATE_DTYPE rows for every confirmed track of `centroids` (CENTROID_DTYPE).

        t0_us: the frame origin (frame k spans [t0 + k·dt, t0 + (k+1)·dt)); default: the
        latest origin consistent with the centroids' times. velocity_prior: a callable
        (t_us, x, y) -> (n, 2) px/s, or None. sigma: per-centroid per-axis σ in px (default
        :meth:`measurement_sigma`).
        """
        sig = self.measurement_sigma(centroids) if sigma is None else _check_sigma(sigma, centroids)
        if t0_us is None and len(centroids):
            t0_us = int((centroids["t"] - centroids["frame"] * self.dt_us).min())
        parts = []
        for tr in np.unique(centroids["track"][centroids["track"] >= 0]):
            rows = np.flatnonzero(centroids["track"] == tr)
            rows = rows[np.argsort(centroids["t"][rows], kind="stable")]
            parts.append(self.smooth_track(centroids[rows], sig[rows], t0_us, velocity_prior, rows))
        return np.concatenate(parts) if parts else np.zeros(0, ESTIMATE_DTYPE)

    # -- one track ----------------------------------------------------------------------
    def smooth_track(self, cents, sigma, t0_us, velocity_prior=None, index=None):
        """Rows for one track's time-sorted centroids (see :meth:`smooth`)."""
        t_meas = cents["t"].astype(np.int64)
        frames = cents["frame"].astype(np.int64)
        coast_f = self._coast_frames(t_meas, frames, t0_us)
        t_coast = t0_us + coast_f * self.dt_us + self.dt_us // 2
        t_all = np.concatenate([t_meas, t_coast])
        order = np.argsort(t_all, kind="stable")
        t_all = t_all[order]
        measured = order < len(t_meas)
        z = np.column_stack([cents["x"], cents["y"]]).astype(float)
        shift = _prior_displacement(velocity_prior, t_all, t_meas, z)
        resid = z - shift[measured]
        ts = (t_all - t_all[0]) * 1e-6
        x, P, outlier = self._fit(ts, resid, sigma, measured)
        out = np.zeros(len(t_all), ESTIMATE_DTYPE)
        out["t"], out["track"] = t_all, cents["track"][0]
        out["frame"] = np.concatenate([frames, coast_f])[order]
        out["x"], out["y"] = x[:, 0] + shift[:, 0], x[:, 2] + shift[:, 1]
        v_prior = _prior_velocity(velocity_prior, t_all, out["x"], out["y"])
        out["vx"], out["vy"] = x[:, 1] + v_prior[:, 0], x[:, 3] + v_prior[:, 1]
        # rounding can leave a variance a hair below zero
        out["sigma_x"] = np.sqrt(np.maximum(P[:, 0, 0], 0.0))
        out["sigma_y"] = np.sqrt(np.maximum(P[:, 2, 2], 0.0))
        idx = np.arange(len(cents)) if index is None else np.asarray(index)
        out["centroid"] = np.concatenate([idx, np.full(len(coast_f), -1)])[order]
        out["n_events"] = np.concatenate([cents["n_events"], np.zeros(len(coast_f), int)])[order]
        out["coasted"] = ~measured
        out["outlier"][measured] = outlier
        out["source"] = np.where(measured, MEASURED, COASTED)
        return out

    def refine(self, est, centroids, crossings, velocity_prior=None, sigma=None, along_weight=0.1,
               t0_us=None, pixel_lag=None):
        """`est` (from :meth:`smooth`) refitted track by track with pixel crossings
        (evstar.crossings.pixel_crossings of the events near the stars) as along-track
        measurements; see :func:`along_track_fit`. Frames of a track's life that had no row
        get one where crossings fall in them (source "measured": the star was seen passing
        pixels) or within coast_ms of a crossing (coasted). A `pixel_lag`
        (evstar.calibration.PixelLag) moves each crossing back by its pixels' calibrated lag
        first. Returns (rows, crossings used)."""
        from .crossings import along_track

        sig = self.measurement_sigma(centroids) if sigma is None else _check_sigma(sigma, centroids)
        got, owner, u, resid = along_track(crossings, est)
        q_all = np.column_stack([crossings["x"], crossings["y"]]).astype(float)
        parts, used = [], 0
        if t0_us is None and len(est):
            t0_us = int((est["t"] - est["frame"] * self.dt_us).min())
        for tid in np.unique(est["track"]):
            mine = owner == tid
            t_c = crossings["t"][got[mine]]
            if pixel_lag is not None and len(t_c):   # when the star really passed each pixel
                t_c, resid[mine] = _lag_corrected(t_c, crossings["pairs"][got[mine]], resid[mine],
                                                  est[est["track"] == tid], pixel_lag)
            rows = self._fill_frames(est[est["track"] == tid], t_c, t0_us)
            meas = rows["centroid"][~rows["coasted"]]
            s_cent = np.where(rows["outlier"][~rows["coasted"]], _IGNORED_SIGMA, sig[meas])
            fit, n = along_track_fit(
                rows, np.column_stack([centroids["x"][meas], centroids["y"][meas]]), s_cent,
                (t_c, q_all[got[mine]], u[mine], resid[mine]),
                velocity_prior,
                along_weight=along_weight, sigma_floor_px=self.sigma_floor_px,
                process_noise_min=self.process_noise_min)
            # rows added for crossings stand only when the crossings were used
            parts.append(fit if n else est[est["track"] == tid])
            used += n
        out = np.concatenate(parts) if parts else est
        return out[np.lexsort((out["t"], out["track"]))], used

    def _fill_frames(self, rows, t_cross, t0_us):
        """`rows` of one track plus a row for each frame of its life without one that holds a
        crossing (measured) or lies within coast_ms of one (coasted); positions and velocities
        interpolated (the refit replaces them)."""
        if not len(t_cross):
            return rows
        f_cross = np.floor((np.asarray(t_cross) - t0_us) / self.dt_us).astype(np.int64)
        rows = rows.copy()
        rows["source"][rows["coasted"] & np.isin(rows["frame"], f_cross)] = MEASURED
        life = np.arange(rows["frame"].min(), rows["frame"].max() + 1)
        empty = life[~np.isin(life, rows["frame"])]
        if not len(empty):
            return rows
        mid = t0_us + empty * self.dt_us + self.dt_us // 2
        seen = np.isin(empty, f_cross)
        keep = seen | _near_any(mid, np.sort(t_cross), self.coast_ms * 1000.0)
        new = np.zeros(int(keep.sum()), rows.dtype)
        new["t"], new["frame"], new["track"] = mid[keep], empty[keep], rows["track"][0]
        for f in ("x", "y", "vx", "vy", "sigma_x", "sigma_y"):
            new[f] = np.interp(new["t"], rows["t"], rows[f])
        new["centroid"], new["coasted"] = -1, True
        new["source"] = np.where(seen[keep], MEASURED, COASTED)
        out = np.concatenate([rows, new])
        return out[np.argsort(out["t"], kind="stable")]

    def _fit(self, ts, resid, sigma, measured):
        """Smoothed states and covariances, and the outlier flag per measurement: a centroid
        whose standardised residual from the smoothed track exceeds outlier_sigma (either axis)
        is dropped and the track fitted again (a star cut in two by the extractor, a noise
        cluster taken by the track), at most _OUTLIER_PASSES times."""
        outlier = np.zeros(len(resid), bool)
        for _ in range(_OUTLIER_PASSES):
            sig = np.where(outlier, _IGNORED_SIGMA, sigma)
            keep = ~outlier
            q = self._q(ts[measured][keep], resid[keep], sigma[keep])
            x, P = _kalman_rts(ts, resid, sig, measured, q)
            if self.outlier_sigma is None:
                break
            # standardised residuals: the residual from the smoothed track over its own σ
            # (R − P: a point the fit follows closely has a small residual and a small σ)
            var = sigma[:, None] ** 2 - P[measured][:, [0, 2], [0, 2]]
            d = resid - x[measured][:, [0, 2]]
            res = (np.abs(d) / np.sqrt(np.maximum(var, 1e-6 * sigma[:, None] ** 2))).max(1)
            new = (res > self.outlier_sigma) & ~outlier
            # never more than a quarter of a track: beyond that the model, not the data, is off
            if not new.any() or (outlier | new).sum() > len(resid) // 4:
                break
            outlier |= new
        return x, P, outlier

    def _coast_frames(self, t_meas, frames, t0_us):
        """Frames without a centroid whose mid-time is within coast_ms of a centroid of the
        track (the previous or the next one): gaps, and the frames just before its first and
        after its last centroid (a star fading out keeps its predicted position, flagged;
        frames before 0 are never reported, and the caller drops what lies past the
        recording or outside the sensor)."""
        limit = self.coast_ms * 1000.0
        k = int(limit // self.dt_us) + 1 if self.coast_ends else 0
        life = np.arange(max(frames.min() - k, 0), frames.max() + k + 1)
        empty = life[~np.isin(life, frames)]
        if not len(empty):
            return empty
        mid = t0_us + empty * self.dt_us + self.dt_us // 2
        return empty[_near_any(mid, t_meas, limit)]

    def _q(self, ts, resid, sigma):
        if self.process_noise != AUTO:
            return float(self.process_noise)
        return max(estimate_process_noise(ts, resid, sigma), self.process_noise_min)


def _near_any(t, times, limit):
    """Per t: is one of the sorted `times` within `limit` of it?"""
    i = np.searchsorted(times, t)
    before = np.where(i > 0, t - times[np.maximum(i - 1, 0)], np.inf)
    after = np.where(i < len(times), times[np.minimum(i, len(times) - 1)] - t, np.inf)
    return (before <= limit) | (after <= limit)


def estimate_process_noise(ts, z, sigma):
    """White-acceleration spectral density q (px²/s³) of one track by maximum likelihood of
    its innovation sequence: positions z (n, 2) at times ts (s) with per-axis σ (n,), the
    constant-velocity filter run for every q of a log grid at once (both axes share q).
    0 when the track is too short or no q beats a straight line."""
    if len(ts) < 4:
        return 0.0
    ll = _innovation_loglik(np.asarray(ts, float), np.asarray(z, float), np.asarray(sigma, float))
    return float(_Q_GRID[int(np.argmax(ll))])


def _innovation_loglik(ts, z, sigma):
    """Log-likelihood (per q of _Q_GRID) of the innovations of a per-axis CV filter; the
    first two steps, which only set the initial position and velocity, are left out."""
    q = _Q_GRID[:, None]
    shape = (len(_Q_GRID), 2)
    p, v = np.broadcast_to(z[0], shape).copy(), np.zeros(shape)
    p00, p01, p11 = np.full(shape, sigma[0] ** 2), np.zeros(shape), np.full(shape, _V0_VAR)
    ll = np.zeros(shape)
    for k in range(1, len(ts)):
        h = ts[k] - ts[k - 1]
        p = p + h * v
        p00 = p00 + 2 * h * p01 + h * h * p11 + q * h**3 / 3
        p01 = p01 + h * p11 + q * h * h / 2
        p11 = p11 + q * h
        s = p00 + sigma[k] ** 2
        y = z[k] - p
        if k >= 2:
            ll -= 0.5 * np.log(s) + _huber(y * y / s)
        k0, k1 = p00 / s, p01 / s
        p, v = p + k0 * y, v + k1 * y
        p11 = p11 - k1 * p01
        p00, p01 = (1 - k0) * p00, (1 - k0) * p01
    return ll.sum(1)


def _huber(u):
    """−log-likelihood of a squared normalised innovation u, Gaussian up to _HUBER_C σ and
    linear beyond it, so one jump (a cut star, a stray cluster) does not decide q."""
    return np.where(u <= _HUBER_C**2, u / 2, _HUBER_C * np.sqrt(u) - _HUBER_C**2 / 2)


def _kalman_rts(ts, z, sigma, measured, q):
    """Smoothed states (n, 4) = (x, vx, y, vy) and covariances (n, 4, 4) at times ts (s);
    z, sigma: the measured steps' positions and per-axis σ (or (m, 2, 2) covariances)."""
    n = len(ts)
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    # a diffuse start about the first centroid: the first update brings it in (once)
    kf.x = np.array([z[0, 0], 0.0, z[0, 1], 0.0])
    kf.P = np.eye(4) * _DIFFUSE
    h = np.r_[0.0, np.diff(ts)]
    Fs = np.tile(np.eye(4), (n, 1, 1))
    Fs[:, 0, 1] = Fs[:, 2, 3] = h
    block = q * np.stack([np.stack([h**3 / 3, h**2 / 2], -1), np.stack([h**2 / 2, h], -1)], -2)
    Qs = np.zeros((n, 4, 4))
    Qs[:, :2, :2] = Qs[:, 2:, 2:] = block
    zs = [None] * n
    Rs = [None] * n
    for k, i in enumerate(np.flatnonzero(measured)):
        zs[i] = z[k]
        Rs[i] = sigma[k] if np.ndim(sigma[k]) == 2 else np.eye(2) * sigma[k] ** 2
    Rs = [kf.R if r is None else r for r in Rs]
    mu, cov, _, _ = kf.batch_filter(zs, Fs=list(Fs), Qs=list(Qs), Rs=Rs)
    x, P, _, _ = kf.rts_smoother(mu, cov, Fs=list(Fs), Qs=list(Qs))
    return x, P


def along_track_fit(est, z_cent, sigma, crossings, velocity_prior=None, along_weight=0.1,
                    gate_sigma=4.0, sigma_floor_px=0.01, process_noise_min=1.0, pool_us=10_000):
    """Refit one track's smoothed rows `est` with crossing times as along-track measurements.

    A crossing says the star's centre passed pixel q at time t: a measurement of the position
    along the motion u only, z = q with covariance σ_a²·uuᵀ + (huge)·nnᵀ. The centroids
    (z_cent, σ: those of est's measured rows) keep their cross-track σ; along the motion
    their σ is divided by `along_weight` (a per-frame mean of a moving star's events is biased
    along the motion by its ON/OFF lobes and the pixels' lag; where no crossing is near, the
    centroids still carry the track). σ_a is the robust spread (1.4826 MAD) of the crossings'
    residuals from `est`; crossings beyond `gate_sigma` σ_a of their median are dropped.
    crossings: (t µs, q (n, 2), u (n, 2), residual along u from the track (n,), as
    evstar.crossings.along_track gives them). The crossings of each `pool_us` are pooled into
    one measurement (the filter's cost is per step). Returns new rows (est's times, frames
    and flags) and the number of crossings used.
    """
    t_c, q, u, r = crossings
    # too few crossings, or all within a pixel or two along the motion, do not pin the
    # track's velocity: the centroids alone then (a short or nearly static track)
    along = (q * u).sum(1) if len(t_c) else np.zeros(0)
    if len(t_c) < MIN_CROSSINGS or np.ptp(along) < MIN_CROSSING_SPAN_PX:
        return est, 0
    med = np.median(r)
    s_a = max(1.4826 * np.median(np.abs(r - med)), sigma_floor_px)
    ok = np.abs(r - med) <= gate_sigma * s_a
    t_c, q, u = t_c[ok], q[ok], u[ok]
    if velocity_prior is not None:  # IMU-known changes of speed reveal the pixels' lag
        t_c = t_c - 1e6 * pixel_lag_s(t_c, q, u, velocity_prior)
    t_c, q, u, s_c = _pool_crossings(t_c, q, u, est, s_a, pool_us)
    t_c = np.round(t_c).astype(np.int64)
    measured = ~est["coasted"]
    v = np.column_stack([est["vx"][measured], est["vy"][measured]])
    u_cent = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-9)
    # every row: est's (measured or coasted), then the crossings; sorted by time together
    n_est, n = len(est), len(est) + len(t_c)
    t_all = np.concatenate([est["t"].astype(np.int64), t_c])
    is_meas = np.concatenate([measured, np.ones(len(t_c), bool)])
    is_cent = np.concatenate([measured, np.zeros(len(t_c), bool)])
    z = np.zeros((n, 2))
    z[is_meas] = np.vstack([z_cent, q])
    R = np.tile(np.eye(2), (n, 1, 1))
    R[is_meas] = np.concatenate([_covariances(u_cent, sigma / along_weight, sigma),
                                 _covariances(u, s_c, np.full(len(t_c), _IGNORED_SIGMA))])
    sig = np.zeros(n)
    sig[is_cent] = sigma
    order = np.argsort(t_all, kind="stable")
    t_s, m_s, c_s = t_all[order], is_meas[order], is_cent[order]
    z_meas = z[order][m_s]
    shift = _prior_displacement(velocity_prior, t_s, t_s[m_s], z_meas)
    resid = z_meas - shift[m_s]
    ts = (t_s - t_s[0]) * 1e-6
    cent = c_s[m_s]
    q_track = estimate_process_noise(ts[c_s], resid[cent], sig[order][c_s])
    x, P = _kalman_rts(ts, resid, R[order][m_s], m_s, max(q_track, process_noise_min))
    back = np.empty(n, np.int64)
    back[order] = np.arange(n)
    back = back[:n_est]                               # est's rows in the sorted order
    out = est.copy()
    out["x"], out["y"] = x[back, 0] + shift[back, 0], x[back, 2] + shift[back, 1]
    v_prior = _prior_velocity(velocity_prior, out["t"], out["x"], out["y"])
    out["vx"], out["vy"] = x[back, 1] + v_prior[:, 0], x[back, 3] + v_prior[:, 1]
    out["sigma_x"] = np.sqrt(np.maximum(P[back, 0, 0], 0.0))   # rounding can make it -0
    out["sigma_y"] = np.sqrt(np.maximum(P[back, 2, 2], 0.0))
    return out, int(ok.sum())


def pixel_lag_s(t_us, q, u, velocity_prior, max_se_s=LAG_MAX_SE_S):
    """The time τ by which a track's crossings trail the star (a pixel low-pass delays the
    intensity peak by ~1/(2π f_c)), fitted to the crossings with the IMU's image motion:
    along the motion u, pixel q is passed at t − τ, so u·q = u·(s0 + D(t) + b·t) − τ·u·v(t)
    with D, v the prior's displacement and velocity and s0, b (a gyro bias) free. τ is told
    apart from s0 and b only when the speed changes (a sinusoidal slew, not a constant rate):
    0 when its standard error exceeds `max_se_s`, or too few crossings. Robust: three passes
    dropping residuals beyond 5 MAD."""
    if len(t_us) < MIN_CROSSINGS:
        return 0.0
    order = np.argsort(t_us, kind="stable")
    t, q, u = np.asarray(t_us, float)[order], q[order], u[order]
    disp = _prior_displacement(velocity_prior, t, t, q)
    v = _prior_velocity(velocity_prior, t, q[:, 0], q[:, 1])
    ts = (t - t[0]) * 1e-6
    A = np.column_stack([u[:, 0], u[:, 1], u[:, 0] * ts, u[:, 1] * ts, -(u * v).sum(1)])
    y = (u * (q - disp)).sum(1)
    for _ in range(3):
        sol, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ sol
        keep = np.abs(r) <= 5 * 1.4826 * np.median(np.abs(r)) + 1e-9
        if keep.sum() < MIN_CROSSINGS:
            return 0.0
        A, y = A[keep], y[keep]
    sol, *_ = np.linalg.lstsq(A, y, rcond=None)
    s2 = float(((y - A @ sol) ** 2).sum()) / max(len(y) - A.shape[1], 1)
    # τ's own information: its regressor less what the offset and drift columns explain
    # (nothing left at a constant speed: τ is then a position offset, not a lag)
    other, *_ = np.linalg.lstsq(A[:, :4], A[:, 4], rcond=None)
    info = float(((A[:, 4] - A[:, :4] @ other) ** 2).sum())
    if info <= 1e-9 * float((A[:, 4] ** 2).sum()):
        return 0.0
    return float(sol[4]) if np.sqrt(s2 / info) <= max_se_s else 0.0


def _lag_corrected(t_c, pairs, resid, track, pixel_lag):
    """Crossing times moved back by the calibrated lag at each one's brightness (level pairs)
    and the track's speed, and their along-track residuals moved with them."""
    speed = np.hypot(np.interp(t_c, track["t"], track["vx"]), np.interp(t_c, track["t"], track["vy"]))
    lag_us = pixel_lag.lag_at(pairs, speed)
    return t_c - lag_us, resid + speed * lag_us * 1e-6


def _pool_crossings(t_c, q, u, est, s_a, pool_us):
    """Crossings binned by `pool_us`: per bin one measurement at the bin's mean time, its
    along position the mean of the crossings' moved there with the track's speed (the
    crossings of a bin lie along one short stretch of the motion), σ = s_a/√n."""
    b = np.floor(t_c / pool_us).astype(np.int64)
    _, inv, n = np.unique(b, return_inverse=True, return_counts=True)
    t_mean = np.bincount(inv, t_c) / n
    u_mean = np.column_stack([np.bincount(inv, u[:, 0]), np.bincount(inv, u[:, 1])])
    u_mean /= np.maximum(np.linalg.norm(u_mean, axis=1, keepdims=True), 1e-12)
    # along positions relative to the track at the bin's time, on the bin's one direction
    # (projecting absolute pixel coordinates on slightly different directions would not do)
    pos = np.column_stack([np.interp(t_mean, est["t"], est["x"]), np.interp(t_mean, est["t"], est["y"])])
    speed = np.hypot(np.interp(t_c, est["t"], est["vx"]), np.interp(t_c, est["t"], est["vy"]))
    along = ((q - pos[inv]) * u_mean[inv]).sum(1) - speed * (t_c - t_mean[inv]) * 1e-6
    a_mean = np.bincount(inv, along) / n
    return t_mean, pos + u_mean * a_mean[:, None], u_mean, s_a / np.sqrt(n)


def _covariances(u, s_along, s_cross):
    """(n, 2, 2) covariances with σ s_along along the unit vectors u and s_cross across."""
    n = np.column_stack([-u[:, 1], u[:, 0]])
    return (s_along[:, None, None] ** 2 * u[:, :, None] * u[:, None, :]
            + s_cross[:, None, None] ** 2 * n[:, :, None] * n[:, None, :])


def _prior_velocity(prior, t_us, x, y):
    if prior is None:
        return np.zeros((len(t_us), 2))
    v = np.asarray(prior(np.asarray(t_us), np.asarray(x, float), np.asarray(y, float)), float)
    if v.shape != (len(t_us), 2) or not np.all(np.isfinite(v)):
        raise ParameterError(f"velocity_prior must return finite (n, 2) px/s, got shape {v.shape}")
    return v


def _prior_displacement(prior, t_all, t_meas, z):
    """(n, 2) px the prior moves a star from t_all[0] to each t_all: the trapezoid rule on
    a grid of at most _PRIOR_STEP_S (so a prior from noisy gyro samples is averaged over
    each interval, not read at its two ends), along the measured positions interpolated."""
    if prior is None:
        return np.zeros((len(t_all), 2))
    t = np.asarray(t_all, float)
    n_sub = np.maximum(np.ceil(np.diff(t) * 1e-6 / _PRIOR_STEP_S), 1).astype(np.int64)
    starts = np.r_[0, np.cumsum(n_sub)]            # node index of each t_all on the fine grid
    frac = np.arange(starts[-1]) - np.repeat(starts[:-1], n_sub)
    fine = np.r_[np.repeat(t[:-1], n_sub) + frac * np.repeat(np.diff(t) / n_sub, n_sub), t[-1:]]
    v = _prior_velocity(prior, fine, np.interp(fine, t_meas, z[:, 0]), np.interp(fine, t_meas, z[:, 1]))
    steps = (v[1:] + v[:-1]) / 2 * (np.diff(fine) * 1e-6)[:, None]
    return np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])[starts]


def _check_sigma(sigma, centroids):
    s = np.asarray(sigma, float)
    if s.ndim == 0:
        s = np.full(len(centroids), float(s))
    if s.shape != (len(centroids),) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise ParameterError(f"sigma must be positive finite, one per centroid ({len(centroids)}), "
                         f"got shape {s.shape}")
    return s


def imu_velocity_prior(imu, camera):
    """A velocity prior from gyro rates: the image velocity (px/s) of a fixed star at pixel
    (x, y) at camera time t when the camera turns at ω (camera frame; ḋ = −ω × d for a
    camera-frame direction d), through the camera model (distortion included)."""
    from .motion.imu_integration import interpolate

    def prior(t_us, x, y):
        omega, _ = interpolate(imu, t_us)
        d = camera.unproject(np.column_stack([x, y]))
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        h = 1e-4   # s: a step small against any slew, large against rounding
        uv1 = camera.project(d - np.cross(omega, d) * h)
        uv0 = camera.project(d)
        return (uv1 - uv0) / h

    return prior


def smooth(centroids, dt_us=10_000, t0_us=None, velocity_prior=None, sigma=None, **params):
    """TrackSmoother(dt_us, **params).smooth(centroids, t0_us, velocity_prior, sigma)."""
    return TrackSmoother(dt_us, **params).smooth(centroids, t0_us, velocity_prior, sigma)
