"""A/B of the whole pipeline (issue 13): the package at a git revision (A, --before)
against the working tree (B), in one process, runs alternating A-B / B-A.

Both versions are imported side by side (A from `git archive` of the revision into a
temporary folder; each version's modules are swapped into sys.modules while it runs, so
its lazy imports resolve to its own files) and share one Taichi runtime. Each simulates
the star-field scenes of bench_pipeline.py --fields itself, runs the pipeline twice
(compilation, warm-up), then --repeats timed runs. Asserts identical outputs for every
scene and compensation mode: keep mask, centroids (every field), before/after images,
per-frame counts and metrics. Writes perf/results/ab_pipeline.json (+ .md; --out names another) and prints
the table: per-stage and total medians (and ranges: min-max of the runs), s.

    python perf/ab_pipeline.py --before main [--repeats 5] [--stars 50,100] [--modes none,imu]
        [--changed pf]   (modes whose outputs are known to differ: reported, not asserted)
        [--out ab_pipeline]   (the results' file name in perf/results/)
"""
import argparse
import io
import os
import pathlib
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
ROOT = pathlib.Path(__file__).resolve().parent.parent
SCENE = "--preset evk4 --stars {} --rate 10 --noise-hz 1 --duration 4"
STAGES = ("pf_first_pass", "particle_filter", "compensate", "denoise", "extract", "estimate", "track")
COLUMNS = ([("stars", "stars", ""), ("compensate_mode", "compensate", ""), ("stage", "stage", ""),
            ("a_s", "A s", ".3f"), ("a_range", "A range", ""), ("b_s", "B s", ".3f"),
            ("b_range", "B range", ""), ("ratio", "B / A", ".2f")])


def _names():
    return [k for k in sys.modules if k.split(".")[0] in ("evstar", "evstar_kernels")]


class Versions:
    """Two versions of the package, one importable at a time (use)."""

    def __init__(self, rev):
        tmp = pathlib.Path(tempfile.mkdtemp(prefix="ab_pipeline_"))
        archive = subprocess.run(["git", "archive", rev], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        tarfile.open(fileobj=io.BytesIO(archive)).extractall(tmp / "src")
        self.paths, self.roots = {}, {"A": os.path.realpath(tmp / "src"), "B": str(ROOT)}
        for tag, src in (("A", tmp / "src"), ("B", ROOT)):
            (tmp / tag).mkdir()
            os.symlink(src / "evstar", tmp / tag / "evstar")
            os.symlink(src / "kernels", tmp / tag / "evstar_kernels")
            self.paths[tag] = str(tmp / tag)
        self.modules, self.current = {}, None
        for tag in ("A", "B"):
            m = self.use(tag)
            import evstar.backends  # noqa: F401 (this version's)
            if tag == "A":
                m.backends.taichi("cpu")
            else:  # one Taichi runtime: B's backends take A's
                m.backends._taichi_arch = self.modules["A"]["evstar.backends"]._taichi_arch

    def use(self, tag):
        """Make `tag`'s modules (and folder, for its lazy imports) current; its evstar."""
        if self.current is not None:
            self.modules[self.current] = {k: sys.modules[k] for k in _names()}
        for k in _names():
            del sys.modules[k]
        sys.modules.update(self.modules.get(tag, {}))
        sys.path[:] = [p for p in sys.path if p not in self.paths.values()]
        sys.path.insert(0, self.paths[tag])
        self.current = tag
        import evstar
        return evstar

    def check(self):
        """Each version's modules came from its own folder."""
        self.use(self.current)
        for tag, mods in self.modules.items():
            stray = [k for k, m in mods.items() if getattr(m, "__file__", None)
                     and not os.path.realpath(m.__file__).startswith(self.roots[tag])]
            assert not stray, f"{tag} imported {stray} from elsewhere"


def _outputs(r):
    fc = r.frame_counts
    return [r.keep, r.centroids, r.image_before, r.image_after,
            *(np.asarray(fc[k]) for k in sorted(fc)), np.array(repr(sorted(r.metrics.items())))]


def _same(a, b):
    return len(a) == len(b) and all(x.dtype == y.dtype and x.shape == y.shape
                                    and x.tobytes() == y.tobytes() for x, y in zip(a, b))


_OUTPUT_NAMES = ("keep", "centroids", "image_before", "image_after")


def _differences(a, b):
    """How outputs that are not identical differ: per output, the entries that differ, and
    for float fields (the centroids') the largest difference."""
    out = []
    for i, (x, y) in enumerate(zip(a, b)):
        name = _OUTPUT_NAMES[i] if i < len(_OUTPUT_NAMES) else f"output {i}"
        if x.shape != y.shape or x.dtype != y.dtype:
            out.append(f"{name}: {x.shape} {x.dtype} against {y.shape} {y.dtype}")
        elif x.tobytes() != y.tobytes():
            if x.dtype.names:
                parts = []
                for f in x.dtype.names:
                    if x[f].tobytes() == y[f].tobytes():
                        continue
                    if x[f].dtype.kind == "f":
                        d = np.abs(x[f] - y[f])
                        parts.append(f"{f} max {np.nanmax(d):.2e}")
                    else:
                        parts.append(f"{f} {int(np.sum(x[f] != y[f]))} differ")
                out.append(f"{name}: {', '.join(parts)}")
            else:
                out.append(f"{name}: {int(np.sum(x != y))} entries differ")
    return "; ".join(out)


def compare(v, stars, mode, repeats, changed=()):
    """Rows (one per stage and the total) of one scene and mode; asserts identical outputs
    (modes in `changed`: only says whether they are)."""
    runs, times = {}, {"A": [], "B": []}
    for tag in ("A", "B"):
        m = v.use(tag)
        from evstar import bench
        s = bench.field_scene(SCENE.format(stars).split())
        pipe = m.Pipeline(m.Config().replace(**{"motion.compensate": mode}))
        pipe.run(s.events, s.imu, s.camera)
        runs[tag] = (pipe, s, _outputs(pipe.run(s.events, s.imu, s.camera)))
    same = _same(runs["A"][2], runs["B"][2])
    assert same or mode in changed, f"{stars} stars, {mode}: outputs differ"
    print(f"{stars} stars, {mode}: outputs "
          + ("identical" if same else f"differ (expected): {_differences(runs['A'][2], runs['B'][2])}"))
    for i in range(repeats):
        for tag in ("A", "B") if i % 2 == 0 else ("B", "A"):
            v.use(tag)
            pipe, s, _ = runs[tag]
            t = time.perf_counter()
            r = pipe.run(s.events, s.imu, s.camera)
            times[tag].append({**r.timings_s, "total": time.perf_counter() - t})
    rows = []
    for stage in (*STAGES, "total"):
        runs_s = {t: [d.get(stage, 0.0) for d in times[t]] for t in ("A", "B")}
        a, b = (float(np.median(runs_s[t])) for t in ("A", "B"))
        rows.append({"stars": stars, "compensate_mode": mode, "stage": stage, "a_s": a,
                     "a_range": _range(runs_s["A"]), "b_s": b, "b_range": _range(runs_s["B"]),
                     "ratio": b / a if a else float("nan")})
    return rows


def _range(runs_s):
    """'min–max' of a stage's runs (s)."""
    return f"{min(runs_s):.3f}–{max(runs_s):.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, help="git revision of A")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--stars", default="50,100")
    ap.add_argument("--modes", default="none,imu")
    ap.add_argument("--changed", default="", help="modes whose outputs may differ")
    ap.add_argument("--out", default="ab_pipeline", help="results file name (no suffix)")
    a = ap.parse_args()
    v = Versions(a.before)
    rows = [r for stars in map(int, a.stars.split(",")) for mode in a.modes.split(",")
            for r in compare(v, stars, mode, a.repeats, a.changed.split(","))]
    report(v, rows, COLUMNS, a)


def report(v, rows, columns, args):
    """Check that A's and B's modules stayed apart, then write rows to
    perf/results/<args.out>.json and .md (B's evstar.profiling) and print the table."""
    v.check()
    v.use("B")
    from evstar import profiling

    text = profiling.table(rows, columns)
    profiling.write_results(RESULTS / f"{args.out}.json", rows, vars(args))
    (RESULTS / f"{args.out}.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
