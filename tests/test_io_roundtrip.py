"""Every writer round-trips through its reader; writes are atomic."""
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from evstar import Camera, Events, EvstarWarning, FormatError, Imu, io
from conftest import random_events


def _imu(n=50, seed=1):
    rng = np.random.default_rng(seed)
    return Imu(np.arange(n) * 1000, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 9.8)


@pytest.mark.parametrize("ext", ["csv", "npz", "h5", "aedat4"])
def test_events_round_trip(tmp_path, ext):
    ev = random_events(5000, 640, 480, seed=3)
    path = tmp_path / f"ev.{ext}"
    io.write(path, ev)
    back = io.read(path, sensor_size=(640, 480)).events if ext == "csv" else io.read(path).events
    assert back == ev


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.integers(0, 300), w=st.integers(1, 2000), h=st.integers(1, 2000), seed=st.integers(0, 99),
       ext=st.sampled_from(["csv", "npz", "h5", "aedat4"]))
def test_random_streams_round_trip(tmp_path, n, w, h, seed, ext):
    rng = np.random.default_rng(seed)
    ev = Events(np.sort(rng.integers(0, 2**40, n)), rng.integers(0, w, n), rng.integers(0, h, n),
                rng.integers(0, 2, n), w, h)
    path = tmp_path / f"r{seed}.{ext}"
    io.write(path, ev)
    assert io.read(path, sensor_size=(w, h)).events == ev if ext == "csv" else io.read(path).events == ev


@pytest.mark.parametrize("ext", ["npz", "h5"])
def test_imu_and_camera_round_trip(tmp_path, ext):
    ev, imu = random_events(100), _imu()
    imu = Imu(imu.t, imu.gyro, imu.accel, R_cam_imu=np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]]),
              time_offset_us=-123)
    cam = Camera(64, 48, 50.5, 51, 31.5, 23.5, k1=0.01)
    io.write(tmp_path / f"a.{ext}", ev, imu=imu, camera=cam)
    rec = io.read(tmp_path / f"a.{ext}")
    assert rec.events == ev and rec.imu == imu and rec.camera == cam


def test_aedat4_imu_round_trip_in_si_units(tmp_path):
    ev, imu = random_events(3000, seed=5), _imu(80)
    io.write(tmp_path / "a.aedat4", ev, imu=imu)
    rec = io.read(tmp_path / "a.aedat4")
    assert rec.events == ev
    np.testing.assert_array_equal(rec.imu.t, imu.t)
    # AEDAT4 stores float32 °/s and g
    np.testing.assert_allclose(rec.imu.gyro, imu.gyro, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(rec.imu.accel, imu.accel, rtol=1e-6, atol=1e-5)


def test_aedat4_is_readable_by_the_aedat_library(tmp_path):
    aedat = pytest.importorskip("aedat", reason="aedat is a test extra")
    ev = random_events(2000, seed=9)
    io.write(tmp_path / "a.aedat4", ev, imu=_imu())
    got = [p for p in aedat.Decoder(str(tmp_path / "a.aedat4")) if "events" in p]
    t = np.concatenate([p["events"]["t"] for p in got])
    np.testing.assert_array_equal(t, ev.t)


def test_imu_csv_and_camera_json_round_trip(tmp_path):
    imu = _imu()
    io.write_imu(tmp_path / "imu.csv", imu)
    assert io.read_imu(tmp_path / "imu.csv") == imu
    cam = Camera(346, 260, 200.0, 200.0, 172.5, 129.5)
    io.write_camera(tmp_path / "camera.json", cam)
    assert io.read_camera(tmp_path / "camera.json") == cam


def test_csv_warns_instead_of_dropping_imu(tmp_path):
    with pytest.warns(EvstarWarning, match="holds no IMU"):
        io.write(tmp_path / "a.csv", random_events(10), imu=_imu())


def test_failed_write_leaves_no_file(tmp_path):
    ev = Events([-5, 0], [0, 1], [0, 1], [1, 0], 4, 4)
    with pytest.raises(FormatError, match="before t=0"):
        io.write(tmp_path / "a.aedat4", ev)
    assert os.listdir(tmp_path) == []


def test_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    path = tmp_path / "a.h5"
    io.write(path, random_events(10))
    before = path.read_bytes()

    class Boom(Exception):
        pass

    def explode(*a, **k):
        raise Boom()
    monkeypatch.setattr("h5py.File.create_group", explode)
    with pytest.raises(Boom):
        io.write(path, random_events(20))
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["a.h5"]


@pytest.mark.parametrize("ext", ["csv", "npy", "h5"])
def test_windows_equal_whole_read(tmp_path, ext):
    ev = random_events(4000, seed=11, duration_us=1_000_000)
    path = tmp_path / f"w.{ext}"
    if ext == "npy":
        np.save(path, ev.to_structured())
    else:
        io.write(path, ev)
    parts = [w for _, w in io.windows(path, 70_000, sensor_size=(64, 48))]
    assert all(len(w) for w in parts)
    assert Events.concatenate(parts) == ev


@pytest.mark.parametrize("ext, counted", [("h5", True), ("npy", True), ("npz", False),
                                           ("csv", False), ("aedat4", False)])
def test_a_stream_knows_its_event_count_where_the_format_tells_it(tmp_path, ext, counted):
    """A streamed run's progress bar has a total where the file says how many events it
    holds without decoding them (HDF5, .npy), and none elsewhere."""
    ev = random_events(3000, seed=5)
    path = tmp_path / f"n.{ext}"
    if ext == "npy":
        np.save(path, ev.to_structured())
    else:
        io.write(path, ev)
    assert io.event_count(path) == (len(ev) if counted else None)


def test_written_files_get_the_usual_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        io.write(tmp_path / "a.npz", random_events(10))
    finally:
        os.umask(old)
    assert (tmp_path / "a.npz").stat().st_mode & 0o777 == 0o644
