"""Hot pixels are never reported as stars by the pipeline, whatever the estimator."""
import numpy as np
import pytest

import evstar
from evstar import sim


@pytest.fixture(scope="module")
def run():
    sensor = sim.SensorSpec(hot_pixels=40, hot_pixel_hz=800.0)
    return sim.simulate(sim.paper_preset(8.0, duration_s=0.3, sensor=sensor), seed=5)


def on_hot(rows, run):
    w = run.events.width
    hot = set(run.truth.hot_pixels.tolist())
    pix = (np.floor(rows["y"] + 0.5) * w + np.floor(rows["x"] + 0.5)).astype(np.int64)
    return np.array([p in hot for p in pix])


@pytest.mark.parametrize("estimator", ["mean", "crossings"])
def test_no_position_on_a_hot_pixel(run, estimator):
    cfg = evstar.Config().replace(**{"estimate.estimator": estimator, "denoise.method": "ndsef",
                                     "denoise.threshold": 2})   # a loose filter lets them through
    rows = evstar.Pipeline(cfg).run(run.events).centroids
    assert len(rows) > 20 and not on_hot(rows, run).any()
    off = cfg.replace(**{"hotpixels.remove": False})
    assert on_hot(evstar.Pipeline(off).run(run.events).centroids, run).any()   # they were there


def _turning_hot(run, pixels, start_s):
    """run's events plus `pixels` ((x, y, Hz) each) firing from start_s on: hot pixels the
    calibration window (the run's first chunk_frames frames) never saw."""
    ev = run.events
    rng = np.random.default_rng(0)
    t0, t1 = int(ev.t[0]), int(ev.t[-1])
    parts = [(ev.t, ev.x, ev.y, ev.p)]
    for x, y, hz in pixels:
        n = rng.poisson(hz * (t1 - t0 - start_s * 1e6) * 1e-6)
        parts.append((np.sort(rng.integers(t0 + int(start_s * 1e6), t1, n)),
                      np.full(n, x, ev.x.dtype), np.full(n, y, ev.y.dtype),
                      rng.integers(0, 2, n).astype(ev.p.dtype)))
    t, x, y, p = (np.concatenate(c) for c in zip(*parts))
    order = np.argsort(t, kind="stable")
    return evstar.Events(t[order], x[order], y[order], p[order], ev.width, ev.height)


@pytest.mark.parametrize("mode", ["none", "imu"])
def test_a_pixel_turning_hot_after_the_calibration_window_is_no_star(mode):
    """Two pixels turn hot 2.5 s into a 4 s pan, past the 2 s calibration window: their
    tracks stay still while the star moves (hotpixels.still_tracks); 95-144 false rows each
    before. The star's rows are unchanged."""
    scene = sim.simulate(sim.paper_preset(8.0, duration_s=4.0, magnitude=4.0), seed=3)
    ev = _turning_hot(scene, [(40, 50, 300.0), (120, 30, 1000.0)], 2.5)
    cfg = evstar.Config().replace(**{"motion.compensate": mode})
    rows = evstar.Pipeline(cfg).run(ev, scene.imu, scene.camera).centroids
    star, err = evstar.accuracy.match(rows, scene.truth.star_position)
    assert np.count_nonzero(star >= 0) > 300 and np.count_nonzero(star < 0) == 0
    alone = evstar.Pipeline(cfg).run(scene.events, scene.imu, scene.camera).centroids
    np.testing.assert_array_equal(rows["x"], alone["x"])


def _track(tid, xy, n=60, dt_us=10_000, jitter=0.0, seed=0):
    rows = np.zeros(n, evstar.extract.CENTROID_DTYPE)
    rng = np.random.default_rng(seed)
    rows["t"], rows["track"] = np.arange(n) * dt_us, tid
    rows["x"], rows["y"] = np.asarray(xy, float) + jitter * rng.standard_normal((2, n))
    return rows


def test_still_tracks_are_those_that_stay_still_where_another_moves():
    from evstar.hotpixels import still_tracks

    n = 60
    moving = _track(0, (np.linspace(10, 60, n), np.full(n, 20.0)))
    still = _track(1, (np.full(n, 40.0), np.full(n, 50.0)), jitter=0.05)
    still["x"][[5, 17, 33]] += [1.5, -2.0, 1.2]          # background events in its clusters
    slow = _track(2, (np.linspace(80, 82, n), np.full(n, 30.0)))   # 3.4 px/s: a slow star
    brief = _track(3, (np.full(20, 90.0), np.full(20, 90.0)), n=20)   # 0.19 s
    both = np.concatenate([moving, still, slow, brief])
    assert still_tracks(both).tolist() == [1]
    assert still_tracks(np.concatenate([still, slow])).tolist() == []   # nothing moves
    untracked = still.copy()
    untracked["track"] = -1
    assert still_tracks(np.concatenate([moving, untracked])).tolist() == []
