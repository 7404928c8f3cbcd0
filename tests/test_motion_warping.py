"""Event warping: a star moving under a known rotation lands on its reference-time position."""
import math

import numpy as np
import pytest

from evstar import Camera, Events, Imu
from evstar.motion import AttitudeTrack, frame_reference_times, rotate_pixels, warp_to_reference
from evstar_kernels.reference import so3

DEG = math.pi / 180
OMEGA = np.array([0.2, -0.3, 0.1])  # rad/s, ~21 °/s
Q0 = so3.quat_exp([0.3, -0.2, 0.5])
PINHOLE = Camera.from_fov(640, 480, 30)
DISTORTED = Camera(640, 480, PINHOLE.fx, PINHOLE.fy, PINHOLE.cx, PINHOLE.cy, k1=-0.12, k2=0.03)


def attitude(t_us):
    return so3.quat_mul(so3.quat_exp(-np.outer(np.asarray(t_us, np.float64) * 1e-6, OMEGA)), Q0)


def star_path(camera, t_us, start_px=(300.0, 200.0)):
    """Exact image positions of one star (a fixed world direction) at times t_us."""
    ray = camera.unproject(np.array([start_px]))
    world = so3.quat_rotate(so3.quat_conj(Q0), ray[0])
    return camera.project(so3.quat_rotate(attitude(t_us), world))


def imu_track(rate_hz=1000, duration_us=120_000, offset_us=0):
    t = np.arange(-offset_us, duration_us + 1, int(1e6 / rate_hz))
    imu = Imu(t, np.tile(OMEGA, (len(t), 1)), time_offset_us=offset_us)
    return AttitudeTrack.from_imu(imu)


def test_frame_reference_times():
    frame, t_ref = frame_reference_times([100, 5099, 5100, 25_000], 5000)
    assert frame.tolist() == [0, 0, 1, 4]
    assert t_ref.tolist() == [2600, 2600, 7600, 22600]
    frame, t_ref = frame_reference_times([0, 9999, 10_000], 10_000, t0_us=-5000, reference="start")
    assert frame.tolist() == [0, 1, 1] and t_ref.tolist() == [-5000, 5000, 5000]
    with pytest.raises(ValueError, match="dt_us"):
        frame_reference_times([0], 0)
    with pytest.raises(ValueError, match="reference"):
        frame_reference_times([0], 10, reference="end")


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_star_under_constant_rotation_lands_on_reference_position(camera):
    rng = np.random.default_rng(0)
    t = np.sort(rng.integers(0, 100_000, 4000))
    xy = star_path(camera, t)
    _, t_ref = frame_reference_times(t, 10_000, t0_us=0)
    xw, yw = warp_to_reference(t, xy[:, 0], xy[:, 1], t_ref, imu_track(), camera)
    target = star_path(camera, t_ref)
    err = np.hypot(xw - target[:, 0], yw - target[:, 1])
    assert err.max() < 0.05
    spread = np.hypot(xy[:, 0] - target[:, 0], xy[:, 1] - target[:, 1])
    assert spread.max() > 1.5  # unwarped, the star smears over ±2 px within a frame


def test_imu_clock_offset_and_rate_do_not_matter_when_aligned():
    t = np.arange(0, 100_000, 37)
    xy = star_path(PINHOLE, t)
    _, t_ref = frame_reference_times(t, 20_000, t0_us=0)
    target = star_path(PINHOLE, t_ref)
    for track in (imu_track(rate_hz=200, offset_us=3000), imu_track(rate_hz=1000, offset_us=-700)):
        xw, yw = warp_to_reference(t, xy[:, 0], xy[:, 1], t_ref, track, PINHOLE)
        assert np.hypot(xw - target[:, 0], yw - target[:, 1]).max() < 0.05


def test_rotate_pixels_identity_and_inverse():
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 639, 500), rng.uniform(0, 479, 500)
    for cam in (PINHOLE, DISTORTED):
        xi, yi = rotate_pixels(x, y, so3.quat_identity(500), cam)
        np.testing.assert_allclose(np.c_[xi, yi], np.c_[x, y], atol=1e-6)
        q = so3.quat_exp(np.tile([0.01, -0.02, 0.005], (500, 1)))
        xr, yr = rotate_pixels(*rotate_pixels(x, y, q, cam), so3.quat_conj(q), cam)
        np.testing.assert_allclose(np.c_[xr, yr], np.c_[x, y], atol=1e-6)


def test_a_strongly_distorted_corner_warps_onto_itself_within_a_thousandth_of_a_pixel():
    # the kernels' fixed-point inversion: 5 steps were 0.03 px off here
    cam = Camera(346, 260, 300.0, 300.0, 172.5, 129.5, k1=-0.3, k2=0.1)
    x, y = np.array([0.0, 345.0, 0.0, 345.0]), np.array([0.0, 0.0, 259.0, 259.0])
    xi, yi = rotate_pixels(x, y, so3.quat_identity(4), cam)
    assert np.hypot(xi - x, yi - y).max() < 1e-3


def test_rays_turned_behind_the_camera_are_nan():
    q = so3.quat_exp(np.array([[0.0, math.pi * 0.9, 0.0]]))
    x, y = rotate_pixels(np.array([320.0]), np.array([240.0]), q, PINHOLE)
    assert np.isnan(x[0]) and np.isnan(y[0])


def test_integer_events_warp_within_rounding_of_the_reference_position():
    from evstar.motion import compensate

    t = np.arange(0, 100_000, 20)
    xy = star_path(PINHOLE, t)
    ev = Events(t, np.rint(xy[:, 0]), np.rint(xy[:, 1]), np.ones(len(t)), 640, 480)
    imu = Imu(np.arange(0, 100_001, 1000), np.tile(OMEGA, (101, 1)))
    comp = compensate(ev, imu, PINHOLE, dt_us=10_000, mode="imu")
    target = star_path(PINHOLE, comp.t_ref_us)
    err = np.hypot(comp.x - target[:, 0], comp.y - target[:, 1])
    assert err.max() < 0.5 * math.sqrt(2) + 0.01  # only the input's pixel rounding remains
    none = compensate(ev, None, None, dt_us=10_000, mode="none")
    smear = np.hypot(none.x - target[:, 0], none.y - target[:, 1])
    assert smear.max() > 2.0 and smear.mean() > 2 * err.mean()


@pytest.mark.parametrize("backend", ["warp", "taichi"])
@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_warp_kernel_agrees_with_numpy(camera, backend):
    rng = np.random.default_rng(7)
    t = np.sort(rng.integers(-3000, 123_000, 20_000))  # a little beyond the track at both ends
    x, y = rng.uniform(0, 639, len(t)), rng.uniform(0, 479, len(t))
    _, t_ref = frame_reference_times(t, 10_000, t0_us=-5000)
    track = imu_track(rate_hz=800, offset_us=1000)
    kw = dict(extrapolate_us=10_000)
    xn, yn = warp_to_reference(t, x, y, t_ref, track, camera, backend="reference", **kw)
    xw, yw = warp_to_reference(t, x, y, t_ref, track, camera, backend=backend, device="cpu", **kw)
    np.testing.assert_allclose(xw, xn, atol=1e-9)
    np.testing.assert_allclose(yw, yn, atol=1e-9)
    assert np.abs(xn - x).max() > 1.0  # it did move the events
    # unsorted reference times take the general path
    perm = rng.permutation(len(t))
    xp, _ = warp_to_reference(t[perm], x[perm], y[perm], t_ref[perm], track, camera,
                              backend=backend, **kw)
    np.testing.assert_allclose(xp, xw[perm], atol=1e-9)
    # event coordinates as they are stored (uint16) warp like their float values
    xi, yi = np.round(x).astype(np.uint16), np.round(y).astype(np.uint16)
    xu, _ = warp_to_reference(t, xi, yi, t_ref, track, camera, backend=backend, **kw)
    xf, _ = warp_to_reference(t, xi.astype(float), yi.astype(float), t_ref, track, camera,
                              backend="reference", **kw)
    np.testing.assert_allclose(xu, xf, atol=1e-9)


@pytest.mark.parametrize("backend", ["warp", "taichi"])
def test_warp_kernel_marks_rays_behind_the_camera(backend):
    t = np.array([0.0, 50_000.0])
    track = AttitudeTrack(np.array([0.0, 100_000.0]),
                          np.stack([so3.quat_identity(), so3.quat_exp([0.0, 3.0, 0.0])]))
    x, y = warp_to_reference(t, np.array([320.0, 320.0]), np.array([240.0, 240.0]),
                             np.array([100_000.0, 100_000.0]), track, PINHOLE, backend=backend)
    assert np.isnan(x[0]) and np.isfinite(x[1])


@pytest.mark.parametrize("backend", ["reference", "warp", "taichi"])
def test_warped_pixels_are_the_rounded_coordinates(backend):
    """With a sensor, every backend also gives the warped events' pixels: exactly
    reference.pixels.rounded_pixels of its own coordinates (off the sensor, behind the
    camera: outside, pixel 0)."""
    from evstar.motion.warping import frame_references, warp_indexed
    from evstar_kernels.reference.pixels import rounded_pixels

    rng = np.random.default_rng(11)
    t = np.sort(rng.integers(0, 120_000, 20_000))
    x, y = rng.uniform(-2, 641, len(t)), rng.uniform(-2, 481, len(t))
    turn = AttitudeTrack(np.array([0.0, 120_000.0]),
                         np.stack([so3.quat_identity(), so3.quat_exp([0.0, 3.0, 0.0])]))
    for track, dt in ((imu_track(), 10_000), (turn, 240_000)):  # turn: rays go behind
        xy, px, py, inside = warp_indexed(t, x, y, *frame_references(t, dt), track, PINHOLE, dt,
                                          sensor=(640, 480), backend=backend)
        np.testing.assert_array_equal(xy, np.column_stack(warp_to_reference(
            t, x, y, frame_reference_times(t, dt)[1], track, PINHOLE, dt, backend=backend)))
        xw = xy[:, 0]
        for got, want in zip((px, py, inside), rounded_pixels(xw, xy[:, 1], 640, 480)):
            assert got.dtype == want.dtype and np.array_equal(got, want)
        assert 0 < inside.sum() < len(t)
    assert np.isnan(xw).any()


def test_warping_input_errors():
    track = imu_track()
    with pytest.raises(ValueError, match="backend"):
        warp_to_reference([0], [1.0], [1.0], [0.0], track, PINHOLE, backend="cupy")
    with pytest.raises(ValueError, match="CPU only"):
        warp_to_reference([0], [1.0], [1.0], [0.0], track, PINHOLE, device="cuda")
    from evstar import DataError
    with pytest.raises(DataError, match="covers 0..120000"):
        warp_to_reference([0, 130_000], [1.0, 1.0], [1.0, 1.0], [0.0, 0.0], track, PINHOLE)


def test_taichi_warp_device_data_path(monkeypatch):
    """The CUDA data path (Taichi ndarrays, copies in and out, launches cut into pieces)
    run on the CPU gives the numpy result."""
    from evstar_kernels.taichi import launch

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", True)
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 777)
    rng = np.random.default_rng(3)
    t = np.sort(rng.integers(0, 120_000, 3000))
    x, y = rng.uniform(0, 639, len(t)), rng.uniform(0, 479, len(t))
    _, t_ref = frame_reference_times(t, 10_000)
    track = imu_track()
    xn, yn = warp_to_reference(t, x, y, t_ref, track, DISTORTED, backend="reference")
    xt, yt = warp_to_reference(t, x, y, t_ref, track, DISTORTED, backend="taichi")
    np.testing.assert_allclose(xt, xn, atol=1e-9)
    np.testing.assert_allclose(yt, yn, atol=1e-9)
    from evstar.motion.warping import frame_references, warp_indexed
    from evstar_kernels.reference.pixels import rounded_pixels

    out = warp_indexed(t, x, y, *frame_references(t, 10_000), track, DISTORTED, sensor=(600, 400),
                       backend="taichi")
    np.testing.assert_array_equal(out[0], np.column_stack([xt, yt]))
    for got, want in zip(out[1:], rounded_pixels(xt, yt, 600, 400)):
        np.testing.assert_array_equal(got, want)
