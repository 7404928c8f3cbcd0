"""The gyro's clock against the camera's: an offset the IMU's timestamps carry, measured on
the stars.

An IMU stamped by its own clock (a separate board, a USB link) is late or early against
the events by milliseconds, and nothing in a file says by how much. At a constant rate it
does not matter; where the rate changes the gyro's image velocity is off by the
acceleration times the offset, and the estimator integrates that: on a 10°/1 Hz sinusoid
(DVXplorer Lite, 12 mm) a 3 ms offset put the crossings estimator's positions 1.4 px off,
where the per-frame means were 0.1 px off (perf/study_accuracy.py, fresh-39).

Between two pixel crossings of one track 40-80 ms apart the star moved along its motion by
the two pixels' distance along it; the star at the first pixel turned by the gyro between
their times + δ predicts that distance. δ is the least clipped squared difference over
such pairs where the path runs straight (a grid search, then Gauss-Newton steps), a gyro
bias's constant image velocity fitted beside it, and it is taken only where the data can
tell it: the smoothed gyro rate changes over a gap well beyond what its noise makes it
seem to (a constant rate tells nothing), δ stands MIN_Z standard errors from zero (each
100 ms block of pairs taken as one), the gyro's turns slower than ALIAS_PERIODS x δ tell
it too (a vibration's period aliases it), and, behind a pixel lag, δ exceeds the lag
itself and stands out on the least-lagged third of the pairs too (whose δ is taken where
the rest pull all's off it); where no lag was measured, none is taken behind pixels that
show a low-pass (their levels pass apart, or they relax slower than they rise: a faint
star's lag reads as an offset).
Where no lag was measured the tracks' centroids, on the camera's own clock, have the
last word: the moved gyro must explain them no worse than the record as given, and an
offset the crossings tell by LOOSE_Z standard errors only must explain them better by
strong evidence.
Crossing times are the star's own behind a pixel lag (moved back by the measured one),
but an error of that lag still reads as an offset: smaller ones are left as they are."""
from __future__ import annotations

import numpy as np

from .assignment import REACH_PX
from .crossings import near_tracks
from .frames import groups
from .motion.imu_integration import interp_rows
from .smoothing import PRIOR_EVIDENCE, lag_corrected
from .robust import robust_sigma

#: the most the IMU's clock is searched off the camera's (µs each way)
SEARCH_US = 25_000
#: the search's grid (µs) on at most COARSE_PAIRS pairs, then Gauss-Newton steps from its
#: best point, their derivative's half-step (µs)
COARSE_STEP_US, COARSE_PAIRS, GAUSS_NEWTON_STEPS, STEP_US = 1000, 1000, 3, 500.0
#: rounds of weights (each from the residuals where the last round's fit stands)
WEIGHT_ROUNDS = 2
#: two crossings of one track compared lie this far apart in time (µs): the offset moves
#: their predicted distance by the change of rate over the gap, so the longer the gap the
#: more it tells against the crossings' timing noise (on fresh-39's sinusoids the offsets
#: of gaps of 8-30 ms missed the true ones by up to 480 µs, of 40-80 ms by up to 120),
#: while the gyro's turn over it is integrated exactly
MIN_GAP_US, MAX_GAP_US = 40_000, 80_000
#: a pair's residual counts up to this (px): a crossing of another star or of noise; in
#: the weighted steps up to CLIP_SIGMA times its speed class's scatter (SPEED_CLASSES equal
#: shares of the pairs by speed; a scatter no smaller than MIN_SCATTER_PX)
CLIP_PX, CLIP_SIGMA, SPEED_CLASSES, MIN_SCATTER_PX = 1.0, 4.0, 8, 0.01
#: the gyro's rates are smoothed over this long (µs) for the search: longer than its
#: noise's sample-to-sample changes, shorter than a turn (a 5 Hz sinusoid's quarter period
#: is 50 ms)
SMOOTH_US = 20_000
#: a pair's path must run this straight: the sine of the angle between its halves
MAX_BEND = 0.05
#: the pairs the search evaluates at most (evenly spread over the run), and the crossings
#: it pairs at most per pair (every k-th of a crowded field's)
MAX_PAIRS, CROSSINGS_PER_PAIR = 4000, 8
#: the offset's standard error takes the pairs of each block of this many µs of the run
#: as one (they share crossings and a stretch of the motion) ...
BLOCK_US = 100_000
#: ... of which it needs this many, and the offset must reach MIN_Z of its standard errors
MIN_BLOCKS, MIN_Z = 5, 5.0
#: ... or, where no pixel lag was measured, LOOSE_Z of them where the tracks' centroids,
#: on the camera's own clock, are explained better by the moved gyro by strong evidence
#: (smoothing.PRIOR_EVIDENCE·√tracks: _centroids_gain): the independent simulator's
#: untold 3 ms on two ideal-pixel sinusoids read 2.35 and 2.46 ms at 3.7 and 5.0 standard
#: errors, which the centroids took by 15 and 19 (0.326 -> 0.073, 0.379 -> 0.071 px); a
#: told clock behind a 1 ms refractory period read 1.1 ms there, which they refused (−11)
LOOSE_Z = 2.0
#: the straight pairs it needs: a path that bends all the while (a platform's vibration
#: across the motion) leaves a handful, whose blocks' scatter then passed a 22 ms offset
#: as 5 standard errors (7 of 386 pairs on a 0.05°, 20 Hz vibration; told none: 0.35 px)
MIN_PAIRS = 30
#: an offset must exceed this (µs): on fast stars the pixels' timing biases (a refractory
#: period's early pairs, flanks timed while the star speeds up) read as one of up to
#: 0.1 ms (the independent simulator's 75 °/s sinusoid on an HD sensor, told its clock,
#: measured 107 ± 11 µs, and taken 0.012 px to 0.101 with it); an untold offset below
#: costs up to 0.2 px on a 10°/1 Hz sinusoid
MIN_OFFSET_US = 500.0
#: behind a pixel lag an offset must also exceed this share of the lag the crossings were
#: moved back by: the profiles' lag of bright crossings is off by up to 43 % of itself
#: (the accuracy grid's told dark-sky sinusoids with the IMU read 9-43 % of it as an
#: offset, and took 0.024-0.138 px to 0.375-0.535 with it)
LAG_SHARE = 1.0
#: ... and the offset must stand out on the least-lagged third of the pairs as well, whose
#: offset may be the one taken (LEAST_APART): the faint crossings' lag is the least sure (the
#: independent simulator's HD dark-sky sinusoid, told its clock, read 509 ± 43 µs on all
#: pairs — 1773 ± 242 on the most-lagged third, 251 ± 49 on the least — and took 0.012 px
#: to 0.253 with it; an untold 3 ms read 2501 on all and 2752 on the least-lagged third; a
#: Scorpius EVK4 dark-sky field's untold 5 ms 4280 on all, 4763 on the least-lagged third,
#: and each track's gyro lag fit took the rest for a lag: 0.344 -> 0.231 px, told 0.188)
LEAST_LAGGED = 1 / 3
#: ... and is taken instead of all the pairs' where the two stand this many standard errors
#: of their difference apart (a Hausman test: the third's pairs are among all's, so that
#: variance is the third's less all's): a single star's third is noisier (fresh-39's dark-sky
#: sinusoid, an untold 5 ms: 5157 ± 77 on all, 5292 ± 101 on the third, 2.1 apart; taking
#: it moved 0.076 -> 0.136 px), where a field's least-lagged stars tell what the others'
#: lag errors hide (the Scorpius field above: 4280 ± 65 and 4763 ± 87, 8.4 apart)
LEAST_APART = 3.0
#: where no pixel lag was measured, an offset is taken only where the crossings' deepest
#: levels pass less than this share of it after their top: a clock delays every level
#: alike, a pixel low-pass a dimmer one more. A faint star's unmeasured lag behind a dark
#: sky read as an offset (magnitude 6 on the paper's 10°/1 Hz sinusoid: 2.7 ms, its levels
#: 1.4 ms apart, 1.8 px behind; the accuracy grid's stray-lit dark-sky sinusoid 1.6 ms, 1.2
#: apart, 0.73 px), where without a low-pass the levels of a k with 100 profiles or more
#: passed within 0.02 ms
DELAY_SHARE = 0.25
#: an offset must be told by the gyro's turns slower than a period of this many times
#: itself as well (the rates smoothed over that long): a turn of period P tells an offset
#: only modulo P, and a crossing's level pairs, timed over the star's passage (T ~ 2σ/v),
#: see a motion of frequency f with a gain cos(π f T) that turns negative where the passage
#: outlasts half its period — a 30 Hz, 0.03° vibration along a 9 °/s pan read as a 15.6 ms
#: offset, half its period (fresh-56 of perf/study_accuracy.py; 0.221 px, 0.033 without
#: the IMU). Under a quarter period an offset cannot alias
ALIAS_PERIODS = 4.0
#: the gyro's rate must change over a gap this many times more than its noise alone seems
#: to, and by more than MIN_RATE_CHANGE (rad/s RMS: a noiseless gyro at a constant rate)
NOISE_RATIO, MIN_RATE_CHANGE = 3.0, 1e-3


def on_camera_clock(config, prior, imu, camera, t_events, crossings, centroids,
                    measured_lag=None, filter_result=None, depth_delay_us=0.0,
                    slow_decay=False):
    """(the velocity prior, the offset µs or None): where the run measures the clock
    (motion.measure_clock) and the crossings tell an offset, the prior
    (evstar.estimation.velocity_prior of these arguments) of the IMU moved by it; else
    `prior` as it is. Where no pixel lag was measured the tracks' centroids must not be
    explained worse by the moved prior, and an offset the crossings tell by LOOSE_Z
    standard errors only must explain them better by strong evidence (_centroids_gain).
    measured_lag: the pixels' lag the run measured (the estimate's calibration file
    wins); depth_delay_us: how much later the crossings' deepest levels
    pass than their top (evstar.level_lag.LevelProfiles.depth_delay_us); slow_decay:
    whether the stars' pixels relax slower than they rise (LevelProfiles.slow_decay)."""
    from . import estimation

    if prior is None or crossings is None or not config.motion.measure_clock:
        return prior, None
    lag = estimation.run_lag(config.estimate, measured_lag)
    reading = _reading(crossings, centroids, imu, camera, lag, depth_delay_us, slow_decay,
                       MIN_Z if lag is not None else LOOSE_Z)
    if reading is None:
        return prior, None
    offset, z = reading
    need = 0.0 if z > MIN_Z else PRIOR_EVIDENCE   # told by fewer: strong evidence
    # the moved record covers the events as far as the given one did
    held = config.replace(**{"motion.extrapolate_us": config.motion.extrapolate_us
                             + int(np.ceil(abs(offset)))})
    moved = estimation.velocity_prior(held, corrected(imu, offset), camera, t_events,
                                      filter_result)
    if lag is None:
        gain, tracks = _centroids_gain(config, centroids, prior, moved)
        if not (gain > need * np.sqrt(tracks) if need else gain >= 0):
            return prior, None
    return moved, offset


def _centroids_gain(config, centroids, prior, moved):
    """(how much better the tracks' centroids, timed by the camera's own clock, are
    explained by the `moved` prior than by the given one: the difference of their
    TrackSmoother.prior_loglik, the tracks that tell). The moved prior must not explain
    them worse: a vibration fast against the crossings' passages bends their pairs' paths
    into an offset (13.8 and 19.6 ms on the independent simulator's 12 and 18 Hz
    vibrations, C8 and C6, whose moved priors explained the centroids worse by 294 and 79:
    0.152 and 0.101 px), where the untold 3 ms offsets of two sinusoids (G4, G13)
    explained them better by 47 and 177. Only where the pixels show no lag: behind one the
    centroids trail the star by it, and read it as part of the clock's offset (the dark
    sky's 30 Hz pixels of tests/test_clock.py: the true 5 ms explained them worse than
    none)."""
    from .estimation import track_smoother

    smoother = track_smoother(config)
    sigma = smoother.measurement_sigma(centroids)
    gain = (smoother.prior_loglik(centroids, moved, sigma)
            - smoother.prior_loglik(centroids, prior, sigma))
    return float(gain.sum()), len(gain)


def as_measured(imu, result, extrapolate_us):
    """`imu` as a run (an evstar.Result) used it: moved by the clock offset the run measured
    (metrics imu_time_offset_us) and its ends held over the run's centroids (as far as
    extrapolate_us + the offset: the given record reached them); `imu` where none was
    measured. For what reads the gyro after the run: the attitude filter (an untold 3 ms on
    an Orion DAVIS346 sinusoid took its attitude from 0.018 px RMS to 0.785 px)."""
    offset = result.metrics.get("imu_time_offset_us")
    if imu is None or offset is None or not len(result.centroids):
        return imu
    from .motion import hold_ends

    t = result.centroids["t"]
    return hold_ends(corrected(imu, -offset), int(t.min()), int(t.max()),
                     extrapolate_us + int(np.ceil(abs(offset))))


def corrected(imu, offset_us):
    """`imu` with its clock moved: the gyro sample it stamped t now at camera time
    t + time_offset_us − offset_us (measured_offset_us's δ read later)."""
    from .imu import Imu

    return Imu(imu.t, imu.gyro, imu.accel, R_cam_imu=imu.R_cam_imu,
               time_offset_us=imu.time_offset_us - int(round(offset_us)))


def measured_offset_us(crossings, centroids, imu, camera, lag=None, depth_delay_us=0.0,
                       slow_decay=False, min_z=MIN_Z):
    """δ (µs) such that the gyro's rate stamped camera time t + δ is the camera's at t,
    measured on `crossings` (CROSSING_DTYPE) assigned to the tracks of the linked
    `centroids`; None where the crossings do not tell it (see the module docstring). lag:
    the pixels' PixelLag the crossings are late by, or None; depth_delay_us: how much later
    their deepest levels pass than their top, where no lag was measured (DELAY_SHARE);
    slow_decay: the stars' pixels relax slower than they rise (a low-pass: where no lag was
    measured, none is taken; evstar.level_lag.SLOW_DECAY_RATIO); min_z: the standard
    errors the offset must stand from zero."""
    reading = _reading(crossings, centroids, imu, camera, lag, depth_delay_us, slow_decay, min_z)
    return None if reading is None else reading[0]


def _reading(crossings, centroids, imu, camera, lag, depth_delay_us, slow_decay, min_z):
    """(measured_offset_us's δ, the fewest standard errors any of its fits told it by), or
    None: one search serves every min_z up to that."""
    t_cam = imu.t_cam.astype(np.float64)
    if len(t_cam) < 3 or not _rate_changes(imu):
        return None
    pairs = _pairs(crossings, centroids, lag, t_cam)
    if pairs is None:
        return None
    turned = _turned(t_cam, imu.gyro_cam)
    straight = _straight(pairs, t_cam, turned, camera)
    chosen = _spread(pairs, straight)
    fit = None if chosen is None else _offset_of(chosen, t_cam, turned, camera, min_z)
    offset = None if fit is None else fit[0]
    if offset is None or (lag is None and (slow_decay
                                           or depth_delay_us > DELAY_SHARE * abs(offset))):
        return None
    slow_z = _slow_turns_z(offset, imu, chosen, t_cam, camera, min_z)
    if slow_z is None:
        return None
    z = min(_z(fit), slow_z)
    if not np.any(pairs[-1] > 0):
        return offset, z
    # behind a pixel lag the least-lagged pairs must tell it too, and where the rest pull
    # it off by more than their noise, theirs is taken (LEAST_LAGGED, LEAST_APART)
    least = _spread(pairs, straight & _least_lagged(pairs[-1]))
    if least is None:
        return offset, z
    confirmed = _offset_of(least, t_cam, turned, camera, min_z)
    if confirmed is None or confirmed[0] * offset <= 0:
        return None
    # the third's pairs are among all's: their difference's variance is the third's less all's
    se = np.sqrt(max(confirmed[1] ** 2 - fit[1] ** 2, 0.0))
    return (confirmed[0] if abs(confirmed[0] - offset) > LEAST_APART * se else offset,
            min(z, _z(confirmed)))


def _z(fit):
    """The standard errors an (offset, standard error) stands from zero."""
    return abs(fit[0]) / fit[1] if fit[1] > 0 else np.inf


def _slow_turns_z(offset, imu, pairs, t_cam, camera, min_z=MIN_Z):
    """The standard errors by which the gyro's turns slower than a period of
    ALIAS_PERIODS x |offset| tell the offset too (its sign; inf where the search's own
    smoothing keeps only such turns), or None where they do not: see ALIAS_PERIODS."""
    window = ALIAS_PERIODS * abs(offset)
    if window <= SMOOTH_US:   # the search's own smoothing keeps only such turns
        return np.inf
    if not _rate_changes(imu, window):
        return None
    slow = _offset_of(pairs, t_cam, _turned(t_cam, imu.gyro_cam, window), camera, min_z)
    return _z(slow) if slow is not None and slow[0] * offset > 0 else None


def _offset_of(pairs, t_cam, turned, camera, min_z=MIN_Z):
    """(the offset µs, its standard error) the pairs tell, or None where it does not stand
    min_z standard errors out."""
    offset, se = _fitted(pairs, lambda some: _predicted(some, t_cam, turned, camera))
    # the pixels' own timing biases read as an offset (MIN_OFFSET_US), behind a pixel lag
    # an error of the crossings' lag too (LAG_SHARE); at the search's edge the loss had no
    # minimum inside it
    floor = max(MIN_OFFSET_US, LAG_SHARE * float(np.median(pairs[-1])))
    inside = abs(offset) < SEARCH_US - COARSE_STEP_US
    return (offset, se) if inside and abs(offset) > max(min_z * se, floor) else None


def _least_lagged(lag):
    """The pairs whose mean lag is within the LEAST_LAGGED share of the least."""
    return lag <= np.quantile(lag, LEAST_LAGGED)


def _fitted(pairs, prediction):
    """(the offset µs, its standard error) of the least clipped squared residuals between
    the pairs' along distances and those prediction(pairs)(offset) predicts, with a gyro
    bias's share: a grid search on COARSE_PAIRS of them, then weighted Gauss-Newton steps
    on all (each pair by its speed class's scatter)."""
    predicted = prediction(pairs)
    t_i, t_j, x_i, y_i, x_j, y_j, ux, uy, _ = pairs
    seen = (x_j - x_i) * ux + (y_j - y_i) * uy
    # a gyro bias adds a constant image velocity (b_x, b_y): its share along each pair's
    # motion over its gap is fitted beside the offset (the default MEMS bias, 0.1 °/s,
    # left 0.04 px on 7 px pairs at 20 °/s, which a slope of the gyro's noise had read
    # as a 12 ms offset)
    bias = np.column_stack([ux, uy]) * ((t_j - t_i) * 1e-6)[:, None]
    ones = np.ones(len(seen))

    few = _evenly(len(seen), COARSE_PAIRS)
    at_few = prediction([a[few] for a in pairs])

    def loss(offset):   # the grid's, on a few pairs: where the minimum lies
        r = seen[few] - at_few(offset)
        b, _ = _clipped_fit(bias[few], r, ones[few], CLIP_PX)
        return np.minimum((r - bias[few] @ b) ** 2, CLIP_PX ** 2).sum()

    coarse = np.arange(-SEARCH_US, SEARCH_US + 1, COARSE_STEP_US, dtype=np.float64)
    offset = coarse[int(np.argmin([loss(off) for off in coarse]))]
    speed = np.abs(seen) / (t_j - t_i)
    for _ in range(WEIGHT_ROUNDS):   # the weights from the residuals where the fit stands
        r = seen - predicted(offset)
        weight, clip = _speed_class_weights(r - bias @ _clipped_fit(bias, r, ones, CLIP_PX)[0],
                                            speed)
        for _ in range(GAUSS_NEWTON_STEPS):   # the residuals are linear in a small step
            r = seen - predicted(offset)
            g = (predicted(offset + STEP_US) - predicted(offset - STEP_US)) / (2 * STEP_US)
            x = np.column_stack([g, bias])
            step, ok = _clipped_fit(x, r, weight, clip)
            offset += step[0]
    r = (seen - predicted(offset) - x @ np.r_[0.0, step[1:]])[ok]
    # the standard error, each block's pairs taken as one (they share crossings and a
    # stretch of the motion): the sandwich of the blocks' weighted scores
    block = ((t_i[ok] - t_i.min()) // BLOCK_US).astype(np.int64)
    x, w = x[ok], weight[ok]
    score = np.stack([np.bincount(block, weights=w * c * r) for c in x.T], 1)
    a_inv = np.linalg.pinv((x * w[:, None]).T @ x)
    return float(offset), float(np.sqrt(max((a_inv @ score.T @ score @ a_inv)[0, 0], 0.0)))


def _speed_class_weights(r, speed):
    """(per pair 1 / its class's robust residual variance, its clip: CLIP_SIGMA of that
    scatter, at most CLIP_PX), classes SPEED_CLASSES equal shares of the pairs by speed: a
    slow pair's crossings time the star's passage poorly (on an Orion DAVIS346 8 mm
    sinusoid the pairs under 80 px/s scattered 0.6-0.8 px, the others 0.1), and near a
    turn, where the offset shows most, they are many."""
    edges = np.quantile(speed, np.linspace(0, 1, SPEED_CLASSES + 1)[1:-1])
    cls = np.searchsorted(edges, speed)
    scatter = np.empty(len(r))
    for c in np.unique(cls):
        m = cls == c
        scatter[m] = max(robust_sigma(r[m]), MIN_SCATTER_PX)
    return 1 / scatter ** 2, np.minimum(CLIP_SIGMA * scatter, CLIP_PX)


def _clipped_fit(columns, r, weight, clip):
    """(weighted least-squares coefficients of r on the columns over the residuals within
    `clip` (px, per row) of a first fit on all, which residuals those are)."""
    sw = np.sqrt(weight)
    first = np.linalg.lstsq(columns * sw[:, None], r * sw, rcond=None)[0]
    ok = np.abs(r - columns @ first) < clip
    return np.linalg.lstsq(columns[ok] * sw[ok, None], r[ok] * sw[ok], rcond=None)[0], ok


def _rate_changes(imu, window_us=SMOOTH_US):
    """Whether the gyro's rate smoothed over window_us changes over a pair's gap by more
    than its own white noise makes it seem to: the RMS over its record of that change at
    least NOISE_RATIO times a constant-rate gyro's of the same measured noise (a constant
    rate tells no offset, and a noisy gyro's smoothed rate still wanders)."""
    from .smoothing import gyro_noise_density

    t = imu.t_cam.astype(np.float64)
    if t[-1] - t[0] < 2 * MIN_GAP_US:   # too short to compare rates a gap apart
        return False
    rate_hz = 1e6 / max(float(np.median(np.diff(t))), 1.0)
    white = (np.random.default_rng(0).standard_normal((len(t), 3))
             * gyro_noise_density(imu) * np.sqrt(rate_hz))

    def rms_change(gyro):
        smooth = _smoothed(t, gyro, window_us)
        later = interp_rows(t + MIN_GAP_US, t, smooth)
        return np.sqrt(np.mean(np.sum((later - smooth)[t + MIN_GAP_US <= t[-1]] ** 2, 1)))

    return rms_change(imu.gyro_cam) > max(NOISE_RATIO * rms_change(white), MIN_RATE_CHANGE)


def _smoothed(t_cam, gyro, window_us=SMOOTH_US):
    """The rates fitted over window_us (a quadratic Savitzky-Golay fit): the offset is read
    off how the rate changes, and a white noise's changes from sample to sample, which the
    raw rates hold, had passed for that at a constant rate."""
    from scipy.signal import savgol_filter

    step = float(np.median(np.diff(t_cam))) if len(gyro) > 1 else window_us
    window = int(window_us // max(step, 1.0)) // 2 * 2 + 1
    return savgol_filter(gyro, window, 2, axis=0) if 5 <= window <= len(gyro) else gyro


def _turned(t_cam, gyro, window_us=SMOOTH_US):
    """(n, 3) the rates smoothed over window_us (rad/s, camera frame) integrated from the
    first sample (rad, trapezoids) at the camera times: over a pair's gap its difference is
    the turn."""
    g = _smoothed(t_cam, gyro, window_us)
    dt = np.diff(t_cam.astype(np.float64)) * 1e-6
    return np.r_[np.zeros((1, 3)), np.cumsum(0.5 * (g[1:] + g[:-1]) * dt[:, None], axis=0)]


def _predicted(pairs, t_cam, turned, camera):
    """offset -> per pair the second crossing's distance (px) along the motion from the
    first that the gyro predicts: the first pixel's star turned by the gyro between their
    times + the offset."""
    t_i, t_j, _, _, _, _, ux, uy, _ = pairs
    moved = _moved(pairs, t_cam, turned, camera)

    def predicted(offset):
        du, dv = moved(t_i + offset, t_j + offset)
        return du * ux + dv * uy

    return predicted


def _moved(pairs, t_cam, turned, camera):
    """(t_from, t_to) -> (du, dv): per pair, how far the star at its first pixel moves in
    the image as the gyro turns between the two times."""
    from .camera import unit

    x_i, y_i = pairs[2], pairs[3]
    d = unit(*camera.unproject_columns(x_i, y_i))

    def moved(t_from, t_to):
        w = interp_rows(t_to, t_cam, turned) - interp_rows(t_from, t_cam, turned)
        u, v = camera.project_turned(*d, *w.T)
        return u - x_i, v - y_i

    return moved


def _straight(pairs, t_cam, turned, camera):
    """Per pair: does the star's image path run straight over its gap (forwards or back:
    the two halves of its gyro-predicted move within MAX_BEND of parallel)? On a curved
    path the crossed pixels' offsets across it add to the along distance by their sum
    times the sine of half the turn, and their mean offset is not nil (on the independent
    simulator's 2 Hz coning that read as a 5 ms offset)."""
    t_i, t_j = pairs[0], pairs[1]
    moved = _moved(pairs, t_cam, turned, camera)
    mid = (t_i + t_j) / 2
    (au, av), (bu, bv) = moved(t_i, mid), moved(mid, t_j)
    size = np.hypot(au, av) * np.hypot(bu, bv)
    return np.abs(au * bv - av * bu) <= MAX_BEND * np.maximum(size, 1e-12)


def _pairs(crossings, centroids, lag, t_cam):
    """[t_i, t_j, x_i, y_i, x_j, y_j, ux, uy, lag]: the times (µs, lag taken off) and pixels
    of each crossing i and the first of its track's crossings j MIN_GAP_US or more later
    (within MAX_GAP_US), the track's unit direction at i and the pair's mean lag (µs): those
    whose times the search keeps on the gyro's record; None without a track. Of many
    crossings every k-th is taken (CROSSINGS_PER_PAIR per pair the search evaluates)."""
    tracks = _tracks(centroids)
    if tracks is None or not len(crossings):
        return None
    step = -(-len(crossings) // (CROSSINGS_PER_PAIR * MAX_PAIRS))
    crossings = crossings[::step]
    ci, tid, _, _, ux, uy = near_tracks(crossings, tracks, REACH_PX)
    t = crossings["t"][ci].astype(np.float64)
    late = np.zeros(len(t))
    if lag is not None:   # when the star passed each pixel, at its own track's speed
        rows_of = dict(zip(*groups(tracks["track"])))
        for k, m in zip(*groups(tid)):
            track = {f: tracks[f][rows_of[k]] for f in ("t", "vx", "vy")}
            t[m], _, late[m] = lag_corrected(t[m], crossings["pairs"][ci[m]],
                                             crossings["t_outer"][ci[m]], np.zeros(len(m)),
                                             track, lag)
    x, y = crossings["x"][ci].astype(np.float64), crossings["y"][ci].astype(np.float64)
    order = np.lexsort((t, tid))
    t, x, y, tid, ux, uy, late = (a[order] for a in (t, x, y, tid, ux, uy, late))
    # one search over all tracks: each track's times on its own stretch of one line
    span = (t.max() - t.min() + 2 * MAX_GAP_US) if len(t) else 0.0
    key = np.unique(tid, return_inverse=True)[1] * span + (t - (t.min() if len(t) else 0.0))
    i = np.arange(len(t))
    j = np.searchsorted(key, key + MIN_GAP_US)
    ok = j < len(t)
    i, j = i[ok], j[ok]
    keep = ((tid[j] == tid[i]) & (t[j] - t[i] <= MAX_GAP_US)
            & (t[i] >= t_cam[0] + SEARCH_US) & (t[j] <= t_cam[-1] - SEARCH_US))
    i, j = i[keep], j[keep]
    return [t[i], t[j], x[i], y[i], x[j], y[j], ux[i], uy[i], (late[i] + late[j]) / 2]


def _spread(pairs, keep):
    """The pairs `keep` selects, at most MAX_PAIRS of them evenly spread over the run; None
    where they are fewer than MIN_PAIRS or span fewer than MIN_BLOCKS blocks."""
    i = np.flatnonzero(keep)
    i = i[_evenly(len(i), MAX_PAIRS)]
    t = pairs[0][i]
    if len(i) < MIN_PAIRS or len(np.unique((t - t.min()) // BLOCK_US if len(t) else t)) < MIN_BLOCKS:
        return None
    return [a[i] for a in pairs]


def _evenly(n, most):
    """Indices of at most `most` of n items, evenly spread (all of them where n <= most)."""
    return np.linspace(0, n - 1, min(n, most)).round().astype(np.int64)


def _tracks(centroids):
    """The linked centroids' tracks as near_tracks takes them (t, track, x, y, vx, vy, sorted
    by track then time; velocities by differences between each row's neighbours in its
    track), those of three rows or more; None without one."""
    from .frames import run_neighbours

    c = centroids[centroids["track"] >= 0]
    c = c[np.lexsort((c["t"], c["track"]))]
    # one row a time (a joined track can hold two): differences need distinct times
    c = c[np.r_[True, (c["track"][1:] != c["track"][:-1]) | (c["t"][1:] != c["t"][:-1])]]
    _, where, count = np.unique(c["track"], return_inverse=True, return_counts=True)
    c = c[count[where] >= 3]
    if not len(c):
        return None
    out = {f: np.ascontiguousarray(c[f]) for f in ("t", "track", "x", "y")}
    before, after = run_neighbours(out["track"])
    dt = (out["t"][after] - out["t"][before]) * 1e-6
    out["vx"] = (out["x"][after] - out["x"][before]) / dt
    out["vy"] = (out["y"][after] - out["y"][before]) / dt
    return out
