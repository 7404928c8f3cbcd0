"""Ground truth: truth.npz round trip (atomic), positions from the attitude table, and
reproducibility for a seed."""
import os

import numpy as np
import pytest

from evstar import FormatError, sim


@pytest.fixture(scope="module")
def run():
    return sim.simulate(sim.paper_sinusoid(duration_s=0.4), seed=11)


def test_truth_npz_round_trip(run, tmp_path):
    path = tmp_path / "deep" / "truth.npz"
    sim.save_truth(path, run.truth)
    assert os.listdir(path.parent) == ["truth.npz"]          # no temporary file left behind
    back = sim.load_truth(path)
    t = run.truth
    assert back.labels.dtype == np.int32 and np.array_equal(back.labels, t.labels)
    for name in ("t_us", "quat_cw", "omega_cam", "star_xy", "hot_pixels", "imu_t_us", "gyro_bias",
                 "accel_bias", "star_flux"):
        assert np.array_equal(getattr(back, name), getattr(t, name)), name
    assert np.array_equal(back.stars.directions, t.stars.directions)
    assert back.camera == run.camera and back.meta["seed"] == 11
    probe = np.array([123_456, 345_678])
    assert np.array_equal(back.star_position(probe), t.star_position(probe))


def test_save_truth_replaces_an_existing_file_atomically(run, tmp_path):
    path = tmp_path / "truth.npz"
    path.write_bytes(b"old")
    sim.save_truth(path, run.truth)
    assert len(sim.load_truth(path).labels) == len(run.events)


def test_load_truth_errors(tmp_path):
    with pytest.raises(FormatError, match="no such file"):
        sim.load_truth(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(FormatError, match="missing"):
        sim.load_truth(tmp_path / "other.npz")
    (tmp_path / "cut.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(FormatError, match="not a readable truth"):
        sim.load_truth(tmp_path / "cut.npz")


def test_positions_between_table_samples_follow_the_motion(run):
    """Slerp of the 1 kHz attitude table agrees with the exact trajectory to 1e-3 px."""
    t_us = np.arange(0, 400_000, 997)
    exact = run.camera.project(run.scenario.trajectory.rotation(t_us * 1e-6) @ run.truth.stars.directions[0])
    assert np.abs(run.truth.star_position(t_us, star=0) - exact).max() < 1e-3
    assert np.abs(run.truth.star_xy[:, 0] - run.truth.star_position(run.truth.t_us, 0)).max() < 1e-9


def test_paper_sinusoid_swings_the_star_10_degrees_each_way_and_keeps_it_in_view():
    run = sim.simulate(sim.paper_sinusoid(sensor=sim.SensorSpec.ideal()), seed=0)
    x = run.truth.star_xy[:, 0, 0]
    swing = run.camera.fx * np.tan(np.radians(10))
    assert x.max() == pytest.approx(run.camera.cx + swing, abs=1e-3)   # at t = 0.25 s
    assert x.min() == pytest.approx(run.camera.cx - swing, abs=1e-3)   # at t = 0.75 s
    assert 0 <= x.min() and x.max() < run.camera.width
    assert x[np.searchsorted(run.truth.t_us, 250_000)] == pytest.approx(x.max())


def test_same_seed_same_run_and_another_seed_another():
    scn = sim.paper_preset(12.0, duration_s=0.2)
    a, b, c = (sim.simulate(scn, seed=s) for s in (5, 5, 6))
    assert a.events == b.events and a.imu == b.imu and np.array_equal(a.truth.labels, b.truth.labels)
    assert a.events != c.events and not np.array_equal(a.imu.gyro, c.imu.gyro)


def test_components_draw_from_independent_streams():
    """Changing the noise rate leaves the star's events and the IMU untouched."""
    scn = sim.paper_preset(12.0, duration_s=0.2)
    a = sim.simulate(scn, seed=5)
    b = sim.simulate(scn.replace(sensor=sim.SensorSpec(noise_hz=5.0)), seed=5)
    star_a, star_b = a.events[a.truth.labels >= 0], b.events[b.truth.labels >= 0]
    assert star_a == star_b and a.imu == b.imu
    assert (b.truth.labels == -1).sum() > 2 * (a.truth.labels == -1).sum()


def test_events_are_valid_and_time_sorted(run):
    ev = run.events
    assert np.all(np.diff(ev.t) >= 0)
    assert ev.t[0] >= 0 and ev.t[-1] < 400_000
    assert ev.x.max() < ev.width and ev.y.max() < ev.height
    assert len(run.truth.labels) == len(ev)
    assert set(np.unique(run.truth.labels)) <= {-2, -1, 0}
