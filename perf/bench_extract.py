"""Extraction throughput: grid DBSCAN (Taichi) vs scikit-learn, side by side.

Scenes are made by the product (``evstar simulate DIR --preset evk4 --stars N --rate 10
--noise-hz 1 --duration D``, cached) and filtered as the Pipeline filters them (MR-NDSEF with
the calibration window's background rate, hot pixels removed); `Extractor.centroids` then
runs on the kept events with clustering="grid" and "sklearn" in interleaved pairs (the
order alternating), so both see the same machine load. Reported per scene: kept events,
clusters, median time with min-max, kept events/s, and the median of the per-pair ratios
sklearn / grid. Both backends' centroids are checked to agree first.

Scaling: the 50-star scene cut to its first 1, 2 and 4 s (events), and 1, 50 and 200 stars
over 1 s (stars).

    python perf/bench_extract.py [--repeats 5] [--quick] [--cache /tmp/evstar-bench]

Writes perf/results/extract.json and prints a table.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import platform
import subprocess
import sys
import time

import numpy as np

import evstar
from evstar import io
from evstar.extract import Extractor

RESULTS = pathlib.Path(__file__).resolve().parent / "results"


def scene(cache, stars, duration_s):
    """Kept events of the evk4 scene with `stars` stars over `duration_s` s (cached)."""
    d = pathlib.Path(cache) / f"evk4-{stars}-{duration_s:g}s"
    kept = d / "kept.npz"
    if not kept.exists():
        if not (d / "events.h5").exists():
            subprocess.run([sys.executable, "-m", "evstar", "simulate", str(d), "--preset", "evk4",
                            "--stars", str(stars), "--rate", "10", "--noise-hz", "1",
                            "--duration", f"{duration_s:g}"], check=True, capture_output=True)
        ev = io.read(d / "events.h5")
        ev = ev if isinstance(ev, evstar.Events) else ev.events
        pipe = evstar.Pipeline(evstar.Config())
        t0 = int(ev.t[0])
        keep = pipe.make_filter(t0, pipe.calibration_rate(ev, t0)).apply(ev)
        hot = pipe.calibration_hot_pixels(ev, t0)
        if hot is not None:
            keep &= ~hot[ev.y, ev.x]
        k = ev[keep]
        np.savez(kept, t=k.t, x=k.x, y=k.y, p=k.p, size=[ev.width, ev.height], t0=t0, n=len(ev))
    z = np.load(kept)
    ev = evstar.Events(z["t"], z["x"], z["y"], z["p"], int(z["size"][0]), int(z["size"][1]))
    return ev, int(z["t0"]), int(z["n"])


def agree(a, b):
    return (len(a) == len(b) and all(np.array_equal(a[f], b[f]) for f in ("t", "n_events", "split"))
            and np.allclose(a["x"], b["x"], atol=1e-9) and np.allclose(a["y"], b["y"], atol=1e-9))


def compare(ev, t0, repeats):
    """Interleaved timings of both backends on the same events."""
    ex = {c: Extractor(t_origin_us=t0, clustering=c) for c in ("grid", "sklearn")}
    out = {c: ex[c].centroids(ev) for c in ex}  # warm-up (kernel compilation) and check
    times = {c: [] for c in ex}
    for r in range(repeats):
        for c in (("grid", "sklearn") if r % 2 == 0 else ("sklearn", "grid")):
            t = time.perf_counter()
            ex[c].centroids(ev)
            times[c].append(time.perf_counter() - t)
    ratios = np.array(times["sklearn"]) / np.array(times["grid"])
    row = {"kept_events": len(ev), "centroids": len(out["grid"]),
           "split": int(out["grid"]["split"].sum()), "agree": agree(out["grid"], out["sklearn"])}
    for c in ex:
        ts = np.array(times[c])
        row[c] = {"median_s": float(np.median(ts)), "min_s": float(ts.min()), "max_s": float(ts.max()),
                  "kept_events_per_s": float(len(ev) / np.median(ts))}
    row["ratio_sklearn_over_grid"] = {"median": float(np.median(ratios)), "min": float(ratios.min()),
                                      "max": float(ratios.max())}
    return row


def line(name, row):
    g, s, r = row["grid"], row["sklearn"], row["ratio_sklearn_over_grid"]
    return (f"| {name} | {row['kept_events']:,} | {row['centroids']:,} | "
            f"{g['median_s']:.3f} ({g['min_s']:.3f}-{g['max_s']:.3f}) | {g['kept_events_per_s'] / 1e6:.1f} | "
            f"{s['median_s']:.3f} ({s['min_s']:.3f}-{s['max_s']:.3f}) | {s['kept_events_per_s'] / 1e6:.2f} | "
            f"{r['median']:.1f}x ({r['min']:.1f}-{r['max']:.1f}) | {row['agree']} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="1 s scenes, 3 repeats, no scaling")
    ap.add_argument("--cache", default="/tmp/evstar-bench")
    args = ap.parse_args(argv)
    repeats = 3 if args.quick else args.repeats
    rows = {}
    main_s = 1 if args.quick else 4
    ev50, t0, n50 = scene(args.cache, 50, main_s)
    rows["50 stars"] = compare(ev50, t0, repeats) | {"all_events": n50, "duration_s": main_s}
    ev1, t1, n1 = scene(args.cache, 1, main_s)
    rows["1 star"] = compare(ev1, t1, repeats) | {"all_events": n1, "duration_s": main_s}
    if not args.quick:
        for secs in (1, 2):  # events: the 50-star scene's first seconds
            cut = ev50[ev50.t < t0 + secs * 1_000_000]
            rows[f"50 stars, first {secs} s"] = compare(cut, t0, repeats) | {"duration_s": secs}
        for stars in (1, 50, 200):  # stars: 1 s scenes
            ev, ts, n = scene(args.cache, stars, 1)
            rows[f"{stars} stars, 1 s"] = compare(ev, ts, repeats) | {"all_events": n, "duration_s": 1}
    head = ("| scene | kept events | centroids | grid s median (min-max) | grid M ev/s | "
            "sklearn s median (min-max) | sklearn M ev/s | sklearn/grid | same |")
    table = [head, "|" + "---|" * 9] + [line(k, v) for k, v in rows.items()]
    print("\n".join(table))
    RESULTS.mkdir(exist_ok=True)
    meta = {"repeats": repeats, "python": platform.python_version(), "machine": platform.machine(),
            "cpu_threads": evstar.backends.taichi("cpu").lang.impl.current_cfg().cpu_max_num_threads,
            "note": "interleaved pairs in one process; ratio = median over pairs of sklearn/grid"}
    (RESULTS / "extract.json").write_text(json.dumps({"meta": meta, "scenes": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
