"""Crossings assigned to tracks whose centroids are late or early against them
(evstar.assignment), and the run's own pixel lag where the gyro tells it."""
import numpy as np
import pytest

from evstar.crossings import CROSSING_DTYPE


def path(speed=1000.0, late_us=6000.0, y=50.0):
    """A track moving +x at `speed` px/s (rows every 10 ms for 0.3 s) and the crossings of
    every pixel it passes, each `late_us` before the track reaches it (its centroids late)."""
    rows = np.zeros(30, [("t", "<i8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
                         ("vx", "<f8"), ("vy", "<f8")])
    rows["t"] = 5_000 + 10_000 * np.arange(30)
    rows["x"], rows["y"], rows["vx"] = 100.0 + speed * rows["t"] * 1e-6, y, speed
    c = np.zeros(250, CROSSING_DTYPE)
    c["x"], c["y"], c["pairs"] = 110 + np.arange(250), int(y), 3
    c["t"] = (c["x"] - 100.0) / speed * 1e6 - late_us
    return c, rows


def test_a_track_late_beyond_the_reach_is_moved_onto_its_crossings():
    from evstar.assignment import assign, track_shifts
    from evstar.crossings import near_tracks, within

    c, rows = path()
    assert len(within(near_tracks(c, rows, 3.0), 3.0)[0]) == 0   # 6 px behind: none
    shift = track_shifts(c, rows)
    assert list(shift) == [0] and shift[0] == pytest.approx(6000.0, abs=1.0)
    (got, owner, _, along), moved = assign(c, rows)
    assert list(moved) == [0]
    inside = (c["t"] >= rows["t"][0] - 6000) & (c["t"] <= rows["t"][-1] - 6000)
    assert set(got) == set(np.flatnonzero(inside)) and np.all(owner == 0)
    assert np.abs(along).max() < 0.01


@pytest.mark.parametrize("speed, late_us", [(1000.0, 2000.0), (200.0, 9000.0), (1000.0, 20_000.0),
                                            (1000.0, -6000.0)])
def test_tracks_within_reach_beyond_any_lag_or_ahead_are_not_moved(speed, late_us):
    """2 ms at 1000 px/s and 9 ms at 200 px/s are within 3 px; 20 ms is no pixel's lag; a
    track ahead of its crossings (a faint star's crossings lag more than its events)
    stays."""
    from evstar.assignment import assign, track_shifts

    c, rows = path(speed, late_us)
    assert track_shifts(c, rows) == {}
    assert len(assign(c, rows)[1]) == 0


def test_a_fast_star_behind_a_slow_photoreceptor_is_placed_with_the_gyro():
    """EVK4 optics, a 10°/1 Hz sinusoid on a 30 Hz dark sky with the IMU: its centroids trail
    its crossings by ~2 ms, 5 px at the peak; before, 0.72 px mean, 3.0 max."""
    from evstar import Config, Pipeline, accuracy, sim

    scene = sim.paper_sinusoid(10.0, duration_s=1.0, magnitude=3.0, psf_sigma_px=1.0,
                               sensor=sim.sensor_model("dark-sky"), camera="evk4")
    run = sim.simulate(scene, seed=5)
    rows = Pipeline(Config().replace(**{"motion.compensate": "imu"})).run(
        run.events, run.imu, run.camera).centroids
    star, err = accuracy.match(rows, run.truth.star_position)
    assert np.all(star >= 0)
    assert err.mean() < 0.2 and err.max() < 0.5
