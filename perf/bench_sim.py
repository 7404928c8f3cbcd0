"""Simulator throughput: wall time and events/s of evstar.sim.simulate for ~10 M-event streams.

Scenes (each run long enough to give --events events):
  paper-sinusoid  the paper's camera (DVXplorer Lite, 12 mm), magnitude-3 star on the 10°/1 Hz
                  sinusoid, 1.5 Hz/pixel background, 5 hot pixels: mostly noise events
  star-field      DVXplorer 640x480 on the 10°/1 Hz sinusoid around Orion, the Hipparcos stars
                  to magnitude 6.5 that come into view, 1.5 Hz/pixel background: mostly star events
  noise-only      DVXplorer 640x480, no stars, 1.5 Hz/pixel background and 5 hot pixels

    python perf/bench_sim.py [--events 1e7] [--repeat 3] [--scenes paper-sinusoid,star-field]

Writes perf/results/sim.json and prints a table; the median of the repeats is quoted.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import platform
import statistics
import time

import numpy as np

from evstar import sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "sim.json"


def scene(name, duration_s):
    if name == "paper-sinusoid":
        return sim.paper_sinusoid(duration_s=duration_s)
    cam = sim.camera_preset("dvxplorer")
    if name == "noise-only":
        return sim.Scenario(cam, sim.StarField.empty(), sim.ConstantRate(10.0), duration_s)
    if name == "star-field":
        motion = sim.Sinusoid(10.0, 1.0, R0=sim.attitude_from_radec(83.8, -5.4))
        stars = sim.hipparcos_field_along(cam, motion, 1.0, mag_limit=6.5)  # one period sweeps it all
        return sim.Scenario(cam, stars, motion, duration_s)
    raise ValueError(f"unknown scene {name!r}")


def duration_for(name, n_events):
    """Seconds of simulated time that give about n_events: a 0.5 s pilot run, then one
    full-length run to correct for stars entering and leaving the field (also a warm-up)."""
    duration = n_events / (len(sim.simulate(scene(name, 0.5), seed=0).events) / 0.5)
    return duration * n_events / len(sim.simulate(scene(name, duration), seed=0).events)


def bench(name, n_events, repeat):
    duration = duration_for(name, n_events)
    scn = scene(name, duration)
    walls, run = [], None
    for i in range(repeat):
        t0 = time.perf_counter()
        run = sim.simulate(scn, seed=i)
        walls.append(time.perf_counter() - t0)
    labels = run.truth.labels
    med = statistics.median(walls)
    return dict(scene=name, sensor=f"{scn.camera.width}x{scn.camera.height}", stars=len(scn.stars),
                simulated_s=round(duration, 3), events=len(run.events),
                star_events=int((labels >= 0).sum()), noise_events=int((labels == -1).sum()),
                hot_pixel_events=int((labels == -2).sum()), wall_s=[round(w, 3) for w in walls],
                median_s=round(med, 3), events_per_s=round(len(run.events) / med),
                star_events_per_s=round(int((labels >= 0).sum()) / med))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=float, default=1e7)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", default="paper-sinusoid,star-field,noise-only")
    ap.add_argument("--out", default=str(RESULTS))
    args = ap.parse_args(argv)
    rows = [bench(name, int(args.events), args.repeat) for name in args.scenes.split(",")]
    report = dict(benchmark="evstar.sim.simulate", numpy=np.__version__, python=platform.python_version(),
                  machine=platform.machine(), cpu_count=os.cpu_count(),
                  date=time.strftime("%Y-%m-%d %H:%M:%S"), repeat=args.repeat, results=rows)
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(report, indent=2) + "\n")
    os.replace(tmp, out)
    head = f"{'scene':16s} {'sensor':9s} {'stars':>5s} {'sim s':>7s} {'events':>11s} {'star ev':>10s} " \
           f"{'median s':>9s} {'M ev/s':>7s} {'M star ev/s':>11s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['scene']:16s} {r['sensor']:9s} {r['stars']:5d} {r['simulated_s']:7.2f} {r['events']:11,d} "
              f"{r['star_events']:10,d} {r['median_s']:9.2f} {r['events_per_s'] / 1e6:7.2f} "
              f"{r['star_events_per_s'] / 1e6:11.2f}")
    print(f"(median of {args.repeat}; written to {out})")


if __name__ == "__main__":
    main()
