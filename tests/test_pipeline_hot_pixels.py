"""Hot pixels are never reported as stars by the pipeline, whatever the estimator."""
import numpy as np
import pytest

import evstar
from evstar import sim


@pytest.fixture(scope="module")
def run():
    sensor = sim.SensorSpec(hot_pixels=40, hot_pixel_hz=800.0)
    return sim.simulate(sim.paper_preset(8.0, duration_s=0.3, sensor=sensor), seed=5)


def on_hot(rows, run):
    w = run.events.width
    hot = set(run.truth.hot_pixels.tolist())
    pix = (np.floor(rows["y"] + 0.5) * w + np.floor(rows["x"] + 0.5)).astype(np.int64)
    return np.array([p in hot for p in pix])


@pytest.mark.parametrize("estimator", ["mean", "crossings"])
def test_no_position_on_a_hot_pixel(run, estimator):
    cfg = evstar.Config().replace(**{"estimate.estimator": estimator, "denoise.method": "ndsef",
                                     "denoise.threshold": 2})   # a loose filter lets them through
    rows = evstar.Pipeline(cfg).run(run.events).centroids
    assert len(rows) > 20 and not on_hot(rows, run).any()
    off = cfg.replace(**{"hotpixels.remove": False})
    assert on_hot(evstar.Pipeline(off).run(run.events).centroids, run).any()   # they were there
