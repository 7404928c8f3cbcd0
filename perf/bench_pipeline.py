"""Throughput per stage of the whole pipeline (the code of `evstar bench`).

    python perf/bench_pipeline.py [--events 2000000] [--device cpu] [--repeats 3]

Writes perf/results/pipeline.json and pipeline.md.
"""
import argparse
import pathlib

from evstar import bench, profiling

RESULTS = pathlib.Path(__file__).parent / "results"

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--events", type=int, default=2_000_000)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    rows = bench.run(a.events, a.device, a.repeats)
    profiling.write_results(RESULTS / "pipeline.json", rows, vars(a))
    text = bench.markdown(rows)
    (RESULTS / "pipeline.md").write_text(text + "\n")
    print(text)
