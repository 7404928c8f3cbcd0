"""Lost-in-space from a window's pooled events (evstar.attitude.identify_events): the
window-adaptive detection finds faint stars and not noise or hot pixels, a slow rotation
mostly about the boresight that no frame identifies is identified from 50 ms pooled, with
and without the gyro, and a field without stars gives no fix."""
import math

import numpy as np
import pytest

from evstar import Events, ParameterError, sim
from evstar.attitude import Solver, catalog, identify, identify_events
from evstar.attitude.acquire import detect
from evstar.errors import EvstarError

CAM = sim.camera_preset("davis346", 16.0)


@pytest.fixture(scope="module")
def solver(tmp_path_factory):
    return Solver.for_camera(CAM, cache_dir=tmp_path_factory.mktemp("attitude-cache"))


def noise(rng, p=0.08):
    """Pixels with one event each, a fraction p of the sensor (a davis346's background over
    50 ms)."""
    on = np.flatnonzero(rng.random(CAM.width * CAM.height) < p)
    return on % CAM.width, on // CAM.width


def test_detect_finds_faint_stars_in_noise_and_not_a_hot_pixel():
    rng = np.random.default_rng(1)
    x, y = noise(rng)
    stars = rng.uniform([10, 10], [CAM.width - 10, CAM.height - 10], (12, 2))
    xs, ys = [x], [y]
    for sx, sy in stars:      # 12 events over the star's core (some pixels twice)
        xs.append(np.rint(sx + rng.normal(0, 0.9, 12)).astype(int))
        ys.append(np.rint(sy + rng.normal(0, 0.9, 12)).astype(int))
    xs.append(np.full(200, 50)), ys.append(np.full(200, 60))          # a hot pixel
    xy, weight = detect(np.concatenate(xs), np.concatenate(ys), CAM.width, CAM.height, 1e-4)
    d = np.hypot(*(xy[:, None] - stars[None]).transpose(2, 0, 1))
    assert (d.min(axis=0) < 1.0).mean() >= 0.8          # most stars found, close to the truth
    assert (d.min(axis=1) >= 2.0).sum() <= 3             # few chance candidates (~9 expected)
    assert not np.any(np.hypot(*(xy - [50, 60]).T) < 1.5)   # the hot pixel counts once
    assert np.all(np.diff(weight) <= 0)                  # brightest first
    # noise alone at the strictest alpha: ~0.1 chance candidates expected
    assert len(detect(*noise(rng), CAM.width, CAM.height, 1e-6)[0]) <= 2
    assert len(detect(np.zeros(0, int), np.zeros(0, int), CAM.width, CAM.height, 1e-3)[0]) == 0


def slow_roll(seed=3):
    """1 °/s about an axis 24° from the boresight: 0.4 °/s across it — the stars move
    0.3 px in 50 ms, and the pipeline's per-frame detection sees too few of them."""
    axis = np.array([math.sin(math.radians(24)), 0.0, math.cos(math.radians(24))])
    motion = sim.ConstantRate(1.0, axis=axis, R0=sim.attitude_from_radec(83.8, -5.4, 30.0))
    stars = sim.hipparcos_field_along(CAM, motion, 0.05, mag_limit=7.0)
    return sim.simulate(sim.Scenario(CAM, stars, motion, 0.05), seed=seed)


@pytest.mark.parametrize("with_imu", [False, True])
def test_a_slow_roll_is_identified_from_its_pooled_events(solver, with_imu):
    run = slow_roll()
    fix, xy = identify_events(run.events, CAM, imu=run.imu if with_imu else None, solver=solver)
    assert fix.ok and fix.n_matches >= 6
    t0 = int(run.events.t[0])
    assert abs(fix.t_us - (t0 + int(run.events.t[-1]) + 1) // 2) <= 1      # the window's mid-time
    R_cw = run.truth.rotation_at([fix.t_us])[0]
    named = CAM.project(catalog.directions(fix.hip) @ R_cw.T)
    assert np.mean(np.hypot(*(named - xy[fix.centroid_index]).T) <= 3) >= 0.8
    assert math.degrees(math.acos(np.clip((np.trace(fix.R_icrs_cam @ R_cw) - 1) / 2, -1, 1))) < 0.5


def test_the_pooled_warp_reads_only_the_imu_around_its_window(solver):
    """identify_events integrates the samples around its window, not the whole record: the
    same warped pixels, so the same candidates, as compensating with every sample."""
    from evstar.motion import compensate

    motion = sim.Sinusoid(10.0, 1.0, R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(CAM, motion, 0.3, mag_limit=6.0)
    run = sim.simulate(sim.Scenario(CAM, stars, motion, 0.3), seed=2)
    t0, t1 = 180_000, 230_000                     # the rate changes across the window
    near = run.imu.around(t0, t1)
    assert len(near) < len(run.imu) / 4
    assert near.t_cam[0] <= t0 < near.t_cam[1] and near.t_cam[-2] < t1 <= near.t_cam[-1]
    full = compensate(run.events.time_window(t0, t1), run.imu, CAM, dt_us=t1 - t0, t0_us=t0)
    for alpha in solver.settings["pooled_alphas"]:         # identify_events, every sample
        expected, weight = detect(full.xi[full.inside], full.yi[full.inside], CAM.width,
                                  CAM.height, alpha)
        before = identify(expected, CAM, (t0 + t1) // 2, solver=solver, weight=weight)
        if before.ok:
            break
    fix, xy = identify_events(run.events, CAM, t0, t1, imu=run.imu, solver=solver)
    assert fix.ok and before.ok
    np.testing.assert_allclose(xy, expected, atol=1e-9)
    assert np.array_equal(fix.hip, before.hip)
    np.testing.assert_allclose(fix.q_icrs_cam, before.q_icrs_cam, atol=1e-12)


def test_the_slow_roll_needs_the_looser_alphas(solver, tmp_path):
    run = slow_roll()
    strict = Solver.for_camera(CAM, cache_dir=solver.path.rsplit("/", 1)[0],
                               pooled_alphas=[1e-12])
    assert strict.path == solver.path
    fix, xy = identify_events(run.events, CAM, solver=strict)
    assert not fix.ok and len(xy) < 4
    with pytest.raises(ParameterError, match="pooled_alphas"):
        Solver.for_camera(CAM, cache_dir=tmp_path, pooled_alphas=[2.0])


def test_noise_alone_and_an_empty_window_give_no_fix(solver):
    rng = np.random.default_rng(5)
    x, y = noise(rng)
    t = np.sort(rng.integers(0, 50_000, len(x)))
    events = Events(t, x, y, rng.integers(0, 2, len(x)), CAM.width, CAM.height)
    fix, _ = identify_events(events, CAM, solver=solver)
    assert not fix.ok and np.all(np.isnan(fix.q_icrs_cam))
    fix, xy = identify_events(events, CAM, 60_000, 70_000, solver=solver)
    assert (fix.ok, fix.status, len(xy), fix.t_us) == (False, "too_few_stars", 0, 65_000)


@pytest.mark.parametrize("kwargs, message", [
    (dict(solver="x"), "solver must be an evstar.attitude.Solver, got str"),
    (dict(t_start_us="abc"), "t_start_us must be a time in µs (an integer), got 'abc'"),
    (dict(t_start_us=50_000, t_stop_us=10_000), "t_stop_us (10000) must not be before t_start_us (50000)"),
])
def test_bad_arguments_are_named(kwargs, message):
    ev = Events(np.arange(10), np.full(10, 5), np.full(10, 5), np.ones(10, np.int8), CAM.width, CAM.height)
    with pytest.raises(EvstarError) as e:          # one line, naming the argument
        identify_events(ev, CAM, **kwargs)
    assert message in str(e.value)


def test_detect_drops_a_ring_plateau_whose_centre_holds_no_event():
    """A busy scene's plateau of equal box counts can be a ring: its centre of mass lies on no
    event, and its weight was 0 (a 0/0 position and a RuntimeWarning on a real recording)."""
    import warnings

    yy, xx = np.mgrid[0:40, 0:40]
    cheb = np.maximum(abs(xx - 20), abs(yy - 20))
    band = (cheb >= 6) & (cheb <= 8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        xy, weight = detect(xx[band].astype(np.int64), yy[band].astype(np.int64), 40, 40, 1e-3)
    assert np.isfinite(xy).all() and (weight > 0).all()
