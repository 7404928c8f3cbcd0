"""evstar.gyro_repair: spikes removed and long gaps filled in a damaged gyro record, and
the pipeline's stars unharmed by either."""
import warnings

import numpy as np
import pytest

from evstar import Config, Imu, Pipeline, accuracy, sim
from evstar.errors import EvstarWarning
from evstar.gyro_repair import (GAP_INTERVALS, SPIKE_HALF_WINDOW, filled, repair_of, repaired,
                                spikes)


def _smooth_rates(rate_hz, rng):
    """Smooth rate records a real slew makes (rad/s, (n, 3)) at `rate_hz`, with and without
    gyro noise: sinusoids of 0.5-20 Hz, a step, a ramp, a constant rate."""
    t = np.arange(0, 2.0, 1 / rate_hz)
    for f in (0.5, 2.0, 7.0, 20.0):
        g = np.column_stack([np.cos(2 * np.pi * f * t + k) * (1.0 + k) for k in range(3)])
        yield g
        yield g + 0.004 * rng.standard_normal(g.shape)
    yield np.where(t[:, None] > 0.7, 0.3, 0.0) * np.ones(3)
    yield np.column_stack([t, -2 * t, 0.1 + 0 * t])
    yield np.full((len(t), 3), 0.2)


@pytest.mark.parametrize("rate_hz", [100.0, 1000.0])
def test_smooth_motion_has_no_spike(rate_hz):
    for g in _smooth_rates(rate_hz, np.random.default_rng(1)):
        assert not spikes(g).any()


@pytest.mark.parametrize("length", [1, 10, SPIKE_HALF_WINDOW // 2])
def test_a_run_of_corrupt_samples_is_found_exactly(length):
    t = np.arange(0, 1.0, 1e-3)
    g = np.column_stack([np.cos(2 * np.pi * t), np.sin(2 * np.pi * t), 0.2 + 0 * t])
    g += 0.004 * np.random.default_rng(2).standard_normal(g.shape)
    bad = g.copy()
    bad[400:400 + length, 1] *= 50
    bad[[2, 997], 0] *= 30                           # at the record's ends too
    assert np.array_equal(np.flatnonzero(spikes(bad)),
                          np.r_[2, np.arange(400, 400 + length), 997])


def test_a_gap_is_filled_closer_than_a_straight_line():
    t = np.arange(0, 1_000_000, 1000, dtype=np.int64)
    g = np.column_stack([np.cos(2 * np.pi * t * 1e-6) * 1.1, 0.3 * np.sin(6 * t * 1e-6), 0 * t])
    g += 0.004 * np.random.default_rng(3).standard_normal(g.shape)
    keep = (t < 400_000) | (t > 500_000)
    t2, g2, gaps = filled(t[keep], g[keep])
    assert gaps == [102_000]
    assert np.all(np.diff(t2) > 0) and np.array_equal(t2, t)   # the same 1 ms grid again
    inside = ~keep
    line = np.column_stack([np.interp(t[inside], t[keep], g[keep, k]) for k in range(3)])
    # the angle a fill gets wrong over the gap, against a straight line's
    err_fill = np.abs((g2[inside] - g[inside]).sum(0)) * 1e-3
    err_line = np.abs((line - g[inside]).sum(0)) * 1e-3
    assert err_fill[0] < err_line[0] / 5


def test_short_holes_and_straight_gaps_are_left_to_the_line():
    t = np.arange(0, 200_000, 1000, dtype=np.int64)
    g = np.cos(2 * np.pi * 5 * t * 1e-6)[:, None] * np.ones(3)      # curving: a 5 Hz swing
    keep = np.ones(len(t), bool)
    keep[[10, 11, 30, 50, 51, 52]] = False              # up to 4 intervals: no fill
    t2, g2, gaps = filled(t[keep], g[keep])
    assert gaps == [] and np.array_equal(t2, t[keep])
    keep[60:60 + GAP_INTERVALS] = False                 # GAP_INTERVALS + 1 intervals: filled
    assert len(filled(t[keep], g[keep])[2]) == 1
    ramp = 0.5 + 2.0 * t[:, None] * 1e-6 * np.ones(3) # a steady change of rate: the line is right
    noisy = ramp + 0.004 * np.random.default_rng(4).standard_normal(ramp.shape)
    assert filled(t[keep], noisy[keep])[2] == []


def test_a_clean_record_is_returned_as_is_and_a_repair_is_told():
    t = np.arange(0, 1_000_000, 1000, dtype=np.int64)
    g = np.column_stack([np.cos(2 * np.pi * t * 1e-6), 0 * t, 0 * t])
    imu = Imu(t, g, time_offset_us=300)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert repaired(imu) is imu and repaired(None) is None
    g[500:505, 0] = 40.0
    keep = (t < 100_000) | (t > 200_000)
    bad = Imu(t[keep], g[keep], time_offset_us=300)
    with pytest.warns(EvstarWarning, match="5 spike sample.*2 gap.* 0.102 s"):
        out = repaired(bad)
    assert out.time_offset_us == 300 and len(out) == len(t)
    assert np.abs(out.gyro[:, 0] - np.cos(2 * np.pi * out.t * 1e-6)).max() < 0.01
    assert repair_of(out)[1].summary() == ""           # a repaired record needs no more


@pytest.fixture(scope="module")
def sinusoid():
    return sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=4.0), seed=3)


def _mean_error(run, imu, repair=True):
    cfg = Config().replace(**{"motion.compensate": "imu", "motion.repair_gyro": repair})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EvstarWarning)
        res = Pipeline(cfg).run(run.events, imu, run.camera)
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    return float(err[star >= 0].mean()), int(np.count_nonzero(star < 0))


def test_a_damaged_gyro_record_leaves_the_star_where_a_clean_one_puts_it(sinusoid):
    """The paper's sinusoid through its fastest stretch: a 100 ms gap put the star 0.162 px
    off (motion.repair_gyro off; 0.121 since the fifty-first session's lag fit by
    generalised least squares) and ten 50x samples 0.121 px with 7 false rows (the clean
    gyro: 0.023)."""
    imu = sinusoid.imu
    clean, _ = _mean_error(sinusoid, imu)
    keep = (imu.t < 400_000) | (imu.t > 500_000)
    gap, false_gap = _mean_error(sinusoid, Imu(imu.t[keep], imu.gyro[keep]))
    as_is, _ = _mean_error(sinusoid, Imu(imu.t[keep], imu.gyro[keep]), repair=False)
    assert as_is > clean + 0.08
    g = imu.gyro.copy()
    g[300:310] *= 50
    spiked, false_spiked = _mean_error(sinusoid, Imu(imu.t, g))
    assert gap < clean + 0.02 and spiked < clean + 0.02
    assert false_gap == 0 and false_spiked == 0


def test_a_gap_no_arc_can_bridge_stays_within_its_neighbours_range():
    """Several turns of a 10 Hz vibration lost in a 300 ms gap: no fill can know them, but
    it must not swing beyond what the samples around the gap show (a free spline: 5x)."""
    t = np.arange(0, 3_000_000, 10_000, dtype=np.int64)
    g = np.cos(2 * np.pi * 10 * t * 1e-6)[:, None] * np.ones(3)
    keep = (t < 1_000_000) | (t > 1_300_000)
    t2, g2, gaps = filled(t[keep], g[keep])
    assert len(gaps) == 1 and np.abs(g2).max() <= 2.0


@pytest.mark.parametrize("mode", ["imu", "none"])
def test_a_run_warns_once_of_a_repair_its_pipeline_and_attitude_both_read(tmp_path, mode):
    """`evstar run` (runs.run_recording) reads the gyro twice, in the pipeline (compensate
    imu) and in the attitude after it: one warning of the repair either way."""
    import warnings

    from evstar import Config, io, runs
    from evstar.errors import EvstarWarning
    from evstar.imu import Imu

    cam = sim.camera_preset("davis346", 16.0)
    traj = sim.ConstantRate(20.0, R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(cam, traj, 0.15, mag_limit=5.0)
    run = sim.simulate(sim.Scenario(cam, stars, traj, 0.15), seed=2)
    gyro = run.imu.gyro.copy()
    gyro[60:63] *= 40.0                                     # three corrupt samples
    io.write(tmp_path / "ev.h5", run.events, camera=cam,
             imu=Imu(run.imu.t, gyro, run.imu.accel))
    cfg = Config().replace(**{"motion.compensate": mode})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        runs.run_recording(tmp_path / "ev.h5", tmp_path / "out", cfg)
    told = [w for w in caught if issubclass(w.category, EvstarWarning)
            and "IMU record was repaired" in str(w.message)]
    assert len(told) == 1, [str(w.message) for w in caught]
