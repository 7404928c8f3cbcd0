"""Throughput of the whole pipeline.

    python perf/bench_pipeline.py [--events 2000000] [--device cpu] [--repeats 3]
        stages on the paper's one-star scene (the code of `evstar bench`):
        perf/results/pipeline.json and pipeline.md
    python perf/bench_pipeline.py --fields [--repeats 3]
        the whole pipeline per compensation mode on simulated star fields (`evstar simulate`
        options below; the throughput issue's scenes): perf/results/pipeline_fields.json, .md

The first call (kernels compiled or loaded from the caches) is reported apart from the
steady-state median; "x real time" is the recording's span over the median.
"""
import argparse
import pathlib

from evstar import bench, profiling

RESULTS = pathlib.Path(__file__).parent / "results"
FIELDS = [
    "--preset evk4 --stars 50 --rate 10 --noise-hz 1 --duration 4",
    "--preset evk4 --stars 100 --rate 10 --noise-hz 1 --duration 4",
]

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=int, default=2_000_000)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--fields", action="store_true", help="the star-field scenes instead")
    a = ap.parse_args()
    if a.fields:
        rows = [r for f in FIELDS for r in bench.field_run(f.split(), device=a.device,
                                                            repeats=a.repeats)]
        name, text = "pipeline_fields", profiling.table(rows, bench.FIELD_COLUMNS)
    else:
        rows = bench.run(a.events, a.device, a.repeats)
        name, text = "pipeline", bench.markdown(rows)
    profiling.write_results(RESULTS / f"{name}.json", rows, vars(a))
    (RESULTS / f"{name}.md").write_text(text + "\n")
    print(text)
