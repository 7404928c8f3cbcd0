"""Track smoother: unbiased and below the per-frame error on straight tracks, honest
posterior σ, coasting limited to coast_ms, turnarounds with and without a velocity prior,
the IMU prior's sign and scale on the simulator, and parameters checked by name."""
import numpy as np
from scipy.optimize import brentq
import pytest

import evstar
from evstar import sim
from evstar.extract import CENTROID_DTYPE
from evstar.smoothing import (COASTED, MEASURED, TrackSmoother, estimate_process_noise,
                              imu_velocity_prior)

DT = 10_000


def centroids(frames, truth_xy, sigma, rng, track=0, jitter_us=2000, n_events=20):
    """Centroids of one track in `frames`, at times near the frame mid, with Gaussian
    noise sigma (px per axis) about truth_xy(t_s) -> (n, 2)."""
    frames = np.asarray(frames)
    c = np.zeros(len(frames), CENTROID_DTYPE)
    c["frame"], c["track"], c["n_events"] = frames, track, n_events
    c["t"] = frames * DT + DT // 2 + (rng.integers(-jitter_us, jitter_us + 1, len(frames))
                                      if jitter_us else 0)
    xy = truth_xy(c["t"] * 1e-6)
    c["x"], c["y"] = xy[:, 0] + rng.normal(0, sigma, len(c)), xy[:, 1] + rng.normal(0, sigma, len(c))
    c["spread"] = sigma * np.sqrt(2 * n_events)
    return c


def line(t):
    return np.column_stack([50 + 40.0 * t, 80 - 15.0 * t])


def test_straight_tracks_unbiased_and_well_below_the_raw_error():
    rng = np.random.default_rng(1)
    sigma, n = 0.3, 50
    cents = np.concatenate([centroids(np.arange(n), line, sigma, rng, track=k) for k in range(100)])
    est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0)
    assert len(est) == len(cents) and np.all(est["source"] == MEASURED)
    truth = line(est["t"] * 1e-6)
    err = np.column_stack([est["x"], est["y"]]) - truth
    # no bias: the mean error is within 4 standard errors of zero on both axes (errors of
    # one track are correlated: the tracks' mean errors are the independent samples)
    per_track = np.array([err[est["track"] == k].mean(0) for k in range(100)])
    assert np.all(np.abs(per_track.mean(0)) < 4 * per_track.std(0) / np.sqrt(100))
    raw = np.column_stack([cents["x"], cents["y"]]) - line(cents["t"] * 1e-6)
    rms, rms_raw = np.sqrt((err**2).mean()), np.sqrt((raw**2).mean())
    # a line fit through n points: σ·sqrt(4/n) on average; the smoother is that fit
    assert rms < 1.3 * sigma * np.sqrt(4 / n) and rms < 0.35 * rms_raw
    # the posterior σ is honest: normalised errors have unit variance
    z2 = np.concatenate([err[:, 0] / est["sigma_x"], err[:, 1] / est["sigma_y"]]) ** 2
    assert 0.8 < z2.mean() < 1.25


def test_coasting_fills_gaps_up_to_the_limit_and_follows_the_motion():
    rng = np.random.default_rng(2)
    frames = np.r_[0:20, 40:60]
    cents = centroids(frames, line, 0.2, rng, jitter_us=0)
    est = TrackSmoother(DT, coast_ms=50, coast_ends=False).smooth(cents, t0_us=0)
    coasted = est[est["coasted"]]
    # last centroid at 195 ms, next at 405 ms: frames whose mid is within 50 ms of either
    assert sorted(coasted["frame"]) == [*range(20, 25), *range(35, 40)]
    assert np.all(coasted["source"] == COASTED) and np.all(coasted["centroid"] == -1)
    assert np.all(coasted["t"] == coasted["frame"] * DT + DT // 2)
    err = np.hypot(*(np.column_stack([coasted["x"], coasted["y"]]) - line(coasted["t"] * 1e-6)).T)
    assert err.max() < 0.3
    # σ grows away from the measurements: coasted rows are less certain than the gap's edges
    edges = est[np.isin(est["frame"], [19, 40]) & ~est["coasted"]]
    assert coasted["sigma_x"].max() > edges["sigma_x"].max()
    assert len(TrackSmoother(DT, coast_ms=0, coast_ends=False).smooth(cents, t0_us=0)) == len(cents)


def test_unconfirmed_centroids_are_left_out_and_rows_sorted_by_track_then_time():
    rng = np.random.default_rng(3)
    a = centroids(np.arange(10), line, 0.2, rng, track=1)
    b = centroids(np.arange(10), line, 0.2, rng, track=0)
    c = centroids(np.arange(10), line, 0.2, rng, track=-1)
    cents = np.concatenate([a, b, c])[rng.permutation(30)]
    est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0)
    assert len(est) == 20 and not np.any(est["track"] < 0)
    assert np.all(np.diff(est["track"]) >= 0)
    assert np.all(np.diff(est["t"][est["track"] == 0]) > 0)
    back = cents[est["centroid"]]
    assert np.array_equal(back["track"], est["track"]) and np.array_equal(back["t"], est["t"])


AMP, FREQ = 100.0, 1.0


def sinusoid(t):
    return np.column_stack([160 + AMP * np.sin(2 * np.pi * FREQ * t), np.full(len(t), 120.0)])


def sinusoid_velocity(t_us, x, y):
    t = np.asarray(t_us) * 1e-6
    return np.column_stack([AMP * 2 * np.pi * FREQ * np.cos(2 * np.pi * FREQ * t), np.zeros(len(t))])


def test_turnaround_followed_better_with_the_velocity_prior():
    rng = np.random.default_rng(4)
    cents = centroids(np.arange(100), sinusoid, 0.3, rng)
    turn = np.abs(np.cos(2 * np.pi * FREQ * cents["t"] * 1e-6)) < 0.3     # near the extremes

    def errors(prior):
        est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0, velocity_prior=prior)
        return np.hypot(*(np.column_stack([est["x"], est["y"]]) - sinusoid(est["t"] * 1e-6)).T)

    raw = np.hypot(*(np.column_stack([cents["x"], cents["y"]]) - sinusoid(cents["t"] * 1e-6)).T)
    free, guided = errors(None), errors(sinusoid_velocity)
    rms = lambda e: np.sqrt(np.mean(e[turn] ** 2))   # noqa: E731
    assert rms(free) < rms(raw)              # q estimated from the data: no lag worse than noise
    assert rms(guided) < 0.4 * rms(free)     # the prior removes the model's lag
    assert rms(guided) < 0.25 * rms(raw)


def test_the_prior_is_asked_once_per_step_for_all_tracks_with_the_same_rows():
    """smooth batches the velocity prior's queries of all tracks (its cost is per call):
    two calls (the displacements, then the velocities of the rows), and the rows of each
    track the same bits as smoothing it alone."""
    rng = np.random.default_rng(5)
    parts = [centroids(np.arange(5 * k, 60 + 9 * k), sinusoid, 0.3, rng, track=k) for k in range(4)]
    cents = np.concatenate(parts)
    calls = []

    def prior(t, x, y):
        calls.append(len(t))
        return sinusoid_velocity(t, x, y)

    smoother = TrackSmoother(DT, coast_ends=False)
    together = smoother.smooth(cents, t0_us=0, velocity_prior=prior)
    assert len(calls) == 2
    for k, c in enumerate(parts):
        alone = smoother.smooth(c, t0_us=0, velocity_prior=prior)
        mine = together[together["track"] == k]
        for f in ("t", "x", "y", "vx", "vy", "sigma_x", "sigma_y"):
            np.testing.assert_array_equal(mine[f], alone[f])


def test_process_noise_estimate_recovers_a_random_acceleration():
    rng = np.random.default_rng(5)
    q, h, n, sigma = 1e4, 0.01, 400, 0.05
    a = rng.normal(0, np.sqrt(q / h), (n, 2))        # white acceleration, piecewise constant
    v = np.cumsum(a * h, axis=0)
    z = np.cumsum(v * h, axis=0) + rng.normal(0, sigma, (n, 2))
    est = estimate_process_noise(np.arange(n) * h, z, np.full(n, sigma))
    assert q / 2 < est < 2 * q
    flat = estimate_process_noise(np.arange(n) * h, rng.normal(0, sigma, (n, 2)), np.full(n, sigma))
    assert flat < 10.0     # noise alone: ~0


def test_a_smoother_estimates_q_once_per_tracks_data(monkeypatch):
    """The refit asks again for most tracks' q with the same centroid data: a smoother's
    memo answers those, with the q the likelihoods give (a track's are its data's alone)."""
    from evstar import smoothing

    rng = np.random.default_rng(4)
    tracks = [(np.arange(n) * 0.01, np.cumsum(rng.normal(0, 0.3, (n, 2)), 0), np.full(n, 0.1))
              for n in (3, 20, 40, 60)]
    want = [smoothing._estimate_q_many([t], "taichi")[0] for t in tracks]
    asked = []
    loglik = smoothing._ENGINES["taichi"][1]
    monkeypatch.setitem(smoothing._ENGINES, "taichi", (smoothing._ENGINES["taichi"][0],
                        lambda ts, grid, w=0.0: asked.append(len(ts)) or loglik(ts, grid, w)))
    memo = {}
    assert smoothing._estimate_q_many(tracks[:3], "taichi", memo) == want[:3]
    assert smoothing._estimate_q_many(tracks[::-1], "taichi", memo) == want[::-1]
    assert asked == [2, 1]          # too short a track is never asked; the others once each
    assert want[2] > 0
    # the same data under a prior's random walk is another question
    smoothing._estimate_q_many(tracks[1:2], "taichi", memo, w=0.5)
    assert asked == [2, 1, 1]


def test_imu_prior_gives_the_image_velocity_of_a_simulated_star():
    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.2), seed=1)
    t = np.linspace(run.events.t[0] + 20_000, run.events.t[-1] - 20_000, 5).astype(np.int64)
    xy = run.truth.star_position(t, 0)
    true_v = (run.truth.star_position(t + 500, 0) - run.truth.star_position(t - 500, 0)) / 1e-3
    v = imu_velocity_prior(run.imu, run.camera)(t, xy[:, 0], xy[:, 1])
    speed = np.linalg.norm(true_v, axis=1)
    assert np.all(speed > 50)                          # 8 °/s ≈ 90 px/s on this camera
    # the gyro's noise and bias: a few % per sample, less on average
    assert np.all(np.linalg.norm(v - true_v, axis=1) < 0.1 * speed)
    assert np.linalg.norm((v - true_v).mean(0)) < 0.05 * speed.mean()


@pytest.mark.parametrize("k1, k2", [(0.0, 0.0), (-0.12, 0.03)])
def test_imu_prior_is_the_rotated_ray_formula_bit_for_bit(k1, k2):
    # the prior runs column by column; the same bits as the (n, 3) form: unproject,
    # normalise, step by -ω × d · h, project, difference over h
    from types import SimpleNamespace

    from evstar.camera import Camera
    from evstar.motion.imu_integration import gyro_at

    rng = np.random.default_rng(2)
    cam = Camera(1280, 720, 900.0, 905.0, 640.2, 359.7, k1, k2)
    t_cam = np.arange(0, 1_000_000, 1000)
    imu = SimpleNamespace(t_cam=t_cam, gyro_cam=rng.normal(0, 0.2, (len(t_cam), 3)))
    t = rng.uniform(0, 999_000, 5000)
    x, y = rng.uniform(-20, 1300, 5000), rng.uniform(-20, 740, 5000)
    omega = gyro_at(imu)(t)
    d = cam.unproject(np.column_stack([x, y]))
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    want = (cam.project(d - np.cross(omega, d) * 1e-4) - cam.project(d)) / 1e-4
    assert imu_velocity_prior(imu, cam)(t, x, y).tobytes() == want.tobytes()


@pytest.mark.parametrize("name, value", [("coast_ms", -1), ("process_noise", "fast"),
                                         ("process_noise", -2.0), ("sigma_floor_px", 0),
                                         ("psf_sigma_px", -1.0), ("min_events", 0),
                                         ("process_noise_min", float("nan")),
                                         ("outlier_sigma", 0)])
def test_bad_parameters_rejected_by_name(name, value):
    with pytest.raises(evstar.ParameterError, match=name):
        TrackSmoother(DT, **{name: value})


def test_bad_sigma_and_prior_rejected():
    rng = np.random.default_rng(6)
    cents = centroids(np.arange(10), line, 0.2, rng)
    with pytest.raises(ValueError, match="sigma"):
        TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0, sigma=np.zeros(10))
    with pytest.raises(ValueError, match="velocity_prior"):
        TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0, velocity_prior=lambda t, x, y: np.zeros(3))


def test_an_outlier_is_flagged_and_does_not_pull_the_track():
    rng = np.random.default_rng(7)
    cents = centroids(np.arange(40), line, 0.1, rng)
    cents["x"][20] += 2.0                                # half of a cut star, 20 σ off
    est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0)
    assert est["outlier"].tolist() == [i == 20 for i in range(40)]
    err = np.hypot(*(np.column_stack([est["x"], est["y"]]) - line(est["t"] * 1e-6)).T)
    assert err.max() < 0.1
    kept = TrackSmoother(DT, outlier_sigma=None, coast_ends=False).smooth(cents, t0_us=0)
    assert not kept["outlier"].any()
    assert np.hypot(*(np.column_stack([kept["x"], kept["y"]]) - line(kept["t"] * 1e-6)).T).max() > 0.1


def test_a_faint_tracks_stray_centroid_is_flagged_not_followed():
    # a faint cluster's spread understates its centroid's error (σ 0.3 said, 0.6 real) and a
    # noise clump shifts one centroid by 3 px: q estimated with it bends the track to it (and
    # then finds no outlier, 5 of these 10 tracks); the stiffest fit's residuals find it
    for seed in range(10):
        rng = np.random.default_rng(seed)
        cents = centroids(np.arange(0, 40, 2), lambda t: np.column_stack([50 + 10.0 * t, 80 + 0 * t]),
                          0.6, rng, n_events=6)
        cents["spread"] = 0.3 * np.sqrt(12)
        cents["x"][8] += 3.0
        est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0)
        assert est["outlier"][est["centroid"] == 8].all()
        assert np.abs(est["x"] - (50 + 10.0 * est["t"] * 1e-6)).max() < 1.5


def test_simulated_faint_star_smoothed_error_well_below_the_per_frame_error():
    run = sim.simulate(sim.paper_preset(4.0, magnitude=5.0, duration_s=0.3), seed=3)
    cfg = evstar.Config().replace(**{"estimate.estimator": "mean"})   # the per-frame centroids
    res = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera, truth=run.truth)
    raw = res.centroids[res.centroids["track"] >= 0]
    assert len(raw) > 20
    est = TrackSmoother(DT, coast_ends=False).smooth(raw, t0_us=int(run.events.t[0]))
    _, e_raw = evstar.accuracy.match(raw, run.truth.star_position)
    _, e_est = evstar.accuracy.match(est, run.truth.star_position)
    assert e_est.mean() < 0.5 * e_raw.mean() and e_est.max() < e_raw.max()


def test_short_tracks_and_no_tracks():
    rng = np.random.default_rng(9)
    assert len(TrackSmoother(DT, coast_ends=False).smooth(np.zeros(0, CENTROID_DTYPE))) == 0
    one = centroids([5], line, 0.2, rng)
    est = TrackSmoother(DT, coast_ends=False).smooth(one, t0_us=0)
    assert len(est) == 1 and est["x"][0] == pytest.approx(one["x"][0], abs=1e-6)
    assert est["sigma_x"][0] == pytest.approx(0.2, rel=1e-3)   # nothing to pool: its own σ
    two = centroids([5, 8], line, 0.2, rng)
    est = TrackSmoother(DT, coast_ends=False).smooth(two, t0_us=0)
    assert est["frame"].tolist() == [5, 6, 7, 8] and est["coasted"].tolist() == [False, True, True, False]


def test_coasting_goes_past_the_track_ends_within_the_limit():
    rng = np.random.default_rng(8)
    cents = centroids(np.arange(10, 31), line, 0.2, rng, jitter_us=0)
    est = TrackSmoother(DT, coast_ms=30).smooth(cents, t0_us=0)
    coasted = est[est["coasted"]]
    # first centroid at 105 ms, last at 305 ms: mids within 30 ms before or after
    assert sorted(coasted["frame"]) == [7, 8, 9, 31, 32, 33]
    err = np.hypot(*(np.column_stack([coasted["x"], coasted["y"]]) - line(coasted["t"] * 1e-6)).T)
    assert err.max() < 0.5 and (coasted["sigma_x"] > est["sigma_x"][~est["coasted"]].max()).all()


def line_velocity(t_us, x, y):
    return np.tile([40.0, -15.0], (len(t_us), 1))


def test_a_gyro_carries_the_track_ends_farther_but_not_across_a_stall():
    """With a velocity prior the frames before a track's first and after its last centroid
    are coasted within coast_gyro_ms (a gap inside it keeps coast_ms), and never beyond a
    readout stall next to the end; without a prior coast_ms holds everywhere."""
    rng = np.random.default_rng(8)
    cents = centroids(np.r_[30:41, 51:61], line, 0.2, rng, jitter_us=0)
    plain = TrackSmoother(DT, coast_ms=30, coast_gyro_ms=150).smooth(cents, t0_us=0)
    assert sorted(plain["frame"][plain["coasted"]]) == [27, 28, 29, 41, 42, 43, 48, 49, 50, 61, 62, 63]
    gyro = TrackSmoother(DT, coast_ms=30, coast_gyro_ms=150).smooth(
        cents, t0_us=0, velocity_prior=line_velocity)
    coasted = gyro[gyro["coasted"]]
    # mids within 150 ms of 305 ms and of 605 ms: frames 15-29 and 61-75; the gap as before
    assert sorted(coasted["frame"]) == list(range(15, 30)) + [41, 42, 43, 48, 49, 50] + list(range(61, 76))
    # the prior moves them on the line: off by the velocity bias the centroids left, in σ
    err = np.hypot(*(np.column_stack([coasted["x"], coasted["y"]]) - line(coasted["t"] * 1e-6)).T)
    assert (err < 3 * np.hypot(coasted["sigma_x"], coasted["sigma_y"]) / np.sqrt(2)).all()
    # a stall from 200 to 250 ms stops the early end at 250 ms, one from 700 ms the late one
    stalled = TrackSmoother(DT, coast_ms=30, coast_gyro_ms=150,
                            stalls=np.array([[200_000, 250_000], [700_000, 760_000]])).smooth(
        cents, t0_us=0, velocity_prior=line_velocity)
    ends = stalled["frame"][stalled["coasted"]]
    assert ends.min() == 25 and ends.max() == 69


def test_the_gyros_farther_ends_join_the_fitted_track_and_never_stand_in_for_another():
    """evstar.coasting.extended: a plain smoothing's rows beyond the fitted track's ends,
    moved by their difference at each end, variance grown from there; none beside another
    track's row of its frame."""
    from evstar.coasting import extended
    from evstar.smoothing import ESTIMATE_DTYPE

    def rows(frames, track, x0, sigma):
        r = np.zeros(len(frames), ESTIMATE_DTYPE)
        r["frame"], r["track"], r["t"] = frames, track, np.asarray(frames) * DT + DT // 2
        r["x"], r["y"] = x0 + 2.0 * np.asarray(frames), 50.0
        r["sigma_x"] = r["sigma_y"] = sigma
        r["source"] = "measured"
        return r

    fitted = rows(np.arange(10, 21), 5, 0.0, 0.05)
    far = rows(np.arange(4, 27), 5, 0.3, 0.1)        # 0.3 px off the fit, σ growing away
    far["sigma_x"] = far["sigma_y"] = 0.1 + 0.02 * np.abs(far["frame"] - 15)
    other = rows([7], 9, 0.0, 0.05)                  # another track's row where frame 7's would be
    out = extended(np.concatenate([fitted, other]), far, [5], 3.0)
    mine = out[out["track"] == 5]
    added = mine[mine["coasted"]]
    assert sorted(added["frame"]) == [4, 5, 6, 8, 9, 21, 22, 23, 24, 25, 26]
    assert np.allclose(added["x"], 2.0 * added["frame"])           # moved onto the fit
    grown = (0.1 + 0.02 * np.abs(added["frame"] - 15)) ** 2 - 0.2 ** 2
    assert np.allclose(added["sigma_x"], np.sqrt(0.05 ** 2 + grown))
    assert (added["source"] == "coasted").all() and (added["centroid"] == -1).all()
    assert extended(fitted, far[:0], [5], 3.0).tobytes() == fitted.tobytes()


def test_only_ends_inside_the_sensor_and_the_recording_are_carried_further():
    from evstar.coasting import open_ends
    from evstar.smoothing import ESTIMATE_DTYPE

    est = np.zeros(6, ESTIMATE_DTYPE)
    est["track"] = [1, 1, 2, 2, 3, 3]
    est["frame"] = [0, 99, 10, 40, 5, 99]
    est["t"] = est["frame"] * DT + DT // 2
    est["x"] = [50, 50, 50, 1.5, 1.0, 50]        # track 2 leaves at the edge, 3 enters there
    est["y"] = 30
    # 1 spans the recording; 2 starts inside after its start; 3 ends at its last frame
    assert open_ends(est, [1, 2, 3], (0, 99), (100, 60), 3.0) == [2]
    assert open_ends(est, [1, 2, 3], (0, 99), None, 3.0) == [2, 3]      # no sensor: no edge
    assert open_ends(est, [1, 2, 3], (0, 120), (100, 60), 3.0) == [1, 2, 3]


def test_a_gyro_coasted_end_holds_a_share_of_the_gyros_turn_in_its_sigma():
    from evstar.coasting import GYRO_SCALE_SHARE, gyro_widened

    rows = np.zeros(6, CENTROID_DTYPE)
    rows["track"], rows["sigma"] = 3, 0.05
    rows["t"] = np.arange(6) * DT
    rows["x"], rows["y"] = 10.0 + np.arange(6), 20.0
    rows["source"] = ["coasted", "coasted", "measured", "coasted", "measured", "coasted"]
    out = gyro_widened(rows, lambda t, x, y: np.tile([300.0, 400.0], (len(t), 1)))
    # 500 px/s: 10 and 5 px before the first measured row, 5 px after the last
    moved = np.array([10.0, 5.0, 0.0, 0.0, 0.0, 5.0])
    want = np.sqrt(0.05 ** 2 + (GYRO_SCALE_SHARE * moved) ** 2 / 2)
    assert np.allclose(out["sigma"], want, rtol=1e-6)
    assert gyro_widened(rows, None)["sigma"].tolist() == rows["sigma"].tolist()


def test_the_pipeline_reports_coasted_rows_only_while_certain():
    from evstar import estimation
    from evstar.config import Config

    rng = np.random.default_rng(9)
    cents = centroids(np.arange(10, 31), line, 0.2, rng, jitter_us=0)
    loose = Config().replace(**{"estimate.estimator": "track", "estimate.coast_ms": 200.0,
                                "estimate.coast_sigma_px": 100.0})
    strict = loose.replace(**{"estimate.coast_sigma_px": 0.3})
    many = estimation.estimate(cents, loose, 0)
    few = estimation.estimate(cents, strict, 0)
    assert (many["source"] == "coasted").sum() > (few["source"] == "coasted").sum() > 0
    assert few["sigma"][few["source"] == "coasted"].max() <= 0.3


def test_a_gap_between_measurements_is_coasted_whatever_its_sigma():
    """The σ gate holds for predictions beyond a track's ends only: a gap's frames, bridged
    by the smoother from both sides, are all reported (a sinusoid's turn, where σ peaks)."""
    from evstar import estimation
    from evstar.config import Config
    from evstar.smoothing import bracketed

    rng = np.random.default_rng(9)
    cents = centroids(np.r_[10:21, 26:37], line, 0.2, rng, jitter_us=0)
    cfg = Config().replace(**{"estimate.estimator": "track", "estimate.coast_ms": 200.0,
                              "estimate.coast_sigma_px": 0.03})
    rows = estimation.estimate(cents, cfg, 0)
    coasted = rows[rows["source"] == "coasted"]
    assert sorted(coasted["frame"]) == [21, 22, 23, 24, 25]   # only the gap: no ends
    assert coasted["sigma"].min() > 0.03                      # each beyond the gate
    err = np.hypot(*(np.column_stack([coasted["x"], coasted["y"]]) - line(coasted["t"] * 1e-6)).T)
    assert err.max() < 3 * coasted["sigma"].max()
    assert not bracketed(rows[rows["source"] != "coasted"]).any()
    # rows less certain than max_sigma_px are no positions, the gap's either
    gate = float(np.median(coasted["sigma"]))
    tight = estimation.estimate(cents, cfg.replace(**{"estimate.max_sigma_px": gate}), 0)
    kept = tight[tight["source"] == "coasted"]
    assert 0 < len(kept) < len(coasted) and tight["sigma"].max() <= gate


def test_the_pipeline_coasts_neither_past_the_recording_nor_off_the_sensor():
    import evstar
    from evstar import sim

    run = sim.simulate(sim.paper_preset(20.0, duration_s=0.2), seed=1)
    rows = evstar.Pipeline().run(run.events).centroids
    assert rows["t"].min() >= run.events.t[0] and rows["t"].max() <= run.events.t[-1]
    assert (rows["x"] >= -0.5).all() and (rows["x"] <= run.events.width - 0.5).all()


def test_a_recording_ending_within_a_frame_has_its_last_frame_at_its_end():
    """A track measured to frame 29 of a recording that ends 3 ms into frame 30 (before its
    mid-time): frame 30's coasted row is at the recording's end, on the line; one ending
    in frame 29 gets none past it."""
    from evstar import estimation
    from evstar.config import Config

    rng = np.random.default_rng(10)
    cents = centroids(np.arange(10, 30), line, 0.2, rng, jitter_us=0)
    cfg = Config().replace(**{"estimate.estimator": "track"})
    end = 30 * DT + 3000
    rows = estimation.estimate(cents, cfg, 0, span_us=(0, end))
    last = rows[rows["frame"] == 30]
    assert len(last) == 1 and last["source"][0] == "coasted" and last["t"][0] == end
    assert np.hypot(last["x"][0] - line(end * 1e-6)[0, 0], last["y"][0] - line(end * 1e-6)[0, 1]) < 0.3
    early = estimation.estimate(cents, cfg, 0, span_us=(0, 29 * DT + 6000))
    assert early["frame"].max() == 29 and early["t"].max() <= 29 * DT + 6000

@pytest.mark.parametrize("engine,atol", [("taichi", 1e-5), ("numpy", 1e-9)])
def test_tracks_smoothed_together_equal_the_filterpy_reference_one_by_one(engine, atol):
    """The Taichi kernel (the default) and the numpy batch run the tracks together (of
    different lengths, with gaps and outliers refitted in later passes); filterpy, one track
    and step at a time, is the reference (the kernel's 4×4 inverse is not LAPACK's; σ: the
    smoothed covariances in another form, equal in exact arithmetic, kalman._rts)."""
    rng = np.random.default_rng(12)
    parts = []
    for k in range(6):
        frames = np.sort(rng.choice(np.arange(5 + 30 * k), 4 + 25 * k, replace=False))
        c = centroids(frames, sinusoid if k % 2 else line, 0.2, rng, track=k, n_events=5 + 3 * k)
        c["x"][len(c) // 2] += 4.0 * (k % 3 > 0)                      # outliers
        parts.append(c)
    cents = np.concatenate(parts)
    cents = cents[np.argsort(cents["t"], kind="stable")]
    fast = TrackSmoother(DT, engine=engine).smooth(cents, t0_us=0)
    ref = TrackSmoother(DT, engine="filterpy").smooth(cents, t0_us=0)
    assert fast["outlier"].sum() >= 3 and np.array_equal(fast["outlier"], ref["outlier"])
    for f in ("t", "frame", "track", "centroid", "coasted"):
        np.testing.assert_array_equal(fast[f], ref[f])
    for f in ("x", "y"):
        np.testing.assert_allclose(fast[f], ref[f], rtol=0, atol=atol)
    for f in ("sigma_x", "sigma_y"):   # filterpy's smoother form rounds off on a few rows
        np.testing.assert_allclose(fast[f], ref[f], rtol=1e-5, atol=atol)


def test_the_pipeline_gives_the_positions_of_the_filterpy_reference(monkeypatch):
    """Smoother, outlier passes, the crossings' refit with the IMU prior and the pixel lag:
    the whole run with filterpy in place of the batched filter, rows equal to 1e-6 px."""
    from evstar import smoothing

    run = sim.simulate(sim.paper_sinusoid(duration_s=0.6), seed=3)
    pipe = evstar.Pipeline(evstar.Config().replace(**{"motion.compensate": "imu"}))
    fast = pipe.run(run.events, run.imu, run.camera).centroids
    monkeypatch.setitem(smoothing._ENGINES, "numpy", smoothing._ENGINES["filterpy"])
    ref = pipe.run(run.events, run.imu, run.camera).centroids
    assert len(fast) == len(ref) > 50 and (fast["track"] >= 0).sum() > 50
    for f in ("t", "track", "frame", "source"):
        np.testing.assert_array_equal(fast[f], ref[f])
    for f in ("x", "y", "sigma"):
        np.testing.assert_allclose(fast[f], ref[f], rtol=0, atol=1e-6)


def test_the_engine_is_checked_by_name():
    with pytest.raises(ValueError, match="engine"):
        TrackSmoother(DT, engine="scipy")


def test_one_level_crossings_are_left_out_only_when_enough_others_remain():
    from evstar.smoothing import MIN_CROSSINGS, _multi_level

    pairs = np.array([1, 2, 1, 3] * MIN_CROSSINGS)
    mine = np.arange(len(pairs))
    kept = _multi_level(mine, pairs)
    assert len(kept) == 2 * MIN_CROSSINGS and np.all(pairs[kept] >= 2)
    few = mine[:MIN_CROSSINGS]                      # only half of them have two levels
    assert np.array_equal(_multi_level(few, pairs), few)


def test_one_level_crossings_stay_where_few_multi_level_ones_lie_near():
    """A faint star's stretch of one-level crossings (a pass over pixels it passed before)
    keeps them where their runs are clean; where multi-level crossings lie within a frame,
    or where a run likely holds a background event, the one-level ones go."""
    from evstar.smoothing import MIN_CROSSINGS, MULTI_NEAR, _multi_level

    n = 4 * MIN_CROSSINGS
    t = np.arange(2 * n) * 2_000.0                  # one crossing every 2 ms for 2n of them
    pairs = np.where(np.arange(2 * n) % 2 == 0, 2, 1)
    pairs[n:] = 1                                   # the second half: one level only
    pairs[n + n // 2] = 3                           # ... but for one multi-level crossing
    mine = np.arange(2 * n)
    clean = np.ones(2 * n, bool)
    kept = _multi_level(mine, pairs, t, DT, clean)
    edge = DT // 2_000                              # crossings within a frame of the other half
    first, second = kept[kept < n - edge], kept[kept >= n + edge]
    assert len(first) == len(range(0, n - edge, 2)) and np.all(pairs[first] >= 2)
    assert len(second) == n - edge                  # sparse: all kept (one multi < MULTI_NEAR)
    assert MULTI_NEAR > 1
    busy = clean.copy()
    busy[n + edge:] = False                         # their runs likely hold background events
    kept = _multi_level(mine, pairs, t, DT, busy)
    assert np.all(pairs[kept[kept >= n + edge]] >= 2)
    # without times, the rule over the whole track as before
    assert np.all(pairs[_multi_level(mine, pairs)] >= 2)


def test_the_pixel_lag_is_fitted_per_class_where_the_multi_level_ones_are_enough():
    from evstar.smoothing import MIN_CROSSINGS, _lag_classes

    pairs = np.array([1, 3] * MIN_CROSSINGS)
    fit, rest = _lag_classes(pairs, len(pairs))
    assert np.array_equal(fit, np.flatnonzero(pairs == 3))
    assert np.array_equal(rest, np.flatnonzero(pairs == 1))
    few = pairs[: MIN_CROSSINGS]                    # half of them multi-level: too few
    fit, rest = _lag_classes(few, len(few))
    assert np.array_equal(fit, np.arange(len(few))) and len(rest) == 0
    fit, rest = _lag_classes(None, 5)
    assert np.array_equal(fit, np.arange(5)) and len(rest) == 0


def test_one_level_crossings_take_their_own_lag_only_where_it_stands_apart():
    """A faint star's one-level crossings lagged 0.64 ± 0.07 ms, its multi-level ones 1.85 ±
    0.09: their own. Q7's 0.17 ± 0.004 against 0.22 ± 0.04 agree within 3 standard errors:
    the multi-level one, as where either is unmeasured or too uncertain (LAG_MAX_SE_S)."""
    from evstar.smoothing import LAG_MAX_SE_S, _classes_lags

    assert _classes_lags((1.85e-3, 0.09e-3), (0.64e-3, 0.07e-3)) == (1.85e-3, 0.64e-3)
    assert _classes_lags((0.22e-3, 0.04e-3), (0.17e-3, 0.004e-3)) == (0.22e-3, 0.22e-3)
    assert _classes_lags((1.85e-3, 0.09e-3), None) == (1.85e-3, 1.85e-3)
    loose = (0.64e-3, 2 * LAG_MAX_SE_S)
    assert _classes_lags((1.85e-3, 0.09e-3), loose) == (1.85e-3, 1.85e-3)
    assert _classes_lags(None, (0.64e-3, 0.07e-3)) == (0.0, 0.0)


def test_a_one_level_run_is_clean_only_when_short_and_quiet():
    """_short_and_clean: a slow star's long runs (flat-topped pixels) and runs that likely hold
    a background event are not; an unknown background makes none clean."""
    from evstar.smoothing import MAX_RUN_BACKGROUND, ONE_LEVEL_WIDTH, _short_and_clean

    short, long_ = 0.9 * ONE_LEVEL_WIDTH * DT, 1.1 * ONE_LEVEL_WIDTH * DT
    quiet = 0.5 * MAX_RUN_BACKGROUND / (2e-6 * short)
    busy = 2.0 * MAX_RUN_BACKGROUND / (2e-6 * short)
    assert list(_short_and_clean(np.array([short, long_]), quiet, DT)) == [True, False]
    assert not _short_and_clean(np.array([short]), busy, DT).any()
    assert not _short_and_clean(np.array([short]), None, DT).any()


def test_the_prior_is_used_where_it_explains_the_track_better():
    """A sinusoid's track with its true velocity as prior: used. A constant pan whose prior
    is a noisy gyro's (white noise integrating into a random walk of 0.1 px per 10 ms): not
    used. Tracks of < 4 centroids keep it."""
    rng = np.random.default_rng(9)
    wave = centroids(np.arange(100), sinusoid, 0.05, rng, track=0)
    pan = centroids(np.arange(100), line, 0.05, rng, track=1)
    short = centroids(np.arange(3), line, 0.05, rng, track=2)
    cents = np.concatenate([wave, pan, short])

    from evstar.smoothing import _PRIOR_STEP_S

    def prior(t_us, x, y):
        true = np.where((np.asarray(y) < 100)[:, None], [40.0, -15.0], sinusoid_velocity(t_us, x, y))
        # white velocity noise of 1 px²/s diffusion on the prior's integration grid
        return true + rng.normal(0, 1 / np.sqrt(_PRIOR_STEP_S), (len(t_us), 2))

    assert TrackSmoother(DT).prior_helps(cents, prior) == {0, 2}


def test_the_prior_is_used_where_the_centroids_follow_part_of_it():
    """A pan vibrating 0.34 px across at 15 Hz, whose per-frame centroids follow half of the
    vibration (as a dark-sky star's did): the whole prior explains them no better than
    none, half of it does, so the prior is used. A track that does not vibrate, under the
    same vibrating prior, is not."""
    rng = np.random.default_rng(50)
    amp, hz = 0.34, 15.0

    def shaking(share):
        return lambda t: line(t) + np.column_stack([np.zeros(len(t)),
                                                    share * amp * np.sin(2 * np.pi * hz * t)])

    half = centroids(np.arange(100), shaking(0.5), 0.15, rng, track=0, jitter_us=0)
    still = centroids(np.arange(100), shaking(0.0), 0.15, rng, track=1, jitter_us=0)
    still["y"] += 100                                   # apart from track 0

    def prior(t_us, x, y):
        t = np.asarray(t_us) * 1e-6
        return np.column_stack([np.full(len(t), 40.0),
                                -15.0 + amp * 2 * np.pi * hz * np.cos(2 * np.pi * hz * t)])

    from evstar import smoothing

    assert TrackSmoother(DT).prior_helps(np.concatenate([half, still]), prior) == {0}
    whole_only = smoothing._PRIOR_GAINS
    try:
        smoothing._PRIOR_GAINS = (1.0,)
        assert TrackSmoother(DT).prior_helps(half, prior) == set()
    finally:
        smoothing._PRIOR_GAINS = whole_only


def test_a_quiet_prior_needs_only_positive_evidence():
    """Two tracks of a pan vibrating 0.15 px across at 14 Hz, whose per-frame centroids (σ
    0.3 px) follow half of it, under a noiseless gyro's prior: it is taken by both in 19 of
    30 seeds (positive evidence, _QUIET_EVIDENCE), where the same prior wandering by a
    gyro's noise (0.01 px²/s, more than the centroids' variance left over the track) needs
    strong evidence and is taken in 9. Centroids that do not move with it at all keep it
    out either way."""
    from evstar.smoothing import with_diffusion

    amp, hz = 0.15, 14.0

    def shaking(t_us, x, y):
        t = np.asarray(t_us) * 1e-6
        return np.column_stack([np.full(len(t), 40.0),
                                -15.0 + amp * 2 * np.pi * hz * np.cos(2 * np.pi * hz * t)])

    def taken(share, prior):
        n = 0
        for seed in range(30):
            rng = np.random.default_rng(seed)
            swing = lambda t: line(t) + np.column_stack(
                [np.zeros(len(t)), share * amp * np.sin(2 * np.pi * hz * t)])
            c = np.concatenate([centroids(np.arange(100), lambda t, k=k: swing(t) + [0.0, 30.0 * k],
                                          0.3, rng, track=k, jitter_us=0) for k in range(2)])
            n += TrackSmoother(DT).prior_helps(c, prior) == {0, 1}
        return n

    noisy = with_diffusion(shaking, 0.01)
    assert taken(0.5, shaking) >= 16 and taken(0.5, noisy) <= 12
    assert taken(0.0, shaking) == 0


def test_half_the_prior_is_tried_with_the_whole_prior_s_noise():
    """A slowly accelerating pan (6 px/s² over 4 s) under a gyro prior that knows the
    acceleration but wanders by its white noise (declared: 0.02 px²/s). The whole prior
    explains the centroids worse than none; half of it, allowed only a quarter of the
    noise, would beat none by 8 — but the fit takes the prior whole, noise and all, so
    the half-size try carries the whole noise and the prior is not used."""
    from evstar.smoothing import _PRIOR_STEP_S, with_diffusion

    rng = np.random.default_rng(1)
    pan = centroids(np.arange(400), lambda t: np.column_stack([50 + 40.0 * t + 5.0 * t * t,
                                                              80 - 15.0 * t]),
                    0.05, rng, track=0, jitter_us=0)

    def prior(t_us, x, y):
        t = np.asarray(t_us) * 1e-6
        true = np.column_stack([40.0 + 10.0 * t, np.full(len(t), -15.0)])
        return true + rng.normal(0, np.sqrt(0.02 / _PRIOR_STEP_S), (len(t), 2))

    assert TrackSmoother(DT).prior_helps(pan, with_diffusion(prior, 0.02)) == set()

def test_a_field_s_tracks_take_the_prior_together():
    """One camera turns every star: eight short tracks (12 frames) of a pan vibrating
    0.1 px at 15 Hz, several of which alone show too little to take the prior, take it
    together; the same tracks under a noisy gyro on a still pan do not."""
    from evstar.smoothing import _PRIOR_STEP_S, with_diffusion

    amp, hz, rng = 0.1, 15.0, np.random.default_rng(5)

    def field(vibrating):
        return [centroids(np.arange(12 * k, 12 * k + 12),
                          lambda t, k=k: line(t) + [0.0, 30.0 * k] + np.column_stack(
                              [np.zeros(len(t)), vibrating * amp * np.sin(2 * np.pi * hz * t)]),
                          0.15, rng, track=k, jitter_us=0) for k in range(8)]

    def shaking(t_us, x, y):
        t = np.asarray(t_us) * 1e-6
        return np.column_stack([np.full(len(t), 40.0),
                                -15.0 + amp * 2 * np.pi * hz * np.cos(2 * np.pi * hz * t)])

    tracks = field(True)
    alone = [k for k, c in enumerate(tracks) if TrackSmoother(DT).prior_helps(c, shaking)]
    assert len(alone) < 8
    assert TrackSmoother(DT).prior_helps(np.concatenate(tracks), shaking) == set(range(8))

    def noisy(t_us, x, y):
        return [40.0, -15.0] + rng.normal(0, np.sqrt(0.5 / _PRIOR_STEP_S), (len(t_us), 2))

    still = np.concatenate(field(False))
    assert TrackSmoother(DT).prior_helps(still, with_diffusion(noisy, 0.5)) == set()

def test_crossings_go_to_the_group_of_their_nearest_track():
    """Tracks smoothed in two groups (with and without the prior): a crossing 1 px from
    track 0 and 2 px from track 1 refines track 0's group only."""
    from evstar.crossings import CROSSING_DTYPE
    from evstar.crossings import along_track
    from evstar.estimation import _by_group, _by_track
    from evstar.smoothing import ESTIMATE_DTYPE

    def rows(track, y):
        r = np.zeros(3, ESTIMATE_DTYPE)
        r["t"], r["track"], r["x"], r["y"], r["vx"] = [0, 10_000, 20_000], track, [10, 20, 30], y, 1000.0
        return r

    groups = [rows(0, 50.0), rows(1, 53.0)]
    c = np.zeros(3, CROSSING_DTYPE)
    c["t"], c["x"], c["y"] = [5_000, 10_000, 15_000], [15, 20, 25], [51, 53, 52]
    mine = _by_group(along_track(c, _by_track(groups)), groups)
    assert mine[0][0].tolist() == [0] and mine[1][0].tolist() == [1, 2]
    # what refine would assign from the group's own crossings and tracks
    for (got, *rest), group in zip(mine, groups):
        own = along_track(c[got], group)
        assert np.array_equal(got[own[0]], got)
        assert all(np.array_equal(a, b) for a, b in zip(own[1:], rest))


def _reversing_track():
    """Rows of a star moving along x as x = 50 + 40·sin(2π·t), t in s, 10 ms apart."""
    from evstar.smoothing import ESTIMATE_DTYPE

    t = np.arange(0, 1_000_000, 10_000)
    rows = np.zeros(len(t), ESTIMATE_DTYPE)
    rows["t"], rows["x"], rows["y"] = t, 50 + 40 * np.sin(2 * np.pi * t * 1e-6), 20.0
    rows["vx"] = 80 * np.pi * np.cos(2 * np.pi * t * 1e-6)
    return rows


def test_crossings_at_a_turn_are_left_out_and_centroids_weigh_there():
    from evstar.smoothing import _in_turns, _single_passes, _turns

    track = _reversing_track()
    turns = _turns(track, radius=3.0)
    # the turns of the sinusoid: x 90 at 0.25 s, x 10 at 0.75 s
    assert len(turns) == 2
    (a0, a1, xa, _), (b0, b1, xb, _) = turns
    assert abs(xa - 90) < 0.1 and a0 < 250_000 < a1 and abs(xb - 10) < 0.1 and b0 < 750_000 < b1
    t_c = np.array([250_000.0, 250_000.0, 100_000.0, 240_000.0])
    q_c = np.array([[89.0, 20.0], [80.0, 20.0], [89.0, 20.0], [88.0, 20.0]])
    # near the turn point in its time: out; far from it, or at another time: kept
    assert list(_single_passes(np.arange(4), t_c, q_c, turns, 3.0)) == [1, 2]
    assert list(_in_turns(np.array([250_000, 100_000, 750_000]), turns)) == [True, False, True]


def test_a_track_that_never_turns_keeps_every_crossing():
    from evstar.smoothing import _single_passes, _turns

    track = _reversing_track()[:20]              # 0–0.19 s: before the first turn
    assert _turns(track, 3.0) == []
    m = np.arange(5)
    assert list(_single_passes(m, np.zeros(5), np.zeros((5, 2)), [], 3.0)) == list(m)


def _lagging_centroids(fitted, a, tau_s):
    """Centroids of the track `fitted` that trail it by `a` px along the motion and by a
    lag of tau_s in time (where the star was tau_s earlier), and its true positions."""
    true = np.column_stack([fitted["x"], fitted["y"]])
    then = np.column_stack([50 + 40 * np.sin(2 * np.pi * (fitted["t"] * 1e-6 - tau_s)),
                            fitted["y"]])      # _reversing_track's motion
    u = np.column_stack([np.sign(fitted["vx"]), np.zeros(len(fitted))])
    return then - a * u, true


def test_centroids_along_bias_is_measured_away_from_the_turns_and_removed():
    """Centroids trailing the star by a constant a along its motion and by a lag in time:
    measured where the star is fast (outside its turns), removed everywhere — at the turns
    too, where the star slows and swings back and the lag is no speed × lag; in the turns'
    time they weigh fully."""
    from evstar.smoothing import _debiased, _turns

    fitted = _reversing_track()
    z, true = _lagging_centroids(fitted, 0.08, 10e-3)
    turns = _turns(fitted, 3.0)
    track = (fitted, z, np.full(len(z), 0.05), None, turns)
    (_, z_fixed, _, _, _), w = _debiased(track, fitted, 0.1, np.ones(len(z), bool), True)
    moving = np.abs(fitted["vx"]) > 1e-6                    # no direction at a standstill
    np.testing.assert_allclose(z_fixed[moving], true[moving], atol=0.02)
    # a lag taken as speed × lag leaves a turn's centroids ½·acceleration·lag² inside it
    at_turn = moving & (np.abs(fitted["t"] - 250_000) <= 10_000)
    as_speed = z[:, 0] + (0.08 + 10e-3 * np.abs(fitted["vx"])) * np.sign(fitted["vx"])
    assert np.all(np.abs(as_speed - true[:, 0])[at_turn] > 0.05)
    assert set(np.unique(w)) == {0.1, 1.0}
    assert np.all(w[np.abs(fitted["t"] - 250_000) <= 10_000] == 1.0)


def test_centroids_the_bias_model_does_not_explain_are_not_trusted_at_the_turns():
    """Calm centroids scattering about their a + b·speed model by several times their σ (a
    lag that changes with speed, trails): no refit that weighs them fully at the turns."""
    from evstar.smoothing import _debiased, _turns

    fitted = _reversing_track()
    z, _ = _lagging_centroids(fitted, 0.08, 2e-3)
    noisy = z + np.column_stack([np.random.default_rng(5).normal(0, 0.5, len(z)), np.zeros(len(z))])
    turns = _turns(fitted, 3.0)
    both = np.ones(len(z), bool)
    for lagging in (True, False):
        assert _debiased((fitted, noisy, np.full(len(z), 0.5), None, turns), fitted, 0.1, both,
                         lagging) is not None
        assert _debiased((fitted, noisy, np.full(len(z), 0.1), None, turns), fitted, 0.1, both,
                         lagging) is None


def test_too_few_calm_centroids_weigh_unmoved_at_the_turns_unless_a_pixel_lag_is_corrected():
    from evstar.smoothing import _debiased, _turns

    fitted = _reversing_track()
    z, _ = _lagging_centroids(fitted, 0.08, 2e-3)
    turns = _turns(fitted, 3.0)
    few = np.zeros(len(z), bool)
    few[[10, 11, 12, 24, 25, 26]] = True                  # 3 calm, 3 in a turn's time
    track = (fitted, z, np.full(len(z), 0.05), None, turns)
    assert _debiased(track, fitted, 0.1, few, True) is None
    (_, z_same, _, _, _), w = _debiased(track, fitted, 0.1, few, False)
    assert np.array_equal(z_same, z) and w[25] == 1.0 and w[11] == 0.1 and w[40] == 0.1


def test_lone_lobes_neither_weigh_at_the_turns_nor_set_the_bias():
    """One-polarity centroids (a slow faint star's lone ON lobe, ~1.7 σ_PSF ahead), at a
    turn and away from it: they keep along_weight at the turn, and the bias measured on the
    balanced centroids alone moves those onto the star."""
    from evstar.smoothing import _debiased, _turns

    fitted = _reversing_track()
    z, true = _lagging_centroids(fitted, 0.08, 2e-3)
    u = np.sign(fitted["vx"])
    lone = np.zeros(len(z), bool)
    lone[[10, 22, 24, 26, 60, 72, 74]] = True           # 24, 26 and 74 in the turns' time
    z[lone, 0] += 2.0 * u[lone]
    turns = _turns(fitted, 3.0)
    (_, z_fixed, _, _, _), w = _debiased((fitted, z, np.full(len(z), 0.05), None, turns),
                                         fitted, 0.1, ~lone, True)
    assert np.all(w[lone] == 0.1) and w[25] == 1.0
    moving = (np.abs(fitted["vx"]) > 1e-6) & ~lone
    np.testing.assert_allclose(z_fixed[moving], true[moving], atol=0.02)


def test_one_level_crossings_get_the_scatter_of_their_own_class():
    from evstar.smoothing import _class_scatter

    rng = np.random.default_rng(5)
    levels = np.r_[np.ones(40, int), np.full(40, 3)]
    r = np.r_[0.8 + rng.normal(0, 1.0, 40), rng.normal(0, 0.1, 40)]   # fragments: off and noisy
    med, s = _class_scatter(r, levels, 0.01)
    assert 0.6 < s[0] < 1.5 and 0.06 < s[-1] < 0.15
    assert abs(med[0] - 0.8) < 0.4 and abs(med[-1]) < 0.05
    together = _class_scatter(r, None, 0.01)[1]
    assert np.all(together == together[0])
    few = np.r_[np.ones(2, int), np.full(78, 3)]            # a class of 2: no scatter of its own
    assert np.all(_class_scatter(r, few, 0.01)[1] == together[0])


def test_pooled_crossings_weigh_each_by_its_scatter():
    from evstar.smoothing import ESTIMATE_DTYPE, _pool_crossings

    est = np.zeros(2, ESTIMATE_DTYPE)
    est["t"], est["x"], est["vx"] = [0, 10_000], [0.0, 0.0], [1e-9, 1e-9]
    q = np.array([[0.0, 0.0], [1.0, 0.0]])
    u = np.array([[1.0, 0.0], [1.0, 0.0]])
    t, pos, _, s = _pool_crossings(np.array([4000.0, 6000.0]), q, u, est, np.array([0.1, 1.0]), 10_000)
    assert len(t) == 1 and abs(pos[0, 0] - 1 / 101) < 1e-6     # weights 100 : 1
    assert abs(s[0] - 1 / np.sqrt(101)) < 1e-9


def test_pooled_crossings_of_a_speeding_star_sit_where_it_was_at_their_mean_time():
    """A star speeding up at 20 000 px/s² (an EVK4's 10°/1 Hz sinusoid after a turn) crosses
    a pixel every ~1 ms: moved to their 10 ms bin's mean time each with its own speed, they
    sat a·var(Δt)/2 ≈ 0.07 px behind it; with the speed midway, on it."""
    from evstar.smoothing import ESTIMATE_DTYPE, _pool_crossings

    a, v0 = 20_000.0, 1000.0                                   # px/s², px/s
    x = lambda t: v0 * t * 1e-6 + 0.5 * a * (t * 1e-6) ** 2
    est = np.zeros(21, ESTIMATE_DTYPE)
    est["t"] = np.arange(21) * 1000                            # rows every ms (the fit's)
    est["x"], est["vx"] = x(est["t"]), v0 + a * est["t"] * 1e-6
    pixels = np.arange(1.0, x(20_000.0))
    t_c = np.array([brentq(lambda t, q=q: x(t) - q, 0, 20_000) for q in pixels])
    q = np.column_stack([pixels, np.zeros(len(pixels))])
    u = np.tile([1.0, 0.0], (len(pixels), 1))
    t, pos, _, _ = _pool_crossings(t_c, q, u, est, np.full(len(pixels), 0.1), 10_000)
    assert len(t) == 2 and np.all(np.abs(pos[:, 0] - x(t)) < 0.005)


def test_a_wild_first_centroid_is_flagged_though_it_drags_its_neighbours_past_the_gate():
    # another star's centroid, 10 px off, starts a short track, two frames before the rest
    # (the tracker's first frames have no flow to gate it): the stiff fit bends to it, more
    # than a quarter of the track lies beyond outlier_sigma, and the track followed it
    # (9.6 px off); the worst alone is dropped and the track refitted
    rng = np.random.default_rng(8)
    cents = centroids(np.r_[0, np.arange(3, 14)], line, 0.3, rng)
    cents["y"][0] += 10.0
    est = TrackSmoother(DT, coast_ends=False).smooth(cents, t0_us=0)
    assert est["outlier"][0]
    rest = ~est["outlier"] & ~est["coasted"]
    err = np.hypot(*(np.column_stack([est["x"], est["y"]]) - line(est["t"] * 1e-6)).T)
    assert err[rest].max() < 0.5


def test_a_few_crossings_are_trusted_only_where_their_runs_are_clean():
    """A slow star's crossings, too few or too close together along the motion to pin a
    velocity, are kept on a quiet sensor and left out where their runs (twice the outer
    half-width) likely hold a background event; many crossings are kept either way (their
    own spread screens them)."""
    from evstar.smoothing import MAX_RUN_BACKGROUND, _trusted

    width = np.full(40, 100_000.0)                       # runs of 0.2 s
    busy, quiet = 1.0, 0.1                               # background events/pixel/s
    assert busy * 0.2 > MAX_RUN_BACKGROUND > quiet * 0.2
    pairs = np.full(40, 2)
    close, far = np.linspace(0, 1.5, 40), np.linspace(0, 10, 40)   # px along the motion
    few, many = np.arange(6), np.arange(40)
    for rate in (busy, None):                            # None: the background unknown
        assert len(_trusted(few, pairs, width, close, rate)) == 0
    assert np.array_equal(_trusted(few, pairs, width, close, quiet), few)
    assert np.array_equal(_trusted(many, pairs, width, far, busy), many)


def test_a_slow_track_moves_onto_its_few_clean_crossings():
    """A faint star at 10 px/s whose 15 centroids trail it by 0.3 px along the motion (the
    lobes of a few events) and 6 crossings within 2 px of each other: on a quiet sensor the
    refit moves the track onto the crossings; on a busy one it is left as it was."""
    from evstar.crossings import CROSSING_DTYPE

    rng = np.random.default_rng(21)

    def slow(t):
        return np.column_stack([100.3 + 10.0 * t, 50.5 + 0.0 * t])

    frames = np.sort(rng.choice(np.arange(50), 15, replace=False))
    cents = centroids(frames, slow, 0.2, rng, n_events=5)
    cents["x"] -= 0.3                                    # the lobes' bias, along the motion
    smoother = TrackSmoother(DT, coast_ends=False)
    est = smoother.smooth(cents, t0_us=0)
    c = np.zeros(6, CROSSING_DTYPE)
    c["x"], c["y"] = [101, 101, 102, 102, 103, 103], [50, 51] * 3
    c["t"] = np.round((c["x"] - 100.3) / 10.0 * 1e6).astype(np.int64)   # the star at the pixel
    c["pairs"], c["t_outer"] = 2, 60_000                 # runs of 0.12 s
    quiet, busy = 0.1, 1.5                               # background events/pixel/s

    def along_err(rows):
        return np.mean(rows["x"] - slow(rows["t"] * 1e-6)[:, 0])

    assert along_err(est) < -0.2
    rows, used = smoother.refine(est, cents, c, background_hz=quiet)
    assert used == 6 and abs(along_err(rows)) < 0.1
    rows, used = smoother.refine(est, cents, c, background_hz=busy)
    assert used == 0 and np.array_equal(rows, est)


def test_a_crossing_on_a_changing_speed_is_moved_to_when_the_star_passed_its_pixel():
    """A level pair's flanks are where the star was d before and d past the pixel; slowing
    down, it reaches the far flank late, so the flanks' mean time is after its passage. No
    flank lies farther along than the star reaches across its crossed pixels.
    Exact kinematics on x = 50 + 40·sin(2πt): the corrected times are ≥ 7× closer."""
    from scipy.optimize import brentq

    from evstar.smoothing import _speed_change_corrected

    track = _reversing_track()
    x = lambda t: 50 + 40 * np.sin(2 * np.pi * t * 1e-6)
    d, q = 3.0, np.array([60.0, 70.0, 80.0, 84.0])
    when = lambda level: np.array([brentq(lambda t: x(t) - v, 0, 250_000) for v in level])
    t0, t1, t2 = when(q), when(q - d), when(q + d)
    t_c, width = 0.5 * (t1 + t2), 0.5 * (t2 - t1)
    u = np.tile([1.0, 0.0], (len(q), 1))
    # the pixels: one 3 px off the track (the star's reach: no flank lies farther along)
    pix = np.column_stack([q, [20.0, 20.0, 23.0, 20.0]])
    fixed, resid = _speed_change_corrected(t_c, width, pix, u, np.zeros(len(q)), track)
    assert np.all(t_c > t0)                                 # slowing down: the mean is late
    # ... also at 84 px, 6 px from the turn (90 px), where the speed over the flanks
    # changes by a third: the flanks' mean was furthest off there
    assert np.all(np.abs(fixed - t0) < 0.15 * np.abs(t_c - t0))
    assert np.argmax(t_c - t0) == 3
    np.testing.assert_allclose(resid, -np.interp(t_c, track["t"], track["vx"]) * (fixed - t_c) * 1e-6)
    # at a constant speed nothing moves
    steady = track.copy()
    steady["x"], steady["vx"] = 50 + 40.0 * steady["t"] * 1e-6, 40.0
    same, _ = _speed_change_corrected(t_c, width, pix, u, np.zeros(len(q)), steady)
    np.testing.assert_allclose(same, t_c, atol=1e-6)
    # pixels all on the track: flanks within 0.5 px, far less than the pairs' 3 px
    near, _ = _speed_change_corrected(t_c, width, np.column_stack([q, np.full(4, 20.0)]), u,
                                      np.zeros(len(q)), track)
    assert np.all(np.abs(near - t_c)[:3] < 0.1 * np.abs(fixed - t_c)[:3])


def test_on_an_acceleration_fit_a_crossing_is_moved_while_the_star_keeps_its_way():
    """exact (a constant-acceleration fit's path): a star slowing to rest reaches a pixel's
    far flank at a seventh of its speed at the crossing; the crossing is still moved to when
    it passed the pixel (the flanks' mean time, left late, had put a slew's last rows up to
    1.5 px behind: fresh-60 of perf/study_accuracy.py). Where the fit turns back within the
    flanks (its model run past the stop), nothing moves."""
    from scipy.optimize import brentq

    from evstar.smoothing import ESTIMATE_DTYPE, _speed_change_corrected

    v0, a = 40.0, 40.0                                       # px/s, px/s²: at rest after 1 s
    x = lambda t: 50 + v0 * t - 0.5 * a * t * t               # t in s, up to the stop
    t = np.arange(0, 1_100_000, 10_000)
    ts = t * 1e-6
    track = np.zeros(len(t), ESTIMATE_DTYPE)
    track["t"], track["y"] = t, 20.0
    track["x"], track["vx"] = x(np.minimum(ts, 1.0)), np.maximum(v0 - a * ts, 0.0)
    d, q = 0.99, np.array([60.0, 69.0])
    when = lambda level: np.array([brentq(lambda s: x(s) - v, 0, 1.0) * 1e6 for v in level])
    t0, t1, t2 = when(q), when(q - d), when(q + d)
    t_c, width = 0.5 * (t1 + t2), 0.5 * (t2 - t1)
    u = np.tile([1.0, 0.0], (2, 1))
    pix = np.column_stack([q, [20.0, 21.5]])                 # the star's reach: 2 px
    far = np.interp(t_c + width, t, track["vx"]) / np.interp(t_c, t, track["vx"])
    assert 0 < far[1] < 0.2                                   # ... was left unmoved below 1/5
    fixed, _ = _speed_change_corrected(t_c, width, pix, u, np.zeros(2), track, exact=True)
    assert np.all(t_c > t0) and np.all(np.abs(fixed - t0) < 0.05 * (t_c - t0))
    # the same star's constant-deceleration fit runs on past the stop, turning back
    past = track.copy()
    past["x"], past["vx"] = x(ts), v0 - a * ts
    assert past["vx"][-1] < 0
    late = t_c + np.array([0.0, 0.05e6])                     # the second's far flank at -1 px/s
    moved, _ = _speed_change_corrected(late, width, pix, u, np.zeros(2), past, exact=True)
    back = np.interp(late + width, t, past["vx"])
    assert back[1] < 0 < back[0] and late[1] + width[1] < t[-1]
    assert moved[0] != late[0] and moved[1] == late[1]


def test_on_a_small_sinusoid_the_speed_change_correction_brings_the_star_closer():
    """A magnitude-3.5 star on a ±1.6° 1 Hz sinusoid through a DAVIS346 behind 8 mm (±12 px:
    near its turns the star slows and speeds up hardest): crossings moved to when the star
    passed their pixels (estimate.speed_change) beat the flanks' mean times, with the IMU's
    prior (also in the turns' time, which the correction once left out: 0.055 -> 0.054 px)
    and without it (from the first fit; reversing tracks once kept their flanks' times)."""
    from evstar import Config, Pipeline, accuracy

    run = sim.simulate(sim.paper_sinusoid(1.6, 1.0, duration_s=0.6, magnitude=3.5,
                                          camera="davis346", focal_length_mm=8.0), seed=6)
    err = {}
    for mode in ("imu", "none"):
        for on in (True, False):
            cfg = Config().replace(**{"motion.compensate": mode, "estimate.speed_change": on})
            rows = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
            star, e = accuracy.match(rows, run.truth.star_position)
            err[mode, on] = e[star >= 0].mean()
    assert err["imu", True] < 0.6 * err["imu", False]
    assert err["none", True] < 0.95 * err["none", False]


def test_a_faint_stars_one_level_stretches_time_it_where_nothing_else_does(monkeypatch):
    """A magnitude-6 star on the paper's 10°/1 Hz sinusoid behind OFF thresholds below ON
    (0.2 against 0.28): after each turn it passes pixels it passed before, whose references
    sit high, and gives one level pair per pixel there. Dropping a track's one-level
    crossings wherever it has enough multi-level ones (MULTI_NEAR 0: the rule before) left
    those stretches to its centroids."""
    from evstar import Config, Pipeline, accuracy, smoothing

    sensor = sim.sensor_model("default", threshold_on=0.28, threshold_off=0.2)
    run = sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.5, magnitude=6.0,
                                          sensor=sensor), seed=3)
    err, default = {}, smoothing.MULTI_NEAR
    for near in (default, 0):
        monkeypatch.setattr(smoothing, "MULTI_NEAR", near)
        rows = Pipeline(Config()).run(run.events, run.imu, run.camera).centroids
        star, e = accuracy.match(rows, run.truth.star_position)
        err[near] = e[star >= 0].mean()
    assert err[default] < 0.8 * err[0]


def test_without_imu_an_accelerating_star_is_corrected_from_its_crossings_first_fit():
    """A magnitude-3.5 star speeding up from rest (a slew's first half, no IMU): its
    crossings, moved by the speed change its first fit with them shows, beat the flanks'
    mean times (which put it ahead); at a constant rate nothing moves."""
    from evstar import Config, Pipeline, accuracy
    from evstar.sim.motion import Slew
    from evstar.sim.scene import Scenario
    from evstar.sim.targets import star_at_pixel

    cam = sim.camera_preset("dvxplorer-lite")
    move = Slew(8.0, 1.2)
    star = star_at_pixel(cam, move.rotation(0.0)[0], (cam.cx - 40, cam.cy), 3.5)
    speeding = sim.simulate(Scenario(cam, star, move, 0.6, psf_sigma_px=1.2), seed=3)
    steady = sim.simulate(sim.paper_preset(8.0, magnitude=3.5, duration_s=0.3), seed=3)
    err, x = {}, {}
    for name, run in (("speeding", speeding), ("steady", steady)):
        for on in (True, False):
            cfg = Config().replace(**{"estimate.speed_change": on})
            rows = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
            star_of, e = accuracy.match(rows, run.truth.star_position)
            err[name, on], x[name, on] = e[star_of >= 0].mean(), rows["x"].tobytes()
    assert err["speeding", True] < 0.8 * err["speeding", False]
    assert x["steady", True] == x["steady", False]


def test_a_bias_line_through_noisy_offsets_of_a_narrow_speed_range_is_not_extended():
    """Offsets of one constant bias, noisy, at speeds 95–108 px/s: a fitted line's chance
    slope extended to a turn's speeds would move the centroids there by ~1 px; the
    median is used. A clear speed term is kept and extended."""
    from evstar.smoothing import _speed_terms

    rng = np.random.default_rng(3)
    s = rng.uniform(95, 108, 50)
    off = -0.2 + rng.normal(0, 0.15, 50)
    off[:10] += 0.25 * (s[:10] > 104)       # a chance tilt at the fast end
    a, b = _speed_terms(s, off, 0.15)
    assert a == np.median(off) and b == 0.0
    clear = -0.05 - 2e-3 * s + rng.normal(0, 0.002, 50)
    a, b = _speed_terms(s, clear, 0.15)
    assert abs(a + 0.05) < 0.02 and abs(b + 2e-3) < 2e-4
    # a clear 20 ms lag whose value at rest the narrow range cannot pin within σ: the
    # median; from speeds down to 5 px/s the line
    steep = lambda v: -0.05 - 2e-2 * v + rng.normal(0, 0.05, len(v))
    a, b = _speed_terms(s, steep(s), 0.15)
    assert b == 0.0
    wide = rng.uniform(5, 108, 50)
    a, b = _speed_terms(wide, steep(wide), 0.15)
    assert abs(a + 0.05) < 0.05 and abs(b + 2e-2) < 1e-3


def test_a_lag_slope_the_crossings_measured_needs_less_evidence():
    """Noisy offsets of a 2.35 ms lag over 40–250 px/s whose slope is ~2.5 SE from zero: the
    median alone without a measured lag, the line where the crossings' lag agrees (within 2
    SE), still the median where it does not (perf/study_indep.py scene 22: a bright star
    behind slow pixels with unequal thresholds, 2.9 SE)."""
    from evstar.smoothing import _speed_terms

    rng = np.random.default_rng(15)
    s = rng.uniform(40, 250, 60)
    off = 0.2 - 2.35e-3 * s + rng.normal(0, 0.4, 60)
    b_fit, _ = np.polyfit(s, off, 1)
    res = np.sqrt(np.sum((off - np.polyval(np.polyfit(s, off, 1), s)) ** 2) / 58)
    t = abs(b_fit) / (res / np.sqrt(np.sum((s - s.mean()) ** 2)))
    assert 2.0 < t < 3.0                                   # the case: between the two rules
    assert _speed_terms(s, off, 0.5)[1] == 0.0
    a, b = _speed_terms(s, off, 0.5, expected_b=-2.35e-3)
    assert b == pytest.approx(b_fit) and b < 0
    assert _speed_terms(s, off, 0.5, expected_b=+5e-3)[1] == 0.0


def test_smoother_defaults_are_the_declared_ones():
    """A stage class's defaults come from evstar.parameters (coast_ms had drifted to 30)."""
    import inspect

    from evstar.parameters import ESTIMATE

    sig = inspect.signature(TrackSmoother.__init__)
    for name, p in sig.parameters.items():
        if name in ESTIMATE:
            assert p.default == ESTIMATE[name].default, name
    assert TrackSmoother(DT).coast_ms == ESTIMATE["coast_ms"].default


def test_without_imu_a_slew_from_rest_to_rest_is_followed_as_it_speeds_up_and_stops():
    """A magnitude-3.5 star on a 1 s slew peaking at 10 °/s (rest to rest, no IMU): the
    constant-acceleration refit (evstar.kalman_ca) with its crossings moved on its own path
    keeps it within the noise while it speeds up and slows down, where the constant-velocity
    fit had led it by up to 0.27 px and trailed it by as much (fresh-40 of
    perf/study_accuracy.py on seed 40: 0.086 / 0.66 px -> 0.026 / 0.08; on this seed
    0.096 / 0.68 -> 0.046 / 0.44, its last row pooled as the star stops)."""
    rows, star_of, e = _slew_without_imu("dvxplorer-lite", 10.0, seed=5)
    assert (star_of >= 0).all() and e.mean() < 0.07 and e.max() < 0.55


def _slew_without_imu(camera, peak, seed):
    """(rows, their star, error px) of a magnitude-3.5 star through `camera`'s centre midway
    on a 1 s rest-to-rest slew peaking at `peak` °/s, the pipeline run without the IMU."""
    from evstar import Config, Pipeline, accuracy
    from evstar.sim.motion import Slew
    from evstar.sim.scene import Scenario
    from evstar.sim.targets import star_at_pixel

    cam = sim.camera_preset(camera)
    move = Slew(peak, 1.0)
    star = star_at_pixel(cam, move.rotation(0.5)[0], (cam.cx, cam.cy), 3.5)
    run = sim.simulate(Scenario(cam, star, move, 1.0), seed=seed)
    rows = Pipeline(Config()).run(run.events, run.imu, run.camera).centroids
    return (rows, *accuracy.match(rows, run.truth.star_position))


def test_without_imu_a_hard_start_from_rest_keeps_its_acceleration_refit():
    """The independent simulator's HD sensor, two stars accelerating from rest at 50 °/s²
    (perf/study_indep.py --fresh5 L6, no IMU): the constant-velocity fit extrapolated back
    from the first crossings, 50 ms in, put the first rows 1.4–1.6 px behind; the
    acceleration refit, right there, departed from it by 1.85–1.95 px and was rejected. Its
    departure is measured from the first crossing on (0.19 px): kept, every row within
    0.2 px (0.092 / 1.56 px before)."""
    import pathlib
    import sys

    from evstar import Config, Pipeline, accuracy

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "perf"))
    import study_indep as si

    i, spec = si.held_out_scene("L6")
    scene, sensor = si.scene_of(i, spec)
    run = si.S.simulate(scene, sensor, seed=i, imu=False)
    rows = Pipeline(Config()).run(run.events).centroids
    star_of, e = accuracy.match(rows, lambda t: scene.positions(np.asarray(t, float) * 1e-6))
    assert (star_of >= 0).all() and e.mean() < 0.06 and e.max() < 0.2


def test_without_imu_a_slew_s_ends_are_coasted_with_the_acceleration_refit_s_sigma():
    """A 25 °/s-peak DAVIS346 slew from rest to rest, no IMU: the star fires too few events
    for a centroid in its first and last frames. Coasted there by the acceleration refit,
    those rows took the constant-velocity fit's σ (over coast_sigma_px: dropped, 96 % of the
    frames); with the refit's own σ every frame has a position, each coasted one within its
    σ."""
    rows, star_of, e = _slew_without_imu("davis346", 25.0, seed=1)
    assert (star_of >= 0).all() and np.array_equal(np.unique(rows["frame"]), np.arange(100))
    coasted = rows["source"] == COASTED
    assert coasted.sum() >= 2 and np.all(e[coasted] <= rows["sigma"][coasted])
    assert e.mean() < 0.05 and e.max() < 0.3


def test_an_acceleration_refit_is_measured_against_the_first_fit_on_its_measured_rows():
    """_departure: the largest distance between two fits of a track at the refit's measured
    rows (coasted ones left out: past a slew's end the two may part by more, rightly), within
    from the first crossing on where the crossings' times are given;
    _with_larger_sigma: each row keeps the larger σ of the two, but for the rows coasted
    before or after the refit's measured ones."""
    from evstar.smoothing import ESTIMATE_DTYPE, _departure, _with_larger_sigma

    a = np.zeros(5, ESTIMATE_DTYPE)
    a["t"] = np.arange(5) * 10_000
    a["x"], a["y"] = np.arange(5.0), 2.0
    a["sigma_x"] = a["sigma_y"] = 0.1
    a["source"] = MEASURED
    b = a.copy()
    b["x"] += [0.0, 0.3, 0.0, 0.0, 3.0]
    b["sigma_x"] = [0.05, 0.2, 0.05, 0.05, 0.05]
    b["source"][4] = COASTED
    assert _departure(b, a) == pytest.approx(0.3)
    b["source"][4] = MEASURED
    assert _departure(b, a) == pytest.approx(3.0)
    # ... from the first crossing on: before it the first fit extrapolates
    c = a.copy()
    c["x"] += [2.0, 0.3, 0.0, 0.0, 0.0]
    assert _departure(c, a) == pytest.approx(2.0)
    assert _departure(c, a, np.array([5_000, 32_000])) == pytest.approx(0.3)
    assert _departure(b, a, np.array([5_000, 32_000])) == pytest.approx(3.0)
    out = _with_larger_sigma(b, a)
    np.testing.assert_allclose(out["sigma_x"], [0.1, 0.2, 0.1, 0.1, 0.1])
    np.testing.assert_array_equal(out["x"], b["x"])
    # ... but a row coasted beyond the refit's measured ones keeps the refit's own σ: the
    # position is that model's extrapolation; one coasted between two measured rows does not
    b["source"][[0, 2]] = COASTED
    np.testing.assert_allclose(_with_larger_sigma(b, a)["sigma_x"], [0.05, 0.2, 0.1, 0.1, 0.1])


def test_a_star_speeding_up_from_rest_has_a_position_from_the_start_with_the_gyro():
    """A star speeding up from rest (10 °/s²) gives no events at first: its track starts
    20–30 ms late. With the gyro its first frames are coasted back to the start
    (coast_gyro_ms), on the star; coasting only coast_ms misses them."""
    from evstar import accuracy
    from evstar.sim.motion import Slew
    from evstar.sim.presets import camera_preset
    from evstar.sim.scene import Scenario
    from evstar.sim.targets import star_at_pixel

    cam = camera_preset("dvxplorer-lite")
    motion = Slew(10.0, 2.0)                       # speeding up for 1 s, recorded 0.5 s
    star = star_at_pixel(cam, motion.rotation(0.25)[0], (cam.cx, cam.cy), 4.0)
    run = sim.simulate(Scenario(cam, star, motion, 0.5, psf_sigma_px=1.2), seed=5)
    ev = run.events
    frames = np.arange((ev.t[-1] - ev.t[0]) // DT + 1)
    mid = ev.t[0] + frames * DT + DT // 2

    def covered(coast_gyro_ms):
        cfg = evstar.Config().replace(**{"motion.compensate": "imu",
                                         "estimate.coast_gyro_ms": coast_gyro_ms})
        rows = evstar.Pipeline(cfg).run(ev, run.imu, run.camera).centroids
        star_of, err = accuracy.match(rows, run.truth.star_position)
        share, _ = accuracy.detection(rows[star_of >= 0], run.truth.star_position, frames, mid,
                                      cam.width, cam.height)
        return share, err[star_of >= 0].max()

    short, (whole, worst) = covered(60.0)[0], covered(500.0)
    assert short < 0.99 and whole == 1.0 and worst < 0.5
