"""Hot-pixel map: finds the simulator's hot pixels, never flags a star's pixels (slow or
fast, bright or faint), forgets a pixel that stops firing, and removes one-pixel centroids
on hot pixels only; parameters checked by name."""
import numpy as np
import pytest

import evstar
from evstar import sim
from evstar.extract import CENTROID_DTYPE
from evstar.hotpixels import HotPixelMap, hot_pixels, remove_hot_centroids


def findable(pixels, width):
    """The pixels of `pixels` (y·width + x) with at most one other of them among their 8
    neighbours (the test is against the second-brightest neighbour: a hot pair is found, a
    hot pixel with two hot neighbours looks like a star's track, by design)."""
    xy = np.column_stack([pixels % width, pixels // width])
    d = np.abs(xy[:, None] - xy[None]).max(2)
    return set(pixels[(d <= 1).sum(1) <= 2].tolist())


@pytest.mark.parametrize("rate_dps, magnitude", [(0.5, 1.0), (2.0, 3.0), (8.0, 1.0), (2.0, 5.0)])
def test_finds_hot_pixels_and_never_a_star(rate_dps, magnitude):
    spec = sim.SensorSpec(hot_pixels=20, hot_pixel_hz=30.0)
    run = sim.simulate(sim.paper_preset(rate_dps, magnitude=magnitude, duration_s=1.0, sensor=spec),
                       seed=3)
    w = run.camera.width
    hot = HotPixelMap(w, run.camera.height)
    hot.update(run.events)
    found, truth = set(hot.pixels.tolist()), set(run.truth.hot_pixels.tolist())
    ev, lab = run.events, run.truth.labels
    star_pixels = set((ev.y[lab >= 0].astype(np.int64) * w + ev.x[lab >= 0]).tolist())
    assert len(star_pixels) > 20
    assert not found & star_pixels
    assert found <= truth                                  # no false alarm
    assert findable(run.truth.hot_pixels, w) <= found      # every lone or paired one found


def test_running_window_forgets_a_pixel_that_stops():
    n = 200
    ev = evstar.Events(np.arange(n) * 2_000, np.full(n, 10), np.full(n, 7), np.ones(n, int), 32, 24)
    hot = HotPixelMap(32, 24, window_us=400_000)
    assert hot.update(ev).mask[7, 10] and hot.is_hot(10.2, 6.8) and not hot.is_hot(11, 7)
    later = evstar.Events(np.array([1_000_000]), np.array([3]), np.array([3]), np.array([1]), 32, 24)
    hot.update(later)                       # 600 ms after its last event: out of the window
    assert not hot.mask.any() and hot.counts.sum() == 1
    assert not hot.is_hot(-5, 100)          # off the sensor: not hot


def test_a_pixel_with_bright_neighbours_is_not_hot():
    counts = np.ones((20, 20))
    counts[10, 10] = 200
    assert hot_pixels(counts)[10, 10]
    counts[10, 11] = 80                     # one neighbour of its own order: a hot pair
    assert hot_pixels(counts)[10, 10] and hot_pixels(counts)[10, 11]
    counts[10, 9] = 80                      # two: a star's track across it
    assert not hot_pixels(counts)[10, 10]


def test_a_hot_pair_on_a_quiet_sensor_is_never_reported_as_a_star():
    # two diagonal hot pixels at ~100 Hz on a 0.1 Hz sensor: each is the other's brightest
    # neighbour; a test against the brightest missed both, and their events made a
    # one-pixel "star" in 4 frames of 100
    spec = sim.sensor_model("default", noise_hz=0.1)
    run = sim.simulate(sim.paper_preset(20.0, magnitude=3, sensor=spec), seed=41)
    w = run.camera.width
    truth = run.truth.hot_pixels
    xy = np.column_stack([truth % w, truth // w])
    assert (np.abs(xy[:, None] - xy[None]).max(2) == 1).any()      # the scene holds a pair
    res = evstar.Pipeline(evstar.Config()).run(run.events, run.imu, run.camera)
    star, _ = evstar.accuracy.match(res.centroids, run.truth.star_position)
    assert (star >= 0).all()


def test_remove_hot_centroids_drops_only_point_like_centroids_on_hot_pixels():
    mask = np.zeros((24, 32), bool)
    mask[7, 10] = True
    c = np.zeros(3, CENTROID_DTYPE)
    c["x"], c["y"], c["spread"] = [10.1, 10.0, 20.0], [7.2, 7.0, 5.0], [0.0, 1.6, 0.0]
    kept = remove_hot_centroids(c, mask)
    assert kept["spread"].tolist() == [1.6, 0.0]      # the star on it and the one elsewhere stay


@pytest.mark.parametrize("name, value", [("window_us", 0), ("alpha", 1.5), ("alpha", 0),
                                         ("neighbour_ratio", 0.5)])
def test_bad_parameters_rejected_by_name(name, value):
    with pytest.raises(evstar.ParameterError, match=name):
        HotPixelMap(32, 24, **{name: value})


def test_bad_spread_rejected_by_name():
    with pytest.raises(evstar.ParameterError, match="max_spread_px"):
        remove_hot_centroids(np.zeros(0, CENTROID_DTYPE), np.zeros((2, 2), bool), max_spread_px=-1)


def test_neighbour_and_box_sums_equal_scipys_filters():
    from scipy import ndimage

    from evstar.hotpixels import (_BOX, _box_sums, _neighbour_candidates, _padded,
                                  _second_neighbour)

    rng = np.random.default_rng(3)
    counts = rng.poisson(2.0, (37, 53))
    counts[rng.integers(0, 37, 20), rng.integers(0, 53, 20)] += rng.integers(5, 500, 20)
    iy, ix = np.nonzero(counts >= 0)                    # every pixel, edges included
    padded = np.pad(counts, 1)
    second = [np.sort(np.delete(padded[y:y + 3, x:x + 3].ravel(), 4))[-2] for y, x in zip(iy, ix)]
    assert np.array_equal(_second_neighbour(_padded(counts), iy, ix), second)
    # the cheap screen never drops a pixel that passes the exact test
    passes = (counts > 0) & (counts >= 4 * np.reshape(second, counts.shape))
    assert passes.any() and not (passes & ~_neighbour_candidates(_padded(counts), 4)).any()
    box = ndimage.correlate(counts, np.ones((_BOX, _BOX), int), mode="constant")
    assert np.array_equal(_box_sums(_padded(counts), iy, ix), box[iy, ix])
