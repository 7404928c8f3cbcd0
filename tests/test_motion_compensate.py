"""compensate(): modes none | imu | pf on a synthetic star field seen through a biased gyro."""
import math

import numpy as np
import pytest

from evstar import Camera, DataError, Events, Imu
from evstar.motion import ParticleFilter, StarObservations, compensate, hold_ends, warp_to_reference
from evstar_kernels.reference import so3

DEG = math.pi / 180
CAMERA = Camera.from_fov(320, 240, 20)
OMEGA = np.array([0.3, -1.0, 0.2]) / np.linalg.norm([0.3, -1.0, 0.2]) * 12 * DEG
BIAS = np.array([0.8, -0.6, 0.4]) * DEG  # ~1.1 °/s: large, so its effect within a frame shows
DURATION_US = 600_000
DT_US = 20_000


def truth(t_us):
    return so3.quat_exp(-np.outer(np.asarray(t_us, np.float64) * 1e-6, OMEGA))


@pytest.fixture(scope="module")
def scene():
    """Five stars drifting across the image; exact (float) event positions; 1 kHz biased gyro;
    centroids every 10 ms with 0.05 px noise."""
    rng = np.random.default_rng(4)
    start = np.array([[60, 60], [250, 70], [150, 120], [80, 190], [230, 180.0]])
    world = so3.quat_rotate(so3.quat_identity(), CAMERA.unproject(start))
    t = np.arange(0, DURATION_US, 25)
    paths = [CAMERA.project(so3.quat_rotate(truth(t), d)) for d in world]
    xy = np.concatenate(paths)
    tt = np.tile(t, len(world))
    order = np.argsort(tt, kind="stable")
    tt, xy = tt[order], xy[order]
    on = (xy[:, 0] > -0.5) & (xy[:, 0] < 319.5) & (xy[:, 1] > -0.5) & (xy[:, 1] < 239.5)
    t_imu = np.arange(0, DURATION_US + 1, 1000)
    gyro = OMEGA + BIAS + rng.normal(size=(len(t_imu), 3)) * 0.005 * DEG * math.sqrt(1000)
    t_obs = np.arange(0, DURATION_US, 10_000)
    uv = np.stack([CAMERA.project(so3.quat_rotate(truth(t_obs), d)) for d in world], 1)
    k = np.broadcast_to(np.arange(len(world)), uv.shape[:2])
    vis = (uv[..., 0] > 3) & (uv[..., 0] < 316) & (uv[..., 1] > 3) & (uv[..., 1] < 236)
    obs = StarObservations(np.broadcast_to(t_obs[:, None], k.shape)[vis], k[vis],
                           uv[vis][:, 0] + rng.normal(size=vis.sum()) * 0.05,
                           uv[vis][:, 1] + rng.normal(size=vis.sum()) * 0.05)
    events = Events(tt[on], np.rint(xy[on, 0]), np.rint(xy[on, 1]), np.ones(on.sum()), 320, 240)
    return dict(events=events, xy=xy[on], imu=Imu(t_imu, gyro), obs=obs)


def relative_error_px(comp, events):
    """Error of the compensation's rotation t -> t_ref against the truth, in pixels (max per event)."""
    q = comp.attitude.relative(comp.t_ref_us, events.t, extrapolate_us=DT_US)
    q_true = so3.quat_mul(truth(comp.t_ref_us), so3.quat_conj(truth(events.t)))
    return np.linalg.norm(so3.quat_log(so3.quat_mul(q, so3.quat_conj(q_true))), axis=1) * CAMERA.fx


def test_none_keeps_the_coordinates(scene):
    ev = scene["events"]
    comp = compensate(ev, dt_us=DT_US, mode="none")
    np.testing.assert_array_equal(comp.xi, ev.x)
    np.testing.assert_array_equal(comp.yi, ev.y)
    assert comp.inside.all() and comp.attitude is None
    out, idx = comp.events()
    np.testing.assert_array_equal(out.x, ev.x)
    np.testing.assert_array_equal(idx, np.arange(len(ev)))


def test_none_makes_on_demand_what_the_other_modes_make_at_once(scene):
    """Mode 'none' builds its per-event arrays when read: the same as a Compensation built
    from the events' own pixels."""
    from evstar.motion import Compensation
    from evstar.motion.warping import frame_reference_times

    ev = scene["events"]
    lazy = compensate(ev, dt_us=DT_US, mode="none", t0_us=int(ev.t[0]) - 1234)
    frame, t_ref = frame_reference_times(ev.t, DT_US, int(ev.t[0]) - 1234)
    eager = Compensation(ev, "none", ev.x, ev.y, frame, t_ref)
    for name in ("x", "y", "xi", "yi", "inside", "frame", "t_ref_us"):
        a, b = getattr(lazy, name), getattr(eager, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    idx = np.flatnonzero(np.arange(len(ev)) % 3 == 0)
    np.testing.assert_array_equal(lazy.coordinates(idx), eager.coordinates(idx))
    assert len(lazy) == len(ev) and repr(lazy) == repr(eager)
    with pytest.raises(ValueError, match="dt_us"):
        compensate(ev, dt_us=0, mode="none")


def test_pf_removes_the_bias_that_imu_mode_keeps(scene):
    ev, imu = scene["events"], scene["imu"]
    imu_mode = compensate(ev, imu, CAMERA, DT_US, mode="imu")
    pf_mode = compensate(ev, imu, CAMERA, DT_US, mode="pf", observations=scene["obs"],
                         particle_filter=ParticleFilter(1024, seed=0))
    late = ev.t >= 300_000  # once the filter has converged
    e_imu, e_pf = relative_error_px(imu_mode, ev)[late], relative_error_px(pf_mode, ev)[late]
    assert e_imu.max() > 0.15                      # 1.1 °/s over up to 10 ms at 57 px/°
    assert e_pf.max() < 0.3 * e_imu.max() and e_pf.mean() < 0.3 * e_imu.mean()
    # on the exact (float) star positions the pf warp lands within 0.05 px
    xy = scene["xy"]
    xw, yw = warp_to_reference(ev.t, xy[:, 0], xy[:, 1], pf_mode.t_ref_us, pf_mode.attitude, CAMERA,
                               extrapolate_us=DT_US)
    xi, yi = warp_to_reference(ev.t, xy[:, 0], xy[:, 1], imu_mode.t_ref_us, imu_mode.attitude,
                               CAMERA, extrapolate_us=DT_US)
    truth_track = _truth_track()
    xt, yt = warp_to_reference(ev.t, xy[:, 0], xy[:, 1], pf_mode.t_ref_us, truth_track, CAMERA,
                               extrapolate_us=DT_US)
    assert np.hypot(xw - xt, yw - yt)[late].max() < 0.05 < np.hypot(xi - xt, yi - yt)[late].max()
    # a stored filter result gives the same warp without observations
    again = compensate(ev, imu, CAMERA, DT_US, mode="pf", filter_result=pf_mode.filter_result)
    np.testing.assert_array_equal(again.x, pf_mode.x)
    # offline (the final bias everywhere) also fixes the frames before the filter converged
    offline = compensate(ev, imu, CAMERA, DT_US, mode="pf", filter_result=pf_mode.filter_result,
                         causal=False)
    early = ev.t < 100_000
    e_off, e_on = relative_error_px(offline, ev)[early], relative_error_px(pf_mode, ev)[early]
    assert e_off.max() < 0.05 < e_on.max()


def _truth_track():
    from evstar.motion import AttitudeTrack

    t = np.arange(-DT_US, DURATION_US + DT_US + 1, 1000)
    return AttitudeTrack(t, truth(t))


def test_rounded_coordinates_and_events_leaving_the_sensor(scene):
    ev, imu = scene["events"], scene["imu"]
    comp = compensate(ev, imu, CAMERA, DT_US, mode="imu")
    np.testing.assert_array_equal(comp.xi, np.floor(comp.x + 0.5))
    np.testing.assert_array_equal(comp.yi, np.floor(comp.y + 0.5))
    assert not comp.inside.all()  # stars near the border are warped off the sensor
    out, idx = comp.events()
    assert len(out) == comp.inside.sum() and np.all(np.diff(out.t) >= 0)
    np.testing.assert_array_equal(out.x, comp.xi[idx])
    np.testing.assert_array_equal(out.t, ev.t[idx])


def test_input_errors(scene):
    ev, imu = scene["events"], scene["imu"]
    with pytest.raises(ValueError, match="mode"):
        compensate(ev, imu, CAMERA, DT_US, mode="dv")
    with pytest.raises(ValueError, match="'imu' needs an IMU"):
        compensate(ev, None, CAMERA, DT_US, mode="imu")
    with pytest.raises(ValueError, match="'pf' needs a camera"):
        compensate(ev, imu, None, DT_US, mode="pf")
    with pytest.raises(ValueError, match="observations"):
        compensate(ev, imu, CAMERA, DT_US, mode="pf")
    short = Imu(imu.t[:200], imu.gyro[:200])
    with pytest.raises(DataError, match=r"IMU ends \d+ µs before the last event, more than "
                                        "extrapolate_us = 5000 µs"):
        compensate(ev, short, CAMERA, DT_US, mode="imu")


@pytest.mark.parametrize("backend", ["reference", "warp"])
def test_empty_stream_and_backends(scene, backend):
    ev, imu = scene["events"], scene["imu"]
    empty = compensate(ev[np.zeros(len(ev), bool)], imu, CAMERA, DT_US, mode="imu", backend=backend)
    assert len(empty) == 0 and len(empty.events()[0]) == 0
    part = ev[:5000]
    a = compensate(part, imu, CAMERA, DT_US, mode="imu", backend=backend)
    b = compensate(part, imu, CAMERA, DT_US, mode="imu", backend="reference")
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)


def test_imu_end_samples_are_held_up_to_extrapolate_us():
    imu = Imu([1000, 2000, 3000], [[1, 0, 0], [2, 0, 0], [3, 0, 0]], [[0, 0, 9], [0, 0, 8], [0, 0, 7]],
              time_offset_us=100)
    held = hold_ends(imu, 600, 4100, extrapolate_us=1000)
    np.testing.assert_array_equal(held.t_cam, [600, 1100, 2100, 3100, 4100])
    np.testing.assert_array_equal(held.gyro[:, 0], [1, 1, 2, 3, 3])  # the nearest sample's rate
    np.testing.assert_array_equal(held.accel[:, 2], [9, 9, 8, 7, 7])
    assert hold_ends(imu, 1100, 3100, 0) is imu  # covered: unchanged
    with pytest.raises(DataError, match="IMU starts 1001 µs after the first event, more than "
                                        "extrapolate_us = 1000 µs"):
        hold_ends(imu, 99, 3100, extrapolate_us=1000)


def test_real_davis_imu_starting_after_the_events_compensates(real_dir):
    """emlb_demo-01: the IMU starts 691 µs after the first event and ends 856 µs before the last."""
    from evstar import Config, Pipeline, io

    rec = io.read(real_dir / "emlb_demo-01.aedat4")
    camera = Camera.from_fov(rec.events.width, rec.events.height, 70.0)
    comp = compensate(rec.events, rec.imu, camera, 10_000, "imu")
    assert np.all(np.isfinite(comp.x)) and comp.inside.mean() > 0.99
    assert 0 < np.abs(comp.x - rec.events.x).max() < 1.0  # a slow hand-held rotation
    with pytest.raises(DataError, match="IMU starts 691 µs after the first event"):
        compensate(rec.events, rec.imu, camera, 10_000, "imu", extrapolate_us=500)
    cfg = Config().replace(**{"motion.compensate": "imu"})
    result = Pipeline(cfg).run(rec.events, rec.imu, camera)
    assert result.compensation.mode == "imu" and result.metrics["events"] == len(rec.events)
