import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import evstar
from evstar import DataError, Events, Imu, Camera
from conftest import random_events


def test_fields_are_contiguous_with_documented_dtypes():
    ev = Events([3, 1, 2][::-1][::-1], [0, 1, 2], [2, 1, 0], [1, 0, -1], 4, 3, sort=True)
    assert [a.dtype for a in (ev.t, ev.x, ev.y, ev.p)] == [np.int64, np.uint16, np.uint16, np.int8]
    assert all(a.flags.c_contiguous for a in (ev.t, ev.x, ev.y, ev.p))
    assert ev.t.tolist() == [1, 2, 3] and ev.x.tolist() == [1, 2, 0] and ev.p.tolist() == [0, 0, 1]


def test_unsorted_timestamps_are_an_error_unless_sort_requested():
    with pytest.raises(DataError, match="decrease at index 1"):
        Events([5, 4], [0, 0], [0, 0], [1, 1], 2, 2)


@pytest.mark.parametrize("field,x,y", [("x", 10, 0), ("y", 0, 5), ("x", -1, 0)])
def test_coordinates_outside_sensor_name_field_and_value(field, x, y):
    with pytest.raises(DataError, match=rf"'{field}' = {x if field == 'x' else y} at index 0"):
        Events([0], [x], [y], [1], 10, 5)


def test_bad_polarity_and_length_mismatch():
    with pytest.raises(DataError, match="'p'"):
        Events([0], [0], [0], [3], 2, 2)
    with pytest.raises(DataError, match="'x' has 2 entries"):
        Events([0], [0, 1], [0], [1], 2, 2)


def test_time_window_and_mask_keep_order():
    ev = random_events(500)
    w = ev.time_window(20_000, 40_000)
    assert np.all((w.t >= 20_000) & (w.t < 40_000))
    assert len(w) == np.count_nonzero((ev.t >= 20_000) & (ev.t < 40_000))
    m = ev.x > 30
    assert ev[m] == Events(ev.t[m], ev.x[m], ev.y[m], ev.p[m], 64, 48)
    assert ev.at_sorted(np.flatnonzero(m)) == ev[m] == ev[np.flatnonzero(m)]
    with pytest.raises(DataError, match="time order"):
        ev[np.flatnonzero(m)[::-1]]


def test_concatenate_requires_time_order_and_same_sensor():
    ev = random_events(100)
    a, b = ev[:40], ev[40:]
    assert Events.concatenate([a, b]) == ev
    with pytest.raises(DataError, match="time-sorted"):
        Events.concatenate([b, a])
    with pytest.raises(DataError, match="sensor sizes"):
        Events.concatenate([a, Events.empty(10, 10)])


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 10**12), st.integers(0, 639), st.integers(0, 479),
                          st.integers(0, 1)), max_size=50))
def test_structured_round_trip(rows):
    rows.sort(key=lambda r: r[0])
    t, x, y, p = (np.array(c, dtype=np.int64) for c in zip(*rows)) if rows else [np.zeros(0, int)] * 4
    ev = Events(t, x, y, p, 640, 480)
    s = ev.to_structured()
    assert set(s.dtype.names) == {"x", "y", "t", "p"}
    assert Events.from_structured(s, 640, 480) == ev


def test_imu_rejects_nan_and_bad_rotation():
    with pytest.raises(DataError, match="gyro.*sample 1"):
        Imu([0, 1], [[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(DataError, match="R_cam_imu"):
        Imu([0], [[0, 0, 0]], R_cam_imu=np.diag([1, 1, -1]))


def test_imu_camera_frame_applies_rotation_and_offset():
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    imu = Imu([0, 1000], [[1, 0, 0], [0, 2, 0]], R_cam_imu=R, time_offset_us=-50)
    np.testing.assert_allclose(imu.gyro_cam, [[0, 1, 0], [-2, 0, 0]])
    assert imu.t_cam.tolist() == [-50, 950]


def test_imu_coverage_warning():
    ev = random_events(10)
    with pytest.warns(evstar.EvstarWarning, match="IMU covers"):
        Imu([50_000, 60_000], np.zeros((2, 3))).warn_if_not_covering(ev)


def test_camera_validation_and_projection_round_trip():
    with pytest.raises(DataError, match="'fx'"):
        Camera(10, 10, "abc", 1, 0, 0)
    cam = Camera(640, 480, 500, 510, 320, 240, k1=-0.1, k2=0.01)
    uv = np.array([[10.0, 20.0], [600.5, 470.25], [320, 240]])
    np.testing.assert_allclose(cam.project(cam.unproject(uv, iterations=50)), uv, atol=1e-6)


@pytest.mark.parametrize("threshold", [1, 10**9])        # the helper thread, and without
def test_gather_takes_every_array_and_raises_a_bad_index(monkeypatch, threshold):
    from evstar import events as E

    monkeypatch.setattr(E, "PARALLEL_GATHER", threshold)
    rng = np.random.default_rng(2)
    arrays = [rng.integers(0, 1000, 5000).astype(d) for d in (np.int64, np.uint16, np.int8)]
    idx = np.sort(rng.choice(5000, 1200, replace=False))
    for got, a in zip(E.gather(arrays, idx), arrays):
        assert got.dtype == a.dtype and np.array_equal(got, a[idx])
    with pytest.raises(IndexError):
        E.gather(arrays, np.array([0, 5000]))
    ev = Events(np.arange(5000), arrays[1] % 64, arrays[1] % 32, arrays[2] > 0, 64, 32)
    sub = ev[rng.random(5000) < 0.3]
    assert len(sub) > 1000 and np.all(np.diff(sub.t) >= 0)
