"""A/B of the first pipeline call in a fresh process (issue 13's "first-call compile ≤ 3 s
with a warm cache"): the package at a git revision (A, --before) against the working tree
(B), fresh processes alternated A-B / B-A.

Each process imports evstar, loads the 50-star EVK4 field (simulated once, here) and times
its import, the first `Pipeline.run` (Taichi's front end runs on every kernel, then the
offline cache's LLVM code is compiled) and a second run (steady state); the first minus
the second is what compiling costs. One warm-up process per version fills the caches
first. Writes perf/results/<--out>.json (+ .md) and prints medians with their ranges and
the per-pair ratio B / A of the first call.

    python perf/ab_first_call.py --before main [--repeats 5] [--mode none] [--out ab_first_call]
"""
import argparse
import ast
import pathlib
import pickle
import statistics
import subprocess
import sys
import tempfile

from ab_pipeline import RESULTS, SCENE, Versions

CHILD = """
import sys, time, pickle
sys.path.insert(0, {path!r})
t0 = time.perf_counter()
import evstar
from evstar import Config, Pipeline, backends
backends.taichi("cpu")
t1 = time.perf_counter()
ev, imu, cam = pickle.load(open({scene!r}, "rb"))
pipe = Pipeline(Config().replace(**{{"motion.compensate": {mode!r}}}))
t2 = time.perf_counter()
pipe.run(ev, imu, cam)
t3 = time.perf_counter()
pipe.run(ev, imu, cam)
t4 = time.perf_counter()
assert evstar.__file__.startswith({path!r}), evstar.__file__
print(repr({{"import_s": t1 - t0, "first_s": t3 - t2, "second_s": t4 - t3}}))
"""
COLUMNS = [("version", "version", ""), ("import_s", "import + Taichi s", ".2f"),
           ("first_s", "first call s", ".2f"), ("second_s", "second call s", ".2f"),
           ("compile_s", "first − second s", ".2f"), ("range", "first call range s", "")]


def child(path, scene, mode):
    code = CHILD.format(path=path, scene=scene, mode=mode)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])  # the dict the child printed


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, help="git revision of A")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--mode", default="none", help="motion.compensate")
    ap.add_argument("--out", default="ab_first_call")
    a = ap.parse_args()
    v = Versions(a.before)
    v.use("B")
    from evstar import bench, profiling
    scene = pathlib.Path(tempfile.mkdtemp(prefix="ab_first_call_")) / "scene.pkl"
    s = bench.field_scene(SCENE.format(50).split())
    scene.write_bytes(pickle.dumps((s.events, s.imu, s.camera)))
    runs = {"A": [], "B": []}
    for tag in ("A", "B"):  # warm-up: fills the offline caches
        child(v.paths[tag], str(scene), a.mode)
    for i in range(a.repeats):
        for tag in ("A", "B") if i % 2 == 0 else ("B", "A"):
            runs[tag].append(child(v.paths[tag], str(scene), a.mode))
            print(tag, {k: round(x, 2) for k, x in runs[tag][-1].items()}, flush=True)
    rows = []
    for tag in ("A", "B"):
        med = {k: statistics.median(r[k] for r in runs[tag]) for k in runs[tag][0]}
        firsts = [r["first_s"] for r in runs[tag]]
        rows.append({"version": f"{tag} ({a.before})" if tag == "A" else "B (working tree)", **med,
                     "compile_s": statistics.median(r["first_s"] - r["second_s"] for r in runs[tag]),
                     "range": f"{min(firsts):.2f}–{max(firsts):.2f}"})
    ratios = [b["first_s"] / x["first_s"] for x, b in zip(runs["A"], runs["B"])]
    text = (profiling.table(rows, COLUMNS) + f"\n\nfirst call B / A per pair: "
            + ", ".join(f"{r:.2f}" for r in ratios))
    profiling.write_results(RESULTS / f"{a.out}.json", rows,
                            {**vars(a), "runs": runs, "first_ratios": ratios})
    (RESULTS / f"{a.out}.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
