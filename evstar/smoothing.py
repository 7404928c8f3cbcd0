"""Multi-frame position estimates along tracks: a Kalman filter + RTS smoother per track.

One frame's centroid of a star with N events cannot beat σ_PSF/√N; a track's centroids,
pooled by a motion model, can. Per confirmed track (``track >= 0``) this runs, in
continuous time (the centroids' own timestamps, irregular where frames are missed), a
constant-velocity model per image axis — state (position, velocity), process noise white
acceleration of spectral density q (px²/s³) — through a Kalman filter and its
Rauch–Tung–Striebel smoother (:mod:`evstar.kalman`: a Taichi kernel, a thread per track,
by default; its numpy specification steps all tracks at once, ``engine="numpy"``;
filterpy's, one step at a time, is the reference, ``engine="filterpy"``).

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
  state is only the prior's error (a gyro bias) and turnarounds cost nothing. A prior may
  carry the random-walk density w (px²/s) of that displacement (:func:`with_diffusion`;
  a gyro's white noise, :func:`imu_diffusion`): the positions' process noise then adds w per
  second, and a pixel-lag fit counts the walk in its uncertainty (on an EVK4 behind 16 mm a
  MEMS gyro's walk, 0.4 px/√s, taken as exact had put a field's stars 0.100 px off).
* A centroid farther than ``outlier_sigma`` × its σ from the smoothed track (half of a
  star the extractor cut in two, a noise cluster the tracker took) is flagged ``outlier``
  and the track refitted without it; its frame keeps the refitted position.
* Frames of a track's life without a centroid are "coasted": the smoothed position at the
  frame's mid-time, flagged, when it lies within ``coast_ms`` of a measurement on either
  side (with a velocity prior, a track's ends reach ``coast_gyro_ms``, up to a readout
  stall: evstar.coasting); farther from both, nothing is reported for that frame.

Output rows (:data:`ESTIMATE_DTYPE`) are sorted by track, then time.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import kalman, kalman_ca, lobes
from .errors import ParameterError
from .frames import groups
from .parameters import AUTO, ESTIMATE, SMOOTHER
from .robust import robust_sigma

# rows of (n, 2) and (n, 2, 2) arrays are gathered with take / compress (axis 0) on the hot
# paths: the same values as a[index], which costs ~10x on them in numpy 2

ESTIMATE_DTYPE = np.dtype([
    ("t", "<i8"), ("frame", "<i8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
    ("vx", "<f8"), ("vy", "<f8"), ("sigma_x", "<f8"), ("sigma_y", "<f8"),
    ("n_events", "<i4"), ("centroid", "<i8"), ("coasted", "?"), ("outlier", "?"),
    ("source", "<U8")])
MEASURED, COASTED = "measured", "coasted"
_Q_GRID = np.r_[0.0, np.logspace(-2, 9, 45)]   # px²/s³ candidates for the q estimate
_MIN_Q_STEPS = 4                       # measured steps a track needs for a q (or prior) estimate
_Q_MEMO_TRACKS = 4096                  # q estimates a smoother remembers (then forgets them all)
#: log-likelihood by which a track with the velocity prior must beat it without: "strong"
#: evidence (Kass & Raftery's 2Δ > 6), since the centroids alone hardly see a gyro's noise
PRIOR_EVIDENCE = 3.0
#: ... and "positive" evidence (2Δ > 2) where the prior is quiet: its random walk over a
#: track less than the variance all its centroids together leave (their σ² over their
#: number), so that taking it costs nothing the centroids could see. Per-frame centroids
#: average a swing across a slow star's motion over its passage (±σ/v: ±41 ms at 29 px/s),
#: so a noiseless gyro's 14 Hz, 0.15 px vibration across a DAVIS346 pan won only by 1.6
#: and 1.9 (the independent simulator's E8: 0.112 px without the prior, 0.037 with it)
_QUIET_EVIDENCE = 1.0
#: shares of the prior's displacement the evidence test also tries: per-frame centroids
#: follow a fast motion in part (their lobes, the pixels' sampling and low-pass; across a
#: 15 Hz, 0.34 px vibration the means followed 64 % of it on the default sensor and 50 %
#: behind a dark-sky low-pass, where the whole prior then explained them no better than
#: none — 217.8 against 217.6 — and the vibration was smoothed away: 0.242 px, 0.023 on
#: the default sensor). Tried with half the random walk too (g² of it), half the prior
#: beat none by 3–13 on 14 of 27 constant-pan tracks of a 50-star EVK4 field whose whole
#: prior lost by up to 20, and taking it whole there cost 0.026 -> 0.029 px: the gyro's
#: noise is what the fit will carry. A field's tracks decide together (prior_helps): 2936
#: and 564 over 146 and 132 tracks of an Orion DAVIS346 pan vibrating 0.03° at 15 Hz (8
#: and 2 °/s), +15 over 140 of the same pan still — its stars' curvature across the lens
#: beside the gyro's noise, which taken on every track doubled the field's common error
#: (0.007 -> 0.017 px): hence the √n
_PRIOR_GAINS = (1.0, 0.5)
_OUTLIER_PASSES = 4                    # fits per track at most (outliers dropped between)
_IGNORED_SIGMA = 1e4                   # px: the σ that makes an outlier weightless
_MIN_STIFF_CENTROIDS = 10              # centroids a track needs for the stiff outlier screen
_PRIOR_STEP_S = 1e-3                   # s: the velocity prior is integrated on this grid
MIN_CROSSINGS = 8                      # a track's crossings needed to refit it with them
MULTI_NEAR = 2                         # multi-level crossings within a frame that leave out a
                                       # one-level one (_multi_level) ...
ONE_LEVEL_WIDTH = 0.5                  # ... which stays only where its run's outer half-width
                                       # is under this many frames (_short_and_clean)
MIN_CROSSING_SPAN_PX = 3.0             # ... spread at least this far along the motion
MIN_FEW_CROSSINGS = 4                  # fewer or shorter (>= this many): the centroids weigh
                                       # fully along the motion, the crossings add to them
MAX_RUN_BACKGROUND = 0.1               # expected background events in a run beyond which a
                                       # track's few crossings are left out
GATE_SIGMA = 4.0                       # robust σ beyond which a track's crossing is dropped
LAG_MAX_SE_S = 0.2e-3                  # s: a pixel lag fitted less precisely is not applied
LAG_SURE_SE_S = 0.05e-3                # s: ... one fitted this precisely is, whatever its size
LAG_CLASSES_APART = 3.0                # standard errors a track's one-level crossings' lag
                                       # must stand from its multi-level ones' to be theirs
LAG_POOL_TRACKS = 5                    # lag fits a field pools (_pooled_lags) from
_POOL_MIN_SE2 = 1e-14                  # s²: the least variance a pooled fit's error is taken at
#: the lag's generalised least squares (_walk_gls): the least white variance (px²) and the
#: least time between rows (s) it takes (crossings within 10 µs are simultaneous to a walk;
#: residuals that agree exactly)
_GLS_MIN_S2, _GLS_MIN_DT_S = 1e-6, 1e-5
#: per engine: (smoothed states of CVProblems, innovation log-likelihoods of tracks)
_ENGINES = {
    "taichi": (kalman.cv_rts_taichi, kalman.innovation_loglik_taichi),
    "numpy": (kalman.cv_rts, kalman.innovation_loglik),
    "filterpy": (kalman.cv_rts_filterpy,
                 lambda tracks, grid, w=0.0: [kalman.innovation_loglik_one(*t, grid, w)
                                              for t in tracks]),
}


class LagFit(NamedTuple):
    """A track's pixel lag fit (_lag_estimate): τ (s), its standard error (s), and the part
    of that error the prior's random walk makes (s) — one gyro's walk, the same for every
    track that passes at the same time."""
    tau: float
    se: float
    walk_se: float


class _TrackLags(NamedTuple):
    """A track's lag fits (_lag_fits): the indices of its crossings the multi-level fit
    covers and of the rest (_lag_classes), and the two classes' LagFits (None: too few)."""
    fit: np.ndarray
    rest: np.ndarray
    multi: LagFit | None
    one: LagFit | None


class _Track(NamedTuple):
    """One track's smoothing problem: its centroids, their σ and indices, the coasted frames,
    all steps' times (µs; s from the first: ts), which are measured, the prior's
    displacement per step and the measured positions less it (resid)."""
    cents: np.ndarray
    sigma: np.ndarray
    index: np.ndarray
    coast_f: np.ndarray
    order: np.ndarray
    t_all: np.ndarray
    measured: np.ndarray
    shift: np.ndarray
    resid: np.ndarray
    ts: np.ndarray


class TrackSmoother:
    """Smoothed positions per frame of every confirmed track; see the module docstring.

    dt_us: the pseudo-frame length of the centroids' frames (coasted rows sit at their
    mid-times). Parameters are those of ``evstar.parameters.ESTIMATE``; engine that of
    ``evstar.parameters.SMOOTHER``.
    """

    # defaults: the declarations' (a coast_ms of 30 here had drifted from [estimate]'s 60)
    def __init__(self, dt_us=10_000, *, process_noise=ESTIMATE["process_noise"].default,
                 process_noise_min=ESTIMATE["process_noise_min"].default,
                 coast_ms=ESTIMATE["coast_ms"].default,
                 sigma_floor_px=ESTIMATE["sigma_floor_px"].default,
                 psf_sigma_px=ESTIMATE["psf_sigma_px"].default,
                 min_events=ESTIMATE["min_events"].default,
                 outlier_sigma=ESTIMATE["outlier_sigma"].default,
                 coast_ends=ESTIMATE["coast_ends"].default,
                 coast_gyro_ms=ESTIMATE["coast_gyro_ms"].default,
                 speed_change=ESTIMATE["speed_change"].default, engine=SMOOTHER["engine"].default,
                 stalls=None):
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
        self.coast_gyro_ms = ESTIMATE.check("coast_gyro_ms", coast_gyro_ms)
        self.speed_change = ESTIMATE.check("speed_change", speed_change)
        self.engine = SMOOTHER.check("engine", engine)
        # the readout's stalls ((n, 2) µs, time-sorted): a gyro-coasted end stops at one
        self.stalls = np.zeros((0, 2)) if stalls is None else np.asarray(stalls, np.float64)
        # the q estimated for each track's centroid data (_estimate_q_many): refine asks
        # again for the same data of most tracks (~25 % of the estimate stage's kernel time)
        self._q_memo = {}
        # {track id: whether its gyro-fitted lag is known (lag_pinned)}, of refine's calls
        self.lag_pinned_ = {}

    # -- measurement noise --------------------------------------------------------------
    def measurement_sigma(self, centroids):
        """Per-axis σ (px) of each centroid: psf_sigma_px/√N when given, else spread/√(2N)
        (spread is the 2-D RMS radius, √2 × the per-axis σ), where a centroid of fewer than
        ``min_events`` events takes its track's median spread (a spread from a handful of
        events is itself noise); floored at ``sigma_floor_px``. A centroid touching the
        sensor's edge (``border``) has a star cut by it, its mean pulled inward by up to the
        profile's width: σ at least that per-axis width (psf_sigma_px, or spread/√2)."""
        n = np.maximum(centroids["n_events"].astype(float), 1.0)
        border = centroids["border"]
        if self.psf_sigma_px is not None:
            sigma = np.maximum(self.psf_sigma_px / np.sqrt(n), self.sigma_floor_px)
            return np.where(border, np.maximum(sigma, self.psf_sigma_px), sigma)
        spread = centroids["spread"].astype(float).copy()
        few = centroids["n_events"] < self.min_events
        for tr in np.unique(centroids["track"][few]):
            rows = centroids["track"] == tr
            rich = rows & ~few
            pool = centroids["spread"][rich if rich.any() else rows]
            spread[rows & few] = np.median(pool)
        sigma = np.maximum(spread / np.sqrt(2 * n), self.sigma_floor_px)
        return np.where(border, np.maximum(sigma, spread / np.sqrt(2)), sigma)

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
        tracks = _batched([self._prepare(centroids[rows], sig[rows], t0_us, velocity_prior, rows)
                           for rows in _track_rows(centroids)], velocity_prior)
        fits = self._fit_many(tracks, diffusion(velocity_prior))
        parts = _batched([self._rows(tr, *fit, velocity_prior) for tr, fit in zip(tracks, fits)],
                         velocity_prior)
        return np.concatenate(parts) if parts else np.zeros(0, ESTIMATE_DTYPE)

    def prior_helps(self, centroids, velocity_prior, sigma=None):
        """Confirmed track ids whose centroids the velocity prior explains better: per track,
        the innovation likelihood (maximised over q) of the positions less the prior's
        displacement against that of the positions themselves — one model each, the same data
        and one free parameter. A gyro's white noise integrates into the displacement as a
        random walk (0.03 px per 10 ms at f = 2469 px for 1.2·10⁻⁴ rad/s/√Hz): on a constant
        pan the plain track is the better model, through a sinusoid's turnarounds the prior,
        which must win by PRIOR_EVIDENCE. Per-frame centroids follow a fast motion only in
        part (_PRIOR_GAINS), so the prior is also tried scaled down: whether the centroids
        move with it at all is the question, and the fit then takes it whole — so each
        scaled try carries the whole prior's random walk. One camera turns every star: where
        the tracks together (the sum of their log-likelihood ratios: the prior for all
        against none) pass PRIOR_EVIDENCE·√(tracks), every track takes it, though a short
        one alone shows too little either way (the sum of n ratios that favour neither
        scatters as √n). A quiet prior (_QUIET_EVIDENCE) needs less evidence. Tracks too
        short to tell keep the prior."""
        sig = self.measurement_sigma(centroids) if sigma is None else _check_sigma(sigma, centroids)
        every = _track_rows(centroids)
        rows = [r for r in every if len(r) >= _MIN_Q_STEPS]
        scaled, plain = _with_and_without(centroids, rows, sig, velocity_prior)
        w = diffusion(velocity_prior)
        best = np.max([self._best_loglik(less, w) for less in scaled.values()], axis=0) \
            if rows else []
        alone = self._best_loglik(plain, 0.0)
        ids = [int(centroids["track"][r[0]]) for r in rows]
        gain = np.asarray(best) - np.asarray(alone)
        need = np.where(_quiet_walk(plain, w), _QUIET_EVIDENCE, PRIOR_EVIDENCE)
        helps = set(ids) if gain.sum() > need.max(initial=0.0) * np.sqrt(len(gain)) else \
            {i for i, g, n in zip(ids, gain, need) if g > n}
        return helps | ({int(centroids["track"][r[0]]) for r in every} - set(ids))

    def prior_loglik(self, centroids, velocity_prior, sigma=None):
        """Per confirmed track long enough to tell (ascending id), the innovation
        log-likelihood, maximised over q, of its positions less the velocity prior's
        displacement (prior_helps's measure of how well a prior explains them)."""
        sig = self.measurement_sigma(centroids) if sigma is None else _check_sigma(sigma, centroids)
        rows = [r for r in _track_rows(centroids) if len(r) >= _MIN_Q_STEPS]
        if not rows:
            return np.zeros(0)
        less = _with_and_without(centroids, rows, sig, velocity_prior)[0][1.0]
        return np.asarray(self._best_loglik(less, diffusion(velocity_prior)))

    def _best_loglik(self, data, w):
        """Per (ts, positions, σ) of `data` its innovation log-likelihood at the best q of
        _Q_GRID, with w the prior's random-walk density."""
        return [float(np.max(ll)) for ll in _ENGINES[self.engine][1](data, _Q_GRID, w)]

    # -- one track ----------------------------------------------------------------------
    def smooth_track(self, cents, sigma, t0_us, velocity_prior=None, index=None):
        """Rows for one track's time-sorted centroids (see :meth:`smooth`)."""
        idx = np.arange(len(cents)) if index is None else np.asarray(index)
        [tr] = _batched([self._prepare(cents, sigma, t0_us, velocity_prior, idx)], velocity_prior)
        return _batched([self._rows(tr, *self._fit_many([tr], diffusion(velocity_prior))[0],
                                    velocity_prior)], velocity_prior)[0]

    def _prepare(self, cents, sigma, t0_us, velocity_prior, index):
        """The _Track of one track's time-sorted centroids: their steps and the coasted
        frames', positions less the prior's displacement (a _batched step)."""
        t_meas = cents["t"].astype(np.int64)
        frames = cents["frame"].astype(np.int64)
        coast_f = self._coast_frames(t_meas, frames, t0_us, velocity_prior is not None)
        t_coast = t0_us + coast_f * self.dt_us + self.dt_us // 2
        t_all = np.concatenate([t_meas, t_coast])
        order = np.argsort(t_all, kind="stable")
        t_all = t_all[order]
        measured = order < len(t_meas)
        z = np.column_stack([cents["x"], cents["y"]]).astype(float)
        shift = yield from _displacement(velocity_prior, t_all, t_meas, z)
        resid = z - shift[measured]
        ts = (t_all - t_all[0]) * 1e-6
        return _Track(cents, sigma, index, coast_f, order, t_all, measured, shift, resid, ts)

    def _rows(self, tr, x, P, outlier, velocity_prior):
        """ESTIMATE_DTYPE rows of a fitted _Track (a _batched step)."""
        cents, coast_f, order, measured, shift = tr.cents, tr.coast_f, tr.order, tr.measured, tr.shift
        out = np.zeros(len(tr.t_all), ESTIMATE_DTYPE)
        out["t"], out["track"] = tr.t_all, cents["track"][0]
        out["frame"] = np.concatenate([cents["frame"].astype(np.int64), coast_f])[order]
        out["x"], out["y"] = x[:, 0] + shift[:, 0], x[:, 2] + shift[:, 1]
        v_prior = yield from _velocity(velocity_prior, tr.t_all, out["x"], out["y"])
        out["vx"], out["vy"] = x[:, 1] + v_prior[:, 0], x[:, 3] + v_prior[:, 1]
        # rounding can leave a variance a hair below zero
        out["sigma_x"] = np.sqrt(np.maximum(P[:, 0, 0], 0.0))
        out["sigma_y"] = np.sqrt(np.maximum(P[:, 2, 2], 0.0))
        out["centroid"] = np.concatenate([tr.index, np.full(len(coast_f), -1)])[order]
        out["n_events"] = np.concatenate([cents["n_events"], np.zeros(len(coast_f), int)])[order]
        out["coasted"] = ~measured
        out["outlier"][measured] = outlier
        out["source"] = np.where(measured, MEASURED, COASTED)
        return out

    def refine(self, est, centroids, crossings, velocity_prior=None, sigma=None, along_weight=0.1,
               t0_us=None, pixel_lag=None, assigned=None, background_hz=None):
        """`est` (from :meth:`smooth`) refitted track by track with pixel crossings
        (evstar.crossings.pixel_crossings of the events near the stars) as along-track
        measurements; see :func:`along_track_fit`. Frames of a track's life that had no row
        get one where crossings fall in them (source "measured": the star was seen passing
        pixels) or within coast_ms of a crossing (coasted). A `pixel_lag`
        (evstar.calibration.PixelLag) moves each crossing back by its pixels' calibrated lag
        first. A track that reverses loses the crossings its turns merge (_single_passes) and
        is fitted twice: then its centroids, less their along bias measured on the first
        fit, weigh fully at the turns (_debiased). assigned: along_track(crossings, est) where
        the caller has it (evstar.estimation assigns once for its groups). Returns (rows,
        crossings used)."""
        from .crossings import along_track

        sig = self.measurement_sigma(centroids) if sigma is None else _check_sigma(sigma, centroids)
        got, owner, u, resid = along_track(crossings, est) if assigned is None else assigned
        # the assigned crossings' fields, gathered once (m below indexes them)
        t_got = crossings["t"][got]
        q_got = np.column_stack([crossings["x"][got], crossings["y"][got]]).astype(float)
        pairs = crossings["pairs"][got]             # level pairs of each assigned crossing
        width = crossings["t_outer"][got]
        half = crossings["t_half"][got]             # their pairs' RMS half-width
        # their positions along the motion (the row sum's arithmetic but for a zero's sign)
        along = q_got[:, 0] * u[:, 0] + q_got[:, 1] * u[:, 1]
        if t0_us is None and len(est):
            t0_us = int((est["t"] - est["frame"] * self.dt_us).min())
        tids, est_rows = groups(est["track"])
        mine = dict(zip(*groups(owner)))
        tracks, both = [], []      # both: a reversing track's centroids of both lobes
        lags = []                  # the median lag (s) its crossings were moved back by
        flanks = []                # per track its crossings' (RMS half-widths, lags µs)
        for tid, rows in zip(tids, est_rows):
            m = _trusted(mine.get(tid, np.zeros(0, np.int64)), pairs, width, along, background_hz,
                         t_got, self.dt_us)
            track = est[rows]
            radius = _turn_radius(centroids, track)
            turns = _turns(track, radius)
            m = _single_passes(m, t_got, q_got, turns, radius)
            t_c, r_c = t_got[m], resid[m]
            lag_us = np.zeros(len(t_c))
            if pixel_lag is not None and len(t_c):   # when the star really passed each pixel
                t_c, r_c, lag_us = lag_corrected(t_c, pairs[m], width[m], r_c, track, pixel_lag)
            if self.speed_change and velocity_prior is not None and len(t_c):
                t_c, r_c = _speed_change_corrected(t_c, half[m], q_got.take(m, 0), u.take(m, 0),
                                                   r_c, track, lag_us)
            flanks.append((half[m], lag_us))
            full = self._fill_frames(track, t_c, t0_us)
            meas = full["centroid"][~full["coasted"]]
            z = np.column_stack([centroids["x"][meas], centroids["y"][meas]])
            s_cent = np.where(full["outlier"][~full["coasted"]], _IGNORED_SIGMA, sig[meas])
            tracks.append((full, z, s_cent, (t_c, q_got.take(m, 0), u.take(m, 0), r_c, pairs[m]),
                           turns))
            both.append(lobes.balanced(centroids[meas]) if turns else None)
            lags.append(float(np.median(lag_us)) * 1e-6 if pixel_lag is not None and len(lag_us)
                        else None)
        w = [np.full(len(z), float(along_weight)) for _, z, _, _, _ in tracks]
        lag_fits = _field_lags(tracks, velocity_prior, self.sigma_floor_px)
        self.lag_pinned_.update({int(t): lag_pinned(f) for t, f in zip(tids, lag_fits)})
        fitted = self._fit_along(tracks, w, velocity_prior, lag_fits)
        reversing = [i for i, t in enumerate(tracks) if t[4] and fitted[i][0] is not None]
        moved = set()
        if self.speed_change and velocity_prior is None:
            moved = self._turn_flanks_corrected(tracks, fitted, reversing, flanks)
        # a reversing track's centroids, less their along-motion bias measured against the
        # fit where crossings tell it, weigh fully at its turns where that bias's model
        # explains them (_debiased)
        again = {i: _debiased(tracks[i], fitted[i][0], along_weight, both[i],
                              pixel_lag is not None, lags[i]) for i in reversing}
        redo = [i for i in reversing if again[i] is not None or i in moved]
        if redo:
            args = [again[i] if again[i] is not None else (tracks[i], w[i]) for i in redo]
            for i, f in zip(redo, self._fit_along([a[0] for a in args], [a[1] for a in args],
                                                  velocity_prior, [lag_fits[i] for i in redo])):
                fitted[i] = f
        if self.speed_change and velocity_prior is None:
            self._refit_speed_changes(tracks, fitted, w, flanks)
        parts = [est[rows] if r is None else r for rows, (r, _) in zip(est_rows, fitted)]
        used = sum(n for _, n in fitted)
        out = np.concatenate(parts) if parts else est
        return out[np.lexsort((out["t"], out["track"]))], used

    def _refit_speed_changes(self, tracks, fitted, weights, flanks):
        """Without a velocity prior: the tracks that change speed but never reverse (a slew
        speeding up from rest or slowing down) refitted with a constant-acceleration model
        (evstar.kalman_ca) and their crossings moved to when the star passed each pixel
        (_speed_change_corrected, exactly on that fit's path), ACCEL_PASSES times: each fit
        reads the speed change better off crossings the last one moved. The
        constant-velocity fit bent a slew's acceleration straight and moved them a third of
        the way: a 10 °/s slew from rest and back 0.086 -> 0.026 px, on a dark sky 0.160 ->
        0.127 (fresh-40 of perf/study_accuracy.py). The speed change is read off the
        crossings' fits — which pin it, where the centroids' smoothed speed wanders by
        ±25 % on a slow faint star; not where the first fit's speed changes less than
        SPEED_CHANGE_RATIO or the crossings move by less than _SPEED_CHANGE_REFIT_PX (a
        constant-rate pan keeps its fit); where the refit departs from the first fit by more
        than MAX_ACCEL_DEPARTURE_PX (_departure), the constant-velocity refit on the first
        fit's speed change instead (_refit_on_first_fit). A reversing track's crossings are
        moved before its refit at the turns instead (_turn_flanks_corrected). `tracks` and
        `fitted`, per track (rows, crossings used), are updated in place."""
        todo = [i for i, (track, (rows, _)) in enumerate(zip(tracks, fitted))
                if _speeds_change(track, rows)]
        first, w = [tracks[i] for i in todo], [weights[i] for i in todo]
        fits, qs = self._fit_accelerating(first, w)
        moved = first
        for k in range(ACCEL_PASSES):
            shifted = [(t, t[3][0]) if rows is None else
                       _flank_corrected(t, flanks[i], rows, exact=True)
                       for t, i, (rows, _) in zip(first, todo, fits)]
            if k == 0:   # crossings that barely move on the first fit's path: it stays
                keep = [rows is not None and np.max(np.abs(t_new - t[3][0]) * _speed_at(rows, t[3][0]))
                        * 1e-6 >= _SPEED_CHANGE_REFIT_PX
                        for t, (_, t_new), (rows, _) in zip(first, shifted, fits)]
            moved = [t for t, _ in shifted]
            fits, _ = self._fit_accelerating(moved, w, qs)
        rest = []
        for i, t, f, ok in zip(todo, moved, fits, keep):
            if ok and f[0] is not None and _departure(f[0], fitted[i][0], t[3][0]) \
                    <= MAX_ACCEL_DEPARTURE_PX:
                tracks[i], fitted[i] = t, (_with_larger_sigma(f[0], fitted[i][0]), f[1])
            else:
                rest.append(i)
        self._refit_on_first_fit(tracks, fitted, weights, flanks, rest)

    def _refit_on_first_fit(self, tracks, fitted, weights, flanks, todo):
        """The tracks `todo` (indices) refitted at a constant velocity with their crossings
        moved by the speed change their first fit shows, where they move by at least
        _SPEED_CHANGE_REFIT_PX: those whose acceleration refit _refit_speed_changes does not
        keep (the refit before the fortieth session)."""
        redo = []
        for i in todo:
            rows, t_c = fitted[i][0], tracks[i][3][0]
            moved, t_new = _flank_corrected(tracks[i], flanks[i], rows)
            if np.max(np.abs(t_new - t_c) * _speed_at(rows, t_c)) * 1e-6 >= _SPEED_CHANGE_REFIT_PX:
                tracks[i] = moved
                redo.append(i)
        if redo:
            for i, f in zip(redo, self._fit_along([tracks[i] for i in redo],
                                                  [weights[i] for i in redo], None)):
                fitted[i] = f

    def _fit_accelerating(self, tracks, weights, qs=None):
        """_fit_along's result with the constant-acceleration model (no velocity prior), in
        each track's frame: along its motion the jerk density its likelihood picks with the
        path held straight (kalman_ca.best), then across it its own. One density for both
        axes let the across one bend with the along one's (a close pair's track went 0.34 px
        sideways within 10 ms on an Orion DAVIS346 8 mm slew); the across held at the
        least, a wide lens's curved paths came out 0.3 px off. qs: those densities (per
        track, None where nothing was fitted) as a first call returns them beside its
        fits: the later passes keep them (the likelihoods cost most of the step)."""
        problems = _batched([_along_track_problem(full, z, s, cr, None, along_weight=w,
                                                  sigma_floor_px=self.sigma_floor_px)
                             for (full, z, s, cr, _), w in zip(tracks, weights)], None)
        fit = [i for i, p in enumerate(problems) if p is not None and (qs is None or qs[i])]
        u = {i: _main_direction(problems[i].est) for i in fit}
        turned = [_turned(problems[i].problem, u[i]) for i in fit]
        if qs is None:
            along = [q for q, _ in kalman_ca.best(turned, second=float(kalman_ca.Q_GRID[0]))]
            across = [q for q, _ in kalman_ca.best(turned, kalman_ca.Q_GRID[::2], first=along)]
            qs = [None] * len(problems)
            for i, q in zip(fit, zip(along, across)):
                qs[i] = q
        states = dict(zip(fit, kalman_ca.ca_rts([t._replace(q=qs[i]) for i, t in zip(fit, turned)])))
        fits = [(None, 0) if i not in states else
                (_batched([_along_track_rows(p, *_unturned(*states[i], u[i]), None)], None)[0],
                 p.n_used)
                for i, p in enumerate(problems)]
        return fits, qs

    def _turn_flanks_corrected(self, tracks, fitted, reversing, flanks):
        """Without a velocity prior: the reversing tracks' crossings moved to when the star
        passed each pixel (_speed_change_corrected), the speed change read off their first
        fit, before their refit at the turns. Near a turn a star slows and speeds up
        hardest: on a 1 Hz sinusoid of ±12 px its crossings lay up to 0.3 px off, as the
        flanks' mean time predicts (DAVIS346 8 mm fields: isolated stars 0.09–0.125 ->
        0.05–0.09 px). Not behind a pixel lag (a crossing's time then holds the pixel's
        response, and following the first fit's bend took a faint star of a dark-sky
        sinusoid 1.3 px off at a turn: perf/study_indep.py --fresh F4, 0.177 -> 0.267).
        `tracks` is updated in place; returns the indices of those that moved."""
        moved = set()
        for i in reversing:
            t_c = tracks[i][3][0]
            if len(t_c) < MIN_CROSSINGS or np.any(flanks[i][1] > 0):
                continue
            track, t_new = _flank_corrected(tracks[i], flanks[i], fitted[i][0])
            if np.any(t_new != t_c):
                tracks[i] = track
                moved.add(i)
        return moved

    def _fit_along(self, tracks, weights, velocity_prior, lags=None):
        """Per track (full rows, centroid positions, their σ, crossings, turns) and its
        centroids' along weights: (refitted rows or None where nothing to fit, crossings
        used), all tracks' filters batched. lags: per track its _TrackLags (_field_lags)
        where the caller has them, else each fits its own."""
        lags = [None] * len(tracks) if lags is None else lags
        steps = [_along_track_problem(full, z, s, cr, velocity_prior, along_weight=w,
                                      sigma_floor_px=self.sigma_floor_px, lag_fits=lag)
                 for (full, z, s, cr, _), w, lag in zip(tracks, weights, lags)]
        problems = _batched(steps, velocity_prior)
        fits = iter(_along_track_fit_many([p for p in problems if p is not None],
                                          velocity_prior, self.process_noise_min, self.engine,
                                          self._q_memo, self.process_noise))
        return [(None, 0) if p is None else next(fits) for p in problems]

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

    def _fit_many(self, tracks, w=0.0):
        """Smoothed states and covariances, and the outlier flag per measurement, of each
        _Track: a centroid whose standardised residual from the smoothed track exceeds
        outlier_sigma (either axis) is dropped and the track fitted again (a star cut in two
        by the extractor, a noise cluster taken by the track), at most _OUTLIER_PASSES times.
        Each pass fits the tracks still refitting all at once. w: the prior's random-walk
        density (px²/s)."""
        outlier = self._stiff_outliers(tracks, w)
        fits = [None] * len(tracks)
        todo = list(range(len(tracks)))
        for _ in range(_OUTLIER_PASSES):
            keep = [~outlier[i] for i in todo]
            qs = self._q_many([(tracks[i].ts[tracks[i].measured][k], tracks[i].resid[k],
                                tracks[i].sigma[k]) for i, k in zip(todo, keep)], w)
            problems = [_cv_problem(tracks[i], outlier[i], q, w) for i, q in zip(todo, qs)]
            again = []
            for i, fit in zip(todo, _ENGINES[self.engine][0](problems)):
                fits[i] = fit
                new = self._new_outliers(tracks[i], *fit, outlier[i])
                if new is not None:
                    outlier[i] |= new
                    again.append(i)
            todo = again
            if not todo:
                break
        return [(x, P, o) for (x, P), o in zip(fits, outlier)]

    def _stiff_outliers(self, tracks, w=0.0):
        """Per track, the centroids beyond outlier_sigma from its stiffest fit (q =
        process_noise_min): an estimated q follows a stray centroid of a faint track (a noise
        clump merged into the star's cluster) instead of flagging it."""
        out = [np.zeros(len(tr.resid), bool) for tr in tracks]
        if self.process_noise != AUTO or self.outlier_sigma is None:
            return out
        # a short track's few centroids cannot tell which of them is off
        long = [i for i, tr in enumerate(tracks) if len(tr.resid) >= _MIN_STIFF_CENTROIDS]
        problems = [_cv_problem(tracks[i], out[i], self.process_noise_min, w) for i in long]
        for i, fit in zip(long, _ENGINES[self.engine][0](problems) if problems else []):
            new = self._new_outliers(tracks[i], *fit, out[i])
            if new is not None:
                out[i] = new
        return out

    def _new_outliers(self, tr, x, P, outlier):
        """Centroids newly beyond outlier_sigma, or None when there are none or the track
        is not to be refitted."""
        if self.outlier_sigma is None:
            return None
        m, sigma = tr.measured, tr.sigma
        # standardised residuals: the residual from the smoothed track over its own σ
        # (R − P: a point the fit follows closely has a small residual and a small σ)
        var = sigma[:, None] ** 2 - P[m][:, [0, 2], [0, 2]]
        d = tr.resid - x[m][:, [0, 2]]
        res = (np.abs(d) / np.sqrt(np.maximum(var, 1e-6 * sigma[:, None] ** 2))).max(1)
        new = (res > self.outlier_sigma) & ~outlier
        if not new.any():
            return None
        # never more than a quarter of a track: beyond that the model, not the data, is off
        if (outlier | new).sum() > len(tr.resid) // 4:
            # unless one wild centroid pulls its neighbours' residuals past the threshold
            # too: the worst alone, where it stands out of the rest's spread as an outlier
            # of a fitting model would (and the track refitted without it)
            worst = np.argmax(np.where(outlier, -np.inf, res))
            spread = max(float(np.median(res[~outlier])), 1.0)
            if outlier.sum() + 1 > len(tr.resid) // 4 or res[worst] <= self.outlier_sigma * spread:
                return None
            new = np.zeros_like(new)
            new[worst] = True
        return new

    def _coast_frames(self, t_meas, frames, t0_us, gyro=False):
        """Frames without a centroid whose mid-time is within coast_ms of a centroid of the
        track (the previous or the next one): gaps, and the frames just before its first and
        after its last centroid (a star fading out keeps its predicted position, flagged;
        frames before 0 are never reported, and the caller drops what lies past the
        recording or outside the sensor). With a gyro prior (`gyro`) the ends reach
        coast_gyro_ms: the gyro, not a constant velocity, carries the star there (a star
        speeding up from rest gives no events at first: perf/study_indep.py --fresh2 G12
        with the IMU had 91 % of its frames, its fainter star's first 140 ms left out)."""
        limit = self.coast_ms * 1000.0
        end = max(limit, self.coast_gyro_ms * 1000.0) if gyro else limit
        k = int(end // self.dt_us) + 1 if self.coast_ends else 0
        life = np.arange(max(frames.min() - k, 0), frames.max() + k + 1)
        empty = life[~np.isin(life, frames)]
        if not len(empty):
            return empty
        mid = t0_us + empty * self.dt_us + self.dt_us // 2
        near = _near_any(mid, t_meas, limit)
        if end > limit:   # never across a readout stall (evstar.pieces bridges those)
            a, b = self.stalls[:, 0], self.stalls[:, 1]
            after_stall = np.max(b[a < t_meas[0]], initial=-np.inf)
            before_stall = np.min(a[b > t_meas[-1]], initial=np.inf)
            near |= ((mid < t_meas[0]) & (t_meas[0] - mid <= end) & (mid > after_stall)) | \
                    ((mid > t_meas[-1]) & (mid - t_meas[-1] <= end) & (mid < before_stall))
        return empty[near]

    def _q_many(self, tracks, w=0.0):
        """q per (ts, positions, σ) of measured steps: the set one or the ML estimate (with
        the prior's random-walk density w)."""
        if self.process_noise != AUTO:
            return [float(self.process_noise)] * len(tracks)
        return [max(q, self.process_noise_min)
                for q in _estimate_q_many(tracks, self.engine, self._q_memo, w)]


def _cv_problem(track, outlier, q, w=0.0):
    """The kalman.CVProblem of a _Track's centroids at q and w, its outliers weightless."""
    return kalman.CVProblem(track.ts, track.measured, track.resid,
                            kalman.diagonal_covariances(np.where(outlier, _IGNORED_SIGMA, track.sigma)),
                            q, w)


def _with_and_without(centroids, rows, sigma, velocity_prior):
    """Per track (`rows`: its centroids' indices, time-sorted) its likelihood data (ts s,
    positions, σ): {gain g: the positions less g times the prior's displacement} for each
    of _PRIOR_GAINS, and the positions as they are."""
    t = [centroids["t"][r].astype(float) for r in rows]
    z = [np.column_stack([centroids["x"][r], centroids["y"][r]]).astype(float) for r in rows]
    shifts = _batched([_displacement(velocity_prior, ti, ti, zi) for ti, zi in zip(t, z)],
                      velocity_prior)
    ts = [(ti - ti[0]) * 1e-6 for ti in t]
    return ({g: [(a, zi - g * shift, sigma[r]) for a, zi, shift, r in zip(ts, z, shifts, rows)]
             for g in _PRIOR_GAINS},
            [(a, zi, sigma[r]) for a, zi, r in zip(ts, z, rows)])


def _quiet_walk(tracks, w):
    """Per track (ts s, positions, σ) whether a prior's random walk of density w (px²/s)
    over it is less than the variance its centroids together leave (σ² / their number)."""
    return np.array([w * (ts[-1] - ts[0]) < np.median(sig) ** 2 / len(ts)
                     for ts, _, sig in tracks], bool)


def with_diffusion(velocity_prior, w):
    """`velocity_prior` (a callable (t_us, x, y) -> (n, 2) px/s) carrying w, the random-walk
    density (px²/s) of its integrated displacement, which the smoother adds to the positions'
    process noise (imu_diffusion: a gyro's)."""
    def prior(t_us, x, y):
        return velocity_prior(t_us, x, y)

    prior.diffusion_px2_s = float(w)
    return prior


def diffusion(velocity_prior):
    """The random-walk density (px²/s) a velocity prior carries (with_diffusion); 0 for none."""
    return 0.0 if velocity_prior is None else float(getattr(velocity_prior, "diffusion_px2_s", 0.0))


def _near_any(t, times, limit):
    """Per t: is one of the sorted `times` within `limit` of it?"""
    i = np.searchsorted(times, t)
    before = np.where(i > 0, t - times[np.maximum(i - 1, 0)], np.inf)
    after = np.where(i < len(times), times[np.minimum(i, len(times) - 1)] - t, np.inf)
    return (before <= limit) | (after <= limit)


def estimate_process_noise(ts, z, sigma, engine=SMOOTHER["engine"].default):
    """White-acceleration spectral density q (px²/s³) of one track by maximum likelihood of
    its innovation sequence: positions z (n, 2) at times ts (s) with per-axis σ (n,), the
    constant-velocity filter run for every q of a log grid at once (both axes share q).
    0 when the track is too short or no q beats a straight line."""
    return _estimate_q_many([(ts, z, sigma)], SMOOTHER.check("engine", engine))[0]


def _estimate_q_many(tracks, engine, memo=None, w=0.0):
    """estimate_process_noise of each (ts, z, σ), the likelihoods of all at once (position
    random walk w px²/s). memo: a dict of the q of the data already seen, by their bytes
    and w (a smoother's own); only the others' likelihoods are computed (a track's are its
    data's alone)."""
    memo = {} if memo is None else memo
    if len(memo) > _Q_MEMO_TRACKS:
        memo.clear()
    q = [0.0] * len(tracks)
    long = [i for i, t in enumerate(tracks) if len(t[0]) >= _MIN_Q_STEPS]
    args = [tuple(np.asarray(a, float) for a in tracks[i]) for i in long]
    keys = [(float(w),) + tuple((a.shape, a.tobytes()) for a in arg) for arg in args]
    new = [j for j, key in enumerate(keys) if key not in memo]
    for j, ll in zip(new, _ENGINES[engine][1]([args[j] for j in new], _Q_GRID, w) if new else []):
        memo[keys[j]] = float(_Q_GRID[int(np.argmax(ll))])
    for i, key in zip(long, keys):
        q[i] = memo[key]
    return q


def _track_rows(centroids):
    """Per confirmed track (ascending id): its rows of `centroids`, time-sorted."""
    tracks = centroids["track"]
    conf = np.flatnonzero(tracks >= 0)
    conf = conf[np.lexsort((centroids["t"][conf], tracks[conf]))]
    bounds = np.flatnonzero(np.diff(tracks[conf])) + 1
    return np.split(conf, bounds) if len(conf) else []


def along_track_fit(est, z_cent, sigma, crossings, velocity_prior=None, along_weight=0.1,
                    gate_sigma=GATE_SIGMA, sigma_floor_px=0.01, process_noise_min=1.0,
                    pool_us=10_000, engine=SMOOTHER["engine"].default):
    """Refit one track's smoothed rows `est` with crossing times as along-track measurements.

    A crossing says the star's centre passed pixel q at time t: a measurement of the position
    along the motion u only, z = q with covariance σ_a²·uuᵀ + (huge)·nnᵀ. The centroids
    (z_cent, σ: those of est's measured rows) keep their cross-track σ; along the motion
    their σ is divided by `along_weight` (a per-frame mean of a moving star's events is biased
    along the motion by its ON/OFF lobes and the pixels' lag; where no crossing is near, the
    centroids still carry the track). Crossings too few or too close together along the
    motion to pin the velocity (_few; a slow star's) refit it only from MIN_FEW_CROSSINGS
    on, with the centroids at full weight along the motion (TrackSmoother.refine passes
    them only where their runs are clean: _trusted). σ_a is the robust spread (1.4826 MAD)
    of the crossings' residuals from `est`; crossings beyond `gate_sigma` σ_a of their
    median are dropped.
    crossings: (t µs, q (n, 2), u (n, 2), residual along u from the track (n,), as
    evstar.crossings.along_track gives them). The crossings of each `pool_us` are pooled into
    one measurement (the filter's cost is per step). Returns new rows (est's times, frames
    and flags) and the number of crossings used.
    """
    [p] = _batched([_along_track_problem(est, z_cent, sigma, crossings, velocity_prior, along_weight,
                                         gate_sigma, sigma_floor_px, pool_us)], velocity_prior)
    if p is None:
        return est, 0
    return _along_track_fit_many([p], velocity_prior, process_noise_min,
                                 SMOOTHER.check("engine", engine))[0]


class _AlongTrack(NamedTuple):
    """along_track_fit's problem of one track: its rows, the crossings used, all steps' order
    by time, the prior's displacement per step, the kalman.CVProblem (q to be set), and the
    centroid steps' times, positions less the displacement and σ (for the q estimate)."""
    est: np.ndarray
    n_used: int
    order: np.ndarray
    shift: np.ndarray
    problem: kalman.CVProblem
    q_data: tuple


def _along_track_problem(est, z_cent, sigma, crossings, velocity_prior=None, along_weight=0.1,
                         gate_sigma=GATE_SIGMA, sigma_floor_px=0.01, pool_us=10_000,
                         lag_fits=None):
    """along_track_fit up to the filter: an _AlongTrack, or None when the crossings do not
    pin the track (a _batched step). lag_fits: the track's _TrackLags where the caller
    has them (a field's, pooled: _pooled_lags), else fitted here."""
    kept = _kept_crossings(crossings, gate_sigma, sigma_floor_px)
    if kept is None:
        return None
    ok, s_a, few = kept
    if few:      # the centroids carry the velocity, the crossings add where they fall
        along_weight = 1.0
    t_c, q, u = crossings[0][ok], crossings[1].take(ok, 0), crossings[2].take(ok, 0)
    if velocity_prior is not None:  # IMU-known changes of speed reveal the pixels' lag
        if lag_fits is None:
            lag_fits = yield from _lag_fits(crossings, ok, velocity_prior)
        lag_s = np.zeros(len(ok))
        lag_s[lag_fits.fit], lag_s[lag_fits.rest] = _classes_lags(lag_fits.multi, lag_fits.one)
        t_c = t_c - 1e6 * lag_s
    t_c, q, u, s_c = _pool_crossings(t_c, q, u, est, s_a, pool_us)
    t_c = np.round(t_c).astype(np.int64)
    measured = ~est["coasted"]
    v = np.column_stack([est["vx"][measured], est["vy"][measured]])
    u_cent = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-9)
    # every row: est's (measured or coasted), then the crossings; sorted by time together
    n = len(est) + len(t_c)
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
    z_meas = z.take(order, 0).compress(m_s, 0)
    shift = yield from _displacement(velocity_prior, t_s, t_s[m_s], z_meas)
    resid = z_meas - shift[m_s]
    ts = (t_s - t_s[0]) * 1e-6
    cent = c_s[m_s]
    return _AlongTrack(est, len(ok), order, shift,
                       kalman.CVProblem(ts, m_s, resid, R.take(order, 0).compress(m_s, 0), None),
                       (ts[c_s], resid[cent], sig[order][c_s]))


def _kept_crossings(crossings, gate_sigma, sigma_floor_px):
    """(indices of the crossings within `gate_sigma` robust σ of their class's median
    residual, their σ_a, whether they are too few or too close to pin the velocity: _few),
    or None where they do not pin the track at all (along_track_fit)."""
    t_c, q, u, r = crossings[:4]
    # too few crossings, or all within a pixel or two along the motion, do not pin the
    # track's velocity: the centroids alone then (a short or nearly static track)
    few = _few(q[:, 0] * u[:, 0] + q[:, 1] * u[:, 1])   # along the motion (refine's arithmetic)
    if few and len(t_c) < MIN_FEW_CROSSINGS:
        return None
    med, s_a = _class_scatter(r, crossings[4] if len(crossings) > 4 else None, sigma_floor_px)
    ok = np.flatnonzero(np.abs(r - med) <= gate_sigma * s_a)
    return ok, s_a[ok], few


def _lag_fits(crossings, ok, velocity_prior):
    """The _TrackLags of a track's crossings `ok` (a _batched step)."""
    t_c, q, u = crossings[0][ok], crossings[1].take(ok, 0), crossings[2].take(ok, 0)
    fit, rest = _lag_classes(crossings[4][ok] if len(crossings) > 4 else None, len(ok))
    fits = []
    for m in (fit, rest):
        fits.append((yield from _pixel_lag_fit(t_c[m], q.take(m, 0), u.take(m, 0),
                                               velocity_prior)))
    return _TrackLags(fit, rest, *fits)


def _field_lags(tracks, velocity_prior, sigma_floor_px):
    """Per track (as TrackSmoother._fit_along takes them) its _TrackLags, pooled over the
    tracks (_pooled_lags); None each without a velocity prior (nothing to fit a lag with)."""
    if velocity_prior is None:
        return [None] * len(tracks)
    return _pooled_lags(_batched([_track_lag_fits(t[3], velocity_prior, sigma_floor_px)
                                  for t in tracks], velocity_prior))


def _track_lag_fits(crossings, velocity_prior, sigma_floor_px):
    """The _TrackLags of a track's crossings as _along_track_problem keeps them (its default
    gate), or None where it keeps none (a _batched step)."""
    kept = _kept_crossings(crossings, GATE_SIGMA, sigma_floor_px)
    if kept is None:
        return None
    return (yield from _lag_fits(crossings, kept[0], velocity_prior))


def _pooled_lags(lags):
    """The tracks' _TrackLags with their multi-level class's fit pooled over the tracks
    (random effects: a sensor's lag is one, or varies from star to star by an amount the
    fits' spread measures). Where LAG_POOL_TRACKS or more fits are within LAG_MAX_SE_S,
    each of those becomes μ + B·(τ − μ): μ their mean weighted by 1/se², B = σ_b²/(σ_b² +
    se²) with σ_b² their spread beyond their errors (DerSimonian–Laird; the errors whole,
    walk too: where the walk is not quite one for all, its part of the spread is not
    taken for the stars' own). Its standard error takes the walk's errors as one (the same
    gyro's walk, which pooling does not shrink): ((1 − B)·W̄ + B·walk)² + (1 − B)²·Σs²e² +
    B²e², with e² = se² − walk², s the weights' shares and W̄ = Σs·walk. On a 130-star
    EVK4 field at 20 °/s with the IMU (true lag −0.066 ms: a noiseless gyro's fit), each
    track's own fit (se 0.085 ms, 0.080 of it the walk's) put 26 of them 0.1–0.3 ms off,
    their stars' 90th percentile 0.084 -> 0.104 px; pooled, μ = 0.045 ± 0.080 ms, not taken."""
    multi = [i for i, f in enumerate(lags) if f is not None and f.multi is not None
             and f.multi.se <= LAG_MAX_SE_S]
    if len(multi) < LAG_POOL_TRACKS:
        return lags
    fits = [lags[i].multi for i in multi]
    tau = np.array([f.tau for f in fits])
    walk = np.array([f.walk_se for f in fits])
    se2 = np.maximum(np.array([f.se for f in fits]) ** 2, _POOL_MIN_SE2)
    e2 = np.maximum(se2 - walk ** 2, 0.0)
    w = 1.0 / se2
    mu = float((w * tau).sum() / w.sum())
    q = float((w * (tau - mu) ** 2).sum())
    spread = max(0.0, (q - (len(fits) - 1)) / (w.sum() - (w ** 2).sum() / w.sum()))
    b = spread / (spread + se2)
    share = w / w.sum()
    # the walk's errors taken as one (the same gyro): μ's is their weighted mean
    walk_mu, white_mu = float((share * walk).sum()), float((share ** 2 * e2).sum())
    walk_i = (1 - b) * walk_mu + b * walk
    se = np.sqrt(walk_i ** 2 + (1 - b) ** 2 * white_mu + b ** 2 * e2)
    out = list(lags)
    for i, t, s_i, wk in zip(multi, mu + b * (tau - mu), se, walk_i):
        out[i] = lags[i]._replace(multi=LagFit(float(t), float(s_i), float(wk)))
    return out


def _along_track_fit_many(problems, velocity_prior, process_noise_min, engine, memo=None,
                          process_noise=AUTO):
    """(rows, crossings used) of each _AlongTrack: q as set (process_noise) or estimated
    (memo: _estimate_q_many's), and the filter run for all at once."""
    w = diffusion(velocity_prior)
    qs = ([float(process_noise)] * len(problems) if process_noise != AUTO
          else _estimate_q_many([p.q_data for p in problems], engine, memo, w))
    fits = _ENGINES[engine][0]([p.problem._replace(q=max(q, process_noise_min), w=w)
                                for p, q in zip(problems, qs)])
    rows = _batched([_along_track_rows(p, x, P, velocity_prior) for p, (x, P) in zip(problems, fits)],
                    velocity_prior)
    return [(r, p.n_used) for r, p in zip(rows, problems)]


def _along_track_rows(p, x, P, velocity_prior):
    """est's rows of an _AlongTrack with the smoothed positions, velocities and σ (a _batched
    step)."""
    est, n_est = p.est, len(p.est)
    back = np.empty(len(p.order), np.int64)
    back[p.order] = np.arange(len(p.order))
    back = back[:n_est]                               # est's rows in the sorted order
    shift = p.shift
    out = est.copy()
    out["x"], out["y"] = x[back, 0] + shift[back, 0], x[back, 2] + shift[back, 1]
    v_prior = yield from _velocity(velocity_prior, out["t"], out["x"], out["y"])
    out["vx"], out["vy"] = x[back, 1] + v_prior[:, 0], x[back, 3] + v_prior[:, 1]
    out["sigma_x"] = np.sqrt(np.maximum(P[back, 0, 0], 0.0))   # rounding can make it -0
    out["sigma_y"] = np.sqrt(np.maximum(P[back, 2, 2], 0.0))
    return out


def lag_regression(t_us, q, u, velocity_prior):
    """The crossings' lag model u·q = u·(s0 + D(t) + b·t) − τ·u·v(t) as least-squares rows,
    for time-sorted crossings (t µs, pixel q, motion direction u): (y = u·(q − D),
    the offset and drift regressors [u, u·t] (n, 4), τ's regressor −u·v (s), v (n, 2) px/s)."""
    return _batched([_lag_regression(t_us, q, u, velocity_prior)], velocity_prior)[0]


def _lag_regression(t_us, q, u, velocity_prior):
    """lag_regression as a _batched step."""
    disp = yield from _displacement(velocity_prior, t_us, t_us, q)
    v = yield from _velocity(velocity_prior, t_us, q[:, 0], q[:, 1])
    ts = (t_us - t_us[0]) * 1e-6
    local = np.column_stack([u[:, 0], u[:, 1], u[:, 0] * ts, u[:, 1] * ts])
    return (u * (q - disp)).sum(1), local, -(u * v).sum(1), v


def pixel_lag_s(t_us, q, u, velocity_prior, max_se_s=LAG_MAX_SE_S):
    """The time τ by which a track's crossings trail the star (a pixel low-pass delays the
    intensity peak by ~1/(2π f_c)), fitted to the crossings with the IMU's image motion:
    along the motion u, pixel q is passed at t − τ, so u·q = u·(s0 + D(t) + b·t) − τ·u·v(t)
    with D, v the prior's displacement and velocity and s0, b (a gyro bias) free. τ is told
    apart from s0 and b only when the speed changes (a sinusoidal slew, not a constant rate):
    0 when its standard error exceeds `max_se_s`, or too few crossings. Robust: three passes
    dropping residuals beyond 5 MAD."""
    return _batched([_pixel_lag_s(t_us, q, u, velocity_prior, max_se_s)], velocity_prior)[0]


def lag_pinned(fits):
    """Whether a track's lag fits (_TrackLags, or None: no velocity prior) tell its pixels'
    lag: its multi-level class's fit — the one whose lag moves it (_classes_lags) — is within
    LAG_MAX_SE_S. A constant rate tells none (the lag is then an offset along the motion)."""
    return fits is not None and fits.multi is not None and fits.multi.se <= LAG_MAX_SE_S


def _lag_classes(pairs, n):
    """(fit, rest): indices of a track's n crossings whose pixel lag is fitted (pairs:
    their level pairs, None: unknown), and of those that take their own where it stands
    apart (_classes_lags), else fit's: the multi-level ones and the one-level ones where
    MIN_CROSSINGS are multi-level, else all and none. Behind a low-pass the two classes may
    lag apart: a one-level crossing is a fainter peak or a flank pixel, and its pair is the
    top one. One lag for the whole track set from both took a mag-5 star on a dark-sky
    sinusoid with the IMU 0.023 -> 0.39 px (FRESH F8); one from the multi-level ones put a
    mag-5.5 star's stretches of one-level crossings (revisited pixels, OFF below ON) 0.9 px
    ahead of it, whose lags were 2.1 ms against the others' 3.0 (the paper's sinusoid on a
    dark sky; fitted 0.64 ± 0.07 and 1.85 ± 0.09 ms behind the profiles' lag). Where the two
    fits agree within their errors the one-level ones' own only adds its noise (FRESH10 Q7:
    0.17 ± 0.004 against 0.22 ± 0.04 ms, 0.050 -> 0.059 px)."""
    if pairs is not None:
        multi = pairs >= 2
        if multi.sum() >= MIN_CROSSINGS:
            return np.flatnonzero(multi), np.flatnonzero(~multi)
    return np.arange(n), np.arange(0)


def _pixel_lag_s(t_us, q, u, velocity_prior, max_se_s=LAG_MAX_SE_S):
    """pixel_lag_s as a _batched step."""
    return _gated((yield from _pixel_lag_fit(t_us, q, u, velocity_prior)), max_se_s)


def _pixel_lag_fit(t_us, q, u, velocity_prior):
    """(τ s, its standard error s) of pixel_lag_s's robust fit, or None with too few
    crossings or no τ information (a _batched step)."""
    if len(t_us) < MIN_CROSSINGS:
        return None
    order = np.argsort(t_us, kind="stable")
    t_s = np.asarray(t_us, float)[order]
    y, local, lag_col, _ = yield from _lag_regression(t_s, q[order], u[order], velocity_prior)
    return _lag_estimate(y, np.column_stack([local, lag_col]), (t_s - t_s[0]) * 1e-6,
                         diffusion(velocity_prior))


def _gated(fit, max_se_s=LAG_MAX_SE_S):
    """A lag fit's τ (s) where its standard error se is within max_se_s and either within
    LAG_SURE_SE_S (taking it then costs less than the sensors' own timing biases it mends:
    −0.03 to −0.06 ms on the simulator's default pixels, 0.03 px on the paper's sinusoid)
    or τ stands out of it (|τ| > se: τ² − se², the lag's own estimated square, is
    positive), else 0."""
    if fit is None or fit[1] > max_se_s or (fit[1] > LAG_SURE_SE_S and abs(fit[0]) <= fit[1]):
        return 0.0
    return fit[0]


def _classes_lags(multi, one):
    """(the multi-level crossings' lag, the one-level ones') of a track from their fits
    (_pixel_lag_fit): the one-level ones take their own only where both are measured and
    stand LAG_CLASSES_APART standard errors apart, else the multi-level one."""
    tau = _gated(multi)
    if tau == 0.0 or _gated(one) == 0.0:
        return tau, tau
    apart = abs(one[0] - multi[0]) > LAG_CLASSES_APART * np.hypot(one[1], multi[1])
    return tau, one[0] if apart else tau


def _lag_estimate(y, A, ts, w):
    """A LagFit of the lag regression, robust (three passes dropping
    residuals beyond 5 MAD); None with too few rows or no τ information. With a random walk
    in the prior's displacement (w px²/s: a gyro's noise, the same on every track) the
    rows' errors are not independent, and τ is fitted by generalised least squares
    (_walk_gls)."""
    for _ in range(3):
        sol, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ sol
        keep = np.abs(r) <= 5 * robust_sigma(r, 0.0) + 1e-9
        if keep.sum() < MIN_CROSSINGS:
            return None
        A, y, ts = A[keep], y[keep], ts[keep]
    # τ's own information: its regressor less what the offset and drift columns explain
    # (nothing left at a constant speed: τ is then a position offset, not a lag)
    other, *_ = np.linalg.lstsq(A[:, :4], A[:, 4], rcond=None)
    a = A[:, 4] - A[:, :4] @ other
    info = float((a ** 2).sum())
    if info <= 1e-9 * float((A[:, 4] ** 2).sum()):
        return None
    sol, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ sol
    fit = _walk_gls(y, A, ts, w, r) if w > 0 else None
    if fit is not None:
        return fit
    s2 = float((r ** 2).sum()) / max(len(y) - A.shape[1], 1)
    # τ = Σ a·y / info, so the walk adds w·Σ_k Δt_k (Σ_{i≥k} a_i)² / info² (a's rows turned
    # to the main direction: _walk_signs). Where the walk over the pass stays within each
    # crossing's noise (_walk_gls falls back), its sum over a few thousand crossings need
    # not: left out, the error said 0.007 ms where the walk's was ~0.08 (a bright star of
    # a 130-star EVK4 field)
    walk = w * _walk_sum(a * _walk_signs(A[:, :2]), ts) / info ** 2
    return LagFit(float(sol[4]), float(np.sqrt(s2 / info + walk)), float(np.sqrt(walk)))


def _walk_signs(u):
    """+1 or -1 per row of motion directions `u` (n, 2): along the rows' main direction or
    against it (a sinusoid's other half, whose walk is the same W seen from behind)."""
    main = np.linalg.svd(u, full_matrices=False)[2][0]
    return np.where(u @ main >= 0, 1.0, -1.0)


def _walk_sum(g, ts, dt=None):
    """Σ_k Δt_k (Σ_{i≥k} g_i)² = Σ_ij g_i g_j min(t_i, t_j) (from the first row's time; Δt:
    the rows' spacing, `dt` where given): a unit random walk's variance in Σ g_i W(t_i)."""
    dt = np.diff(ts, prepend=ts[0]) if dt is None else dt
    return float((dt * np.cumsum(g[::-1])[::-1] ** 2).sum())


def _walk_gls(y, A, ts, w, resid):
    """A LagFit (walk_se: the part of the standard error the walk makes) by the lag
    regression's generalised least squares where each row's error is u·W(t) + ε — W the
    prior's 2-D random walk (w px²/s per axis), ε the crossings' own white noise — so Cov = s²·I + w·min(t_i, t_j) along the track's
    main direction (rows whose motion u points the other way, a sinusoid's other half,
    turned round: their walk is the same W seen from behind). Ordinary least squares
    weighed the walk's slow wander like independent noise: on an EVK4 26 °/s-peak sinusoid
    with an ideal pixel it read 0.138 ± 0.147 ms for no lag (0.11 px ahead), fresh-39's
    EVK4 sinusoid −0.064 ± 0.071 ms (here −0.057 ± 0.04). Σ⁻¹ = (I − (Q + I/s²)⁻¹/s²)/s²
    with Q the walk's tridiagonal precision: one banded solve. s² from the differences of
    consecutive ordinary least-squares residuals `resid` (the walk moves little between
    them); the standard error scaled up by the fit's χ²/dof where it exceeds 1. None where the walk over the whole
    pass stays within the crossings' own noise (w·span <= s²): ordinary least squares is
    then as good, and the walk's huge precision between close rows makes the solve
    ill-conditioned (a 0.54 s pass behind a 10⁻⁵ px²/s walk read 2.9 ± 0.1 ms for a lag
    ordinary least squares could not tell, ± 9 ms)."""
    from scipy.linalg import solveh_banded

    turn = _walk_signs(A[:, :2])
    y, A = turn * y, turn[:, None] * A
    n, p = A.shape
    d = np.diff(turn * resid)
    s2 = max(float(robust_sigma(d)) ** 2 / 2, _GLS_MIN_S2)
    if w * (ts[-1] - ts[0]) <= s2:
        return None
    dt = np.maximum(np.diff(ts, prepend=ts[0] - _GLS_MIN_DT_S), _GLS_MIN_DT_S)
    prec = 1.0 / (w * dt)
    band = np.zeros((2, n))
    band[0, 1:] = -prec[1:]
    band[1] = prec + np.r_[prec[1:], 0.0] + 1.0 / s2
    z = np.column_stack([y, A])
    wz = (z - solveh_banded(band, z) / s2) / s2                # Σ⁻¹ [y, A]
    cov = np.linalg.pinv(A.T @ wz[:, 1:])   # (a track along an axis: a zero column)
    beta = cov @ (A.T @ wz[:, 0])
    res = y - A @ beta
    scale = max(float(res @ (res - solveh_banded(band, res) / s2)) / s2 / max(n - p, 1), 1.0)
    # the walk's share of τ's variance: τ = Σ g·y with g = Σ⁻¹A·cov's τ column
    walk = w * _walk_sum(wz[:, 1:] @ cov[4], ts, dt)
    return LagFit(float(beta[4]), float(np.sqrt(cov[4, 4] * scale)),
                  float(np.sqrt(min(walk, cov[4, 4]) * scale)))


def _few(along):
    """Are crossings at these positions along the motion (px) too few, or too close
    together, to pin a track's velocity?"""
    return len(along) < MIN_CROSSINGS or np.ptp(along) < MIN_CROSSING_SPAN_PX


def _trusted(m, pairs, width, along, background_hz=None, t=None, dt_us=None):
    """The crossings m of a track that its refit can trust (_multi_level); none where they
    are _few and not _clean: a few crossings cannot be screened by their own spread, and a
    background event within a run splits or stretches it (a slow star's run lasts a large
    part of a second: at 0.7–1.5 °/s on a 1.5 Hz background 15 of 31 one-level crossings
    lay 0.4–2.8 px off). width: outer half-widths (µs: about half a run); along:
    positions along the motion (px); background_hz: events/pixel/s, None: unknown; t, dt_us:
    the crossings' times and the frame (µs), which keep one-level crossings where few others
    lie near (_multi_level)."""
    clean = None if t is None else _short_and_clean(width, background_hz, dt_us)
    m = _multi_level(m, pairs, t, dt_us, clean)
    if len(m) and _few(along[m]) and not _clean(width[m], background_hz):
        return m[:0]
    return m


def _clean(width, background_hz):
    """Do runs of these outer half-widths (µs) likely hold no background event (_quiet, at
    their median)? The background or widths unknown: no."""
    return background_hz is not None and bool(_quiet(np.median(width), background_hz))


def _quiet(width, background_hz):
    """Per run of outer half-width `width` (µs): background_hz × run ≤ MAX_RUN_BACKGROUND
    (NaN: no)."""
    return background_hz * 2e-6 * np.asarray(width) <= MAX_RUN_BACKGROUND


def _short_and_clean(width, background_hz, dt_us):
    """Per crossing (outer half-width µs): is its run short, under ONE_LEVEL_WIDTH frames
    (dt_us), and clean (_clean)? False for all where the background is unknown. A slow star's
    one-level pair lies where its pixel's intensity is flat for long: on evstar's simulator
    at 1–2 °/s (half-widths of 36–40 ms) they put stars 0.05 → 0.21 px and 0.24 → 0.74 px
    off; a faint star's at 250–500 px/s (3–6 ms) follow it as its other crossings do."""
    if background_hz is None:
        return np.zeros(len(width), bool)
    return (np.asarray(width) < ONE_LEVEL_WIDTH * dt_us) & _quiet(width, background_hz)


def _multi_level(m, pairs, t=None, window_us=None, clean=None):
    """The crossings m of a track less its one-level ones where enough others remain: in all
    (t None), or near each (t: crossing times, µs) — where MULTI_NEAR multi-level crossings
    of the track lie within window_us (a frame) of it, or where its run is not `clean` (per
    crossing: _short_and_clean). A single pair is the level just below the pixel's peak,
    where the intensity is flattest: a threshold mismatch or a missed level moves its
    midpoint most (0.6 px along the motion at 1–2 °/s on the paper's camera; 0.05 px at
    8 °/s). Left out over the whole track, they took with them every crossing of
    the stretches where a faint star gives one level only — where it passes pixels it
    passed before (their references sit high after its last OFF run) on a sensor whose OFF
    threshold is below its ON one, and the track then followed its centroids there (a
    telephoto sinusoid behind a low-pass, mag 5: 0.44–0.57 px after its turn)."""
    multi = pairs[m] >= 2
    if multi.sum() < MIN_CROSSINGS:
        return m
    if t is None:
        return m[multi]
    tm, tt = np.sort(t[m[multi]]), t[m]
    near = np.searchsorted(tm, tt + window_us, "right") - np.searchsorted(tm, tt - window_us)
    return m[multi | ((near < MULTI_NEAR) & clean[m])]


#: a pixel this many centroid spreads (≈ 1.4 σ_PSF for a slow star) from a turn may see
#: both passages as one
TURN_SPREADS = 2.0


def _turn_radius(centroids, track):
    """TURN_SPREADS × the median spread of the track's centroids (px)."""
    c = track["centroid"][track["centroid"] >= 0]
    spread = centroids["spread"][c] if len(c) else np.zeros(0)
    spread = spread[np.isfinite(spread)]
    return TURN_SPREADS * float(np.median(spread)) if len(spread) else 0.0


def _turns(track, radius):
    """(t_lo, t_hi, x, y) of each place where the track reverses (consecutive velocities
    opposed; its slower row), t_lo–t_hi the time the track stays within 2·radius of it."""
    v = np.column_stack([track["vx"], track["vy"]])
    pos = np.column_stack([track["x"], track["y"]])
    out = []
    for i in np.flatnonzero(np.sum(v[1:] * v[:-1], axis=1) < 0) if radius > 0 else ():
        i = i if np.hypot(*v[i]) <= np.hypot(*v[i + 1]) else i + 1
        lo, hi = _run_around(np.hypot(*(pos - pos[i]).T) < 2 * radius, i)
        out.append((track["t"][lo], track["t"][hi], *pos[i]))
    return out


def _single_passes(m, t_c, q_c, turns, radius):
    """The crossings m (into t_c, q_c) less those of pixels within `radius` of a turn
    (_turns) in its time: the star passes such a pixel, turns and passes it again before its
    intensity has fallen, so the one rise and fall mark the turn's time, not a passage (the
    estimate then cut the turn by ~0.3 px on a 10°/1 Hz sinusoid, PSF σ 1.5 px)."""
    if not turns:  # most tracks: no gather of their crossings
        return m
    t, q = t_c[m], q_c[m]
    keep = np.ones(len(m), bool)
    for t_lo, t_hi, x, y in turns:
        keep &= ~((t >= t_lo) & (t <= t_hi) & (np.hypot(q[:, 0] - x, q[:, 1] - y) < radius))
    return m[keep]


def _in_turns(t, turns):
    """Per time t: does it lie in a turn's time (_turns), where the crossings cannot tell
    the passages (_single_passes) and the star is slow?"""
    inside = np.zeros(len(t), bool)
    for t_lo, t_hi, _, _ in turns:
        inside |= (t >= t_lo) & (t <= t_hi)
    return inside


def _debiased(track, fitted, along_weight, balanced, lagging, crossing_lag_s=None):
    """(track with its centroids moved by their along-motion offset from `fitted`, their along
    weights: 1 in the turns' time for those `balanced` (bool per centroid: both lobes,
    evstar.lobes.balanced), along_weight elsewhere), or None where that offset's model does
    not explain them. A moving star's per-frame mean trails it by a near-constant amount a
    (ON events lead, OFF events trail; 0.08 px at PSF σ 1, 0.16 at 1.5 on the paper's
    camera from 50 to 700 px/s) and, behind a pixel low-pass, by a lag τ in time. Measured
    on the balanced centroids outside the turns as a + b·speed (_speed_terms, b = −τ), each
    centroid is moved by a along the motion and by the fitted track's displacement over τ
    (at a turn a lag is no speed × τ: the star there is slow and swings back). The turns,
    where crossings cannot tell, then take the centroids in, but for lone lobes (~1.7 σ_PSF
    ahead of the star or behind it: a faint star's frames at a slow turn often are one;
    trusted, a mag-5 star overshot a low-pass sinusoid's turn by 1.7 px); not at all where
    the calm centroids scatter about the model by over _BIAS_FIT_SIGMAS times their σ (a
    dark sky's fast stars trail by a lag that changes with speed: trusted, their 20 °/s
    sinusoid's turns went 2–3 px off). Where too few calm centroids measure it, they weigh
    fully unmoved, unless `lagging` (a pixel lag corrected in the crossings: the centroids
    carry it, unmeasured)."""
    full, z, s_cent, crossings, turns = track
    rows = fitted[~fitted["coasted"]]
    v = np.column_stack([rows["vx"], rows["vy"]])
    speed = np.hypot(v[:, 0], v[:, 1])
    u = v / np.maximum(speed, 1e-9)[:, None]
    turning = _in_turns(rows["t"], turns)
    w = np.where(turning & balanced, 1.0, along_weight)
    pos = np.column_stack([rows["x"], rows["y"]])
    off = np.sum((z - pos) * u, axis=1)
    calm = ~turning & balanced & (s_cent < _IGNORED_SIGMA)
    if calm.sum() < _MIN_BIAS_ROWS or np.ptp(speed[calm]) == 0:
        # too few to measure: a pixel's lag is unknown then, a lobe offset is small
        return None if lagging else ((full, z, s_cent, crossings, turns), w)
    sigma = np.median(s_cent[calm])
    a, b = _speed_terms(speed[calm], off[calm], sigma,
                        None if crossing_lag_s is None else -crossing_lag_s)
    scatter = np.sqrt(np.mean((off[calm] - a - b * speed[calm]) ** 2))
    if scatter > _BIAS_FIT_SIGMAS * sigma:
        return None
    return (full, z - _moved(fitted, rows, b) - a * u, s_cent, crossings, turns), w


def _moved(fitted, rows, b):
    """(n, 2) the displacement of the track `fitted` from each of its rows' times t to
    t + b (s): where the star was when a centroid's events, lagging by −b, say; speed × b
    beyond the fit's ends."""
    t, t_fit = rows["t"].astype(np.float64), fitted["t"].astype(np.float64)
    then = t + b * 1e6
    moved = np.column_stack([np.interp(then, t_fit, fitted["x"]) - rows["x"],
                             np.interp(then, t_fit, fitted["y"]) - rows["y"]])
    beyond = (then < t_fit[0]) | (then > t_fit[-1])
    moved[beyond] = b * np.column_stack([rows["vx"], rows["vy"]])[beyond]
    return moved


#: without an IMU, a track is refitted for its speed change only where its first fit's
#: speed at its crossings spans this factor (a slow faint star's at a constant rate wandered
#: by up to 1.3: 18–23 px/s, its crossings moved by up to 0.14 px, and following that noise
#: took the grid's constant-rate rows 0.002–0.015 px either way) ...
SPEED_CHANGE_RATIO = 1.5
#: ... and its crossings move by at least this (px along the motion)
_SPEED_CHANGE_REFIT_PX = 0.01
#: fits of such a track with its crossings moved by the last one's path (converged by 2 on
#: fresh-40's slews: 4 and 8 changed them by < 0.001 px)
ACCEL_PASSES = 2
_NEWTON_STEPS = 3        # ... solving for the passing time (converged to < 1 µs by 3)
#: an acceleration refit is kept only where its measured rows from the track's first
#: crossing on lie within this of the constant-velocity fit's (_departure; which they leave
#: by 0.6-1.0 px at a single star's slew ends, by a median 0.6 on an Orion DAVIS346 8 mm
#: slew field), where a close pair's mixed crossings had let it take a track 2.5 px off its
#: stars; the others keep the constant-velocity refit (_refit_on_first_fit)
MAX_ACCEL_DEPARTURE_PX = 1.5


def _speeds_change(track, rows):
    """Whether a track without a velocity prior is refitted for its speed change: it never
    reverses, has MIN_CROSSINGS crossings, and its first fit's speed at them spans
    SPEED_CHANGE_RATIO."""
    t_c, turns = track[3][0], track[4]
    if rows is None or turns or len(t_c) < MIN_CROSSINGS:
        return False
    speed = _speed_at(rows, t_c)
    return speed.max() >= SPEED_CHANGE_RATIO * speed.min()


def _departure(rows, other, t_cross=()):
    """The largest distance (px) between a track's measured `rows` and another fit of it
    (`other`, interpolated to their times), from its first crossing on (`t_cross` µs, if
    any): before it a constant-velocity fit only extrapolates, and where the star starts
    from rest there it was 1.4–1.6 px behind, the acceleration fit on it (perf/study_indep.py
    --fresh5 L6: departures of 1.85 and 1.95 px, all of it before the first crossing). After
    the last crossing the check stays: left out there too, the common error of Cygnus
    DVXplorer 8 mm field slews at 8 °/s went 0.042–0.058 -> 0.077–0.099 px."""
    m = rows["source"] == MEASURED
    if len(t_cross):
        m &= rows["t"] >= np.min(t_cross)
    if not m.any():
        return 0.0
    t, t_other = rows["t"][m].astype(np.float64), other["t"].astype(np.float64)
    return float(np.max(np.hypot(rows["x"][m] - np.interp(t, t_other, other["x"]),
                                 rows["y"][m] - np.interp(t, t_other, other["y"]))))


def bracketed(rows):
    """Per row: whether it is a coasted row of a track that has rows of the other sources
    (measured, pooled) both before and after it."""
    out = np.zeros(len(rows), bool)
    tracked = np.flatnonzero(rows["track"] >= 0)
    if not len(tracked):
        return out
    order = tracked[np.lexsort((rows["t"][tracked], rows["track"][tracked]))]
    tr, seen = rows["track"][order], rows["source"][order] != COASTED
    start = np.r_[True, tr[1:] != tr[:-1]]
    group = np.cumsum(start) - 1
    idx = np.arange(len(order))
    # the last seen row at or before each position, and the first at or after, in its track
    before = np.maximum.accumulate(np.where(seen, idx, -1))
    after = np.minimum.accumulate(np.where(seen, idx, len(order))[::-1])[::-1]
    ok_b = (before >= 0) & (group[np.clip(before, 0, None)] == group)
    ok_a = (after < len(order)) & (group[np.clip(after, None, len(order) - 1)] == group)
    out[order] = ~seen & ok_b & ok_a
    return out


def _with_larger_sigma(rows, other):
    """`rows` with each σ the larger of theirs and `other`'s (another fit of the same
    track, interpolated to their times): an acceleration fit's own σ, from a model that
    holds only approximately (a slew's acceleration turns into deceleration at once),
    came out too small — 80 % of an EVK4 slew field's rows within 2.45 σ where the
    constant-velocity fit's σ held 96 % (perf/study_field.py --motion slew). Not the rows
    coasted before or after the refit's measured ones: they are that model's extrapolation,
    whose own σ held their errors on slews from and to rest (error/σ ≤ 0.9) where the
    constant-velocity fit's, over coast_sigma_px, dropped them (perf/study_accuracy.py's
    slews without IMU: frames 94–98 -> 96–100 %)."""
    out = rows.copy()
    t, t_other = rows["t"].astype(np.float64), other["t"].astype(np.float64)
    ends = (rows["source"] == COASTED) & ~bracketed(rows)
    for f in ("sigma_x", "sigma_y"):
        out[f] = np.where(ends, rows[f], np.maximum(rows[f], np.interp(t, t_other, other[f])))
    return out


def _main_direction(rows):
    """A track's unit direction of motion: its rows' summed velocity."""
    v = np.array([rows["vx"].sum(), rows["vy"].sum()])
    n = np.hypot(*v)
    return v / n if n > 0 else np.array([1.0, 0.0])


def _turned(problem, u):
    """A kalman.CVProblem in the frame (along u, across it)."""
    rot = np.array([[u[0], u[1]], [-u[1], u[0]]])
    return problem._replace(z=problem.z @ rot.T, R=rot @ problem.R @ rot.T)


def _unturned(x, P, u):
    """States (x, vx, y, vy) and covariances of _turned's frame back in the image's."""
    M = np.array([[u[0], 0, -u[1], 0], [0, u[0], 0, -u[1]], [u[1], 0, u[0], 0],
                  [0, u[1], 0, u[0]]])
    return x @ M.T, M @ P @ M.T


def _speed_at(rows, t):
    """A track's speed (px/s) at times t, its rows' velocities linear between them."""
    return np.hypot(np.interp(t, rows["t"], rows["vx"]), np.interp(t, rows["t"], rows["vy"]))

#: fewest centroids outside a track's turns that measure its centroids' along bias
_MIN_BIAS_ROWS = 5
#: t statistic a bias's speed term needs (else the bias is the offsets' median), and one
#: within 2 SE of the crossings' measured lag
_BIAS_SLOPE_T = 3.0
_BIAS_SLOPE_T_AGREEING = 2.0
#: most RMS scatter of a track's calm centroids about their bias model, in their median σ,
#: for the model to be trusted at the turns (honest σ: ~1; the low-pass sinusoids of
#: perf/study_indep.py it helps: 0.7–1.1; the dark-sky 20 °/s Scorpius field's tracks 1.1–3.2,
#: whose isolated stars went 0.271 -> 0.295 px at 2, 0.257 at 1.5)
_BIAS_FIT_SIGMAS = 1.5


def _speed_terms(s, off, sigma, expected_b=None):
    """(a, b) of the along offsets `off` at speeds `s` as a + b·speed, where b is significant
    (|b| ≥ _BIAS_SLOPE_T standard errors, or _BIAS_SLOPE_T_AGREEING where it lies within 2 of
    `expected_b`, minus the lag the track's crossings were moved back by: scene 22 of
    perf/study_indep.py, 2.9 SE, its bright star's turns 0.51 -> 0.39 px) and the line's
    value at rest, a, is known to within
    `sigma` (the centroids' σ); else (their median, 0). A turn's speeds lie below the
    fitted ones: a line through a narrow range of noisy speeds, extended to them, moved a
    small sinusoid's centroids by up to 9 px (a low-pass sinusoid's 113–190 px/s: a = 3.8
    px, b = −24 ms)."""
    b, a = np.polyfit(s, off, 1)
    n = len(s)
    sxx = np.sum((s - s.mean()) ** 2)
    res = np.sqrt(np.sum((off - a - b * s) ** 2) / (n - 2)) if n > 2 else np.inf
    se_b = res / np.sqrt(sxx)
    se_a = res * np.sqrt(1.0 / n + s.mean() ** 2 / sxx)
    # a slope that agrees with the lag the crossings were moved back by (expected_b = −lag)
    # needs less evidence of its own: the pixels' lag is what the centroids carry too
    agrees = expected_b is not None and abs(b - expected_b) <= 2 * se_b
    if se_a <= sigma and abs(b) >= (_BIAS_SLOPE_T_AGREEING if agrees else _BIAS_SLOPE_T) * se_b:
        return float(a), float(b)
    return float(np.median(off)), 0.0


def _run_around(flags, i):
    """(first, last) index of the run of True flags holding index i."""
    breaks = np.flatnonzero(~flags)
    lo = breaks[breaks < i].max(initial=-1) + 1
    hi = breaks[breaks > i].min(initial=len(flags)) - 1
    return lo, hi


def _speed_change_corrected(t_c, h, q, u, resid, track, lag_us=0.0, exact=False):
    """Crossing times moved to when the star passed each pixel where its speed changes, and
    their along-track residuals with them. A level pair's flanks are where the star was
    equally far before and past the pixel, so it passed the pixel when its position along
    the motion was the mean of its positions at the two flank times: the flanks' mean time
    only at a constant speed (slowing down, the star reaches the far flank late; on a 1 Hz
    sinusoid at 60 px/s that put a field's stars 0.1–0.25 px off). The track's smoothed
    rows give that position (an offset of theirs cancels) and when it was reached; a
    crossing's flanks are ± h, its pairs' RMS half-width (q: the crossings' pixels, u: the
    motion's direction at each, lag_us: the pixel lag already taken off). Only where the
    star keeps its direction and its speed within a factor 1.5 over the passage and
    within the track's rows; in a turn's time too (the pixels a turn merges into one
    crossing are gone: _single_passes; excluding its whole time left the crossings
    nearest it, whose flanks differ most, uncorrected: IMU-compensated DAVIS346 8 mm
    sinusoids 0.036–0.049 -> 0.023–0.039 px). `track`: the prior-informed smoothed rows
    where there is a velocity prior; without one, the track's first fit with the crossings
    (TrackSmoother._refit_speed_changes, _turn_flanks_corrected): the centroids' smoothed
    speed of a slow faint star wanders by ±25 % on a constant-rate slew, and following
    that bend moved its crossings by noise (0.13 → 0.17 px). exact: `track` is a
    constant-acceleration fit (TrackSmoother._refit_speed_changes): the passing time solved
    on its path (Newton steps, not the first-order shift), wherever the star keeps its way
    over the flanks (a star speeding up from rest doubles its speed across one pixel's
    flanks, one slowing to rest reaches the far flank at a tenth of it: left unmoved there,
    below a fifth, a 14 °/s DAVIS346 slew's last rows trailed by up to 1.5 px) and the
    solution lies within them; not where the fit turns back (its model run past a stop)."""
    ts = track["t"].astype(np.float64)
    if len(ts) < 3 or np.any(np.diff(ts) <= 0):
        return t_c, resid
    at = lambda t, f: np.interp(t, ts, track[f])
    # positions along the motion from the rows' velocities, linear between rows (their
    # positions, linear between rows, would hold no bend within 10 ms)
    along = lambda t: _integral(ts, track["vx"], t) * u[:, 0] + _integral(ts, track["vy"], t) * u[:, 1]
    speed = lambda t: at(t, "vx") * u[:, 0] + at(t, "vy") * u[:, 1]
    v = speed(t_c)
    # a flank lies no farther along the motion than the star reaches across it (its crossed
    # pixels' farthest offset from the track, plus half a pixel): a pixel low-pass stretches
    # the pairs' times, not the distances (on a fast dark-sky sinusoid the RMS half-width
    # was mostly that stretch)
    reach = np.abs((q[:, 0] - at(t_c, "x")) * u[:, 1] - (q[:, 1] - at(t_c, "y")) * u[:, 0]).max() + 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        passage = reach / np.abs(v) * 1e6                 # µs the star takes to cross its reach
        h = np.minimum(h, passage)
        target = 0.5 * (along(t_c - h) + along(t_c + h))
        shift = (target - along(t_c)) / v * 1e6     # µs
        for _ in range(_NEWTON_STEPS if exact else 0):
            shift = shift - (along(t_c + shift) - target) / speed(t_c + shift) * 1e6
    # where the pixel lags longer than that passage, the pairs time the pixel's response,
    # not the flanks (a fast dark-sky sinusoid on an EVK4: 0.30 px without the correction,
    # 0.31 with it there too)
    ok = (np.isfinite(shift) & (t_c - h >= ts[0]) & (t_c + h <= ts[-1]) & (lag_us <= passage))
    for side in (speed(t_c - h) / v, speed(t_c + h) / v):
        # on the fit's path: wherever the star keeps going the same way over the passage
        ok &= (side > 0) if exact else (side >= 0.5) & (side <= 1.5)
    if exact:
        ok &= np.abs(shift) <= h
    shift = np.where(ok, shift, 0.0)
    return t_c + shift, resid - v * shift * 1e-6


def _flank_corrected(track, flank, rows, exact=False):
    """(the _fit_along track tuple with its crossings moved by _speed_change_corrected on
    `rows`, the moved times); flank: the crossings' (RMS half-widths, lags µs)."""
    full, z, s_cent, cr, turns = track
    t_new, r_new = _speed_change_corrected(cr[0], flank[0], cr[1], cr[2], cr[3], rows, flank[1],
                                           exact)
    return (full, z, s_cent, (t_new, *cr[1:3], r_new, *cr[4:]), turns), t_new


def _integral(ts, f, t):
    """∫ f from ts[0] to t (µs·unit / 1e6: px for px/s) of f linear between the knots ts
    (constant beyond them)."""
    span = np.diff(ts) * 1e-6
    knots = np.r_[0.0, np.cumsum(0.5 * (f[1:] + f[:-1]) * span)]
    i = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2)
    d = (np.clip(t, ts[0], ts[-1]) - ts[i]) * 1e-6
    slope = (f[i + 1] - f[i]) / span[i]
    return knots[i] + f[i] * d + 0.5 * slope * d * d


def lag_corrected(t_c, pairs, width, resid, track, pixel_lag):
    """Crossing times moved back by the calibrated lag at each one's brightness (level pairs),
    outer half-width and the track's speed, and their along-track residuals moved with them."""
    speed = _speed_at(track, t_c)
    lag_us = pixel_lag.lag_at(pairs, speed, width)
    return t_c - lag_us, resid + speed * lag_us * 1e-6, lag_us


def _class_scatter(r, levels, floor):
    """Per crossing, the median and robust σ (1.4826 × MAD, at least `floor`) of the
    residuals `r` of its class: one-level and multi-level crossings apart where `levels`
    (pairs per crossing) is given and each class has 3, else all together. A slow star's
    one-level crossings are the noisy ones: a background event within its long passage
    splits a pixel's run into fragments whose single pairs sit off its peak (at 1 °/s, PSF
    σ 1.5 px: their residuals' MAD 2–8× the multi-level ones')."""
    classes = [np.ones(len(r), bool)]
    if levels is not None:
        one = np.asarray(levels) < 2
        if 3 <= one.sum() <= len(r) - 3:
            classes = [one, ~one]
    med, s = np.zeros(len(r)), np.zeros(len(r))
    for c in classes:
        med[c] = np.median(r[c])
        s[c] = max(robust_sigma(r[c], med[c]), floor)
    return med, s


def _pool_crossings(t_c, q, u, est, s_a, pool_us):
    """Crossings binned by `pool_us`: per bin one measurement at the bin's weighted mean
    time, its along position the weighted mean of the crossings' moved there with the
    track's speed midway between the two times (the crossings of a bin lie along one short
    stretch of the motion; each one's own speed moved them by a·Δt² too little, which put
    the bin a·var(Δt)/2 behind a speeding star: 0.06 px on an EVK4 12 mm 10°/1 Hz
    sinusoid), each crossing weighted by 1/σ² (s_a: its σ), the bin's σ = (Σ 1/σ²)^-½."""
    b = np.floor(t_c / pool_us).astype(np.int64)
    if np.all(b[1:] >= b[:-1]):   # time-sorted (the common case): np.unique's inverse, no sort
        inv = np.r_[0, np.cumsum(b[1:] != b[:-1])]
    else:
        _, inv = np.unique(b, return_inverse=True)
    w = 1.0 / s_a ** 2
    n = np.bincount(inv, w)
    t_mean = np.bincount(inv, w * t_c) / n
    u_mean = np.column_stack([np.bincount(inv, u[:, 0]), np.bincount(inv, u[:, 1])])
    u_mean /= np.maximum(np.linalg.norm(u_mean, axis=1, keepdims=True), 1e-12)
    # along positions relative to the track at the bin's time, on the bin's one direction
    # (projecting absolute pixel coordinates on slightly different directions would not do)
    t_est = est["t"].astype(np.float64)   # as np.interp converts it, once for its four calls
    pos = np.column_stack([np.interp(t_mean, t_est, est["x"]), np.interp(t_mean, t_est, est["y"])])
    t_in = t_mean.take(inv)
    mid = 0.5 * (t_c + t_in)
    speed = np.hypot(np.interp(mid, t_est, est["vx"]), np.interp(mid, t_est, est["vy"]))
    p_in, u_in = pos.take(inv, 0), u_mean.take(inv, 0)
    # the dot product column by column (its sum's arithmetic but for the sign of a zero,
    # which the bin sums below drop)
    along = ((q[:, 0] - p_in[:, 0]) * u_in[:, 0] + (q[:, 1] - p_in[:, 1]) * u_in[:, 1]
             - speed * (t_c - t_in) * 1e-6)
    a_mean = np.bincount(inv, w * along) / n
    return t_mean, pos + u_mean * a_mean[:, None], u_mean, 1.0 / np.sqrt(n)


def _covariances(u, s_along, s_cross):
    """(n, 2, 2) covariances with σ s_along along the unit vectors u and s_cross across."""
    n = np.column_stack([-u[:, 1], u[:, 0]])
    return (s_along[:, None, None] ** 2 * u[:, :, None] * u[:, None, :]
            + s_cross[:, None, None] ** 2 * n[:, :, None] * n[:, None, :])


def prior_velocity(prior, t_us, x, y):
    if prior is None:
        return np.zeros((len(t_us), 2))
    v = np.asarray(prior(np.asarray(t_us), np.asarray(x, float), np.asarray(y, float)), float)
    if v.shape != (len(t_us), 2) or not np.all(np.isfinite(v)):
        raise ParameterError(f"velocity_prior must return finite (n, 2) px/s, got shape {v.shape}")
    return v


def prior_displacement(prior, t_all, t_meas, z):
    """(n, 2) px the prior moves a star from t_all[0] to each t_all: the trapezoid rule on
    a grid of at most _PRIOR_STEP_S (so a prior from noisy gyro samples is averaged over
    each interval, not read at its two ends), along the measured positions interpolated."""
    return prior_displacements(prior, [(t_all, t_meas, z)])[0]


def prior_displacements(prior, runs):
    """prior_displacement of each (t_all, t_meas, z) of `runs`, the prior asked once a round."""
    return _batched([_displacement(prior, *run) for run in runs], prior)


def _displacement(prior, t_all, t_meas, z):
    """prior_displacement as a _batched step."""
    if prior is None:
        return np.zeros((len(t_all), 2))
    t = np.asarray(t_all, float)
    n_sub = np.maximum(np.ceil(np.diff(t) * 1e-6 / _PRIOR_STEP_S), 1).astype(np.int64)
    starts = np.r_[0, np.cumsum(n_sub)]            # node index of each t_all on the fine grid
    frac = np.arange(starts[-1]) - np.repeat(starts[:-1], n_sub)
    fine = np.r_[np.repeat(t[:-1], n_sub) + frac * np.repeat(np.diff(t) / n_sub, n_sub), t[-1:]]
    v = yield from _velocity(prior, fine, np.interp(fine, t_meas, z[:, 0]),
                             np.interp(fine, t_meas, z[:, 1]))
    steps = (v[1:] + v[:-1]) / 2 * (np.diff(fine) * 1e-6)[:, None]
    return np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])[starts]


def _velocity(prior, t_us, x, y):
    """prior_velocity as a _batched step: yields the query (t_us, x, y), is sent the answer."""
    if prior is None:
        return np.zeros((len(t_us), 2))
    return (yield np.asarray(t_us), np.asarray(x, float), np.asarray(y, float))


def _batched(steps, prior):
    """The return values of generators that yield velocity-prior queries (t_us, x, y) and are
    sent prior_velocity's answers: each round's queries of all in one call (a prior's cost
    is mostly per call, and the answer for a point does not depend on the others)."""
    out, answer = [None] * len(steps), [None] * len(steps)
    todo = list(range(len(steps)))
    while todo:
        live, queries = [], []
        for i in todo:
            try:
                queries.append(steps[i].send(answer[i]))
                live.append(i)
            except StopIteration as done:
                out[i] = done.value
        if live:
            v = prior_velocity(prior, *(np.concatenate(c) for c in zip(*queries)))
            cuts = np.cumsum([len(q[0]) for q in queries])[:-1]
            for i, part in zip(live, np.split(v, cuts)):
                answer[i] = part
        todo = live
    return out


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
    from .motion.imu_integration import gyro_at

    from .camera import unit

    gyro = gyro_at(imu)

    def prior(t_us, x, y):
        # column by column (np.cross's and np.linalg.norm's arithmetic, without their
        # (n, 3) temporaries: this runs on every crossing of every track)
        ox, oy, oz = gyro(t_us).T
        dx, dy, dz = unit(*camera.unproject_columns(np.asarray(x, float), np.asarray(y, float)))
        h = 1e-4   # s: a step small against any slew, large against rounding
        u1, v1 = camera.project_turned(dx, dy, dz, ox, oy, oz, h)
        u0, v0 = camera.project_columns(dx, dy, dz)
        return np.column_stack([(u1 - u0) / h, (v1 - v0) / h])

    return prior


def gyro_noise_density(imu):
    """The gyro's white-noise density (rad/s/√Hz) per camera axis, measured from its samples:
    their second differences' robust spread (gyro_repair.rate_noise) over the median sample
    rate. A gyro low-passed on chip before it is sampled reads low
    (set estimate.gyro_noise from its datasheet then)."""
    from .gyro_repair import rate_noise

    g = imu.gyro_cam
    if len(g) < 3:
        return np.zeros(3)
    return rate_noise(g) * np.sqrt(float(np.median(np.diff(imu.t))) * 1e-6)


def imu_diffusion(imu, camera, density=None):
    """The random-walk density (px²/s) of imu_velocity_prior's integrated displacement: the
    gyro's white noise n (rad/s/√Hz per camera axis; `density`, else gyro_noise_density)
    turns the image by f·n about x and y, ((fx·n_y)² + (fy·n_x)²) / 2 per image axis (a
    1.2·10⁻⁴ rad/s/√Hz MEMS gyro at f = 3292 px: 0.16 px²/s; its roll term, r·n_z at
    radius r, is left out)."""
    n = gyro_noise_density(imu) if density is None else np.full(3, float(density))
    return float(((camera.fx * n[1]) ** 2 + (camera.fy * n[0]) ** 2) / 2)


def smooth(centroids, dt_us=10_000, t0_us=None, velocity_prior=None, sigma=None, **params):
    """TrackSmoother(dt_us, **params).smooth(centroids, t0_us, velocity_prior, sigma)."""
    return TrackSmoother(dt_us, **params).smooth(centroids, t0_us, velocity_prior, sigma)
