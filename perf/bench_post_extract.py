"""Everything after extraction, old code against new, stage by stage (CPU).

The scene of issue 13: `evstar simulate DIR --preset evk4 --stars 50 --rate 10 --noise-hz 1
--duration 4` (1280×720, 5 M events; made when DIR does not hold it). One run of the
current pipeline gives the stages' inputs (the kept events, the linked centroids, the
crossings); the old code is the package as of git revision `--old` (default: the commit
before this work), imported from `git archive` under another name. Per stage and repeat,
old and new run back to back on the same inputs, in alternating order; the table gives
the medians (min–max) of each and of the per-pair ratios new/old, and checks that both
give the same result (max |Δ| of the estimated positions, px).

    python perf/bench_post_extract.py [--scene /tmp/fe/s50] [--stars 50] [--repeat 7]
        [--old bb74327]

Stages: compensate (mode 'none', with the pipeline's reads of its result), crossings
(estimation.chunk_crossings), track (tracking.Tracker.link), estimate
(estimation.estimate, crossings estimator).
Writes perf/results/post_extract.json and prints a table.
"""
from __future__ import annotations

import argparse
import importlib
import io
import pathlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

import evstar
from evstar.profiling import table, write_results

ROOT = pathlib.Path(__file__).resolve().parents[1]
RESULTS = ROOT / "perf" / "results" / "post_extract.json"
OLD_REV = "bb74327"   # the branch point of the fast-estimate work
COLUMNS = [("stage", "stage", ""), ("old_s", "old s (min-max)", ""),
           ("new_s", "new s (min-max)", ""), ("ratio", "new/old (min-max)", ""),
           ("speedup", "speed-up", ".1f"), ("max_diff", "max |Δ| px", "")]


def old_package(rev):
    """The evstar package at git revision `rev`, imported as `evstar_old`."""
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="evstar_old_"))
    tar = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "evstar"], check=True,
                         capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(tar)) as t:
        t.extractall(tmp, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    (tmp / "evstar").rename(tmp / "evstar_old")
    sys.path.insert(0, str(tmp))
    return importlib.import_module("evstar_old")


def scene(path, stars):
    path = pathlib.Path(path)
    if not (path / "events.h5").exists():
        from evstar.cli import main as cli

        cli(["simulate", str(path), "--preset", "evk4", "--stars", str(stars), "--rate", "10",
             "--noise-hz", "1", "--duration", "4"])
    from evstar.runs import read_recording

    return read_recording(path / "events.h5", camera=path / "camera.json", imu=path / "imu.csv")


def inputs(rec, config):
    """Kept events, linked centroids and crossings of the current pipeline (stages' inputs)."""
    from evstar.pipeline import _RunState

    ev = rec.events
    pipe = evstar.Pipeline(config)
    t0 = int(ev.t[0])
    state = _RunState(config, ev.width, ev.height, t0,
                      pipe.calibration_hot_pixels(ev, t0))
    keep, cents, _, _ = pipe._chunk(ev, None, None, t0, pipe.calibration_rate(ev, t0), "none",
                                    None, state=state)
    linked = pipe.make_tracker().link(cents)
    crossings = state.crossings()
    return {"t0": t0, "keep": keep, "cents": cents, "linked": linked, "crossings": crossings,
            "span": (int(ev.t[0]), int(ev.t[-1])), "sensor": (ev.width, ev.height)}


def stages(pkg, rec, d, config):
    """{stage: fn() -> result} of package `pkg` (evstar or evstar_old)."""
    ev, keep = rec.events, d["keep"]
    est_mod = importlib.import_module(pkg.__name__ + ".estimation")
    tracking = importlib.import_module(pkg.__name__ + ".tracking")
    comp_mod = importlib.import_module(pkg.__name__ + ".motion.compensate")

    def compensate():
        comp = comp_mod.compensate(ev, None, None, config.dt_us, "none", t0_us=d["t0"],
                                   backend="warp")
        ev_f, idx = comp.events()
        kept = idx[keep]
        xy = comp.coordinates(kept) if hasattr(comp, "coordinates") else \
            np.column_stack([comp.x[kept], comp.y[kept]])
        return xy

    return {
        "compensate": compensate,
        "crossings": lambda: est_mod.chunk_crossings(ev, keep, config.estimate.crossing_radius_px),
        "track": lambda: tracking.Tracker().link(d["cents"]),
        "estimate": lambda: est_mod.estimate(d["linked"], config, d["t0"], d["crossings"], None,
                                             d["span"], d["sensor"]),
    }


def difference(a, b):
    """Max |Δ| (px) of positions, or of the arrays; inf when shapes or any non-float field
    (times, pixels, track ids, flags) differ."""
    if isinstance(a, np.ndarray) and a.dtype.names:
        exact = [f for f in a.dtype.names if a.dtype[f].kind != "f"] + ["t"]
        if len(a) != len(b) or not all(np.array_equal(a[f], b[f]) for f in exact):
            return float("inf")
        names = [f for f in ("x", "y") if a.dtype[f].kind == "f"] if "x" in a.dtype.names else []
        return max([float(np.max(np.abs(a[f] - b[f]), initial=0.0)) for f in names], default=0.0)
    return float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float)), initial=0.0)) \
        if np.shape(a) == np.shape(b) else float("inf")


def _span(values, fmt=".3f"):
    return f"{statistics.median(values):{fmt}} ({min(values):{fmt}}-{max(values):{fmt}})"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="/tmp/evstar_bench/s50")
    ap.add_argument("--stars", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--old", default=OLD_REV, help="git revision of the old code")
    args = ap.parse_args(argv)
    config = evstar.Config()
    rec = scene(args.scene, args.stars)
    old = old_package(args.old)
    d = inputs(rec, config)
    fns = {"old": stages(old, rec, d, config), "new": stages(evstar, rec, d, config)}
    times = {s: {"old": [], "new": []} for s in fns["new"]}
    diff = {}
    for i in range(args.repeat + 1):                 # the first round warms up
        for stage in times:
            for which in (("old", "new") if i % 2 else ("new", "old")):
                t = time.perf_counter()
                out = fns[which][stage]()
                if i:
                    times[stage][which].append(time.perf_counter() - t)
                if i == 0:
                    diff.setdefault(stage, {})[which] = out
    rows = []
    for stage, tt in times.items():
        ratio = [n / o for n, o in zip(tt["new"], tt["old"])]
        rows.append({"stage": stage, "old_s": _span(tt["old"]), "new_s": _span(tt["new"]),
                     "ratio": _span(ratio), "speedup": 1 / statistics.median(ratio),
                     "max_diff": f"{difference(diff[stage]['new'], diff[stage]['old']):.1e}",
                     "old_runs_s": tt["old"], "new_runs_s": tt["new"]})
    total = {w: [sum(times[s][w][i] for s in times) for i in range(args.repeat)] for w in ("old", "new")}
    ratio = [n / o for n, o in zip(total["new"], total["old"])]
    rows.append({"stage": "all", "old_s": _span(total["old"]), "new_s": _span(total["new"]),
                 "ratio": _span(ratio), "speedup": 1 / statistics.median(ratio), "max_diff": ""})
    meta = {"scene": str(args.scene), "events": len(rec.events), "stars": args.stars,
            "tracks": int(len(np.unique(d["linked"]["track"][d["linked"]["track"] >= 0]))),
            "crossings": len(d["crossings"]), "repeat": args.repeat, "old": args.old}
    write_results(RESULTS if args.stars == 50 else RESULTS.with_name(f"post_extract_{args.stars}.json"),
                  rows, meta)
    print(meta)
    print(table(rows, COLUMNS))


if __name__ == "__main__":
    main()
