"""A/B of the particle filter's accuracy (issue 13): the filter at a git revision (A, --before)
against the working tree (B), for changes that alter its random draws or arithmetic.

paper_fig8_motion.py runs one filter seed per scene, so its pf rows move by the filter's
Monte Carlo noise whenever the draws change; here each scene's observations (the pipeline's
first pass, identical for A and B) go through both filters with --seeds filter seeds, and
the differences are paired. Scenes: the paper's turntable runs at 4, 12, 20 °/s (4 scene
seeds each) and the 10°/1 Hz sinusoid (2), with paper_fig8_motion's realistic IMU.
Per run: the attitude drift (px, paper_fig8_motion.attitude_drift_px) and the final gyro
bias error per axis (°/s).

    python perf/ab_pf_accuracy.py --before main [--seeds 8]

Prints the table and writes perf/results/ab_pf_accuracy.json.
"""
import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).parent))
from ab_pipeline import Versions  # noqa: E402

from evstar import profiling  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "ab_pf_accuracy.json"
COLUMNS = [("measure", "measure", ""), ("a", "mean A", ".4f"), ("b", "mean B", ".4f"),
           ("b_minus_a", "paired B − A", "+.4f"), ("se", "± s.e.", ".4f")]


def scenes(fig8):
    return ([(f"rate {r:g} s{s}", fig8.rate_run(r, s)) for r in (4.0, 12.0, 20.0) for s in range(4)]
            + [(f"sinusoid s{s}", fig8.sinusoid_run(s)) for s in range(2)])


def observations(m, run):
    """Tracked centroids of an IMU-compensated pass, as the pipeline's filter gets them
    (Pipeline._particle_filter; without its hot-pixel drop and pooled look: the same for A
    and B, which is what the pairing needs)."""
    pipe = m.Pipeline(m.Config().replace(**{"motion.compensate": "pf"}))
    t0 = int(run.events.t[0])
    rate, _ = pipe.calibration(run.events, t0)
    _, cents, _, _ = pipe._chunk(run.events, run.imu, run.camera, t0, rate, "imu", None)
    tracked = pipe.make_tracker().link(cents)
    obs = tracked[(tracked["track"] >= 0) & ~tracked["border"]]
    return {k: np.asarray(obs[k]) for k in ("t", "track", "x", "y")}


def errors(m, fig8, run, obs, seeds):
    """(drift px, |final bias error| °/s per axis) per filter seed."""
    from evstar.motion import ParticleFilter

    imu = m.Imu(run.imu.t, run.imu.gyro, run.imu.accel, R_cam_imu=run.imu.R_cam_imu,
                time_offset_us=run.imu.time_offset_us)   # this version's class
    out = []
    for seed in range(seeds):
        fr = ParticleFilter(seed=seed).run(imu, obs, run.camera)
        drift = fig8.attitude_drift_px(fr.attitude_track(imu), run.truth, run.events.t[0],
                                       run.events.t[-1])
        bias = np.abs(np.degrees(fr.bias[-1] - fig8.true_bias_cam(run.truth, fr.t_us[-1:])[0]))
        out.append([drift, *bias])
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, help="git revision of A")
    ap.add_argument("--seeds", type=int, default=8)
    a = ap.parse_args()
    v = Versions(a.before)
    m = v.use("A")
    import paper_fig8_motion as fig8

    runs = scenes(fig8)
    obs = [observations(m, run) for _, run in runs]
    res = {}
    for tag in ("A", "B"):
        m = v.use(tag)
        res[tag] = np.stack([errors(m, fig8, run, o, a.seeds) for (_, run), o in zip(runs, obs)])
    d = (res["B"] - res["A"]).reshape(-1, 4)
    n = len(d)
    names = ("drift px", "|bias err| x °/s", "|bias err| y °/s", "|bias err| z °/s")
    rows = [{"measure": name, "a": float(res["A"][..., k].mean()), "b": float(res["B"][..., k].mean()),
             "b_minus_a": float(d[:, k].mean()), "se": float(d[:, k].std() / np.sqrt(n))}
            for k, name in enumerate(names)]
    print(f"{len(runs)} scenes x {a.seeds} filter seeds: mean A, mean B, paired B - A ± s.e.")
    print(profiling.table(rows, COLUMNS))
    profiling.write_results(RESULTS, rows, {"before": a.before, "seeds": a.seeds,
                                            "scenes": [name for name, _ in runs]})
    for (name, _), ra, rb in zip(runs, res["A"], res["B"]):
        print(f"  {name:14s} drift A {ra[:, 0].mean():.3f} B {rb[:, 0].mean():.3f}")


if __name__ == "__main__":
    main()
