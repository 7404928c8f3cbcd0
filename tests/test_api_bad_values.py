"""Bad values given to Events, Imu and Camera raise evstar's own errors naming the argument
(found by fuzzing the API: raw IndexError / TypeError / numpy warnings, or silent wrong results)."""
import re
import warnings

import numpy as np
import pytest

from evstar import Camera, DataError, Events, EvstarError, Imu, ParameterError, ParameterTypeError
from conftest import random_events


@pytest.fixture
def ev():
    return random_events(50)


def test_negative_slice_step_is_refused_positive_keeps_order(ev):
    with pytest.raises(ParameterError, match="negative step"):
        ev[::-1]
    with pytest.raises(ParameterError, match="step 0"):
        ev[::0]
    with pytest.raises(ParameterTypeError, match="slice"):
        ev[0.5:2]
    every_third = ev[::3]
    assert np.all(np.diff(every_third.t) >= 0) and np.array_equal(every_third.x, ev.x[::3])
    assert np.array_equal(ev[5:1:1].t, ev.t[5:1])                    # empty, not an error


@pytest.mark.parametrize("index, error, words", [
    (np.array([True, False]), ParameterError, "boolean index has 2 entries for 50"),
    ([0, 50], ParameterError, "index 50 is out of bounds"),
    ([-51], ParameterError, "out of bounds"),
    (np.array([0.0, 1.0]), ParameterTypeError, "dtype float64"),
    (np.array([[0, 1]]), ParameterTypeError, r"shape \(1, 2\)"),
    ("a", ParameterTypeError, "got 'a'"),
    (None, ParameterTypeError, "got None"),
    ([[0], [1, 2]], ParameterTypeError, "integer index array"),
    (3, ParameterTypeError, "slice or mask"),
])
def test_bad_indices_name_the_index(ev, index, error, words):
    with pytest.raises(error, match="Events") as info:
        ev[index]
    assert info.match(words)


def test_empty_and_integer_index_arrays(ev):
    assert len(ev[[]]) == 0 and ev[[]].sensor_size == ev.sensor_size
    assert ev[np.array([1, 4], np.uint32)] == ev[1:5:3]
    assert ev[[-1]].t.tolist() == [ev.t[-1]]


def test_concatenate_and_from_structured_refuse_non_events(ev):
    with pytest.raises(ParameterTypeError, match=r"'parts'\[1\] is a list"):
        Events.concatenate([ev, [1, 2]])
    with pytest.raises(ParameterTypeError, match="'parts' must be a sequence of Events, got NoneType"):
        Events.concatenate(None)
    with pytest.raises(ParameterTypeError, match="'arr' must be a numpy structured array.*got list"):
        Events.from_structured([1, 2], 10, 10)


def test_imu_times_are_checked_like_event_times():
    with pytest.raises(DataError, match="IMU field 't' holds a non-integer value 0.4"):
        Imu([0.4, 0.9, 1.6], np.zeros((3, 3)))
    with pytest.raises(DataError, match="IMU field 't' is not an array"):
        Imu([[0], [1, 2]], np.zeros((2, 3)))
    with pytest.raises(DataError, match="IMU field 't' holds non-finite"):
        Imu([0.0, np.nan], np.zeros((2, 3)))
    assert Imu([0.0, 2.0], np.zeros((2, 3))).t.tolist() == [0, 2]    # whole floats stay valid


@pytest.mark.parametrize("offset", [1.7, "5", None, np.nan, [3], True])
def test_imu_time_offset_must_be_an_integer(offset):
    with pytest.raises(DataError, match=re.escape(f"time_offset_us must be an integer, got {offset!r}")):
        Imu([0], np.zeros((1, 3)), time_offset_us=offset)


def test_imu_time_offset_whole_values_accepted():
    assert Imu([0], np.zeros((1, 3)), time_offset_us=5.0).time_offset_us == 5
    assert Imu([0], np.zeros((1, 3)), time_offset_us=np.int64(-7)).t_cam.tolist() == [-7]


@pytest.mark.parametrize("field", ["gyro", "accel"])
@pytest.mark.parametrize("values", [np.zeros((2, 3)) + 1j, np.full((2, 3), "1")])
def test_imu_refuses_non_real_samples_without_a_numpy_warning(field, values):
    args = {"gyro": np.zeros((2, 3)), "accel": None, field: values}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DataError, match=f"IMU field '{field}' must hold real numbers"):
            Imu([0, 1], args["gyro"], args["accel"])


@pytest.mark.parametrize("width", ["abc", None, np.nan, np.inf, [10], 10.5, 0, True])
def test_camera_width_must_be_a_positive_integer(width):
    with pytest.raises(DataError, match=r"camera field 'width' must be a positive integer, got"):
        Camera(width, 10, 1.0, 1.0, 0, 0)


@pytest.mark.parametrize("field,value", [("cx", 1e9), ("cy", -300.0)])
def test_camera_principal_point_sensors_away_is_a_data_error(field, value):
    ok = dict(width=320, height=240, fx=300.0, fy=300.0, cx=160.0, cy=120.0)
    Camera(**{**ok, "cx": -100.0, "cy": 400.0})        # decentred, off the sensor: accepted
    with pytest.raises(DataError, match=re.escape(f"{field}={value:g}")):
        Camera(**{**ok, field: value})


def test_camera_distortion_beyond_any_lens_is_a_data_error():
    ok = dict(width=320, height=240, fx=300.0, fy=300.0, cx=160.0, cy=120.0)
    Camera(**ok, k1=-0.3, k2=0.1)                      # a wide-angle lens: accepted
    with pytest.raises(DataError, match="k1=1e\\+06.*scales"):
        Camera(**ok, k1=1e6)


def test_camera_focal_length_beyond_float_range():
    with pytest.raises(DataError, match="camera field 'fx' must be a number"):
        Camera(10, 10, 10 ** 400, 1.0, 0, 0)


@pytest.mark.parametrize("fov, error", [(0, ParameterError), (-5, ParameterError),
                                        (180, ParameterError), (np.nan, ParameterError),
                                        ("a", ParameterTypeError), (None, ParameterTypeError)])
def test_from_fov_needs_an_open_field_of_view(fov, error):
    with pytest.raises(error, match="hfov_deg"):
        Camera.from_fov(10, 10, fov)


def test_from_fov_checks_width_and_keeps_valid_fields():
    with pytest.raises(DataError, match="'width'"):
        Camera.from_fov("a", 10, 30)
    wide = Camera.from_fov(640, 480, 179)
    assert wide.fx == pytest.approx(320 / np.tan(np.radians(89.5)))


def test_project_one_direction_and_rays_behind_the_camera():
    cam = Camera(640, 480, 500, 510, 320, 240, k1=-0.1)
    one = cam.project([0.1, -0.2, 1.0])
    assert one.shape == (2,) and np.allclose(one, cam.project([[0.1, -0.2, 1.0]])[0])
    assert cam.unproject(one).shape == (3,)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        uv = cam.project([[0, 0, 0], [0.1, 0, -1], [0, 0, 1]])
    assert np.isnan(uv[:2]).all() and uv[2].tolist() == [320, 240]


@pytest.mark.parametrize("dirs", [[[0, 1]], [[[0, 0, 1]]], [0, 1], [[1j, 0, 1]], [["a", "b", "c"]]])
def test_project_refuses_other_shapes_and_dtypes(dirs):
    with pytest.raises(DataError, match="'dirs'") as info:
        Camera(10, 10, 1, 1, 0, 0).project(dirs)
    assert isinstance(info.value, EvstarError)
