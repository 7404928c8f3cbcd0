"""End to end on the simulator: the paper's magnitude-3 star at 12 °/s through the Pipeline
(MR-NDSEF auto thresholds, no motion compensation) is found in every frame, to < 0.3 px."""
import numpy as np

import evstar
from evstar import accuracy, sim


def test_pipeline_centroids_paper_star_12dps():
    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.2), seed=1)
    cfg = evstar.Config(dt_us=10_000).replace(**{"motion.compensate": "none"})
    result = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera, truth=run.truth)
    m, c = result.metrics, result.centroids

    t0 = int(run.events.t[0])
    frames = np.arange(int((run.events.t[-1] - t0) // cfg.dt_us) + 1)
    assert len(frames) == 20
    detected, _ = accuracy.detection(c, run.truth.star_position, frames, t0 + frames * cfg.dt_us + cfg.dt_us // 2,
                                     run.camera.width, run.camera.height)
    assert detected == 1.0
    assert m["centroids_matched"] == m["centroids"] == len(frames)   # no spurious centroid
    assert m["centroid_error_px"]["mean"] < 0.3
    assert m["centroid_error_px"]["max"] < 1.0
    assert m["tracks"] == 1 and np.all(c["track"] == 0)             # one unbroken track
