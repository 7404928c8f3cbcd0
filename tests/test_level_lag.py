"""The pixel low-pass lag measured from crossings' level profiles (evstar.level_lag)."""
import numpy as np
import pytest

import evstar
from evstar import crossings, sim
from evstar.level_lag import MAX_PROFILES, LevelProfiles, fit_lag


def _profiles(rho, amp, ks=range(4, 13), noise_us=0.0, n=40, seed=0):
    """{k: (median demeaned profile, n)} of m_j = t0 + a_k·ρ^j (+ noise), a_k = amp / k."""
    rng = np.random.default_rng(seed)
    out = {}
    for k in ks:
        j = np.arange(1, k + 1)
        rows = (amp / k) * rho ** j + rng.normal(0, noise_us, (n, k)) + rng.uniform(0, 1e6, (n, 1))
        rows -= rows.mean(axis=1, keepdims=True)
        out[k] = (np.median(rows, axis=0), n)
    return out


@pytest.mark.parametrize("rho", [1.15, 1.3, 1.8])
def test_fit_recovers_a_geometric_lag(rho):
    amp = 4000.0
    ks, lag, r2, got_rho = fit_lag(_profiles(rho, amp, noise_us=20.0))
    want = np.array([(amp / k) * np.mean(rho ** np.arange(1, k + 1)) for k in ks])
    assert abs(got_rho - rho) < 0.03 * rho and r2 > 0.99
    np.testing.assert_allclose(lag, want, rtol=0.08)


def test_profiles_without_a_lowpass_give_none():
    rng = np.random.default_rng(1)
    flat = {k: (rng.normal(0, 60.0, k), 50) for k in range(3, 12)}
    assert fit_lag(flat) is None
    assert fit_lag({3: (np.array([-1.0, 0.0, 1.0]), 50)}) is None      # one profile: no shape


def test_a_profile_falling_with_depth_is_no_lowpass():
    """Deep profiles that a geometric lag fits (R² > 0.99) beside a short one that falls with
    depth, as refractory and jitter effects made them on the default sensor (12 °/s): a
    low-pass delays every deeper level more, so no lag is measured."""
    prof = _profiles(1.3, 1500.0, ks=range(4, 8), noise_us=5.0)
    assert fit_lag(prof) is not None
    prof[2] = (np.array([18.0, -18.0]), 60)
    assert fit_lag(prof) is None


def test_a_long_profile_s_deepest_level_does_not_decide():
    """The deepest level of a profile of >= 4 levels is left out of the shape; a background
    event paired there (a fast dark-sky field at 1.5 Hz: one k of 32 crossings whose
    deepest midpoint came 12 ms early) must not veto the lag of all the others. A level
    that shapes the fit still does."""
    prof = _profiles(1.3, 1500.0, ks=range(4, 12), noise_us=5.0)
    D, n = prof[11]
    prof[11] = (np.r_[D[:-1], D[0] - 10_000.0], 32)
    assert fit_lag(prof) is not None
    prof[11] = (np.r_[D[:-2], D[0] - 10_000.0, D[-1]], 32)
    assert fit_lag(prof) is None


def test_short_profiles_shape_rho_without_their_deepest_level():
    """Unequal thresholds give a bright star only 2–4 pairs. The 4-pair profile's deepest
    level, near the background, lags beyond the geometric trend: left out, the 3- and
    4-pair profiles' upper levels give ρ and the lags; shaping with it took ρ high and
    every lag short (perf/study_indep.py scene 22: 1.1–1.9 against 1.7–2.7 ms)."""
    rho, amp = 1.3, 1500.0
    prof = _profiles(rho, amp, ks=range(2, 5), noise_us=5.0)
    D, n = prof[4]
    deep = np.r_[D[:3], D[3] + 800.0]         # the deepest level 0.8 ms later than the trend
    prof[4] = (deep - deep.mean(), n)
    ks, lag, r2, got_rho = fit_lag(prof)
    assert abs(got_rho - rho) < 0.05 * rho
    want = (amp / 3) * np.mean(rho ** np.arange(1, 4))
    assert lag[list(ks).index(3)] == pytest.approx(want, rel=0.1)


def test_a_sparse_profile_neither_vetoes_nor_shapes_the_lag():
    """A k of a few crossings beside well-filled ones (a fast dark-sky field: 28 of 11
    pairs beside 500s, falling where a background event was paired) leaves the lag as the
    others give it; as full as them, it vetoes."""
    prof = _profiles(1.3, 1500.0, ks=range(4, 11), noise_us=5.0, n=500)
    want = fit_lag(prof)
    odd = np.r_[np.linspace(600.0, 900.0, 9), 200.0, -8000.0]
    prof[11] = (odd - odd.mean(), 28)
    got = fit_lag(prof)
    assert got is not None and got[3] == want[3] and got[2] == pytest.approx(want[2])
    np.testing.assert_allclose(got[1][:-1], want[1])
    prof[11] = (odd - odd.mean(), 500)
    assert fit_lag(prof) is None


def test_a_falling_profile_vetoes_by_its_share_of_all_crossings_not_of_those_kept():
    """A faint star on a dark sky with OFF below ON: 843 crossings of 3 pairs, 433 of 4 and
    73 of 2 whose profile falls with depth (a slow first ON or a leak in their ON run).
    Against the MAX_PROFILES kept the 73 are 15 % of the fullest and veto the lag; against
    all the run's crossings, 9 %. Shaping still counts the kept profiles."""
    prof = _profiles(1.3, 1500.0, ks=range(3, 6), noise_us=5.0, n=MAX_PROFILES)
    want = fit_lag(prof)
    prof[2] = (np.array([845.0, -845.0]), 73)
    assert want is not None and fit_lag(prof) is None
    seen = {2: 73, 3: 843, 4: 433, 5: 65}
    got = fit_lag(prof, seen)
    assert got is not None and got[3] == want[3]
    assert fit_lag(prof, {**seen, 2: 200}) is None


def test_profiles_count_all_the_crossings_they_are_offered():
    prof = LevelProfiles()
    k = np.array([1, 2, 3, 3] * (MAX_PROFILES + 10))
    for _ in range(2):
        sel = prof.wanted(k)
        prof.add(k[sel], np.zeros((len(sel), 3)))
    assert prof.seen == {2: 2 * (MAX_PROFILES + 10), 3: 4 * (MAX_PROFILES + 10)}


def test_profiles_keep_at_most_their_cap_per_k():
    prof = LevelProfiles()
    k = np.array([1, 2, 3] * (MAX_PROFILES + 10))
    for _ in range(2):
        sel = prof.wanted(k)
        prof.add(k[sel], np.zeros((len(sel), 3)))
    med = prof.medians()
    assert sorted(med) == [2, 3] and all(n == MAX_PROFILES for _, n in med.values())
    assert len(prof.wanted(k)) == 0


def test_level_midpoints_average_to_the_pair_sums():
    rng = np.random.default_rng(3)
    n = 20000
    t = np.sort(rng.integers(0, 10**6, n))
    key = rng.integers(0, 50, n).astype(np.uint32)
    p = (rng.random(n) < 0.5).astype(np.int8)
    ts, keys, ps = crossings.by_pixel_then_time(t, key, p, "numpy")
    change, nb, na = crossings._runs(keys, ps)
    for ratio in (1.0, 0.7, 1.6):
        k = crossings._pair_counts(nb, na, ratio, 16)
        m = k > 0
        mids = crossings.level_midpoints(ts, change[m], k[m], ratio, nb[m])
        sums = crossings._pair_sums(ts, change[m], k[m], ratio, nb[m])[0]
        np.testing.assert_allclose(np.nanmean(mids, axis=1), sums / k[m], rtol=0, atol=1e-6)
        assert np.all(np.isnan(mids) == (np.arange(mids.shape[1]) >= k[m][:, None]))


def _run(run, **settings):
    cfg = evstar.Config().replace(**{f"estimate.{k}": v for k, v in settings.items()})
    return evstar.Pipeline(cfg).run(run.events, None, run.camera, truth=run.truth)


def test_measured_lag_removes_the_dark_sky_trail(tmp_path):
    """A dark-sky photoreceptor (15 Hz at the background: not the preset's 30) at 8 °/s;
    the run reports the lag it moved the crossings back by, and prints it."""
    from evstar.outputs import summary_text

    dark = sim.SensorSpec.dark_sky(cutoff_hz_background=15.0)
    run = sim.simulate(sim.paper_preset(8.0, magnitude=3.0, sensor=dark, duration_s=0.4), seed=5)
    raw = _run(run, measure_lag=False)
    measured = _run(run)
    raw_err, err = (r.metrics["centroid_error_px"]["mean"] for r in (raw, measured))
    assert raw_err > 0.25 and err < raw_err / 4, (raw_err, err)
    assert "pixel_lag" not in raw.metrics
    lag = measured.metrics["pixel_lag"]
    # a 15 Hz pixel's time constant is 10.6 ms: its bright levels lag less, its faint ones ms
    assert lag["source"] == "level profiles" and 0 <= lag["lag_ms"][0] < lag["lag_ms"][1] < 10.6
    assert lag["lag_ms"][1] > 1.0
    line = [s for s in summary_text(measured, tmp_path).splitlines() if s.startswith("pixel lag")]
    assert len(line) == 1 and f"{lag['lag_ms'][1]:.1f} ms" in line[0] and "calibrate" in line[0]


def test_a_sensor_without_lowpass_is_left_as_it_was():
    run = sim.simulate(sim.paper_preset(8.0, magnitude=3.0, duration_s=0.4), seed=5)
    off, on = _run(run, measure_lag=False), _run(run)
    np.testing.assert_array_equal(off.centroids, on.centroids)
    assert "pixel_lag" not in on.metrics   # no lag measured: none reported


_TRUE_LAG_US = {1: 3100.0, 2: 3200.0, 3: 3100.0, 4: 2800.0, 5: 2400.0, 6: 2100.0, 7: 1700.0,
                8: 1600.0, 9: 1400.0, 10: 1300.0}
_ROW = np.dtype([("t", "f8"), ("track", "i8"), ("x", "f8"), ("y", "f8"), ("vx", "f8"),
                 ("vy", "f8")])


def _tracks_and_crossings(ks_of_track, seed=0, jitter_us=150.0, speeds=(150, 300), widths=None,
                          slope=0.0):
    """Straight tracks (rows every 10 ms, 0.5 s, `speeds` px/s in various directions) and
    crossings of pixels along them, each timed its k's _TRUE_LAG_US after the star passed
    the pixel (+ jitter); track i's crossings have pairs drawn from ks_of_track[i]. widths:
    per track, the mean outer half-width (µs; ± 1 ms) of its crossings at 200 px/s (as
    1 / speed at its own speed), each of which then lags `slope` µs more per µs it is wider
    than _REF_WIDTH_US (likewise scaled)."""
    rng = np.random.default_rng(seed)
    rows, cross = [], []
    for tid, ks in enumerate(ks_of_track):
        speed, ang = rng.uniform(*speeds), rng.uniform(0, 2 * np.pi)
        v = speed * np.array([np.cos(ang), np.sin(ang)])
        p0 = rng.uniform(100, 200, 2)
        t = np.arange(0, 500_001, 10_000.0)
        r = np.zeros(len(t), _ROW)
        r["t"], r["track"] = t, tid
        r["x"], r["y"] = p0[0] + v[0] * t * 1e-6, p0[1] + v[1] * t * 1e-6
        r["vx"], r["vy"] = v
        rows.append(r)
        T = rng.uniform(20_000, 480_000, 400)       # the star passes the pixel at T
        pix = np.round(p0 + v * T[:, None] * 1e-6 + rng.uniform(-1, 1, (len(T), 1))
                       * np.array([-v[1], v[0]]) / speed)
        # the pixel's own passage time: its centre projected on the motion
        T = T + ((pix - (p0 + v * T[:, None] * 1e-6)) @ v) / speed ** 2 * 1e6
        c = np.zeros(len(T), crossings.CROSSING_DTYPE)
        c["x"], c["y"] = pix[:, 0], pix[:, 1]
        c["pairs"] = rng.choice(ks, len(T))
        c["t"] = T + np.vectorize(_TRUE_LAG_US.get)(c["pairs"]) + rng.normal(0, jitter_us, len(T))
        if widths is not None:
            scale = 200.0 / speed
            c["t_outer"] = rng.normal(widths[tid], 1000.0, len(T)) * scale
            c["t"] += slope * (c["t_outer"] - _REF_WIDTH_US * scale)
        cross.append(c)
    return np.concatenate(rows), np.concatenate(cross)


def _assigned(cr, rows):
    return crossings.along_track(cr, rows)[:2]


def _lag(over_us=0.0):
    """The true lag table with k = 2–4 too long by `over_us`."""
    from evstar.calibration import PixelLag

    ks = np.arange(2, 11)
    lag = np.array([_TRUE_LAG_US[k] + (over_us if k < 5 else 0.0) for k in ks])
    return PixelLag(ks, [1.0], lag[:, None], np.zeros((len(ks), 1)), {"source": "test"})


def test_tracks_correct_an_overestimated_faint_lag():
    from evstar.level_lag import track_consistent

    bright = [range(1, 11)] * 4
    rows, cr = _tracks_and_crossings(bright + [range(2, 5)] * 3)
    got, told = track_consistent(_lag(over_us=2000.0), cr, _assigned(cr, rows), rows)
    assert list(told) == [0, 1, 2, 3] and got.meta["source"] == "test"    # the bright ones
    for k in range(1, 11):
        assert abs(got.lag_at(k, 200.0) - _TRUE_LAG_US[k]) < 120, k


_REF_WIDTH_US = 5000.0


def test_the_tracks_tell_how_the_lag_grows_with_a_crossing_s_width():
    """Faint stars' crossings (k = 2–4 only, too few anchors) are wider than the bright
    stars' flank crossings of the same k and lag more: the width slope the bright tracks
    show carries their lag over."""
    from evstar.level_lag import track_consistent

    widths = [_REF_WIDTH_US] * 4 + [8000.0] * 3
    rows, cr = _tracks_and_crossings([range(1, 11)] * 4 + [range(2, 5)] * 3, seed=4,
                                     widths=widths, slope=0.3)
    got, told = track_consistent(_lag(over_us=2000.0), cr, _assigned(cr, rows), rows)
    assert list(told) == [0, 1, 2, 3]
    assert np.all(np.abs(got.width_slope - 0.3) < 0.06), got.width_slope
    faint = np.isin(_assigned(cr, rows)[1], [4, 5, 6])
    c = cr[_assigned(cr, rows)[0][faint]]
    speed = np.hypot(rows["vx"], rows["vy"])[np.searchsorted(rows["track"],
                                                             _assigned(cr, rows)[1][faint])]
    true = (np.vectorize(_TRUE_LAG_US.get)(c["pairs"])
            + 0.3 * (c["t_outer"] - _REF_WIDTH_US * 200.0 / speed))
    err = got.lag_at(c["pairs"], speed, c["t_outer"]) - true
    assert abs(np.median(err)) < 100 and np.median(np.abs(err)) < 150, np.median(err)
    no_width = got.lag_at(c["pairs"], speed) - true       # the table alone: ~0.9 ms short
    assert np.median(no_width) < -600


def test_a_lag_the_tracks_agree_with_stays():
    from evstar.level_lag import track_consistent

    rows, cr = _tracks_and_crossings([range(2, 11)] * 4, seed=1)
    got, _ = track_consistent(_lag(), cr, _assigned(cr, rows), rows)
    for k in range(2, 11):
        assert abs(got.lag_at(k, 200.0) - _TRUE_LAG_US[k]) < 120, k


def test_no_bright_crossings_no_correction():
    """Tracks without crossings of >= 5 pairs have nothing to anchor to; too slow tracks tell
    no time."""
    from evstar.level_lag import track_consistent

    lag = _lag(over_us=2000.0)
    rows, cr = _tracks_and_crossings([range(2, 5)] * 5, seed=2)
    got, told = track_consistent(lag, cr, _assigned(cr, rows), rows)
    assert got is lag and len(told) == 0
    rows, cr = _tracks_and_crossings([range(2, 11)] * 5, seed=2)
    rows["vx"] *= 0.1      # below MIN_SPEED_PX_S as the rows tell it
    rows["vy"] *= 0.1
    assert len(track_consistent(lag, cr, _assigned(cr, rows), rows)[1]) == 0


def test_a_fast_star_s_crossings_count_as_the_refit_assigned_them():
    """At 1,200 px/s a crossing timed 3 ms late lies 3.6 px behind its star: farther than
    along_track's reach from the refitted rows. The crossings the refit was given count."""
    from evstar.level_lag import track_consistent

    rows, cr = _tracks_and_crossings([range(1, 11)] * 4, seed=3, speeds=(1100, 1300))
    assigned = (np.arange(len(cr)), np.repeat(np.arange(4), 400))
    reach = crossings.along_track(cr, rows)[0]
    assert np.mean(cr["pairs"][reach] <= 4) < 0.5 * np.mean(cr["pairs"] <= 4)
    got, told = track_consistent(_lag(over_us=2000.0), cr, assigned, rows)
    assert len(told) == 4
    for k in range(1, 11):
        assert abs(got.lag_at(k, 1200.0) - _TRUE_LAG_US[k]) < 120, k


@pytest.fixture(scope="module")
def fast_dark_field():
    """An EVK4 behind 16 mm panning at 20 °/s over a dark sky (11 px a frame), 0.3 s."""
    scene = sim.field_scenario(sim.camera_preset("evk4", 16.0), 253, -38, 20.0, 0.3,
                               mag_limit=4.5, sensor="dark-sky", noise_hz=0.1)
    return sim.simulate(scene, seed=95)


def test_fast_dark_sky_field_does_not_lead_its_stars(fast_dark_field):
    """The level profiles' lag of k = 2–4 is several ms too long on a fast dark sky (pulses
    far shorter than the pixels' time constant), and the fit led the stars by px; the
    tracks' own bright crossings correct it."""
    from evstar import accuracy

    r = fast_dark_field
    medians = []
    for on in (True, False):
        rows = evstar.Pipeline(evstar.Config().replace(**{"estimate.lag_from_tracks": on})) \
            .run(r.events).centroids
        star, err = accuracy.match(rows, r.truth.star_position)
        medians.append(np.median([err[star == i].mean() for i in np.unique(star[star >= 0])]))
    assert medians[0] < 0.25 < 0.5 < medians[1], medians


def test_faint_stars_on_a_fast_dark_sky_take_the_lag_the_bright_ones_tell():
    """Cygnus to magnitude 6 at 20 °/s on an EVK4's dark sky: the faint stars' crossings
    (most of k = 1–2) kept the level profiles' lag (9.4 ms against ~2.3), their rows led
    them by 4–7 px and 60 % of all rows matched no star. The bright tracks' table and the
    width terms carry the lag over."""
    from evstar import accuracy

    scene = sim.field_scenario(sim.camera_preset("evk4", 16.0), 305, 40, 20.0, 0.25,
                               mag_limit=6.0, sensor="dark-sky", noise_hz=0.1)
    r = sim.simulate(scene, seed=95)
    rows = evstar.Pipeline(evstar.Config()).run(r.events).centroids
    star, err = accuracy.match(rows, r.truth.star_position)
    per_star = [err[star == i].mean() for i in np.unique(star[star >= 0])]
    assert np.mean(star < 0) < 0.02 and len(per_star) > 45, (np.mean(star < 0), len(per_star))
    assert np.median(per_star) < 0.25, np.median(per_star)


def test_a_streamed_run_checks_the_lag_as_a_whole_run_does(fast_dark_field, tmp_path):
    from evstar import io

    io.write(tmp_path / "events.h5", fast_dark_field.events)
    cfg = evstar.Config(chunk_frames=7)
    whole = evstar.Pipeline(cfg).run(fast_dark_field.events).centroids
    streamed = evstar.Pipeline(cfg).run_file(tmp_path / "events.h5", progress=False).centroids
    assert len(whole) > 100
    for f in ("t", "x", "y", "sigma", "track"):
        np.testing.assert_array_equal(whole[f], streamed[f])


def test_a_lag_s_uncertainty_widens_sigma_along_the_motion_by_speed():
    """Rows of a track at 200 px/s, its lag known to 1 ms: 0.2 px along, so each axis's σ
    (the RMS of x and y) gains 0.2²/2; a row of another track and untracked rows keep
    theirs."""
    from evstar.estimation import with_lag_sigma
    from evstar.extract import CENTROID_DTYPE

    rows = np.zeros(12, CENTROID_DTYPE)
    rows["t"] = np.r_[np.arange(10) * 10_000, 0, 0]
    rows["x"] = np.r_[np.arange(10) * 2.0, 5, 7]          # 2 px per 10 ms: 200 px/s
    rows["track"] = np.r_[[3] * 10, 4, -1]
    rows["sigma"] = 0.05
    out = with_lag_sigma(rows[::-1], {3: 1000.0, 4: 1000.0})[::-1]
    np.testing.assert_allclose(out["sigma"][:10], np.sqrt(0.05 ** 2 + 0.2 ** 2 / 2))
    assert out["sigma"][10] == 0.05 and out["sigma"][11] == 0.05   # alone: no speed; untracked
    np.testing.assert_array_equal(out["x"], rows["x"])


def _crossings_run(scenario):
    """(linked centroids, crossings, the crossings estimator's config, t0, the run) of a
    simulated `scenario` (seed 6)."""
    from evstar import Config, Pipeline, estimation, sim

    run = sim.simulate(scenario, seed=6)
    cfg = Config().replace(**{"estimate.estimator": "mean"})
    res = Pipeline(cfg).run(run.events)
    linked = res.centroids[res.centroids["track"] >= 0]
    crossings = estimation.chunk_crossings(run.events, res.keep, 3.0)
    c = cfg.replace(**{"estimate.estimator": "crossings", "estimate.vibration": False})
    return linked, crossings, c, int(run.events.t[0]), run


def test_a_low_pass_the_profiles_could_not_fit_widens_sigma_by_its_depth_delay():
    """No lag measured, no gyro, but the deepest levels pass 2 ms after the top: each moving
    row's σ holds UNMEASURED_LAG_SHARE × 2 ms × its speed along the motion (the positions
    stay); with no depth delay the delay adds nothing. A gyro at this constant rate tells
    no lag either (an offset along the motion): the same σ."""
    from evstar import estimation, sim
    from evstar.estimation import UNMEASURED_LAG_SHARE
    from evstar.smoothing import imu_velocity_prior

    linked, crossings, c, t0, run = _crossings_run(sim.paper_preset(8.0, duration_s=0.3))
    plain = estimation.estimate(linked, c, t0, crossings)
    wide = estimation.estimate(linked, c, t0, crossings, depth_delay_us=2000.0)
    np.testing.assert_array_equal(wide["x"], plain["x"])
    speed = 8.0 * run.camera.fx * np.pi / 180          # px/s near the centre
    along = UNMEASURED_LAG_SHARE * 2000e-6 * speed
    mid = slice(5, -5)                                  # (speeds from neighbours at the ends)
    np.testing.assert_allclose(wide["sigma"][mid], np.sqrt(plain["sigma"][mid] ** 2 + along ** 2 / 2),
                               rtol=0.05)
    none = estimation.estimate(linked, c, t0, crossings, depth_delay_us=0.0)
    np.testing.assert_array_equal(none["sigma"], plain["sigma"])
    gyro = imu_velocity_prior(run.imu, run.camera)
    told = estimation.estimate(linked, c, t0, crossings, velocity_prior=gyro)
    told_deep = estimation.estimate(linked, c, t0, crossings, velocity_prior=gyro,
                                    depth_delay_us=2000.0)
    np.testing.assert_array_equal(told_deep["x"], told["x"])
    np.testing.assert_allclose(told_deep["sigma"][mid], np.sqrt(told["sigma"][mid] ** 2 + along ** 2 / 2),
                               rtol=0.05)


def test_a_gyro_that_pins_the_lag_leaves_sigma_without_the_depth_delay():
    """On the paper's sinusoid the gyro's speed changes tell the pixels' lag (the track's
    fit within LAG_MAX_SE_S: smoothing.lag_pinned): a depth delay adds nothing to σ."""
    from evstar import estimation, sim
    from evstar.smoothing import TrackSmoother, imu_velocity_prior, lag_pinned

    linked, crossings, c, t0, run = _crossings_run(sim.paper_sinusoid(duration_s=0.6))
    gyro = imu_velocity_prior(run.imu, run.camera)
    told = estimation.estimate(linked, c, t0, crossings, velocity_prior=gyro)
    told_deep = estimation.estimate(linked, c, t0, crossings, velocity_prior=gyro,
                                    depth_delay_us=2000.0)
    np.testing.assert_array_equal(told_deep["sigma"], told["sigma"])
    smoother = TrackSmoother(c.dt_us)
    smoother.refine(smoother.smooth(linked, t0, gyro), linked, crossings, gyro, t0_us=t0)
    assert smoother.lag_pinned_ and all(smoother.lag_pinned_.values())
    assert not lag_pinned(None)


def test_only_the_fit_whose_lag_moves_a_track_pins_it():
    """A track's one-level crossings take their own lag only beside a multi-level one
    (smoothing._classes_lags): where the multi-level fit dropped out, no lag moves the track,
    so however precise the one-level fit, σ must keep the depth delay (not pinned)."""
    from evstar.smoothing import LAG_MAX_SE_S, LagFit, _classes_lags, _TrackLags, lag_pinned

    sure = LagFit(1e-3, LAG_MAX_SE_S / 4, 0.0)
    none = np.arange(0)
    assert _classes_lags(None, sure) == (0.0, 0.0)
    assert not lag_pinned(_TrackLags(none, none, None, sure))
    assert lag_pinned(_TrackLags(none, none, sure, None))
    assert not lag_pinned(_TrackLags(none, none, LagFit(1e-3, 2 * LAG_MAX_SE_S, 0.0), sure))


def _track(x_of_t, track=0, n=100, dt_us=10_000, y=50.0):
    """Linked centroids of one track at frame mid-times, x = x_of_t(t s)."""
    from evstar.extract import CENTROID_DTYPE

    rows = np.zeros(n, CENTROID_DTYPE)
    rows["t"] = np.arange(n) * dt_us + dt_us // 2
    rows["x"], rows["y"], rows["track"], rows["frame"] = x_of_t(rows["t"] * 1e-6), y, track, np.arange(n)
    return rows


def test_speed_changes_are_told_by_tracks_that_speed_up_but_never_reverse():
    """κ = a / v of a star accelerating from 20 px/s at 100 px/s² (at t: 100 / (20 + 100 t)),
    at pixels on its path; none at a constant rate, on a reversing track, or off the path."""
    from evstar.level_lag import speed_changes

    speeding = _track(lambda t: 10 + 20 * t + 50 * t ** 2)
    kappa = speed_changes(speeding)
    t = np.array([300_000.0, 600_000.0])
    x = 10 + 20 * t * 1e-6 + 50 * (t * 1e-6) ** 2
    np.testing.assert_allclose(kappa(t, np.column_stack([x, [50.0, 50.0]])),
                               100 / (20 + 100 * t * 1e-6), rtol=0.02)
    assert np.all(np.isnan(kappa(t, np.column_stack([x, [55.0, 55.0]]))))       # 5 px off
    steady = _track(lambda t: 10 + 40 * t)
    turning = _track(lambda t: 50 + 30 * np.sin(2 * np.pi * t))
    for rows in (steady, turning):
        assert np.all(np.isnan(speed_changes(rows)(t, np.column_stack([rows["x"][[30, 60]], [50.0] * 2]))))


def test_a_speed_change_is_taken_off_level_profiles_that_fit_no_low_pass_as_they_are():
    """Crossings of a low-pass (m_j = a·ρ^j) on a star speeding up: each level's midpoint
    comes κ·h_j²/2 early (h_j its pair's half-width), which bends the profiles off the
    geometric model until it no longer fits; told κ, the profiles give the lag without it.
    Profiles that fit as they are keep their fit (on a sinusoid the two signs cancel)."""
    rng = np.random.default_rng(4)
    rho, amp, kappa = 1.3, 4000.0, 8.0              # κ 8 /s: 200 px/s² at 25 px/s
    clean, bent = LevelProfiles(), LevelProfiles()
    for k in range(4, 11):
        n = 60
        j = np.arange(1, k + 1)
        h = np.tile(3000.0 * j, (n, 1))             # deeper pairs are wider (µs)
        lag = (amp / k) * rho ** j + rng.normal(0, 20.0, (n, k)) + rng.uniform(0, 1e6, (n, 1))
        t, xy = rng.uniform(0, 1e6, n), np.zeros((n, 2))
        clean.add(np.full(n, k), lag, h, t, xy)
        bent.add(np.full(n, k), lag - 0.5 * kappa * (h * 1e-6) ** 2 * 1e6, h, t, xy)
    told = lambda t, xy: np.full(len(t), kappa)
    unknown = lambda t, xy: np.full(len(t), np.nan)
    want = clean.lag()
    assert want is not None and bent.lag() is None and bent.lag(unknown) is None
    for kk, (D, _) in bent.medians(told).items():
        np.testing.assert_allclose(D, clean.medians()[kk][0], atol=1e-6)
    np.testing.assert_allclose(bent.lag(told).lag_us, want.lag_us)
    np.testing.assert_allclose(clean.lag(lambda t, xy: np.full(len(t), -kappa)).lag_us, want.lag_us)


def test_crossings_both_ways_are_each_pairings_crossings():
    """estimation.chunk_crossings_both: the refractory pairing's crossings and the plain
    pairing's, from one gathering of the events, are those chunk_crossings gives each way,
    each with the ratio its own levels measure; the profiles take the plain pairs' levels."""
    from evstar import estimation

    run = sim.simulate(sim.paper_preset(12.0, magnitude=3.0, duration_s=0.3), seed=3)
    keep = evstar.Pipeline(evstar.Config()).run(run.events).keep
    both, plain_profiles = LevelProfiles(), LevelProfiles()
    (told, r_told), (plain, r_plain) = estimation.chunk_crossings_both(
        run.events, keep, 3.0, 100.0, profiles=both)
    want_told = estimation.chunk_crossings(run.events, keep, 3.0, with_ratio=True,
                                           refractory_us=100.0)
    want_plain = estimation.chunk_crossings(run.events, keep, 3.0, with_ratio=True,
                                            profiles=plain_profiles)
    assert (r_told, r_plain) == (want_told[1], want_plain[1]) and len(told) > 50
    assert told.tobytes() == want_told[0].tobytes() and plain.tobytes() == want_plain[0].tobytes()
    assert told.tobytes() != plain.tobytes()            # the pairings differ here
    assert repr(both.medians()) == repr(plain_profiles.medians())
    # ratios given are used as given
    (_, r1), (_, r2) = estimation.chunk_crossings_both(run.events, keep, 3.0, 100.0, (1.1, 0.9))
    assert (r1, r2) == (1.1, 0.9)


def _sinusoid_error(sensor, refractory_us):
    run = sim.simulate(sim.paper_sinusoid(10.0, magnitude=4.0, sensor=sensor), seed=37)
    cfg = evstar.Config().replace(**{"estimate.refractory_us": refractory_us})
    r = evstar.Pipeline(cfg).run(run.events, None, run.camera, truth=run.truth)
    return r.metrics["centroid_error_px"]["mean"]


def test_a_told_refractory_period_does_not_mislead_behind_a_lowpass():
    """Behind a pixel low-pass (a 40 Hz dark sky with the simulator's 100 µs refractory
    period) the refractory pairing made the told run worse than the untold one (0.109 ->
    0.192 px); where a run measures a low-pass lag it now takes the crossings a run told no
    period finds."""
    dark = sim.SensorSpec.dark_sky(cutoff_hz_background=40.0, cutoff_hz_max=1500.0,
                                   threshold_on=0.25, threshold_off=0.25)
    untold, told = _sinusoid_error(dark, 0.0), _sinusoid_error(dark, 100.0)
    assert told == untold, (untold, told)


def test_a_told_refractory_period_still_helps_on_fast_pixels():
    """No low-pass: the refractory pairing stays (a bright star at 25 °/s on a DVXplorer,
    the simulator's 100 µs period: 0.041 px untold, 0.013 told)."""
    run = sim.simulate(sim.paper_preset(25.0, magnitude=3.5, psf_sigma_px=0.9,
                                        camera="dvxplorer"), seed=37)
    errors = []
    for refractory_us in (0.0, 100.0):
        cfg = evstar.Config().replace(**{"estimate.refractory_us": refractory_us})
        r = evstar.Pipeline(cfg).run(run.events, None, run.camera, truth=run.truth)
        errors.append(r.metrics["centroid_error_px"]["mean"])
    assert errors[1] < 0.6 * errors[0], errors


def test_the_depth_delay_is_how_much_later_the_deepest_level_passes():
    """Profiles whose deepest level passes 1 ms after their top (a low-pass) give about
    that, less DELAY_SE standard errors; levels passing together within a timestamp jitter
    give about 0; a few wild profiles (a k of 12) do not reach it."""
    from evstar.level_lag import DELAY_SE

    rng = np.random.default_rng(3)
    prof = LevelProfiles()
    k = np.full(400, 3)
    mids = rng.normal(0, 20.0, (400, 3)) + np.array([0.0, 400.0, 1000.0])
    prof.add(k, mids)
    got = prof.depth_delay_us()
    assert 950 < got < 1000
    flat = LevelProfiles()
    flat.add(k, rng.normal(0, 20.0, (400, 3)))
    wild = np.full(12, 4)
    flat.add(wild, rng.normal(0, 5000.0, (12, 4)))
    assert flat.depth_delay_us() < 5 * DELAY_SE


def test_a_delay_no_lag_accounts_for_is_reported_and_warned_of():
    """A 0.5 s star at 7 °/s behind a 25 Hz dark sky (a 400 Hz ceiling, a 6 % mismatch): too
    few profiles to fit a lag, but the deepest levels pass ~1 ms after the top. The run says
    so (metrics' pixel_lag, the summary, a warning naming `evstar calibrate`); on the
    default pixels, whose levels pass together, it says nothing."""
    import warnings

    from evstar import Pipeline, sim
    from evstar.errors import EvstarWarning
    from evstar.estimation import UNMEASURED_LAG_NOTE_US
    from evstar.outputs import summary_text

    dark = sim.sensor_model("dark-sky", cutoff_hz_background=25.0, cutoff_hz_max=400.0,
                            threshold_mismatch=0.06)
    run = sim.simulate(sim.paper_preset(7.0, sensor=dark, magnitude=4.0, psf_sigma_px=1.1), seed=57)
    with pytest.warns(EvstarWarning, match="could not measure the lag.*evstar calibrate"):
        res = Pipeline().run(run.events, camera=run.camera)
    lag = res.metrics["pixel_lag"]
    assert lag["source"] == "not measured" and lag["depth_delay_ms"] * 1e3 >= UNMEASURED_LAG_NOTE_US
    assert "not measured" in summary_text(res, ".")
    plain = sim.simulate(sim.paper_preset(7.0), seed=57)
    with warnings.catch_warnings():
        warnings.simplefilter("error", EvstarWarning)
        res = Pipeline().run(plain.events, camera=plain.camera)
    assert "pixel_lag" not in res.metrics
