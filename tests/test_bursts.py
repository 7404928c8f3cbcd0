"""Particle hits (evstar.bursts): a spot of pixels firing at once is no star, however many
events it holds; a star's untracked centroid, whose events come all through its frame, stays."""
import numpy as np
import pytest

from evstar import Config, Events, Pipeline, accuracy, sim
from evstar.bursts import BURST_SHARE, SHORT_TRACK, bunched, burst_tracks, flashes
from evstar.extract import CENTROID_DTYPE


def _hits(run, n, size, seed=1):
    """run's events plus n hits of `size` events each within ±2 px and 1 ms."""
    ev, rng = run.events, np.random.default_rng(seed)
    t0, t1 = int(ev.t[0]), int(ev.t[-1])
    parts = [(ev.t, ev.x, ev.y, ev.p)]
    for _ in range(n):
        tc, xc, yc = rng.integers(t0, t1), rng.integers(5, ev.width - 5), rng.integers(5, ev.height - 5)
        parts.append((tc + rng.integers(0, 1000, size), xc + rng.integers(-2, 3, size),
                      yc + rng.integers(-2, 3, size), rng.integers(0, 2, size)))
    t, x, y, p = (np.concatenate(c) for c in zip(*parts))
    o = np.argsort(t, kind="stable")
    return Events(t[o], x[o].astype(ev.x.dtype), y[o].astype(ev.y.dtype), p[o].astype(ev.p.dtype),
                  ev.width, ev.height)


@pytest.mark.parametrize("hits,size", [(50, 30), (200, 60)])
def test_particle_hits_are_not_reported_as_stars(hits, size):
    """50 hits of 30 events made 53 false rows (untracked clusters); 200 of 60 made 272, 72
    of them on 5 tracks the tracker linked hits into."""
    run = sim.simulate(sim.paper_preset(8.0, duration_s=1.0, magnitude=4.0), seed=3)
    clean = Pipeline(Config()).run(run.events, run.imu, run.camera).centroids
    rows = Pipeline(Config()).run(_hits(run, hits, size), run.imu, run.camera).centroids
    star, err = accuracy.match(rows, run.truth.star_position)
    clean_star, clean_err = accuracy.match(clean, run.truth.star_position)
    # now as many false rows as without them, the star as well seen (a hit after the
    # star's last event lengthens the recording into a partial frame: one row more, at
    # the recording's end)
    assert np.count_nonzero(star < 0) <= np.count_nonzero(clean_star < 0) <= 1
    seen, clean_seen = np.count_nonzero(star >= 0), np.count_nonzero(clean_star >= 0)
    assert clean_seen <= seen <= clean_seen + (rows["t"].max() > clean["t"].max())
    assert abs(err[star >= 0].mean() - clean_err[clean_star >= 0].mean()) < 0.005


def test_bunched_events_make_a_burst_and_spread_ones_a_star():
    dt = 10_000
    rows = np.zeros(3, CENTROID_DTYPE)
    rows["frame"], rows["x"], rows["y"] = [2, 2, 5], [10.0, 40.0, 10.0], [10.0, 40.0, 10.0]
    rng = np.random.default_rng(0)
    burst_t = 20_000 + 4000 + rng.integers(0, 600, 30)                 # frame 2, 0.6 ms
    star_t = 20_000 + rng.integers(0, dt, 30)                           # frame 2, all through
    late_burst = 50_000 + 9000 + rng.integers(0, 500, 20)              # frame 5
    noise_t = 50_000 + rng.integers(0, dt, 5)                           # a few beside it
    t = np.concatenate([burst_t, star_t, late_burst, noise_t])
    x = np.concatenate([np.full(30, 10), np.full(30, 41), np.full(20, 11), np.full(5, 9)])
    y = np.concatenate([np.full(30, 9), np.full(30, 40), np.full(20, 10), np.full(5, 12)])
    o = np.argsort(t, kind="stable")
    assert bunched(rows, (t[o], x[o], y[o]), 0, dt).tolist() == [True, False, True]
    assert 0 < BURST_SHARE < 0.5
    assert not bunched(rows, (t[:0], x[:0], y[:0]), 0, dt).any()


def test_short_tracks_of_bunched_centroids_are_hits_linked_by_chance():
    dt = 10_000
    rng = np.random.default_rng(2)
    rows = np.zeros(6, CENTROID_DTYPE)
    rows["frame"] = [1, 2, 3, 1, 2, 3]
    rows["track"] = [0, 0, 0, 1, 1, 1]
    rows["x"] = [10, 12, 14, 50, 52, 54]
    rows["y"] = 20
    t, x, y = [], [], []
    for r in rows:
        hit = r["track"] == 0                  # track 0: hits; track 1: a star's light
        t.append(r["frame"] * dt + (3000 + rng.integers(0, 500, 20) if hit else rng.integers(0, dt, 20)))
        x.append(np.full(20, r["x"])), y.append(np.full(20, 20))
    t, x, y = (np.concatenate(v) for v in (t, x, y))
    o = np.argsort(t, kind="stable")
    near = (t[o], x[o], y[o])
    assert burst_tracks(rows, near, 0, dt).tolist() == [0]
    long = np.concatenate([rows[:3]] * (SHORT_TRACK // 3 + 1))   # longer: a star's, kept
    assert burst_tracks(long, near, 0, dt).tolist() == []


def _flashed(run, n, seed=4):
    """run's events plus n flashes: every pixel firing once within 0.5 ms."""
    ev, rng = run.events, np.random.default_rng(seed)
    ys, xs = np.mgrid[0:ev.height, 0:ev.width]
    parts = [(ev.t, ev.x, ev.y, ev.p)]
    for tc in rng.integers(int(ev.t[0]) + 50_000, int(ev.t[-1]), n):
        parts.append((tc + rng.integers(0, 500, xs.size), xs.ravel(), ys.ravel(),
                      np.ones(xs.size, int)))
    t, x, y, p = (np.concatenate(c) for c in zip(*parts))
    o = np.argsort(t, kind="stable")
    return Events(t[o], x[o].astype(ev.x.dtype), y[o].astype(ev.y.dtype), p[o].astype(ev.p.dtype),
                  ev.width, ev.height)


def test_a_flash_of_the_whole_sensor_is_taken_as_lost(tmp_path):
    """Three flashes in 1 s took the star 0.022 -> 0.088 px (their events joined its
    clusters); taken as lost, the star is as well seen as without them, whole or streamed."""
    from evstar import io

    run = sim.simulate(sim.paper_preset(8.0, duration_s=1.0, magnitude=4.0), seed=3)
    ev = _flashed(run, 3)
    clean = Pipeline(Config()).run(run.events, run.imu, run.camera)
    result = Pipeline(Config()).run(ev, run.imu, run.camera)
    star, err = accuracy.match(result.centroids, run.truth.star_position)
    clean_star, clean_err = accuracy.match(clean.centroids, run.truth.star_position)
    assert abs(err[star >= 0].mean() - clean_err[clean_star >= 0].mean()) < 0.005
    assert np.count_nonzero(star >= 0) >= 99 and np.count_nonzero(star < 0) <= 1
    assert len(result.keep) == len(ev) and not result.keep[flashes(
        ev.t, int(ev.t[0]), Config().dt_us, ev.width * ev.height)].any()
    io.write(tmp_path / "events.h5", ev)
    cfg = Config(chunk_frames=7).replace(**{"estimate.estimator": "mean"})
    whole = Pipeline(cfg).run(ev).centroids
    streamed = Pipeline(cfg).run_file(tmp_path / "events.h5", progress=False).centroids
    for f in whole.dtype.names:
        np.testing.assert_array_equal(whole[f], streamed[f])


def test_flashes_are_bins_far_above_the_sensors_own_rate():
    n_pixels, dt = 10_000, 10_000
    rng = np.random.default_rng(0)
    steady = np.sort(rng.integers(0, 100_000, 30_000))          # 300 a millisecond
    flash = 42_000 + rng.integers(0, 900, 5000)                 # half the pixels at once
    t = np.sort(np.r_[steady, flash])
    got = flashes(t, 0, dt, n_pixels)
    assert np.all(got == ((t >= 42_000) & (t < 43_000)))
    # a sensor busy all the time (every bin 6 % of the pixels) has no flash
    busy = np.sort(rng.integers(0, 100_000, 60_000))
    assert not flashes(busy, 0, dt, n_pixels).any()
