"""Cost of the star-position estimators inside the whole pipeline (CPU).

The paper's 10°/1 Hz sinusoid on its camera (one magnitude-3 star, 1.5 Hz/pixel background),
`--duration` seconds long; per estimator (mean, track, crossings) the pipeline runs once to
warm up and then `--repeat` times; medians (and ranges) of each stage's seconds.

    python perf/bench_estimators.py [--duration 4] [--repeat 5] [--slew]

Writes perf/results/estimators.json and prints a table. --slew: instead a field where every
track speeds up and slows down without an IMU (the crossings estimator's acceleration refit,
evstar.kalman_ca): Orion through a DAVIS346 behind 8 mm, slewed rest to rest in 1 s peaking
at 8 °/s, 1.5 Hz of background, seed 61 (~370 stars); perf/results/estimators_slew.json.
"""
from __future__ import annotations

import argparse
import pathlib
import statistics

from evstar import Config, Pipeline, sim
from evstar.profiling import table, write_results

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
COLUMNS = [("estimator", "estimator", ""), ("rows", "rows", ","), ("extract_s", "extract s", ".3f"),
           ("estimate_s", "estimate s (min-max)", ""), ("us_per_row", "estimate µs/row", ".0f"),
           ("total_s", "pipeline s", ".3f"), ("x_real_time", "× real time", ".1f")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--slew", action="store_true", help="the slewed star field instead")
    args = ap.parse_args(argv)
    if args.slew:
        scene = sim.field_scenario(sim.camera_preset("davis346", 8.0), 83.8, -5.4, 8.0, 1.0,
                                   motion="slew", noise_hz=1.5)
        run, args.duration = sim.simulate(scene, seed=61), 1.0
    else:
        run = sim.simulate(sim.paper_sinusoid(duration_s=args.duration), seed=1)
    rows = []
    for name in ("mean", "track", "crossings"):
        pipe = Pipeline(Config().replace(**{"estimate.estimator": name}))
        parts = (run.events, run.imu, run.camera) if args.slew else (run.events,)
        pipe.run(*parts)                                        # compile and warm up
        runs = [pipe.run(*parts) for _ in range(args.repeat)]
        est = [r.timings_s.get("estimate", 0.0) for r in runs]
        total = statistics.median(sum(r.timings_s.values()) for r in runs)
        n = len(runs[0].centroids)
        rows.append({"estimator": name, "rows": n, "events": len(run.events),
                     "extract_s": statistics.median(r.timings_s["extract"] for r in runs),
                     "estimate_s": f"{statistics.median(est):.3f} ({min(est):.3f}-{max(est):.3f})",
                     "us_per_row": statistics.median(est) / max(n, 1) * 1e6, "total_s": total,
                     "x_real_time": args.duration / total})
    write_results(RESULTS / ("estimators_slew.json" if args.slew else "estimators.json"), rows,
                  {"duration_s": args.duration, "repeat": args.repeat, "slew": args.slew,
                   "events": len(run.events)})
    print(table(rows, COLUMNS))


if __name__ == "__main__":
    main()
