"""Untracked centroids (of no confirmed track) on noisy sensors: reported only where the
background could not have formed them (estimate.untracked_alpha)."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, sim
from evstar.errors import ParameterError
from evstar.estimation import untracked_min_events
from evstar_kernels.reference import poisson


@pytest.mark.parametrize("sensor,rate", [((320, 240), 1.5), ((320, 240), 5.0),
                                         ((1280, 720), 1.5), ((346, 260), 0.1)])
def test_the_least_count_is_where_background_clusters_become_rarer_than_alpha(sensor, rate):
    cfg = Config()
    n = untracked_min_events(cfg, sensor, rate)
    area = np.pi * cfg.extract.eps ** 2
    mu, spots = rate * cfg.dt_us * 1e-6 * area, sensor[0] * sensor[1] / area
    per_frame = spots * poisson.sf(np.array([n - 1, n - 2]), mu)   # P(X >= n), P(X >= n - 1)
    assert per_frame[0] <= cfg.estimate.untracked_alpha < per_frame[1]


def test_more_background_or_a_larger_sensor_needs_more_events():
    cfg = Config()
    counts = [untracked_min_events(cfg, s, r) for s, r in
              (((320, 240), 0.5), ((320, 240), 5.0), ((1280, 720), 5.0))]
    assert counts == sorted(counts) and counts[0] < counts[-1]
    assert untracked_min_events(cfg, (320, 240), 0.0) == 1    # no background: every cluster


def test_noise_clusters_of_a_noisy_sensor_are_not_reported():
    cam = sim.camera_preset("dvxplorer-lite")
    motion = sim.ConstantRate(2.0)
    stars = sim.star_at_pixel(cam, motion.rotation(1.0)[0], (cam.cx, cam.cy), 4.0)
    run = sim.simulate(sim.Scenario(cam, stars, motion, 2.0,
                                    sensor=sim.sensor_model("default", noise_hz=5.0)), seed=208)
    rows = {a: Pipeline(Config().replace(**{"estimate.untracked_alpha": a})).run(
        run.events, run.imu, run.camera).centroids for a in (None, 0.01)}
    false = {a: accuracy.match(r, run.truth.star_position)[0] < 0 for a, r in rows.items()}
    assert false[None].sum() >= 1 and false[0.01].sum() == 0
    assert (rows[None]["track"][false[None]] == -1).all()      # they were untracked clusters
    star = {a: np.sort(r[~false[a]]["t"]) for a, r in rows.items()}
    np.testing.assert_array_equal(star[None], star[0.01])      # the star's rows all stay


@pytest.mark.parametrize("value", [0, 1.5, -0.1])
def test_bad_untracked_alpha_is_rejected_naming_it(value):
    with pytest.raises(ParameterError, match="estimate.untracked_alpha"):
        Config().replace(**{"estimate.untracked_alpha": value})
