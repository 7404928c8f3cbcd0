"""The independent event simulator of perf/indep_sim.py (used by perf/study_indep.py)."""
import math
import pathlib
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "perf"))
import indep_sim as S  # noqa: E402

QUIET = dict(noise_hz=0.0, hot_pixels=0, jitter_us=0.0)


@pytest.mark.parametrize("pixel", ["ideal", "lowpass"])
def test_static_star_without_noise_gives_no_events(pixel):
    scene = S.Scene(64, 48, 100.0, [(30.3, 20.7)], [3.0], S.Linear(0.0), S.Moffat(2.5, 3.0), 0.1)
    run = S.simulate(scene, S.Sensor(pixel=pixel, **QUIET), seed=1)
    assert len(run.events) == 0
    assert np.allclose(run.truth([0, 50_000]), [[[30.3, 20.7]]] * 2)


def test_moving_star_fires_on_ahead_and_off_behind():
    direction = 30.0
    scene = S.Scene(96, 64, 200.0, [(30.0, 25.0)], [3.0], S.Linear(8.0, direction),
                    S.Gaussian(1.0), 0.2)
    run = S.simulate(scene, S.Sensor(pixel="ideal", **QUIET), seed=2)
    ev = run.events
    assert len(ev) > 500 and np.all(run.labels == 0)
    assert np.all(np.diff(ev.t) >= 0)
    xy = run.truth(ev.t)[:, 0]
    u = np.array([math.cos(math.radians(direction)), math.sin(math.radians(direction))])
    along = (ev.x - xy[:, 0]) * u[0] + (ev.y - xy[:, 1]) * u[1]
    on, off = along[ev.p == 1], along[ev.p == 0]
    assert on.mean() > 0.7 and off.mean() < -0.7
    assert np.mean(on > 0) > 0.9 and np.mean(off < 0) > 0.9
    # equal thresholds and a star that comes and goes: as many ON as OFF events, roughly
    assert abs(len(on) - len(off)) < 0.2 * len(ev)


def test_lowpass_step_is_the_exponential():
    f_c = 150.0
    a = 2 * math.pi * f_c
    # a unit step of the input at t = 0, uneven steps: exact at every step's end
    h = np.random.default_rng(0).uniform(20e-6, 300e-6, 60)
    v, t = 0.0, 0.0
    for hk in h:
        v = S.lowpass_step(v, 1.0, 1.0, hk, f_c)
        t += hk
        assert v == pytest.approx(1 - math.exp(-a * t), abs=1e-12)
    # a ramp L = k t from rest: V = k (t − 1/a) + k/a e^(−a t)
    k, v, t = 3.0, 0.0, 0.0
    for hk in h:
        v = S.lowpass_step(v, k * t, k * (t + hk), hk, f_c)
        t += hk
    assert v == pytest.approx(k * (t - 1 / a) + k / a * math.exp(-a * t), abs=1e-12)
    # a sensor whose cutoff does not depend on intensity
    assert S.Sensor(f_min_hz=f_c, f_max_hz=f_c).cutoff_hz(np.array([0.0, 1.0, 1e4])) == \
        pytest.approx([f_c] * 3)


def test_lowpass_pixel_fires_at_the_exponential_crossings():
    """One pixel whose log intensity steps up by 1 at t = 0, cutoff fixed: ON events where
    1 − e^(−a t) crosses n·C (refractory 0), each at its interpolated time."""
    f_c, C, h = 100.0, 0.2, 100e-6
    a = 2 * math.pi * f_c
    ref, blind, pending = np.zeros(1), np.full(1, -np.inf), np.zeros(1, bool)
    c = np.full(1, C)
    out = ([], [], [], [])
    v0 = np.zeros(1)
    for k in range(400):
        v1 = S.lowpass_step(v0, np.ones(1), np.ones(1), h, f_c)
        S._fire(np.zeros(1, np.int64), k * h, (k + 1) * h, v0, v1, ref, blind, pending, c, c,
                0.0, *out, np.zeros(1, np.int64))
        v0 = v1
    t = np.concatenate(out[0])
    assert len(t) == 4 and np.all(np.concatenate(out[2]) == 1)
    expected = -np.log(1 - C * np.arange(1, 5)) / a
    assert np.allclose(t, expected, atol=3e-6)


def test_refractory_period_drops_events_and_resets_the_reference():
    """A steep rise fires once per threshold with no refractory period; with one longer than
    the whole rise, only the first event remains and the reference ends at the top."""
    ramp = dict(v0=np.zeros(1), v1=np.full(1, 1.05))
    for R, n in ((0.0, 5), (1e-3, 1)):
        ref, blind, pending = np.zeros(1), np.full(1, -np.inf), np.zeros(1, bool)
        out = ([], [], [], [])
        c = np.full(1, 0.2)
        S._fire(np.zeros(1, np.int64), 0.0, 1e-4, ramp["v0"], ramp["v1"], ref, blind, pending,
                c, c, R, *out, np.zeros(1, np.int64))
        assert len(np.concatenate(out[0])) == n
        if R:   # still blind at the step's end: reset pending, then at the level of its end
            assert pending[0]
            flat = np.full(1, 1.05)
            S._fire(np.zeros(1, np.int64), 1e-4, 2e-3, flat, flat, ref, blind, pending, c, c, R,
                    *out, np.zeros(1, np.int64))
            assert not pending[0] and ref[0] == pytest.approx(1.05)


def test_background_noise_counts_match_the_poisson_rate():
    rate, T, w, h = 5.0, 1.0, 64, 48
    scene = S.Scene(w, h, 100.0, [], [], S.Linear(0.0), S.Gaussian(1.0), T)
    run = S.simulate(scene, S.Sensor(noise_hz=rate, hot_pixels=0), seed=3)
    n = len(run.events)
    expected = rate * T * w * h
    # Poisson and the log-normal spread of the rates: sd ~ 250 events here
    assert abs(n - expected) < 0.05 * expected
    assert np.mean(run.events.p) == pytest.approx(0.6, abs=0.02)
    assert np.all(run.labels == -1) and np.all(np.diff(run.events.t) >= 0)
    # hot pixels: single pixels at 100–1000 Hz on top of the background
    hot = S.simulate(scene, S.Sensor(noise_hz=0.0, hot_pixels=3), seed=4).events
    counts = np.bincount(hot.y.astype(int) * w + hot.x, minlength=w * h)
    busy = np.sort(counts)[::-1]
    assert busy[3] == 0 and np.all((busy[:3] > 70) & (busy[:3] < 1100))


def test_a_planar_turn_matches_the_single_axis_one_and_its_gyro():
    # Linear as a planar motion (a new axis every time): the same positions and gyro
    class Planar(S.Linear):
        planar = True

    stars = [(100.0, 100.0), (500.0, 400.0)]
    runs = [S.Scene(640, 480, 540.0, stars, [3, 4], m, S.Gaussian(1.0), 1.0, "rotate")
            for m in (S.Linear(10, 30), Planar(10, 30))]
    t = [0.0, 0.3, 0.9]
    np.testing.assert_allclose(runs[1].positions(t), runs[0].positions(t), atol=1e-9)
    np.testing.assert_allclose(S.make_imu(runs[1]).gyro, S.make_imu(runs[0]).gyro, atol=1e-7)


def test_coning_keeps_its_speed_and_comes_back():
    scene = S.Scene(640, 480, 540.0, [(320.0, 240.0)], [3], S.Circle(2.0, 1.0), S.Gaussian(1.0),
                    1.0, "rotate")
    p = scene.positions(np.linspace(0, 1, 2001))[:, 0]
    speed = np.hypot(*np.diff(p, axis=0).T) * 2000
    expected = math.radians(2.0) * 540.0 * 2 * math.pi
    assert np.allclose(speed, expected, rtol=0.01)
    np.testing.assert_allclose(p[-1], p[0], atol=1e-6)
    gyro = S.make_imu(scene).gyro
    np.testing.assert_allclose(np.hypot(gyro[:, 0], gyro[:, 1]), math.radians(2.0) * 2 * math.pi,
                               rtol=0.01)


def test_readout_gaps_lose_every_event_and_leak_fires_on():
    scene = S.Scene(64, 48, 100.0, [(20.0, 24.0)], [3.0], S.Linear(20.0), S.Gaussian(1.0), 0.5)
    run = S.simulate(scene, S.Sensor(noise_hz=0.0, leak_hz=2.0, gaps_s=((0.2, 0.25),)), seed=3)
    t = run.events.t
    assert not np.any((t >= 200_000) & (t < 250_000)) and np.any(t >= 250_000)
    leak = run.labels < 0
    assert np.all(run.events.p[leak] == 1)
    # 2 Hz over 64 x 48 pixels for 0.5 s, less the gap's 10 %
    assert 0.8 * 2 * 64 * 48 * 0.45 < leak.sum() < 1.25 * 2 * 64 * 48 * 0.45


def test_a_shaken_turn_is_its_turn_plus_the_vibration():
    """Shaken: offsets and velocities add; the star, turned about the principal point, swings
    across its motion at the vibration's frequency (a planar motion, like Circle)."""
    base, wave = S.Linear(8.0, 0.0), S.Sinusoid(0.05, 20.0, 90.0)
    move = S.Shaken(base, wave)
    t = np.linspace(0.0, 0.2, 41)
    assert np.allclose(move.offset(t, 300.0), base.offset(t, 300.0) + wave.offset(t, 300.0))
    assert np.allclose(move.velocity(t, 300.0), base.velocity(t, 300.0) + wave.velocity(t, 300.0))
    scene = S.Scene(96, 64, 300.0, [(48.0, 32.0)], [3.0], move, S.Gaussian(1.0), 0.2, "rotate")
    y = scene.positions(t)[:, 0, 1]
    amp = 300.0 * math.radians(0.05)
    assert np.ptp(y) == pytest.approx(2 * amp, rel=0.05)


def test_a_roll_circles_the_principal_point_and_its_gyro_compensates_it():
    """Rolled: a pure roll keeps each star's distance from the principal point and moves it
    at ω·r; its gyro is (0, 0, ω), and evstar's IMU warp with it draws the star's events
    together (with the roll's sign flipped, apart)."""
    import evstar
    from evstar.motion import compensate

    scene = S.Scene(640, 480, 540.0, [(560.0, 240.0)], [3], S.Rolled(40.0, S.Linear(0.0)),
                    S.Gaussian(0.8), 0.3, "rotate")
    t = np.linspace(0, 0.3, 301)
    p = scene.positions(t)[:, 0]
    r = np.hypot(p[:, 0] - 319.5, p[:, 1] - 239.5)
    assert np.ptp(r) < 1e-9
    speed = np.hypot(*np.diff(p, axis=0).T) / np.diff(t)
    assert np.allclose(speed, math.radians(40.0) * r[0], rtol=1e-3)
    run = S.simulate(scene, S.Sensor(noise_hz=0.0), seed=1, imu=True)
    np.testing.assert_allclose(run.imu.gyro, [[0, 0, math.radians(40.0)]] * len(run.imu.t),
                               atol=1e-6)
    ev = run.events
    frame = (ev.t - ev.t[0]) // 10_000

    def spread(sign):
        gyro = run.imu.gyro * [1, 1, sign]
        xy = compensate(ev, evstar.Imu(run.imu.t, gyro), run.camera, 10_000,
                        "imu").coordinates(np.arange(len(ev)))
        return np.mean([np.hypot(*xy[frame == k].std(0)) for k in range(5, 25)])

    assert spread(1) < spread(0) < spread(-1)


def test_stray_light_raises_the_background_linearly():
    scene = S.Scene(64, 48, 100.0, [], [], S.Linear(0.0), S.Gaussian(1.0), 1.0)
    t = S.simulate(scene, S.Sensor(noise_hz=20.0, noise_growth=5.0), seed=2).events.t
    first, last = np.sum(t < 100_000), np.sum(t >= 900_000)
    # the rate ∝ 1 + 4 t/T: on average 1.2 and 4.8 × 20 Hz over the first and last tenth
    assert last / first == pytest.approx(4.8 / 1.2, rel=0.06)
    assert len(t) == pytest.approx(20.0 * 3.0 * 64 * 48, rel=0.05)


def test_a_damaged_gyro_record_of_the_fresh9_grid():
    import study_indep
    from evstar import Imu

    t = np.arange(0, 1_000_000, 1000, dtype=np.int64)
    imu = Imu(t, np.column_stack([np.ones(len(t)), 0 * t, 0 * t]))
    out = study_indep.damaged(imu, {"imu_gaps": ((0.35, 0.45),), "imu_spikes": ((0.2, 3, 40.0),)})
    assert not np.any((out.t > 350_000) & (out.t < 450_000)) and len(out) == len(t) - 101
    assert np.array_equal(np.flatnonzero(out.gyro[:, 0] == 40.0), [200, 201, 202])
