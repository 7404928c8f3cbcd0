"""A/B of the pixel crossings stage (issue 13): evstar.estimation.chunk_crossings as
Pipeline.run calls it (span by span, the first span measuring the threshold ratio, one
LevelProfiles fed by all), at a git revision (A, --before) and in the working tree (B), in
one process (ab_pipeline.Versions), runs alternating A-B / B-A. The calls are recorded from
one run of B's pipeline per scene; each is also timed with a refractory period. Asserts
identical outputs: every crossings field, the ratios and the level profiles. Writes
perf/results/bench_crossings.json (+ .md; --out names another) and prints the table:
medians and ranges (min-max of the runs), s.

    python perf/bench_crossings.py --before b3e0ffc [--repeats 15] [--out bench_crossings]
"""
import argparse
import time

import numpy as np

from ab_pipeline import Versions, _range, report

SCENES = {"evk4 50 stars": "--preset evk4 --stars 50 --rate 10 --noise-hz 1 --duration 4",
          "evk4 50 stars, dark sky": ("--preset evk4 --stars 50 --rate 20 --noise-hz 0.1 "
                                      "--duration 2 --sensor dark-sky")}
REFRACTORY_US = (0.0, 100.0)
COLUMNS = [("scene", "scene", ""), ("refractory_us", "refractory µs", ".0f"),
           ("a_s", "A s", ".3f"), ("a_range", "A range", ""), ("b_s", "B s", ".3f"),
           ("b_range", "B range", ""), ("ratio", "B / A", ".2f")]


def recorded_calls(v, scene):
    """[(args, kwargs less profiles)] of the chunk_crossings calls of one pipeline run (B)."""
    m = v.use("B")
    from evstar import bench, estimation

    s = bench.field_scene(scene.split())
    calls, original = [], estimation.chunk_crossings

    def record(*args, **kwargs):
        calls.append((args, {k: a for k, a in kwargs.items() if k != "profiles"}))
        return original(*args, **kwargs)

    estimation.chunk_crossings = record     # pipeline.py imports it at each call
    try:
        m.Pipeline(m.Config()).run(s.events, s.imu, s.camera)
    finally:
        estimation.chunk_crossings = original
    return calls


def stage(v, tag, calls, refractory_us):
    """(outputs as bytes, seconds) of the recorded calls under version `tag`."""
    v.use(tag)
    from evstar import estimation
    from evstar.level_lag import LevelProfiles

    profiles, out = LevelProfiles(), []
    t = time.perf_counter()
    for args, kwargs in calls:
        out.append(estimation.chunk_crossings(*args, **{**kwargs, "refractory_us": refractory_us},
                                              profiles=profiles))
    seconds = time.perf_counter() - t
    return _bytes(out, profiles), seconds


def _bytes(out, profiles):
    """Every output as bytes (crossings, ratios, profiles by k) for an exact comparison."""
    parts = []
    for o in out:
        crossings, ratio = o if isinstance(o, tuple) else (o, None)
        parts += [crossings.dtype.str, crossings.tobytes(), repr(ratio)]
    for k, rows in sorted(profiles._by_k.items()):
        parts += [k, *(r.tobytes() for r in rows)]
    return parts


def compare(v, name, calls, refractory_us, repeats):
    outs, times = {}, {"A": [], "B": []}
    for tag in ("A", "B"):
        outs[tag] = stage(v, tag, calls, refractory_us)[0]     # warm-up (compiles)
    assert outs["A"] == outs["B"], f"{name}, refractory {refractory_us} µs: outputs differ"
    print(f"{name}, refractory {refractory_us:g} µs: outputs identical")
    for i in range(repeats):
        for tag in ("A", "B") if i % 2 == 0 else ("B", "A"):
            times[tag].append(stage(v, tag, calls, refractory_us)[1])
    a, b = (float(np.median(times[t])) for t in ("A", "B"))
    return {"scene": name, "refractory_us": refractory_us, "a_s": a,
            "a_range": _range(times["A"]), "b_s": b, "b_range": _range(times["B"]),
            "ratio": b / a}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, help="git revision of A")
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--out", default="bench_crossings", help="results file name (no suffix)")
    a = ap.parse_args()
    v = Versions(a.before)
    rows = []
    for name, scene in SCENES.items():
        calls = recorded_calls(v, scene)
        rows += [compare(v, name, calls, r, a.repeats) for r in REFRACTORY_US]
    report(v, rows, COLUMNS, a)


if __name__ == "__main__":
    main()
