"""Faint stars' second look (evstar.pooling): events pooled over longer frames."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, sim
from evstar.errors import ParameterError
from evstar.estimation import estimate
from evstar.extract import CENTROID_DTYPE
from evstar.io import read_centroids, write_centroids
from evstar.pooling import (_FALSE_CLUSTERS_PER_S, _LOBE_GAP_SHARE, _LOBE_OFFSET_PER_SPREAD,
                            _MIN_FAINT_EVENTS, _PAIR_LONG_FRAMES, _faint, _lobes_joined,
                            _merged, _min_size, _seen, kept, pooled_centroids)
from evstar_kernels.reference.denoise import disk_area
from scipy.stats import poisson


def coverage(pool_frames, seed=3, **scene):
    """(fraction of frames with a position of the star, mean error px) of a faint slow star
    (1 °/s, magnitude 4.5: ~6 events per 10 ms frame, unless `scene` says otherwise)."""
    run = sim.simulate(sim.paper_preset(scene.pop("rate_dps", 1.0),
                                        magnitude=scene.pop("magnitude", 4.5), **scene), seed=seed)
    cfg = Config().replace(**{"extract.pool_frames": pool_frames})
    res = Pipeline(cfg).run(run.events, run.imu, run.camera)
    ev = run.events
    n = int((ev.t[-1] - ev.t[0]) // cfg.dt_us) + 1
    frame_t = ev.t[0] + (np.arange(n) + 0.5) * cfg.dt_us
    det, _ = accuracy.detection(res.centroids, run.truth.star_position, np.arange(n), frame_t,
                                ev.width, ev.height)
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    return det, float(err[star >= 0].mean()), res.centroids


def test_pooling_gives_a_faint_slow_star_a_position_in_far_more_frames():
    # magnitude 5 (~4 events per frame): alone, its frame centroids are too rare to make a
    # track (at 4.5 they make one since slow tracks join across longer gaps: evstar.tracking)
    without, _, plain = coverage(1, magnitude=5.0)
    assert not (plain["source"] == "pooled").any()             # pool_frames 1: no second look
    with_pool, err, cents = coverage(4, magnitude=5.0)
    assert (cents["source"] == "pooled").any()
    assert with_pool >= 0.95 and with_pool >= without + 0.15
    assert err < 0.4


def test_a_star_of_three_events_a_frame_is_tracked_through_the_pooled_look():
    # magnitude 5.5 at 1 °/s: ~3.2 star events per frame, ~13 per 40 ms pooled frame, on
    # ~0.4 Hz of background; a fixed pooled size of 15 gave it 68 % of frames
    det, err, cents = coverage(4, magnitude=5.5)
    assert (cents["source"] == "pooled").sum() >= 8
    assert det >= 0.95 and err < 0.4


@pytest.mark.parametrize("rate_hz", [0.0, 0.3, 1.0, 5.0])
def test_the_pooled_size_is_improbable_for_the_background_alone(rate_hz):
    e = Config().extract
    long_us, sensor_px = 40_000, 346 * 260
    n = _min_size(e, rate_hz, long_us, sensor_px)
    assert n >= _MIN_FAINT_EVENTS
    disks_per_s = sensor_px / disk_area(e.eps) / (long_us * 1e-6)
    mu = rate_hz * long_us * 1e-6 * disk_area(e.eps)
    # n events of background in one eps disk: at most _FALSE_CLUSTERS_PER_S a second over
    # the sensor; one fewer would let more through (unless the floor holds it)
    assert poisson.sf(n - 1, mu) * disks_per_s <= _FALSE_CLUSTERS_PER_S
    if n > _MIN_FAINT_EVENTS:
        assert poisson.sf(n - 2, mu) * disks_per_s > _FALSE_CLUSTERS_PER_S
    else:   # the floor, on a quiet sensor: below a frame cluster's min_samples
        assert rate_hz < 0.5 and n < e.min_samples


def test_the_pooled_size_grows_with_the_background_and_the_sensor():
    e = Config().extract
    sizes = [_min_size(e, r, 40_000, 346 * 260) for r in (0.1, 1.0, 5.0, 20.0)]
    assert sizes == sorted(sizes) and sizes[-1] > 3 * sizes[0]
    assert _min_size(e, 5.0, 40_000, 1280 * 720) > _min_size(e, 5.0, 40_000, 346 * 260)


def _pooled(x, y, frame, n, t=None, split=False):
    rows = np.zeros(len(x), CENTROID_DTYPE)
    rows["x"], rows["y"], rows["frame"], rows["n_events"] = x, y, frame, n
    rows["t"] = np.asarray(frame) * 40_000 + 20_000 if t is None else t
    rows["n_on"], rows["spread"], rows["split"] = np.asarray(n) // 2, 1.0, split
    return rows


def test_a_faint_star_s_two_pooled_halves_of_one_long_frame_are_merged():
    rows = _pooled([10.0, 14.0, 10.0, 40.0], [10.0, 10.0, 10.0, 10.0], [0, 0, 1, 1],
                   [10, 30, 12, 12])
    out = _merged(rows, 6.0)
    assert len(out) == 3                       # frame 0's two, 4 px apart, are one
    one = out[out["frame"] == 0][0]
    assert one["n_events"] == 40 and one["n_on"] == 20
    assert one["x"] == pytest.approx(13.0)     # event-weighted: (10·10 + 30·14) / 40
    # the merged spread holds the halves' own and their distance to the mean
    assert one["spread"] == pytest.approx(np.sqrt((10 * (1 + 9) + 30 * (1 + 1)) / 40))
    halves = _pooled([10.0, 14.0], [10.0, 10.0], [0, 0], [10, 30], split=True)
    assert len(_merged(halves, 6.0)) == 2      # a close pair's split halves stay apart


def test_faint_clusters_are_merged_trails_dropped_and_each_in_its_long_frame_s_middle():
    # long frames of 40 ms (k = 4): clusters in long frames 0, 1, 2, 3, 1
    cents = _pooled([10.0, 100.0, 200.0, 300.0, 50.0], [10.0, 10.0, 10.0, 10.0, 90.0],
                    [0, 1, 2, 3, 1], [8, 8, 8, 20, 8])
    cents["n_on"][2] = 1                          # OFF events alone: a fast star's trail
    out = _faint(cents, 15, 4, 6.0)
    # the fourth is of the usual size (the strict look has it); each of the rest in its
    # long frame's middle frame
    assert dict(zip(out["x"].tolist(), out["frame"].tolist())) == {10.0: 2, 100.0: 6, 50.0: 6}


def _lobes(x, frame, n_on, n=10):
    rows = _pooled(x, [50.0] * len(x), frame, [n] * len(x))
    rows["n_on"] = n_on
    return rows


def test_a_slow_wide_star_s_lone_lobes_of_neighbouring_long_frames_are_joined_at_their_midpoint():
    # a star at x = 100 moving +x: ON lobes ~3 px ahead, OFF lobes ~3 px behind; an ON lobe
    # of long frame 2 and an OFF lobe of long frame 3, 6 px apart, are one star
    rows = _lobes([103.0, 97.0], [2, 3], [10, 1])
    out = _lobes_joined(rows, 8.0)
    assert len(out) == 1 and out["x"][0] == pytest.approx(100.0)
    assert out["t"][0] == (rows["t"][0] + rows["t"][1]) // 2
    # counted as its larger lobe (still a faint cluster for kept), of mixed polarity
    assert out["n_events"][0] == 10 and out["n_on"][0] == round(10 * 11 / 20)
    # ... and no more an OFF-only cluster that _faint drops
    assert len(_faint(rows, 15, 4, 6.0, 8.0)) == 1 and len(_faint(rows, 15, 4, 6.0)) == 1
    assert _faint(rows, 15, 4, 6.0)["x"][0] == 103.0      # without joining: the lone ON lobe
    # too far apart, too close for lobes of their width (each ~1.05 x its spread off the
    # star: a half-gap of 3 px is too little for lobes of a spread above 3 / (0.6 x 1.05)),
    # two long frames apart, or both of one polarity: left alone
    assert len(_lobes_joined(_lobes([103.0, 94.5], [2, 3], [10, 1]), 8.0)) == 2
    wide = _lobes([103.0, 97.0], [2, 3], [10, 1])
    limit = 3.0 / (_LOBE_GAP_SHARE * _LOBE_OFFSET_PER_SPREAD)
    wide["spread"] = 1.1 * limit
    assert len(_lobes_joined(wide, 8.0)) == 2
    wide["spread"] = 0.9 * limit
    assert len(_lobes_joined(wide, 8.0)) == 1
    assert len(_lobes_joined(_lobes([103.0, 97.0], [2, 4], [10, 1]), 8.0)) == 2
    assert len(_lobes_joined(_lobes([103.0, 97.0], [2, 3], [10, 10]), 8.0)) == 2


def test_a_faint_lobe_s_offset_per_spread_is_that_of_its_events():
    # a faint star's ON events lie ∝ u·G(u) ahead of it (u > 0: a Rayleigh law) and G(w)
    # across: their mean offset over their spread (sqrt of both variances) is the constant
    rng = np.random.default_rng(5)
    u, w = rng.rayleigh(2.0, 200_000), rng.normal(0.0, 2.0, 200_000)
    assert u.mean() / np.sqrt(u.var() + w.var()) == pytest.approx(_LOBE_OFFSET_PER_SPREAD, rel=0.01)


def test_a_lone_on_lobe_moves_by_the_half_gap_of_its_star_s_nearest_joined_pair():
    # the pair (ON lobe of long frame 2, OFF of 3) measures the lobes' half-gap, 3 px along
    # -x; the star's lone ON lobes 4 and _PAIR_LONG_FRAMES long frames later move by it, one
    # a long frame beyond that does not
    w = _PAIR_LONG_FRAMES
    rows = _lobes([103.0, 97.0, 103.4, 103.8, 104.0], [2, 3, 6, 2 + w, 3 + w], [10, 1, 10, 10, 10])
    out = _lobes_joined(rows, 8.0)
    assert out["x"].tolist() == pytest.approx([100.0, 100.4, 100.8, 104.0])


def test_a_slow_faint_star_with_a_wide_psf_is_not_tracked_by_its_leading_lobe():
    # σ 2.5 px, 1 °/s, magnitude 4: its lobes ~6 px apart, often one a long frame; before
    # the lone lobes were joined (and moved) 80 % of frames at 0.51 px
    det, err, _ = coverage(4, seed=3, magnitude=4.0, psf_sigma_px=2.5, duration_s=1.0)
    assert det >= 0.85 and err < 0.47


def test_the_tracker_gets_no_lone_pooled_centroid_and_no_faint_one_a_seen_star_explains():
    rows = _pooled([10.0, 18.0, 80.0, 200.0, 209.0, 300.0, 305.0],
                   [10.0, 14.0, 80.0, 50.0, 52.0, 300.0, 300.0], [0] * 7,
                   [8, 8, 20, 20, 20, 8, 20],
                   t=[20_000, 100_000, 60_000, 140_000, 230_000, 20_000, 30_000])
    rows["source"] = ["pooled"] * 4 + ["measured", "pooled", "measured"]
    # the first two (faint) repeat 80 ms and 9 px apart (a faint star moving); the fourth
    # has a frame centroid 90 ms later, 9.2 px off; the third has nothing within 12 px and
    # 2.5 long frames (100 ms); the sixth (faint) lies 5 px from a frame centroid of its
    # long frame: that star explains it; frame centroids always go
    assert kept(rows, Config()).tolist() == [True, True, False, True, True, False, True]
    rows["t"][4] += 20_000                        # 110 ms: beyond 2.5 long frames
    assert kept(rows, Config()).tolist() == [True, True, False, False, True, False, True]


def test_a_fast_star_s_trails_on_slow_pixels_pool_into_nothing():
    # a dark sky's pixels relax for tens of ms behind an EVK4's 20 °/s stars: OFF events
    # alone, which pooled into 38 clusters (none a star) and 37 false rows
    scene = sim.field_scenario(sim.camera_preset("evk4", 16.0), 253, -38, 20.0, 0.3,
                               mag_limit=4.5, sensor="dark-sky", noise_hz=0.1)
    run = sim.simulate(scene, seed=95)
    rows = Pipeline(Config()).run(run.events).centroids
    star, _ = accuracy.match(rows, run.truth.star_position)
    assert not (rows["source"] == "pooled").any() and (star < 0).sum() <= 3


def test_a_quiet_sensor_s_faint_wide_star_is_pooled_from_the_events_dbscan_left_out():
    # no background: the filter keeps the star's sparse events, DBSCAN leaves most out, so
    # a second look at the filter's rejects alone found nothing (32-80 % of frames, 1.6 px)
    quiet = sim.sensor_model("default", noise_hz=0.0, hot_pixels=0)
    det, err, cents = coverage(4, seed=21, rate_dps=1.5, sensor=quiet, psf_sigma_px=1.8)
    assert (cents["source"] == "pooled").any()
    assert det >= 0.95 and err < 0.5


def test_a_quiet_sensor_s_faintest_stars_are_found_below_a_frame_cluster_s_size():
    # 0.1 Hz of background: four events in a DBSCAN disk of a 40 ms frame are noise about
    # once in 6 s over the sensor; a magnitude-6.6 star (1.2 events a frame) gives four or
    # five, which min_samples (5) kept out in every frame
    quiet = sim.sensor_model("default", noise_hz=0.1)
    det, err, cents = coverage(4, seed=3, magnitude=6.6, sensor=quiet, duration_s=1.0)
    assert (cents["source"] == "pooled").any()
    assert det >= 0.9 and err < 0.5


def test_a_noisy_sensor_s_background_along_a_star_s_path_pools_into_no_false_track():
    # 10 Hz of background: events along the sinusoid's path, counted with the star's own,
    # passed the second look's density test and pooled into a track beside the star
    spec = sim.sensor_model("default", noise_hz=10.0)
    run = sim.simulate(sim.paper_sinusoid(magnitude=4, sensor=spec, psf_sigma_px=1.2), seed=51)
    res = Pipeline(Config().replace(**{"motion.compensate": "imu"})).run(
        run.events, run.imu, run.camera)
    star, _ = accuracy.match(res.centroids, run.truth.star_position)
    n_frames = int(np.ptp(run.events.t) // Config().dt_us) + 1
    assert (star >= 0).any() and (star < 0).sum() <= n_frames // 100     # was 14 of 100


def test_a_pooled_centroid_in_a_frame_where_a_frame_centroid_saw_the_star_is_dropped():
    frame = np.zeros(2, CENTROID_DTYPE)
    frame["x"], frame["y"], frame["frame"] = (10.0, 50.0), (10.0, 10.0), (5, 9)
    pooled = np.zeros(3, CENTROID_DTYPE)
    # the first shares frame 5 with a frame centroid 2 px away; the second is far from both;
    # the third is near the star of frame 9 but in frame 8
    pooled["x"], pooled["y"], pooled["frame"] = (12.0, 30.0, 50.0), (10.0, 10.0, 10.0), (5, 5, 8)
    assert _seen(pooled, frame, 6.0).tolist() == [True, False, False]


def test_unlinked_pooled_centroids_are_dropped_by_the_estimator():
    rows = np.zeros(5, CENTROID_DTYPE)
    rows["t"] = np.arange(5) * 10_000 + 5_000
    rows["x"], rows["y"], rows["n_events"], rows["spread"] = 20.0, 20.0, 20, 1.0
    rows["frame"], rows["track"] = np.arange(5), [0, 0, 0, -1, -1]
    rows["source"] = ["measured", "pooled", "measured", "pooled", "measured"]
    for name in ("mean", "track"):
        out = estimate(rows, Config().replace(**{"estimate.estimator": name}), 0)
        assert "pooled" in out["source"]                  # the linked one stays, so marked
        unlinked = out[out["track"] < 0]
        assert len(unlinked) == 1 and unlinked["source"][0] == "measured"


@pytest.mark.parametrize("suffix", [".csv", ".h5", ".npz"])
def test_the_pooled_source_survives_the_centroid_files(tmp_path, suffix):
    rows = np.zeros(3, CENTROID_DTYPE)
    rows["t"], rows["source"] = [1, 2, 3], ["measured", "pooled", "coasted"]
    path = tmp_path / f"c{suffix}"
    write_centroids(path, rows)
    assert read_centroids(path)["source"].tolist() == ["measured", "pooled", "coasted"]


@pytest.mark.parametrize("bad", [0, -2, 1.5, "many"])
def test_bad_pool_frames_is_rejected_by_name(bad):
    with pytest.raises(ParameterError, match="pool_frames"):
        Config().replace(**{"extract.pool_frames": bad})


def test_a_noisy_sensor_s_background_alone_pools_into_no_cluster():
    # 10 Hz of background: _min_size (~23 events in a 40 ms disk) exceeds the usual pooled
    # size (15), which alone let 15-43-event noise clumps into tracks (study_indep H12)
    rng = np.random.default_rng(7)
    w, h, dur_us, rate = 346, 260, 400_000, 10.0
    n = rng.poisson(rate * w * h * dur_us * 1e-6)
    t = np.sort(rng.integers(0, dur_us, n))
    from evstar import Events

    ev = Events(t, rng.integers(0, w, n), rng.integers(0, h, n), rng.integers(0, 2, n), w, h)
    cfg = Config()
    assert _min_size(cfg.extract, rate, cfg.dt_us * cfg.extract.pool_frames, w * h) > 15
    rows = pooled_centroids(cfg, ev, np.ones(n, bool), 0, rate, np.zeros(0, CENTROID_DTYPE))
    assert len(rows) <= 1
