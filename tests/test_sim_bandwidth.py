"""Photoreceptor bandwidth, leak and shot noise of the simulated sensor: the low-pass
against its analytic step response, the cutoff law, the trail it gives a moving star, and
that with all of it off the simulator is unchanged."""
import copy
import math

import numpy as np
import pytest

from evstar import sim
from evstar.errors import ParameterError
from evstar.sim.psf import pixel_profile, window_half_width
from evstar.sim.render import Chunk, render_chunks, time_grid
from evstar.sim.sensor import PixelState, _Tails, star_events

CAM = sim.camera_preset("dvxplorer-lite")
PIXEL = (160, 120)


def blink(t_on, t_off):
    """Attitude with the star (on the boresight) in view only during [t_on, t_off)."""
    away = sim.attitude_from_radec(90.0, 0.0)

    def rotation(t):
        inside = (t >= t_on) & (t < t_off)
        return np.where(inside[:, None, None], np.eye(3), away)
    return sim.FunctionTrajectory(rotation)


def step_response_events(spec, t_on, t_off, duration_s, dt_s, seed=0):
    """Events of a magnitude-3 star switched on at t_on and off at t_off, on a uniform grid
    of dt_s; with the initial references and the pixel intensities."""
    stars = sim.star_at_pixel(CAM, np.eye(3), PIXEL, 3.0)
    flux = stars.flux(sim.FLUX_MAG3)
    grid = np.arange(int(round(duration_s / dt_s)) + 1) * dt_s
    state = PixelState(CAM.width * CAM.height, spec, np.random.default_rng(seed))
    ref0 = state.ref.copy()
    t, pix, pol, star = star_events(CAM, stars, flux, blink(t_on, t_off), grid, spec, 1.0, state)
    # the star sits on pixel PIXEL's centre: pixel-integrated PSF of each neighbour
    prof = pixel_profile(np.zeros(1), np.full(1, -8), 17, 1.0)[0]
    x, y = pix % CAM.width - PIXEL[0] + 8, pix // CAM.width - PIXEL[1] + 8
    intensity = 1 + flux[0] * prof[y] * prof[x]
    return t, pix, pol, ref0[pix], intensity


def first_grid_time(t, dt_s):
    return math.ceil(t / dt_s - 1e-9) * dt_s


def test_low_pass_follows_the_analytic_step_response():
    """Each pixel's filtered log intensity rises as L1 (1 − exp(−2π f_c(I1) (t − t0))) and
    falls back as L(t1) exp(−2π f_c(1) (t − t1)): every ON and OFF event at its analytic time."""
    dt = 1e-5
    spec = sim.SensorSpec.ideal(cutoff_hz_background=10.0, cutoff_hz_max=100.0)
    t_on, t_off = 0.01, 0.04
    t, pix, pol, ref0, intensity = step_response_events(spec, t_on, t_off, 0.15, dt)
    # the input ramps over the grid step up to the first grid time in view: its middle
    t0, t1 = first_grid_time(t_on, dt) - dt / 2, first_grid_time(t_off, dt) - dt / 2
    L1 = np.log(intensity)
    w_on = 2 * math.pi * spec.cutoff_hz(intensity)
    w_off = 2 * math.pi * spec.cutoff_hz_background
    theta = spec.threshold_on
    err_on, err_off, n_checked = [], [], 0
    for p in np.unique(pix):
        mine = pix == p
        tp, pp = t[mine], pol[mine]
        order = np.argsort(tp)
        tp, pp = tp[order], pp[order]
        n_on = int(np.sum(pp == 1))
        levels = ref0[mine][0] + theta * np.arange(1, n_on + 1)
        assert np.all(pp[:n_on] == 1) and np.all(pp[n_on:] == 0)       # rise, then fall
        assert np.all(levels < L1[mine][0]) and ref0[mine][0] + theta * (n_on + 1) > L1[mine][0] - 0.01
        expect_on = t0 + np.log(L1[mine][0] / (L1[mine][0] - levels)) / w_on[mine][0]
        err_on.append(np.abs(tp[:n_on] - expect_on))
        L_t1 = L1[mine][0] * -math.expm1(-w_on[mine][0] * (t1 - t0))
        down = levels[-1] - theta * np.arange(1, len(tp) - n_on + 1)
        expect_off = t1 + np.log(L_t1 / down) / w_off
        err_off.append(tp[n_on:] - expect_off)
        n_checked += len(tp)
    assert n_checked > 300
    assert np.concatenate(err_on).max() < dt
    # the decay runs at the background cutoff: OFF events spaced exactly as the exponential,
    # offset as a whole by the step that ramps the input down (its cutoff set mid-ramp)
    assert max(np.ptp(e) for e in err_off if len(e)) < dt
    assert np.abs(np.concatenate(err_off)).max() < 3 * dt


def test_brighter_pixels_have_higher_cutoffs():
    spec = sim.SensorSpec(cutoff_hz_background=30.0, cutoff_hz_max=2000.0)
    f = spec.cutoff_hz([0.5, 1.0, 2.0, 23.0, 66.0, 1000.0])
    assert f == pytest.approx([30.0, 30.0, 60.0, 690.0, 1980.0, 2000.0])
    assert np.all(np.isinf(sim.SensorSpec().cutoff_hz([1.0, 50.0])))   # off: unlimited


def offsets(magnitude, spec, rate_dps=8.0, seed=1):
    """Along-motion offsets (px) of the star's events from the truth at their times, ON mask."""
    run = sim.simulate(sim.paper_preset(rate_dps, magnitude=magnitude, sensor=spec), seed=seed)
    m = run.truth.labels >= 0
    ev = run.events[m]
    xy = run.truth.star_position(ev.t, star=0)
    return ev.x - xy[:, 0], ev.p == 1


def test_dark_sky_events_trail_the_star_and_more_for_a_fainter_one():
    mean = {}
    for mag in (3.0, 5.0):
        for name, spec in (("off", sim.SensorSpec(jitter_us=0.0)),
                           ("on", sim.SensorSpec.dark_sky(jitter_us=0.0))):
            dx, on = offsets(mag, spec)
            mean[mag, name] = dx.mean(), dx[on].mean(), dx[~on].mean()
    for mag in (3.0, 5.0):
        assert abs(mean[mag, "off"][0]) < 0.1                     # no bandwidth limit: centred
        assert mean[mag, "on"][0] < mean[mag, "off"][0] - 0.15    # stars move to +x: trail is -x
        assert mean[mag, "on"][1] < mean[mag, "off"][1]           # ON events lag too
        assert mean[mag, "on"][2] < mean[mag, "off"][2]           # OFF events trail further
    assert mean[5.0, "on"][0] < mean[3.0, "on"][0] - 0.05


def test_one_millisecond_grid_is_fine_enough_for_the_low_pass():
    """Slow stars are simulated on 1 ms steps, longer than a bright pixel's time constant:
    the exact ramp response keeps the events' offsets to 0.01 px of a 0.1 ms grid's."""
    spec = sim.SensorSpec.dark_sky(jitter_us=0.0, noise_hz=0.0, hot_pixels=0, leak_hz=0.0)
    scn = sim.paper_preset(8.0, duration_s=0.2, magnitude=4.0, sensor=spec)
    flux = scn.stars.flux(scn.flux_mag3)
    speed = scn.camera.fx * math.radians(8.0)
    result = []
    for max_step_s in (1e-3, 1e-4):
        grid = time_grid(scn.trajectory, scn.camera, scn.duration_s, scn.grid_step_px, max_step_s=max_step_s)
        state = PixelState(scn.camera.width * scn.camera.height, spec, np.random.default_rng(0))
        t, pix, pol, _ = star_events(scn.camera, scn.stars, flux, scn.trajectory, grid, spec, 1.0, state)
        dx = pix % scn.camera.width - (scn.camera.cx + speed * (t - 0.1))   # truth: centre at 0.1 s
        result.append((len(t), dx.mean(), dx[pol == 1].mean(), dx[pol == 0].mean()))
    (n0, *d0), (n1, *d1) = result
    assert n0 > 500 and abs(n0 / n1 - 1) < 0.01
    assert np.allclose(d0, d1, atol=0.01)


def filtered_samples(samples, grid, spec, tail_s):
    """The photoreceptor as a plain loop: per pixel, its window samples plus background ones
    for tail_s after each run of them, low-passed sample by sample (exact ramp response)."""
    out = {}
    for pix, seq in samples.items():
        steps = {k: (L, star) for k, L, star in seq}
        k, u, y, filtered = seq[0][0], 0.0, 0.0, []        # at the background until then
        while k < len(grid):
            if k in steps:
                u1, star = steps[k]
                last_seen = k
            elif grid[k] <= grid[last_seen] + tail_s[star]:
                u1 = 0.0
            else:
                k = min([j for j in steps if j > k], default=len(grid))
                continue
            if k == 0:
                y = u1                                             # settled at the start
            elif not filtered or k - 1 == filtered[-1][0]:
                w = 2 * math.pi * float(spec.cutoff_hz(math.exp((u + u1) / 2)))
                x = w * (grid[k] - grid[k - 1])
                y = u1 + (y - u) * math.exp(-x) - (u1 - u) * -math.expm1(-x) / x
            else:
                raise AssertionError("a single star passing once leaves no gaps")
            u = u1
            filtered.append((k, y, star))
            k += 1
        out[pix] = filtered
    return out


@pytest.mark.parametrize("refractory_us", [0.0, 300.0])
def test_low_pass_detection_matches_a_per_pixel_loop(refractory_us):
    """The vectorised photoreceptor, tails and detector against the per-pixel loops."""
    from test_sim_sensor import reference_events, samples_of

    spec = sim.SensorSpec.ideal(threshold_mismatch=0.03, refractory_us=refractory_us,
                                cutoff_hz_background=30.0, cutoff_hz_max=2000.0)
    scn = sim.paper_preset(16.0, duration_s=0.1, magnitude=4.0, sensor=spec)
    flux = scn.stars.flux(scn.flux_mag3)
    grid = time_grid(scn.trajectory, scn.camera, scn.duration_s, scn.grid_step_px)
    state = PixelState(scn.camera.width * scn.camera.height, spec, np.random.default_rng(3))
    samples = filtered_samples(samples_of(scn, flux, grid, spec), grid, spec,
                               state.filter.tail_s(flux, 1.0))
    expected = reference_events(copy.deepcopy(state), samples, grid, refractory_us * 1e-6)
    t, pix, pol, star = star_events(scn.camera, scn.stars, flux, scn.trajectory, grid, spec, 1.0, state)
    order = np.lexsort((t, pix))
    got = np.column_stack([pix[order], t[order], pol[order], star[order]])
    assert len(got) == len(expected) > 500
    assert np.array_equal(got[:, [0, 2, 3]], expected[:, [0, 2, 3]])
    assert np.abs(got[:, 1] - expected[:, 1]).max() < 1e-9


def test_low_pass_orders_give_identical_events():
    spec = sim.SensorSpec.dark_sky(jitter_us=0.0, noise_hz=0.0, hot_pixels=0, refractory_us=300.0)
    scn = sim.paper_preset(20.0, duration_s=0.2, sensor=spec)
    flux = scn.stars.flux(scn.flux_mag3)
    grid = time_grid(scn.trajectory, scn.camera, scn.duration_s, scn.grid_step_px)
    state = PixelState(scn.camera.width * scn.camera.height, spec, np.random.default_rng(2))
    a, b = (np.column_stack(star_events(scn.camera, scn.stars, flux, scn.trajectory, grid, spec, 1.0,
                                        copy.deepcopy(state), layout=layout))
            for layout in ("steps", "columns"))
    a, b = (e[np.lexsort((e[:, 0], e[:, 1]))] for e in (a, b))     # by pixel, then time
    assert len(a) > 1000 and np.array_equal(a, b)


def test_tails_carry_across_chunks():
    """A chunk cut in two gets the same tail samples as in one piece: tails cut at a chunk's
    end carry over into the next."""
    spec = sim.SensorSpec.dark_sky()
    scn = sim.paper_preset(8.0, duration_s=0.3, magnitude=4.0, sensor=spec)
    flux = scn.stars.flux(scn.flux_mag3)
    grid = time_grid(scn.trajectory, scn.camera, scn.duration_s, scn.grid_step_px)
    half = np.array([window_half_width(f, 1.0, spec.min_log_change) for f in flux])
    (whole,) = render_chunks(scn.camera, scn.stars.directions, flux, half, 1.0, spec.min_log_change,
                             scn.trajectory, grid)
    tail_s = PixelState(1, spec, np.random.default_rng(0)).filter.tail_s(flux, 1.0)
    one = _Tails(tail_s, grid).add(whole)
    tails = _Tails(tail_s, grid)
    pieces = []
    for k0, k1 in ((0, 150), (151, 152), (153, len(grid) - 1)):   # one piece of two steps
        m = (whole.step >= k0) & (whole.step <= k1)
        pieces.append(tails.add(Chunk(whole.pix[m], whole.contrib[m], whole.star[m], whole.step[m], (k0, k1))))
    assert len(one.pix) > len(whole.pix) + 5000                    # tails were added
    def table(chunks):
        t = np.concatenate([np.column_stack([c.step, c.pix, c.star, c.contrib]) for c in chunks])
        return t[np.lexsort((t[:, 1], t[:, 0]))]                  # a step's pixels are distinct
    assert np.array_equal(table([one]), table(pieces))


def test_with_the_new_physics_off_runs_are_unchanged():
    scn = sim.paper_preset(12.0, duration_s=0.2)
    base = sim.simulate(scn, seed=4)
    # the background cutoff only matters with a maximum cutoff set
    same = sim.simulate(scn.replace(sensor=sim.SensorSpec(cutoff_hz_background=55.0)), seed=4)
    assert base.events == same.events and np.array_equal(base.truth.labels, same.truth.labels)
    lp = sim.simulate(scn.replace(sensor=sim.SensorSpec(cutoff_hz_max=1000.0)), seed=4)
    assert lp.events != base.events
    # the noise streams do not move when the low-pass is on: same background events
    noise = base.truth.labels == -1
    assert np.array_equal(base.events.t[noise], lp.events.t[lp.truth.labels == -1])


def test_leak_gives_each_pixel_a_periodic_on_train():
    spec = sim.SensorSpec.ideal(leak_hz=2.0)
    cam = sim.camera_preset("davis346")
    run = sim.simulate(sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(0.0), 2.0, sensor=spec),
                       seed=1)
    ev = run.events
    n_pix = cam.width * cam.height
    assert np.all(run.truth.labels == -1) and np.all(ev.p == 1)
    assert abs(len(ev) - 2.0 * 2.0 * n_pix) < 0.01 * len(ev)        # leak_hz per pixel
    pix = ev.y.astype(np.int64) * cam.width + ev.x
    order = np.lexsort((ev.t, pix))
    same = np.diff(pix[order]) == 0
    assert np.abs(np.diff(ev.t[order])[same] - 500_000).max() <= 1   # one every 1 / leak_hz


def test_leak_period_follows_each_pixels_on_threshold():
    spec = sim.SensorSpec(leak_hz=1.0, threshold_mismatch=0.04, noise_hz=0.0, hot_pixels=0)
    cam = sim.camera_preset("dvxplorer-lite")
    run = sim.simulate(sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(0.0), 3.0, sensor=spec),
                       seed=2)
    ev = run.events
    pix = ev.y.astype(np.int64) * cam.width + ev.x
    order = np.lexsort((ev.t, pix))
    same = np.diff(pix[order]) == 0
    first_gap = same & ~np.insert(same[:-1], 0, False)             # one per pixel
    period = np.diff(ev.t[order])[first_gap] * 1e-6
    assert len(period) > 50_000
    assert period.mean() == pytest.approx(1.0, abs=0.01)
    assert period.std() == pytest.approx(0.04 / 0.2, rel=0.1)        # θ_on spread / θ_on


def test_shot_noise_grows_with_the_stars_light():
    spec = sim.SensorSpec.ideal(shot_noise_hz=0.5)
    stars = sim.star_at_pixel(CAM, np.eye(3), PIXEL, 3.0)
    scn = sim.Scenario(CAM, stars, sim.ConstantRate(0.0), 2.0, sensor=spec)
    run = sim.simulate(scn, seed=5)
    ev = run.events
    assert np.all(run.truth.labels == -1)                           # noise, not the star's signal
    flux = stars.flux(sim.FLUX_MAG3)[0]
    expected = 0.5 * flux * 2.0                                     # the window holds ~all the flux
    assert abs(len(ev) - expected) < 4 * math.sqrt(expected)
    d = np.hypot(ev.x.astype(float) - PIXEL[0], ev.y.astype(float) - PIXEL[1])
    assert np.mean(d <= 1.5) > 0.6                                  # mostly on the bright core
    assert abs(ev.p.mean() - 0.5) < 4 * math.sqrt(0.25 / len(ev))
    again = sim.simulate(scn, seed=5)
    assert again.events == ev


def test_dark_sky_preset_and_checks():
    spec = sim.SensorSpec.dark_sky()
    assert spec.lowpass and spec.cutoff_hz(1.0) == 30.0 and spec.cutoff_hz_max == 2000.0
    assert spec.leak_hz == 0.1 and spec.shot_noise_hz == 0.0
    assert sim.sensor_model("dark-sky") == spec and sim.sensor_model("default") == sim.SensorSpec()
    assert sim.sensor_model("dark-sky", noise_hz=0.5).noise_hz == 0.5
    assert not sim.SensorSpec().lowpass
    for bad in (dict(cutoff_hz_max=10.0), dict(cutoff_hz_background=0.0), dict(leak_hz=-1.0),
                dict(shot_noise_hz=-0.1), dict(cutoff_hz_max=math.inf)):
        with pytest.raises(ParameterError):
            sim.SensorSpec(**bad)
    with pytest.raises(ParameterError, match="unknown sensor model"):
        sim.sensor_model("moonlit")


def test_simulate_command_takes_the_dark_sky_sensor(tmp_path, capsys):
    from evstar.cli import main

    out = tmp_path / "run"
    args = ["simulate", str(out), "--rate", "8", "--duration", "0.1", "--sensor", "dark-sky"]
    assert main(args) == 0
    truth = sim.load_truth(out / "truth.npz")
    assert truth.meta["sensor"]["cutoff_hz_max"] == 2000.0 and truth.meta["sensor"]["leak_hz"] == 0.1
    assert main(["simulate", str(tmp_path / "x"), "--sensor", "bright"]) == 2
    assert "invalid choice: 'bright'" in capsys.readouterr().err
