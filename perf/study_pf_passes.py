"""What a second pass in pf mode would buy (issue 13): until the eighth session Pipeline.run
with motion.compensate = "pf" ran a first pass with IMU compensation (its tracked centroids
feed the particle filter), then compensated, denoised and extracted again with the filter's
bias-corrected gyro; this study (run before pf became one pass) is why it is one pass now.

Per star-field scene (bench_pipeline.py --fields): how far the second pass moves each event
(px) and how many change rounded pixel; how far its centroids lie from the first pass's
(nearest, same frame); both passes' centroid errors against the simulator's truth; and the
filter's gyro-bias error (camera frame, °/s, RMS after 1 s, mean of --seeds filter seeds)
from every frame's observations and from every second frame's (a first pass on half the
frames would cost half).

    python perf/study_pf_passes.py [--stars 50,100] [--seeds 4]

Writes perf/results/study_pf_passes.json and .md.
"""
import argparse
import pathlib
import sys

import numpy as np

from evstar import Config, Pipeline, accuracy, bench, profiling
from evstar.motion import ParticleFilter

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from paper_fig8_motion import true_bias_cam  # noqa: E402

RESULTS = pathlib.Path(__file__).parent / "results"
SCENE = "--preset evk4 --stars {} --rate 10 --noise-hz 1 --duration 4"
COLUMNS = [("stars", "stars", ""), ("event_shift_p99_px", "event shift p99 px", ".4f"),
           ("pixel_changed_pct", "events changing pixel %", ".2f"),
           ("centroid_shift_median_px", "centroid shift median px", ".4f"),
           ("centroid_shift_p99_px", "centroid shift p99 px", ".4f"),
           ("error_pass1_px", "error pass 1 mean px", ".4f"),
           ("error_pass2_px", "error pass 2 mean px", ".4f"),
           ("bias_rms_all_dps", "bias RMS all frames °/s", ""),
           ("bias_rms_half_dps", "bias RMS every 2nd frame °/s", "")]


def _shift(c1, c2):
    """Distance of each first-pass centroid to the nearest second-pass one of its frame."""
    out = []
    for t in np.intersect1d(c1["t"], c2["t"]):
        a, b = c1[c1["t"] == t], c2[c2["t"] == t]
        out.append(np.hypot(a["x"][:, None] - b["x"], a["y"][:, None] - b["y"]).min(1))
    return np.concatenate(out)


def _bias_rms(obs, imu, camera, truth, seeds, every):
    """Mean over filter seeds of the per-axis bias error RMS after 1 s (°/s)."""
    keep = np.isin(obs["t"], np.unique(obs["t"])[::every])
    sub = {k: obs[k][keep] for k in ("t", "track", "x", "y")}
    rms = []
    for seed in range(seeds):
        r = ParticleFilter(seed=seed).run(imu, sub, camera)
        b_true = true_bias_cam(truth, r.t_us)
        late = r.t_us >= r.t_us[0] + 1_000_000
        rms.append(np.sqrt(np.mean(np.degrees(r.bias - b_true)[late] ** 2, 0)))
    return np.round(np.mean(rms, 0), 4).tolist()


def study(stars, seeds):
    run = bench.field_scene(SCENE.format(stars).split())
    ev, imu, cam = run.events, run.imu, run.camera
    pipe = Pipeline(Config().replace(**{"motion.compensate": "pf"}))
    t0 = int(ev.t[0])
    rate, _ = pipe.calibration(ev, t0)
    _, c1, _, comp1 = pipe._chunk(ev, imu, cam, t0, rate, "imu", None)
    fr, _ = pipe._particle_filter(c1, imu, cam)
    _, c2, _, comp2 = pipe._chunk(ev, imu, cam, t0, rate, "pf", fr)
    moved = np.hypot(comp2.x - comp1.x, comp2.y - comp1.y)
    changed = (comp1.xi != comp2.xi) | (comp1.yi != comp2.yi)
    shift = _shift(c1, c2)
    errors = [accuracy.match(c, run.truth.star_position, 3.0) for c in (c1, c2)]
    tracked = pipe.make_tracker().link(c1)
    obs = tracked[(tracked["track"] >= 0) & ~tracked["border"]]
    return {"stars": stars, "event_shift_p99_px": float(np.nanpercentile(moved, 99)),
            "pixel_changed_pct": 100 * float(changed.mean()),
            "centroid_shift_median_px": float(np.median(shift)),
            "centroid_shift_p99_px": float(np.percentile(shift, 99)),
            "error_pass1_px": float(errors[0][1][errors[0][0] >= 0].mean()),
            "error_pass2_px": float(errors[1][1][errors[1][0] >= 0].mean()),
            "bias_rms_all_dps": _bias_rms(obs, imu, cam, run.truth, seeds, 1),
            "bias_rms_half_dps": _bias_rms(obs, imu, cam, run.truth, seeds, 2)}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--stars", default="50,100")
    ap.add_argument("--seeds", type=int, default=4)
    a = ap.parse_args()
    rows = [study(int(s), a.seeds) for s in a.stars.split(",")]
    text = profiling.table(rows, COLUMNS)
    profiling.write_results(RESULTS / "study_pf_passes.json", rows, vars(a))
    (RESULTS / "study_pf_passes.md").write_text(text + "\n")
    print(text)
