"""Faint stars' second look (evstar.pooling): events pooled over longer frames."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, sim
from evstar.errors import ParameterError
from evstar.estimation import estimate
from evstar.extract import CENTROID_DTYPE
from evstar.io import read_centroids, write_centroids
from evstar.pooling import _seen


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


def test_a_quiet_sensor_s_faint_wide_star_is_pooled_from_the_events_dbscan_left_out():
    # no background: the filter keeps the star's sparse events, DBSCAN leaves most out, so
    # a second look at the filter's rejects alone found nothing (32-80 % of frames, 1.6 px)
    quiet = sim.sensor_model("default", noise_hz=0.0, hot_pixels=0)
    det, err, cents = coverage(4, seed=21, rate_dps=1.5, sensor=quiet, psf_sigma_px=1.8)
    assert (cents["source"] == "pooled").any()
    assert det >= 0.95 and err < 0.5


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
