"""A/B of the close-pair split (issue 13): evstar/extract.py and the cluster kernels at a
git revision (A, --before) against the working tree (B), in one process, interleaved pairs.
Asserts identical centroids (every field) for each compensate mode. Writes
perf/results/ab_split.json and prints the table.

    python perf/ab_split.py /tmp/scene_split/events.h5 --before <rev> --pairs 5
"""
import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import evstar
import evstar.pipeline
from evstar import extract, profiling

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
COLUMNS = [("compensate", "compensate", ""), ("variant", "variant", ""),
           ("centroids", "centroids", ","), ("extract_median_s", "extraction median s", ".3f"),
           ("extract_range_s", "range s", ""), ("pipeline_median_s", "pipeline median s", ".3f"),
           ("pipeline_range_s", "range s", "")]


_DIR = tempfile.mkdtemp(prefix="ab_split_")


def _load(name, source):
    """Module `name` from source text (written to a file: Taichi reads kernels' source)."""
    path = os.path.join(_DIR, name.replace(".", "_") + ".py")
    with open(path, "w") as f:
        f.write(source)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def before_extractor(rev):
    """evstar.extract.Extractor as it was at `rev`, with that revision's split kernels."""
    def show(path):
        return subprocess.run(["git", "show", f"{rev}:{path}"], check=True, capture_output=True,
                              text=True).stdout

    _load("evstar_kernels.taichi._ab_clusters", show("kernels/taichi/clusters.py"))
    src = show("kernels/taichi/clusters_launch.py").replace(
        "from . import clusters, launch", "from . import _ab_clusters as clusters, launch")
    _load("evstar_kernels.taichi._ab_launch", src)
    src = show("evstar/extract.py").replace(
        "from evstar_kernels.taichi import clusters_launch",
        "from evstar_kernels.taichi import _ab_launch as clusters_launch")
    return _load("evstar._ab_extract", src).Extractor


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("path")
    ap.add_argument("--before", default="HEAD")
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--modes", default="none,imu")
    args = ap.parse_args()
    rec = evstar.io.read(args.path)
    ev, imu, cam = rec.events, rec.imu, rec.camera
    variants = {"A": before_extractor(args.before), "B": extract.Extractor}
    stage = {}  # extraction seconds of the last run (Extractor.centroids, summed)

    def timed(cls):
        class Timed(cls):
            def centroids(self, *a, **k):
                t = time.perf_counter()
                try:
                    return super().centroids(*a, **k)
                finally:
                    stage["s"] = stage.get("s", 0.0) + time.perf_counter() - t
        return Timed

    variants = {k: timed(v) for k, v in variants.items()}
    rows = []
    for mode in args.modes.split(","):
        pipe = evstar.Pipeline(evstar.Config().replace(**{"motion.compensate": mode}))
        res, times = {}, {"A": ([], []), "B": ([], [])}
        for v in ("A", "B"):  # warm-up (compiles)
            evstar.pipeline.Extractor = variants[v]
            res[v] = pipe.run(ev, imu, cam)
        for name in res["A"].centroids.dtype.names:
            a, b = res["A"].centroids[name], res["B"].centroids[name]
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), (mode, name)
        for i in range(args.pairs):
            for v in (("A", "B") if i % 2 == 0 else ("B", "A")):
                evstar.pipeline.Extractor = variants[v]
                stage.clear()
                t = time.perf_counter()
                r = pipe.run(ev, imu, cam)
                times[v][1].append(time.perf_counter() - t)
                times[v][0].append(stage["s"])
                assert len(r.centroids) == len(res["A"].centroids)
        for v in ("A", "B"):
            ex, whole = (np.array(t) for t in times[v])
            rows.append(dict(compensate=mode, variant=f"{v} ({args.before})" if v == "A" else
                             f"{v} (working tree)", centroids=len(res[v].centroids),
                             extract_median_s=float(np.median(ex)),
                             extract_range_s=f"{ex.min():.3f}–{ex.max():.3f}",
                             pipeline_median_s=float(np.median(whole)),
                             pipeline_range_s=f"{whole.min():.3f}–{whole.max():.3f}"))
    evstar.pipeline.Extractor = extract.Extractor
    profiling.write_results(os.path.join(RESULTS, "ab_split.json"), rows,
                            dict(path=args.path, before=args.before, pairs=args.pairs,
                                 note="centroids identical, every field, in every mode"))
    print(profiling.table(rows, COLUMNS))


if __name__ == "__main__":
    main()
