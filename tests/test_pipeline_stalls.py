"""A readout that stalled (no event at all for longer than a frame): the background is
measured over the time the sensor sent events, and no pixel crossing pairs levels across
the stall."""
import numpy as np
import pytest

from evstar import Config, Pipeline, estimation, sim
from evstar.frames import stalled_us, unstalled


def test_stalls_are_the_gaps_beyond_a_frame():
    t = np.array([0, 5, 10_000, 10_020, 40_000, 40_001], np.int64)
    assert unstalled(t, 10_000) == [(0, 4), (4, 6)]
    assert stalled_us(t, 10_000) == 40_000 - 10_020 - 10_000
    assert stalled_us(t, 10_000, start_us=-25_000) == 15_000 + 19_980
    assert unstalled(t[:2], 10_000) == [(0, 2)] and stalled_us(t[:2], 10_000) == 0


@pytest.fixture(scope="module")
def stalled():
    run = sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=4.0), seed=62)
    ev = run.events
    return run, ev[(ev.t < 400_000) | (ev.t > 700_000)]


def test_the_background_rate_is_not_diluted_by_a_stall(stalled):
    run, ev = stalled
    pipe = Pipeline(Config())
    # the calibration window (2 s) holds the whole run and its stall
    assert pipe.calibration_rate(ev, 0) == pytest.approx(pipe.calibration_rate(run.events, 0),
                                                         rel=0.05)


def test_no_crossing_pairs_levels_across_a_stall(stalled, monkeypatch):
    """(An ON event before a 300 ms stall and an OFF after it made a crossing 100 px off.)"""
    run, ev = stalled
    got = []
    real = estimation.estimate

    def seen(centroids, config, t0_us, crossings=None, *args, **kwargs):   # the run's own
        got.append(crossings)
        return real(centroids, config, t0_us, crossings, *args, **kwargs)

    monkeypatch.setattr(estimation, "estimate", seen)
    res = Pipeline(Config().replace(**{"motion.compensate": "imu"})).run(ev, run.imu, run.camera)
    t = got[0]["t"]
    assert len(t) and not np.any((t > 400_000 + 10_000) & (t < 700_000 - 10_000))
    assert res.metrics.get("background_hz") is None
