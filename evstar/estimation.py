"""Star positions from linked centroids, as the [estimate] section of evstar.Config says.

* ``mean``: the per-frame centroids as they are (the paper's estimator), each with its
  measurement σ.
* ``track``: every confirmed track through the Kalman filter + RTS smoother of
  :mod:`evstar.smoothing` (pooled over frames; frames without a centroid coasted).
* ``crossings`` (default): the same smoother also fed with the times the star's centre
  passed each pixel (:mod:`evstar.crossings`) as measurements along the motion, where the
  per-frame mean of a moving star's events is biased by its ON/OFF lobes.

The result has the centroid layout (:data:`evstar.extract.CENTROID_DTYPE`): one row per
measured frame of a track (its position at the centroid's time; ``source`` "pooled" where
the centroid pooled several frames, evstar.pooling) and per coasted frame (``source``
"coasted", at the frame's mid-time), plus the unconfirmed frame centroids as measured.
"""
from __future__ import annotations

import numpy as np

from . import assignment, lobes, pieces, vibration
from .bursts import bunched, burst_tracks
from .crossings import CROSSING_DTYPE, dilate, sorted_crossings
from .errors import FormatError
from .extract import CENTROID_DTYPE
from .hotpixels import still_tracks
from .parameters import AUTO, MIN_ALPHA
from .tracking import BLENDED

#: keyword arguments of TrackSmoother among the [estimate] settings
_SMOOTHER_KEYS = ("process_noise", "process_noise_min", "coast_ms", "sigma_floor_px",
                  "psf_sigma_px", "min_events", "outlier_sigma", "coast_ends", "coast_gyro_ms",
                  "speed_change")


def track_smoother(config, **overrides):
    """The TrackSmoother of the [estimate] settings (and `overrides` of them), its fits
    coasting coast_ms everywhere (the gyro's farther ends come after: _gyro_coasted)."""
    from .smoothing import TrackSmoother

    e = config.estimate
    params = {k: getattr(e, k) for k in _SMOOTHER_KEYS}
    return TrackSmoother(config.dt_us, **{**params, "coast_gyro_ms": e.coast_ms, **overrides})


def pixel_lag(path):
    """The PixelLag of an `evstar calibrate` file (None for none), read once per version of
    the file (FormatError naming it when it is missing or not one)."""
    if path is None:
        return None
    import os

    from .calibration import PixelLag

    try:
        st = os.stat(path)
    except OSError as e:
        raise FormatError(path, f"cannot read the pixel-lag file ({e.strerror})") from None
    key = (os.path.abspath(path), st.st_mtime_ns, st.st_size)
    if key not in _LAG_FILES:
        _LAG_FILES[key] = PixelLag.load(path)
    return _LAG_FILES[key]


_LAG_FILES = {}


def chunk_crossings(events, keep, radius_px, threshold_ratio=AUTO, with_ratio=False,
                    refractory_us=0.0, profiles=None, fallback_ratio=1.0, order=None,
                    background_hz=None):
    """Pixel crossings of all events within `radius_px` of a kept event: a density filter
    drops a faint star's flank events, which the level pairs need. keep: bool per event, or
    the kept events' ascending indices (frames.kept_indices). threshold_ratio: the
    sensor's C_off / C_on or "auto" (evstar.crossings.threshold_ratio_of); refractory_us:
    the pixels' refractory period (evstar.crossings.sorted_crossings). with_ratio: return
    (crossings, the ratio used). profiles: an evstar.level_lag.LevelProfiles to feed;
    order: an evstar.pixel_order.PixelOrder to feed. background_hz: the background's rate
    (events / pixel / s), whose events in the runs a measured ratio discounts, split by
    polarity as the events away from the stars are (evstar.crossings.background_rates);
    None: not."""
    near, rates = _near_kept(events, keep, radius_px, order, background_hz, profiles)
    if near is None:
        none = np.zeros(0, CROSSING_DTYPE)
        return (none, None if threshold_ratio == AUTO else threshold_ratio) if with_ratio else none
    return sorted_crossings(*near, events.width, threshold_ratio=threshold_ratio,
                            with_ratio=with_ratio, refractory_us=refractory_us,
                            profiles=profiles, fallback_ratio=fallback_ratio,
                            background_hz=rates)


def chunk_crossings_both(events, keep, radius_px, refractory_us, ratios=(AUTO, AUTO),
                         profiles=None, fallback_ratio=1.0, order=None, background_hz=None):
    """chunk_crossings both ways from one gathering of the events: ((crossings paired with
    the pixels' refractory period, their threshold ratio), (the crossings paired as without
    one, theirs)) — each ratio the one given in `ratios` (refractory, plain) or measured with
    that pairing's levels (None where too few changes measure it, fallback_ratio used);
    `profiles` takes the plain pairs' levels. Behind a pixel low-pass a run takes the plain
    ones: they are what a run told no period finds (_RunState.crossings). order and
    background_hz: as chunk_crossings takes them."""
    near, rates = _near_kept(events, keep, radius_px, order, background_hz, profiles)
    if near is None:
        none = np.zeros(0, CROSSING_DTYPE)
        return tuple((none, None if r == AUTO else r) for r in ratios)
    told = sorted_crossings(*near, events.width, threshold_ratio=ratios[0], with_ratio=True,
                            refractory_us=refractory_us, fallback_ratio=fallback_ratio,
                            background_hz=rates)
    plain = sorted_crossings(*near, events.width, threshold_ratio=ratios[1], with_ratio=True,
                             profiles=profiles, fallback_ratio=fallback_ratio,
                             background_hz=rates)
    return told, plain


def _near_kept(events, keep, radius_px, order=None, background_hz=None, profiles=None):
    """((t, pixel key, p) of the events within `radius_px` (square) of a kept event (keep:
    as chunk_crossings takes it), in the pixel-then-time order, fed to `order` (a
    PixelOrder, or None) and to `profiles`' passages (LevelProfiles.add_passages; None:
    not), and the (ON, OFF) rates of a background of `background_hz` (None: None)); (None,
    None) where none is kept."""
    from .crossings import background_rates
    from .frames import events_by_pixel, kept_indices, kept_pixels

    keep = kept_indices(keep)
    if not len(keep):
        return None, None
    mask = dilate(kept_pixels(events, keep), radius_px)
    near = events_by_pixel(events, mask)
    if order is not None:
        order.add(*near)
    if profiles is not None:
        profiles.add_passages(*near)
    return near, (None if background_hz is None else background_rates(events, mask, background_hz))


def velocity_prior(config, imu, camera, t_events, filter_result=None):
    """The gyro's image velocity (evstar.smoothing.imu_velocity_prior) when the run
    compensates with the IMU (an IMU that only came along in the file is not trusted with
    it), bias-corrected by the particle filter's result if there is one, carrying the random
    walk its integral makes (estimate.gyro_noise: measured from the gyro's samples unless
    set; evstar.smoothing.imu_diffusion); else None."""
    if config.motion.compensate == "none" or imu is None or camera is None or not len(t_events):
        return None
    from .motion import hold_ends
    from .smoothing import imu_diffusion, imu_velocity_prior, with_diffusion

    if filter_result is not None:
        imu = filter_result.corrected_imu(imu, causal=config.motion.causal)
    imu = hold_ends(imu, int(t_events[0]), int(t_events[-1]), config.motion.extrapolate_us)
    density = config.estimate.gyro_noise
    return with_diffusion(imu_velocity_prior(imu, camera),
                          imu_diffusion(imu, camera, None if density == AUTO else density))


def estimate(centroids, config, t0_us, crossings=None, velocity_prior=None, span_us=None,
             sensor=None, measured_lag=None, rate_hz=None, near=None, report=None, stalls=None,
             depth_delay_us=0.0):
    """CENTROID_DTYPE rows for linked `centroids` (see the module docstring). Coasted rows
    outside the recording's time span `span_us` (first, last event µs) or the `sensor`
    (width, height) are dropped: there is no star to report there. measured_lag: the
    pixels' lag from the data (evstar.level_lag), used where no pixel_lag_file is given.
    rate_hz: the measured background rate (events/pixel/s), for untracked_alpha. near:
    (t, x, y) of the events near the stars, hot pixels out, for the tracks' positions
    across their motion (evstar.across; needs `sensor`). Where no velocity prior carries a
    track, a track's or a field's vibration is found and followed (evstar.vibration;
    estimate.vibration); a `report` dict gets its summary under "vibration" (vibration.summary).
    stalls: (n, 2) µs spans the readout sent nothing in (frames.stalls): a track is
    smoothed in pieces across them (evstar.pieces). depth_delay_us: how much later the
    crossings' deepest levels pass than their top (evstar.level_lag.LevelProfiles
    .depth_delay_us): where no lag moves the crossings and no gyro pins them, the rows' σ
    holds it as the unknown lag's scale (UNMEASURED_LAG_SHARE)."""
    args = (config, t0_us, crossings, velocity_prior, span_us, sensor, measured_lag, rate_hz,
            near, stalls, depth_delay_us)
    rows, est, kept, carried = _estimate(centroids, *args)
    # a gyro prior that carries a track carries the platform's motion; one that carries
    # none (a gyro too noisy to beat a straight track, or on another clock) leaves the
    # vibration to be sought as without it (fresh-56's 30 Hz vibration along the motion
    # under a gyro 50x the default noise: 0.221 px)
    if est is None or carried or not config.estimate.vibration:
        return rows
    found = vibration.found(est, kept, config.dt_us)
    if not found:
        return rows
    args = (config, t0_us, None if crossings is None else
            vibration.crossings_removed(crossings, est, found)) + args[3:]
    again, est, _, _ = _estimate(vibration.removed(centroids, est, found), *args)
    if est is None:   # (the same tracks: never; kept as the first pass's)
        return rows
    rows, found = again, vibration.refit(est, kept, found, crossings)
    if report is not None:
        report["vibration"] = vibration.summary(found)
    return vibration.added(rows, est, found)


def _estimate(centroids, config, t0_us, crossings, velocity_prior, span_us, sensor,
              measured_lag, rate_hz, near, stalls=None, depth_delay_us=0.0):
    """estimate's rows, the smoothed rows (ESTIMATE_DTYPE) of its tracks and the centroids
    they index (None, None where no track is smoothed), and whether the velocity prior
    carries a track."""
    # a pooled centroid no track took is noise that once pooled into a cluster
    # (evstar.pooling); a blend of two tracks' stars is neither's position; some tracks
    # are no star (no_star_tracks)
    centroids = centroids[((centroids["track"] >= 0) | (centroids["source"] != "pooled"))
                          & (centroids["track"] != BLENDED)
                          & ~np.isin(centroids["track"],
                                     no_star_tracks(centroids, near, t0_us, config.dt_us))]
    e = config.estimate
    args = (config, t0_us, crossings, velocity_prior, span_us, sensor, measured_lag, rate_hz,
            near, depth_delay_us)
    cut, owner = pieces.cut(centroids, 2 * e.coast_ms * 1000, stalls)
    rows, est, kept, carried = _estimate_pieces(cut, *args, stalls=stalls)
    gaps = pieces.bridged(est, owner, velocity_prior) if owner and est is not None else {}
    if any(g.bridged for g in gaps.values()):   # stalls the gyro's turn bridges: fitted across
        cut, owner = pieces.rejoined(centroids, cut, {p: t for p, t in owner.items()
                                                       if not (p in gaps and gaps[p].bridged)})
        rows, est, kept, carried = _estimate_pieces(cut, *args, stalls=stalls)
    rows = pieces.coasted_honestly(pieces.owned(rows, owner), gaps.values(), e.coast_sigma_px)
    if est is None:
        return rows, None, None, carried
    return rows, pieces.owned(est, owner, by_track=True), pieces.owned(kept, owner), carried


def _estimate_pieces(centroids, config, t0_us, crossings, velocity_prior, span_us, sensor,
                     measured_lag, rate_hz, near, depth_delay_us=0.0, stalls=None):
    """_estimate of tracks cut into pieces across stalls (evstar.pieces); carried: whether
    the velocity prior carries a track."""
    from .smoothing import bracketed

    e = config.estimate
    params = {k: getattr(e, k) for k in _SMOOTHER_KEYS}
    smoother = track_smoother(config)
    sigma = smoother.measurement_sigma(centroids) if len(centroids) else np.zeros(0)
    out = centroids.copy()
    out["sigma"] = sigma
    out["source"] = np.where(out["source"] == "pooled", "pooled", "measured")
    if e.estimator == "mean" or not (centroids["track"] >= 0).any():
        return out, None, None, False
    groups = _by_prior(centroids, sigma, smoother, velocity_prior)
    ests = [smoother.smooth(cents, t0_us, prior, sig) for cents, sig, prior in groups]
    # the tracks the gyro carries (coast_gyro_ms at their ends)
    carried = [int(t) for cents, _, prior in groups if prior is not None
               for t in np.unique(cents["track"][cents["track"] >= 0])]
    stiff = track_smoother(config, process_noise=e.process_noise_min)
    groups, ests = _without_lobe_bias(groups, ests, smoother, stiff, t0_us)
    lag = lag_sigma = near_cross = None
    if e.estimator == "crossings" and crossings is not None and len(crossings):
        from .crossings import near_tracks, within
        from .pairs import REACH_PX

        # one assignment serves all three: the estimator's within 3 px, the pair split's
        # and the along blends' (evstar.blends) wider
        assigned_to = _by_track(ests)
        near_cross = near_tracks(crossings, assigned_to,
                                 REACH_PX if e.split_pairs else assignment.REACH_PX)
        every = within(near_cross, assignment.REACH_PX)
        mine = _by_group(every, ests)
        lag = run_lag(e, measured_lag)
        refined = _refined(smoother, ests, mine, groups, crossings, e.along_weight, t0_us, lag,
                           rate_hz)
        if lag is not None:     # the lag's scale as measured (or calibrated), per track
            lag_sigma = {t: LAG_SIGMA_FRACTION * v for t, v in
                         _track_lags(crossings, every[:2], lag).items()}
            if e.pixel_lag_file is None and e.lag_from_tracks:
                refined = _lag_from_tracks(refined, smoother, ests, mine, groups, crossings,
                                           e.along_weight, t0_us, lag, every[:2], rate_hz)
        if lag is not None and velocity_prior is not None:
            refined = _own_lag(refined, smoother, ests, groups, crossings, e.along_weight, t0_us,
                               velocity_prior, assigned_to, lag, rate_hz)
        elif lag is None and depth_delay_us > 0:
            # the levels show a low-pass whose lag the profiles could not tell, nor a gyro
            # (none, or a constant rate: smoothing.lag_pinned): its scale
            lag_sigma = {t: UNMEASURED_LAG_SHARE * depth_delay_us
                         for t in np.unique(np.concatenate(refined)["track"]).tolist()
                         if not smoother.lag_pinned_.get(t, False)}
        ests = refined
    est = np.concatenate(ests)
    if carried and e.coast_ends and e.coast_gyro_ms > e.coast_ms:
        last = (span_us[1] - t0_us) // config.dt_us if span_us is not None else est["frame"].max()
        est = _gyro_coasted(est, groups, carried, config.dt_us, params, t0_us, stalls, sensor,
                            (0, last))
    if span_us is not None:
        est = _last_frame_at_the_end(est, span_us[1], t0_us, config.dt_us)
    loose = out[centroids["track"] < 0]
    if rate_hz is not None and sensor is not None and e.untracked_alpha is not None:
        loose = loose[loose["n_events"] >= untracked_min_events(config, sensor, rate_hz)]
    loose = loose[~lobes.of_tracks(loose, est)]
    if near is not None:   # a particle's hit: a spot firing at once (evstar.bursts)
        loose = loose[~bunched(loose, near, t0_us, config.dt_us)]
    rows = _merge(loose, out, est)
    if carried:   # beyond their ends, the gyro's own errors too
        from .coasting import gyro_widened

        on = np.isin(rows["track"], carried)
        rows[on] = gyro_widened(rows[on], velocity_prior)
    # a prediction far from any measurement is no position: keep coasted rows while certain,
    # and, less certain, those between two of their track's measurements (a gap the smoother
    # bridges from both sides: a sinusoid's turn, where σ peaks with the crossings left out);
    # no row at all whose σ says it is no position (a short track's outlier, a crowded
    # field's track that lost its star)
    sigma = rows["sigma"]
    ok = (sigma <= e.coast_sigma_px) | bracketed(rows)
    if span_us is not None:
        ok &= (rows["t"] >= span_us[0]) & (rows["t"] <= span_us[1])
    if sensor is not None:
        ok &= (rows["x"] >= -0.5) & (rows["x"] <= sensor[0] - 0.5) & \
              (rows["y"] >= -0.5) & (rows["y"] <= sensor[1] - 0.5)
    rows = rows[((rows["source"] != "coasted") | ok) & (sigma <= e.max_sigma_px)]
    rows = joined_duplicates(without_shadows(rows))
    if near is not None and sensor is not None and e.across_kernel_px:
        from . import across

        rows = across.refine(rows, *near, t0_us, config.dt_us, sensor, e.across_kernel_px)
    if lag_sigma is not None:
        rows = with_lag_sigma(rows, lag_sigma)
    if near_cross is not None and e.along_blends:
        from . import blends

        rows = blends.shifted(rows, crossings, near_cross, lag)
    if near_cross is not None and e.split_pairs:   # a pair's two stars share its track's σ
        from . import pairs

        rows = pairs.split(rows, crossings, near_cross, assigned_to)
    return rows, est, centroids, bool(carried)


def run_lag(e, measured_lag):
    """The PixelLag the crossings move back by: the calibration file's, else the measured."""
    return pixel_lag(e.pixel_lag_file) if e.pixel_lag_file is not None else measured_lag


def used_lag(e, measured_lag):
    """run_lag where the crossings estimator moves the crossings back by it, else None."""
    return run_lag(e, measured_lag) if e.estimator == "crossings" else None


def largest_lag_us(e, measured_lag):
    """The largest lag (µs) of the table the crossings move back by (estimate settings `e`);
    0 where they move by none (no lag measured or calibrated, or no crossings estimator)."""
    lag = used_lag(e, measured_lag)
    return 0.0 if lag is None else float(np.max(lag.lag_us))


#: a track whose every row lies this near another track's position at its time shadows it:
#: two stars this close share one DBSCAN cluster (eps 2.5 px) in most frames, and the
#: accuracy studies match a row to a star within the same 3 px
SHADOW_PX = 3.0
#: ... and is that track's outliers when its rows' median σ is this many times the other's
#: (perf/study_indep.py --fresh F12: a faint star's 6 frame centroids 0.7–2.7 px off, which
#: its track's gate had refused, σ 0.3–0.6 px, formed a second track beside its own, σ 0.06;
#: the grid's only other overlapping pair, scene 23's, has σ within 2×)
SHADOW_SIGMA_RATIO = 3.0


#: two tracks whose rows lie this near (px, median over the frames both cover, each within
#: SHADOW_PX) follow one star: half the nearest pair evstar.pairs splits (2 px), so a
#: companion star with a track of its own is kept
DUPLICATE_PX = 1.0
#: ... over at least this many frames
MIN_COMMON_FRAMES = 3


def joined_duplicates(rows):
    """`rows` with a track that runs beside another (DUPLICATE_PX, MIN_COMMON_FRAMES) joined
    to it: one star's two tracks (a slow star's lone lobes, ~1.25 σ_PSF ahead of it and
    behind, jump past the tracker's gate and start a second track beside the first; both
    estimate the star). The longer keeps its id; in the frames both cover, the less certain
    one's rows (median σ there) are dropped."""
    tracked = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    pairs = _side_by_side(rows[tracked])
    if not pairs:
        return rows
    out, drop = rows.copy(), np.zeros(len(rows), bool)
    for a, b in pairs:
        ia, ib = np.flatnonzero(out["track"] == a), np.flatnonzero(out["track"] == b)
        common = np.intersect1d(out["frame"][ia], out["frame"][ib])
        ca, cb = ia[np.isin(out["frame"][ia], common)], ib[np.isin(out["frame"][ib], common)]
        if len(common) < MIN_COMMON_FRAMES or len(ca) != len(common) or len(cb) != len(common):
            continue      # (a track with two rows in a frame: not one star's estimate)
        ca, cb = ca[np.argsort(out["frame"][ca])], cb[np.argsort(out["frame"][cb])]
        d = np.hypot(out["x"][ca] - out["x"][cb], out["y"][ca] - out["y"][cb])
        if np.median(d) > DUPLICATE_PX or d.max() > SHADOW_PX:
            continue
        keep, other = (a, b) if len(ia) >= len(ib) else (b, a)
        drop[cb if np.median(out["sigma"][cb]) > np.median(out["sigma"][ca]) else ca] = True
        out["track"][out["track"] == other] = keep
    return out[~drop]


def _side_by_side(tracked):
    """The (a, b) track id pairs (a < b) with rows of one frame within SHADOW_PX."""
    from scipy.spatial import cKDTree

    if len(np.unique(tracked["track"])) < 2:
        return []
    # rows of one frame only: frames set 10 × SHADOW_PX apart
    pts = np.column_stack([tracked["frame"] * (10.0 * SHADOW_PX), tracked["x"], tracked["y"]])
    near = cKDTree(pts).query_pairs(SHADOW_PX, output_type="ndarray")
    ids = np.sort(tracked["track"][near], axis=1)
    ids = ids[ids[:, 0] != ids[:, 1]]
    return [tuple(v) for v in np.unique(ids, axis=0).tolist()]


#: ... or is brief (BRIEF_ROWS rows or fewer, beside a track BRIEF_RATIO times as long),
#: made of lone lobes (_mostly_lone_lobes) and within BRIEF_PX of it: a slow star's ON-only
#: and OFF-only clusters, 2–3 px either side of it, linked for a few frames into a track
#: of their own (3 ms frames: one of 4 rows up to 3.5 px off)
BRIEF_ROWS, BRIEF_RATIO, BRIEF_PX = 10, 5, 2 * SHADOW_PX


def _mostly_lone_lobes(rows):
    """Are at least half of the rows that hold events lone lobes (lobes.lone)?"""
    held = np.count_nonzero(rows["n_events"] > 0)
    return bool(held) and np.count_nonzero(lobes.lone(rows)) >= held / 2


def without_shadows(rows):
    """`rows` less the tracks that shadow a longer one: a star has one track, and a shorter,
    much less certain one lying on it over its whole span (SHADOW_PX, SHADOW_SIGMA_RATIO),
    or a brief one near it (BRIEF_ROWS, BRIEF_RATIO, BRIEF_PX), is made of that star's
    outlier centroids or lone lobes."""
    from .frames import groups

    tracked = rows[rows["track"] >= 0]
    ids, each = groups(tracked["track"])
    if len(ids) < 2:
        return rows
    by = {int(t): tracked[i[np.argsort(tracked["t"][i], kind="stable")]] for t, i in zip(ids, each)}
    sigma = {t: float(np.median(r["sigma"])) for t, r in by.items()}
    counts = np.array([len(i) for i in each])
    lone = {t: _mostly_lone_lobes(r) for t, r in by.items()}
    longest_first = [int(t) for t in ids[np.argsort(-counts, kind="stable")]]
    drop = set()
    for i, b in enumerate(longest_first):
        rb = by[b]
        for a in longest_first[:i]:
            ra = by[a]
            brief = (len(rb) <= BRIEF_ROWS and len(ra) >= BRIEF_RATIO * len(rb)
                     and lone[b])
            if a in drop or len(ra) <= len(rb) or (
                    not brief and sigma[b] < SHADOW_SIGMA_RATIO * sigma[a]):
                continue
            if rb["t"][0] < ra["t"][0] or rb["t"][-1] > ra["t"][-1]:
                continue
            dx = rb["x"] - np.interp(rb["t"], ra["t"], ra["x"])
            dy = rb["y"] - np.interp(rb["t"], ra["t"], ra["y"])
            if np.all(np.hypot(dx, dy) <= (BRIEF_PX if brief else SHADOW_PX)):
                drop.add(b)
                break
    return rows if not drop else rows[~np.isin(rows["track"], list(drop))]


#: a measured or calibrated pixel lag is known to about this fraction of itself (the level
#: profiles' lag was 20–60 % long at k = 2–4 on short passages before the tracks' check and
#: within ~10 % at k >= 5; docs/measurements.md). On the grid's 29 dark-sky rows the median error/σ went
#: 1.41 -> 1.03 (a calibrated 2-D σ: 1.18); 0.2 overstated σ (0.66). The profiles' lag, not
#: the tracks' told table: with the latter, Cygnus EVK4 dark-sky pans went 0.52–1.29 ->
#: 1.33–1.67
LAG_SIGMA_FRACTION = 0.1
#: where the level profiles show a low-pass (the deepest level passes later than the top:
#: LevelProfiles.depth_delay_us) but fit no lag, and no gyro tells one (none, or a constant
#: rate: smoothing.lag_pinned), the lag left in the rows is taken to be about that delay: on
#: the accuracy grid's dark skies without an IMU whose profiles failed their gates, the rows'
#: error was 0.4–3.4 times the star's speed times it (20 °/s, a shot-noisy sky at 8 °/s, a
#: 60 Hz sky at 6 °/s); with one at a constant rate, fresh-57's 14 °/s sky 2.2 times
UNMEASURED_LAG_SHARE = 1.0
#: ... and a run reports (and warns of) such a delay from this (µs): on the accuracy grid the
#: simulator's default pixels show 0–20 µs at 6–35 °/s, its dark skies 0.4–1.2 ms and 2–3 ms
#: refractory periods ~0.3 ms
UNMEASURED_LAG_NOTE_US = 100.0


def _track_lags(crossings, assigned, lag):
    """{track id: its crossings' median lag (µs)} from the table `lag` (its slowest speed
    column: the lag's scale, for the uncertainty)."""
    got, owner = assigned
    from .frames import groups

    each = lag.lag_at(crossings["pairs"][got], lag.speed_px_s[0])
    return {int(t): float(np.median(each[o])) for t, o in zip(*groups(owner))}


def with_lag_sigma(rows, lag_sigma_us):
    """`rows` with each tracked row's σ widened by its track's lag uncertainty (µs, by track
    id) times its speed, along its motion: a lag's error moves every row of a track along
    its motion by the same time, which the smoother's σ (pooled noise) does not hold."""
    out = rows.copy()
    i = np.flatnonzero(np.isin(rows["track"], list(lag_sigma_us)))
    if not len(i):
        return out
    i = i[np.lexsort((rows["t"][i], rows["track"][i]))]
    speed = _row_speeds(rows["track"][i], rows["t"][i].astype(np.float64), rows["x"][i],
                        rows["y"][i])
    sig_t = np.array([lag_sigma_us[int(t)] for t in rows["track"][i]])
    along = speed * sig_t * 1e-6
    # rows' σ is per axis (the RMS of x and y): an along error adds half its variance to each
    out["sigma"][i] = np.sqrt(rows["sigma"][i] ** 2 + along ** 2 / 2)
    return out


def _row_speeds(track, t, x, y):
    """Per row (sorted by track, then time) its track's speed (px/s) between its neighbours
    in the track (one side at the ends; 0 for a row alone)."""
    from .frames import run_neighbours

    a, b = run_neighbours(track)
    dt = (t[b] - t[a]) * 1e-6
    dist = np.hypot(x[b] - x[a], y[b] - y[a])
    return np.divide(dist, dt, out=np.zeros(len(t)), where=dt > 0)


def _refined(smoother, ests, mine, groups, crossings, along_weight, t0_us, lag, background_hz):
    """Each group's smoothed rows refitted with its crossings (TrackSmoother.refine)."""
    return [smoother.refine(est, cents, crossings, prior, sig, along_weight, t0_us, lag,
                            assigned, background_hz)[0]
            for est, assigned, (cents, sig, prior) in zip(ests, mine, groups)]


def _lag_from_tracks(refined, smoother, ests, mine, groups, crossings, along_weight, t0_us,
                     lag, assigned, background_hz):
    """The `refined` rows refitted with the lag the tracks agree on, as they were where no
    track tells it (evstar.level_lag.track_consistent). The tracks that told it are
    refitted with its table, which their own bright crossings pinned; the others (faint
    stars, whose own crossings cannot check a lag, and which kept the level profiles' lag
    before) with its width terms too, which carry the lag over to their wider crossings.
    (Every track with the width terms: Cygnus EVK4 5 °/s 0.120 -> 0.107 px, but a bright
    field's mid-bright stars led by 0.3 px at 20 °/s, their widths' long tail adding lag.)
    assigned: (crossings, track ids) as the refit assigned them."""
    import dataclasses

    from .level_lag import track_consistent

    lag, told = track_consistent(lag, crossings, assigned, _by_track(refined))
    if not len(told):
        return refined
    bright, faint = _split(ests, told)
    bright = _refined(smoother, bright, mine, groups, crossings, along_weight, t0_us,
                      dataclasses.replace(lag, width_slope=None), background_hz)
    faint = _refined(smoother, faint, mine, groups, crossings, along_weight, t0_us, lag,
                     background_hz)
    return [_in_order(np.concatenate([b, f])) for b, f in zip(bright, faint)]


def _own_lag(refined, smoother, ests, groups, crossings, along_weight, t0_us, velocity_prior,
             tracks, lag, background_hz):
    """The `refined` rows with the tracks whose centroids lie too far from their crossings to
    be assigned them (evstar.assignment) refitted: assigned around the track moved in time,
    with the pixels' lag fitted on the run's own crossings against the gyro's motion, as
    `evstar calibrate` fits a calibration recording (calibration.fit_pixel_lag: by k and
    speed, where the level profiles' one lag per k does not hold — on that EVK4 sinusoid the
    crossings lag 2.9 ms below 500 px/s and 1.3 ms at its 2700 px/s peak; moved with the
    profiles' lag, a run of it without the gyro went 0.80 -> 1.45 px, so such runs are left
    as they are). As they were where no track is that far, or the run cannot tell the lag
    from an offset (a constant rate). tracks: the smoothed rows the crossings were assigned
    to."""
    from .calibration import fit_pixel_lag
    from .errors import DataError

    shift = assignment.track_shifts(crossings, tracks)
    if not shift:   # no track that far: no assignment search more
        return refined
    every, ids = assignment.assign(crossings, tracks, shift)
    mine, far = _by_group(every, ests), _split(ests, ids)[0]

    def with_far(table):   # the far tracks refitted with their crossings and a lag table
        refit = _refined(smoother, far, mine, groups, crossings, along_weight, t0_us, table,
                         background_hz)
        return [_in_order(np.concatenate([r[~np.isin(r["track"], ids)], f]))
                for r, f in zip(refined, refit)]

    try:   # the tracks' rows once refitted with their crossings set which are whose
        # the reach alone (calibrate's extension behind the tracks took the accuracy grid's
        # EVK4 dark-sky sinusoid with the gyro from 0.138 to 0.287 px here)
        own = fit_pixel_lag(crossings, _by_track(with_far(lag)), velocity_prior, behind_px=0.0)
    except DataError:
        return refined
    return with_far(own)


def _split(ests, ids):
    """(per group, its rows of the tracks `ids`), (per group, its other rows)."""
    mine = [np.isin(est["track"], ids) for est in ests]
    return [e[m] for e, m in zip(ests, mine)], [e[~m] for e, m in zip(ests, mine)]


def _in_order(rows):
    """`rows` sorted by track, then time."""
    return rows[np.lexsort((rows["t"], rows["track"]))]


def _by_track(ests):
    """The groups' rows in one array, sorted by track, then time."""
    every = np.concatenate(ests)
    return every[np.lexsort((every["t"], every["track"]))]


def no_star_tracks(centroids, near=None, t0_us=0, dt_us=None):
    """Ids of the tracks of the linked `centroids` that are no star: a track of OFF lobes
    alone is pixels relaxing behind a star (lobes.trail_tracks), one that stays still where
    others move a pixel firing by itself (hotpixels.still_tracks), and, given the events
    `near` the centroids (frames of dt_us from t0_us), one of bunched centroids particle
    hits linked by chance (bursts.burst_tracks)."""
    ids = [lobes.trail_tracks(centroids), still_tracks(centroids)]
    if near is not None:
        ids.append(burst_tracks(centroids, near, t0_us, dt_us))
    return np.concatenate(ids)


def untracked_min_events(config, sensor, rate_hz):
    """The fewest events of a reported untracked centroid: a track confirms a star, while
    one cluster of n events could be background — λ·dt·π·eps² expected in a spot of the
    cluster's radius, and width·height / (π·eps²) such spots in a frame — so n must be
    reached there with probability <= estimate.untracked_alpha anywhere in the frame."""
    from evstar_kernels.reference import poisson

    area = np.pi * config.extract.eps ** 2
    spots = sensor[0] * sensor[1] / area
    mu = rate_hz * config.dt_us * 1e-6 * area
    # per spot no stricter than MIN_ALPHA, where the quantile is still computed (NaN below)
    per_spot = min(max(config.estimate.untracked_alpha / spots, MIN_ALPHA), 1.0)
    return int(poisson.isf(per_spot, mu)) + 1


def _by_prior(centroids, sigma, smoother, prior):
    """(centroids, σ, prior) of the tracks the velocity prior explains better
    (TrackSmoother.prior_helps) and (…, None) of the others, each group that has tracks
    (the caller has some); est["centroid"] indexes `centroids` in both."""
    if prior is None:
        return [(centroids, sigma, None)]
    ids = np.unique(centroids["track"][centroids["track"] >= 0])
    helps = np.isin(ids, sorted(smoother.prior_helps(centroids, prior, sigma)))
    # each group with the other group's tracks unconfirmed: not smoothed there
    return [(_only(centroids, chosen), sigma, p)
            for chosen, p in ((ids[helps], prior), (ids[~helps], None)) if len(chosen)]


def _without_lobe_bias(groups, ests, smoother, stiff, t0_us):
    """The groups' centroids less their tracks' lobe bias (evstar.lobes.debiased, measured
    against the `stiff` smoother's fit) and their smoothed rows, those of the tracks it
    changed smoothed again."""
    out_g, out_e = [], []
    for (cents, sig, prior), est in zip(groups, ests):
        maybe = lobes.candidates(cents)
        if len(maybe):
            sub = _only(cents, maybe)
            fixed, changed = lobes.debiased(sub, stiff.smooth(sub, t0_us, prior, sig))
            if len(changed):
                redo = smoother.smooth(_only(fixed, changed), t0_us, prior, sig)
                est = np.concatenate([est[~np.isin(est["track"], changed)], redo])
                est = est[np.lexsort((est["t"], est["track"]))]
                fixed["track"] = cents["track"]
                cents = fixed
        out_g.append((cents, sig, prior))
        out_e.append(est)
    return out_g, out_e


def _only(centroids, ids):
    """A copy of `centroids` whose tracks other than `ids` are unconfirmed (track -1): the
    smoother leaves them out."""
    out = centroids.copy()
    out["track"][~np.isin(out["track"], ids)] = -1
    return out


def _by_group(every, ests):
    """Per group's smoothed rows, the crossings assigned to its tracks, from `every`
    (along_track of the crossings and all groups' rows), each to its nearest track of all
    groups': a crossing must not refine a star of one group when another's is nearer. The
    nearest of one group's tracks is then that track too, as along_track of the group's own
    crossings would find it (ties to the least id either way)."""
    if len(ests) == 1:
        return [every]
    got, owner, u, resid = every
    parts = []
    for est in ests:
        m = np.isin(owner, np.unique(est["track"]))
        # u (n, 2) by compress: the rows of u[m] at a tenth of its cost
        parts.append((got[m], owner[m], u.compress(m, 0), resid[m]))
    return parts


def _gyro_coasted(est, groups, carried, dt_us, params, t0_us, stalls, sensor, frames):
    """`est` with the ends of the tracks the gyro carries (`carried`) coasted to
    coast_gyro_ms, up to a readout stall, by a plain smoothing of their centroids (`groups`:
    (centroids, σ, prior) each; a TrackSmoother of `params`, evstar.coasting.extended) —
    of those with an end inside the sensor (`sensor`: (width, height), or None) within the
    recording's `frames` (first, last): a field's tracks mostly end where their stars leave
    it."""
    from .coasting import EDGE_PX, extended, open_ends
    from .smoothing import TrackSmoother

    tracks = open_ends(est, carried, frames, sensor, EDGE_PX)
    if not tracks:
        return est
    far = TrackSmoother(dt_us, **params, stalls=stalls)
    coasted = [far.smooth(_only(cents, tracks), t0_us, prior, sig) for cents, sig, prior in groups
               if prior is not None and np.isin(cents["track"], tracks).any()]
    return extended(est, np.concatenate(coasted), tracks, SHADOW_PX) if coasted else est


def _last_frame_at_the_end(est, end_us, t0_us, dt_us):
    """`est` with the coasted rows of the recording's last frame, where it ends before the
    frame's mid-time (a recording is seldom a whole number of frames), moved back along
    their velocity to the recording's end: else they lie past it and are dropped, and the
    last frame of a star too faint to cluster in its remnant had no position."""
    late = est["coasted"] & (est["t"] > end_us) & (t0_us + est["frame"] * dt_us <= end_us)
    if not late.any():
        return est
    out = est.copy()
    back_s = (out["t"][late] - end_us) * 1e-6
    out["x"][late] -= out["vx"][late] * back_s
    out["y"][late] -= out["vy"][late] * back_s
    out["t"][late] = end_us
    return out


def _merge(unconfirmed, measured, est):
    """Unconfirmed centroids + one row per estimate (measured rows keep their centroid's
    fields, with the estimate's position and σ), time-sorted."""
    rows = np.zeros(len(est), CENTROID_DTYPE)
    from_cent = est["centroid"] >= 0
    rows[from_cent] = measured[est["centroid"][from_cent]]
    rows["spread"][~from_cent] = np.nan
    for f in ("t", "x", "y", "track", "frame"):
        rows[f] = est[f]
    rows["sigma"] = np.sqrt((est["sigma_x"] ** 2 + est["sigma_y"] ** 2) / 2)
    rows["source"] = np.where(rows["source"] == "pooled", "pooled", est["source"])
    out = np.concatenate([unconfirmed, rows])
    return out[np.lexsort((out["x"], out["t"]))]
