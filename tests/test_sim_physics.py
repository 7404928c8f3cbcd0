"""Physics of the simulator, each test asserting numbers: drift rate, event counts versus
contrast and magnitude, background rate, and labels against the true star positions."""
import math

import numpy as np
import pytest

from evstar import sim
from evstar.sim.psf import window_half_width


def star_events(run):
    m = run.truth.labels >= 0
    return run.events[m]


@pytest.mark.parametrize("rate_dps", [4.0, 20.0])
def test_star_drifts_at_f_omega_measured_from_its_events(rate_dps):
    run = sim.simulate(sim.paper_preset(rate_dps), seed=2)
    ev = star_events(run)
    frame = ev.t // 10_000                      # 10 ms pseudo-frames
    mean_x = np.bincount(frame, ev.x) / np.bincount(frame)
    t_mid = (np.arange(len(mean_x)) + 0.5) * 0.01
    slope = np.polyfit(t_mid, mean_x, 1)[0]
    expected = run.camera.fx * math.radians(rate_dps)
    assert slope > 0                            # positive rate about "up": stars drift to +x
    assert abs(slope / expected - 1) < 0.01
    mean_y = np.bincount(frame, ev.y) / np.bincount(frame)
    assert np.ptp(mean_y) < 0.5                 # the turntable axis is vertical: no y drift


def test_true_position_moves_at_exactly_f_omega_through_the_centre():
    run = sim.simulate(sim.paper_preset(12.0, sensor=sim.SensorSpec.ideal()), seed=0)
    t = np.array([249_000, 251_000])            # around mid-run, where the star is at the centre
    xy = run.truth.star_position(t, star=0)
    speed = (xy[1, 0] - xy[0, 0]) / 2e-3
    assert speed == pytest.approx(run.camera.fx * math.radians(12.0), rel=1e-6)
    assert run.truth.star_position([250_000], 0)[0] == pytest.approx([run.camera.cx, run.camera.cy], abs=1e-9)


def count_star_events(**options):
    scn = sim.paper_preset(8.0, duration_s=0.2, sensor=sim.SensorSpec.ideal(), **options)
    return int((sim.simulate(scn, seed=5).truth.labels >= 0).sum())


def test_event_count_falls_with_magnitude():
    counts = [count_star_events(magnitude=m) for m in (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)]
    assert all(a > b for a, b in zip(counts, counts[1:])), counts
    assert counts[-1] > 0                         # a magnitude-6 star is still seen, weakly
    assert counts[0] > 1.5 * counts[2]            # 2 magnitudes = 6.3x flux, log response


def test_event_count_grows_with_contrast_over_the_sky():
    counts = [count_star_events(flux_mag3=f) for f in (20.0, 50.0, 150.0, 450.0)]
    assert all(a < b for a, b in zip(counts, counts[1:])), counts


def test_events_per_pixel_of_travel_do_not_depend_on_the_rate():
    """Without photoreceptor bandwidth limits each pixel sees the same log-intensity bump."""
    per_px = []
    for rate in (4.0, 12.0, 20.0):
        scn = sim.paper_preset(rate, duration_s=0.3, sensor=sim.SensorSpec.ideal())
        run = sim.simulate(scn, seed=1)
        travel = run.camera.fx * math.radians(rate) * 0.3
        per_px.append((run.truth.labels >= 0).sum() / travel)
    assert max(per_px) / min(per_px) < 1.02, per_px
    assert 60 < np.mean(per_px) < 200            # the documented calibration: ~115 per pixel


@pytest.mark.parametrize("rate_dps", sim.PAPER_RATES_DPS)
def test_paper_presets_give_a_dense_streak_per_10ms_frame(rate_dps):
    run = sim.simulate(sim.paper_preset(rate_dps), seed=0)
    per_frame = (run.truth.labels >= 0).sum() / 50
    assert 30 < per_frame < 400
    assert per_frame == pytest.approx(50 * rate_dps / 4, rel=0.1)  # proportional to the rate


def test_background_rate_matches_the_set_rate():
    cam = sim.camera_preset("dvxplorer-lite")
    spec = sim.SensorSpec.ideal(noise_hz=2.0, noise_on_fraction=0.3)
    scn = sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(10.0), 1.0, sensor=spec)
    ev = sim.simulate(scn, seed=4).events
    expected = 2.0 * cam.width * cam.height * 1.0
    assert abs(len(ev) - expected) < 4 * math.sqrt(expected)
    counts = np.bincount(ev.y.astype(np.int64) * cam.width + ev.x, minlength=cam.width * cam.height)
    assert counts.var() / counts.mean() == pytest.approx(1.0, abs=0.03)   # Poisson per pixel
    n = len(ev)
    assert abs(ev.p.mean() - 0.3) < 4 * math.sqrt(0.3 * 0.7 / n)
    gaps = np.diff(ev.t)
    assert gaps.mean() * 1e-6 == pytest.approx(1 / expected, rel=0.02)


def test_dropout_thins_every_kind_of_event():
    cam = sim.camera_preset("dvxplorer-lite")
    spec = sim.SensorSpec.ideal(noise_hz=2.0, dropout=0.25)
    scn = sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(10.0), 1.0, sensor=spec)
    n = len(sim.simulate(scn, seed=4).events)
    expected = 0.75 * 2.0 * cam.width * cam.height
    assert abs(n - expected) < 4 * math.sqrt(expected)


def test_labels_agree_with_the_true_star_position_at_each_event():
    scn = sim.paper_preset(16.0, sensor=sim.SensorSpec(jitter_us=0.0, hot_pixels=3))
    run = sim.simulate(scn, seed=8)
    ev, truth = run.events, run.truth
    star = truth.labels >= 0
    xy = truth.star_position(ev.t[star], star=0)
    d = np.hypot(ev.x[star] - xy[:, 0], ev.y[star] - xy[:, 1])
    h = window_half_width(truth.star_flux[0], scn.psf_sigma_px, scn.sensor.min_log_change)
    assert d.max() <= h + 1.0                    # never outside the rendered PSF window
    assert np.median(d) < 3 * scn.psf_sigma_px   # most within a few sigma
    # ON events lead the moving star, OFF events trail it
    on = ev.p[star] == 1
    dx = ev.x[star] - xy[:, 0]
    assert dx[on].mean() > 0.5 and dx[~on].mean() < -0.5
    hot = truth.labels == -2
    assert set(ev.y[hot].astype(np.int64) * run.camera.width + ev.x[hot]) == set(truth.hot_pixels)


def test_hot_pixels_fire_at_their_rate_and_respect_the_refractory_period():
    cam = sim.camera_preset("davis346")
    spec = sim.SensorSpec.ideal(hot_pixels=4, hot_pixel_hz=500.0, refractory_us=300.0)
    scn = sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(0.0), 2.0, sensor=spec)
    run = sim.simulate(scn, seed=3)
    ev = run.events
    assert np.all(run.truth.labels == -2) and len(run.truth.hot_pixels) == 4
    expected = 4 * 500.0 * 2.0
    assert abs(len(ev) - expected) < 4 * math.sqrt(expected)
    pix = ev.y.astype(np.int64) * cam.width + ev.x
    for p in run.truth.hot_pixels:
        assert np.diff(ev.t[pix == p]).min() >= 299   # µs rounding


def test_refractory_period_separates_a_pixels_star_events():
    scn = sim.paper_preset(20.0, sensor=sim.SensorSpec.ideal(refractory_us=2000.0, threshold_on=0.1,
                                                             threshold_off=0.1))
    run = sim.simulate(scn, seed=1)
    ev = run.events
    pix = ev.y.astype(np.int64) * run.camera.width + ev.x
    order = np.lexsort((ev.t, pix))
    same = np.diff(pix[order]) == 0
    assert np.diff(ev.t[order])[same].min() >= 1999
    free = sim.simulate(scn.replace(sensor=sim.SensorSpec.ideal(threshold_on=0.1, threshold_off=0.1)), seed=1)
    assert len(free.events) > 2 * len(ev)         # the long refractory period loses events


def test_overlapping_stars_add_their_fluxes():
    """Two stars in one direction give exactly the events of one star with both fluxes."""
    base = sim.paper_preset(8.0, duration_s=0.2, sensor=sim.SensorSpec.ideal(threshold_mismatch=0.03))
    d = base.stars.directions[0]
    twin = base.replace(stars=sim.StarField([d, d], [3.0, 3.0], [-1, -1]))
    brighter = base.replace(stars=sim.single_star(d, 3.0 - 2.5 * math.log10(2.0)))
    a, b = sim.simulate(twin, seed=6), sim.simulate(brighter, seed=6)
    assert len(a.events) > 0
    assert np.array_equal(a.events.t, b.events.t) and np.array_equal(a.events.x, b.events.x)
    assert np.array_equal(a.events.p, b.events.p)
    assert set(np.unique(a.truth.labels)) <= {0, 1}


def test_threshold_mismatch_spreads_per_pixel_thresholds():
    from evstar.sim.sensor import PixelState

    spec = sim.SensorSpec(threshold_on=0.25, threshold_off=0.15, threshold_mismatch=0.03)
    state = PixelState(100_000, spec, np.random.default_rng(0))
    assert state.c_on.mean() == pytest.approx(0.25, abs=1e-3) and state.c_on.std() == pytest.approx(0.03, rel=0.03)
    assert state.c_off.mean() == pytest.approx(0.15, abs=1e-3)
    gap = -state.ref    # background log intensity 0 minus the reference: inside (-θ_off, θ_on)
    assert np.all(gap < state.c_on) and np.all(gap > -state.c_off)
