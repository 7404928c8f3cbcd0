"""The pixels' lag (a photoreceptor low-pass delays each crossing) is measured from the data
where the IMU says the speed changes, and corrected; where it cannot be told apart from a
position offset (constant rate) nothing is changed."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, sim
from evstar.smoothing import pixel_lag_s


def sinusoid_prior(amp_px_s=200.0, freq_hz=1.0):
    def prior(t_us, x, y):
        v = amp_px_s * np.cos(2 * np.pi * freq_hz * np.asarray(t_us, float) * 1e-6)
        return np.column_stack([v, np.zeros_like(v)])
    return prior


def crossings_along(prior, lag_s, t_us, offset_px=3.0, noise_px=0.03, seed=0):
    """Pixels passed along x by a star moving as `prior` says, each seen `lag_s` late."""
    rng = np.random.default_rng(seed)
    t = np.asarray(t_us, float)
    fine = np.linspace(0, t[-1] * 1e-6, 20001)
    x_true = offset_px + np.cumsum(np.r_[0, np.diff(fine)] * prior(fine * 1e6, 0, 0)[:, 0])
    x = np.interp((t * 1e-6) - lag_s, fine, x_true) + rng.normal(0, noise_px, len(t))
    q = np.column_stack([x, np.full(len(t), 50.0)])
    u = np.tile([1.0, 0.0], (len(t), 1))
    return q, u


@pytest.mark.parametrize("lag_ms", [0.0, 1.0, 2.5])
def test_a_known_lag_is_recovered_on_a_sinusoid(lag_ms):
    prior = sinusoid_prior()
    t = np.sort(np.random.default_rng(1).uniform(0.02e6, 0.98e6, 400))
    q, u = crossings_along(prior, lag_ms * 1e-3, t)
    assert pixel_lag_s(t, q, u, prior) * 1e3 == pytest.approx(lag_ms, abs=0.1)


def test_at_constant_speed_the_lag_is_not_identifiable_and_left_alone():
    prior = lambda t, x, y: np.column_stack([np.full(len(np.atleast_1d(t)), 90.0),
                                             np.zeros(len(np.atleast_1d(t)))])
    t = np.sort(np.random.default_rng(2).uniform(0, 0.5e6, 300))
    q, u = crossings_along(prior, 2e-3, t)
    assert pixel_lag_s(t, q, u, prior) == 0.0


def test_dark_sky_sinusoid_with_imu_loses_its_lag():
    """With the gyro the lag is told from the speed's changes; without it, from the crossings'
    level profiles (estimate.measure_lag, evstar.level_lag); with neither it stays."""
    run = sim.simulate(sim.paper_sinusoid(magnitude=3, sensor=sim.SensorSpec.dark_sky(),
                                          duration_s=1.0), seed=4)
    errors = {}
    for mode, measure in (("none", False), ("none", True), ("imu", True)):
        res = Pipeline(Config().replace(**{"motion.compensate": mode,
                                           "estimate.measure_lag": measure})).run(
            run.events, run.imu, run.camera)
        star, err = accuracy.match(res.centroids, run.truth.star_position)
        errors[mode, measure] = err[star >= 0].mean()
    assert errors["none", False] > 0.5, errors
    assert errors["none", True] < 0.25 and errors["imu", True] < 0.1, errors
