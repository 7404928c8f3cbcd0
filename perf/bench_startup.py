"""Start-up time of the command line: `evstar --help`, `python -c "import evstar"` and
`evstar info` on a small file (whole processes, so interpreter start-up is included).

    python perf/bench_startup.py [--repeat 9]

Writes perf/results/startup.json and prints a table (median, min, max of the repeats).
Target (the throughput issue): `evstar --help` and `import evstar` under 1 s.
"""
from __future__ import annotations

import argparse
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

from evstar.profiling import table, write_results

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "startup.json"
COLUMNS = [("command", "command", ""), ("median_s", "median s", ".3f"), ("min_s", "min s", ".3f"),
           ("max_s", "max s", ".3f")]


def commands(folder):
    small = pathlib.Path(folder) / "small.csv"
    small.write_text("t,x,y,p\n0,1,1,1\n10,2,2,0\n")
    return {"evstar --help": [sys.executable, "-m", "evstar", "--help"],
            "import evstar": [sys.executable, "-c", "import evstar"],
            "evstar info small.csv": [sys.executable, "-m", "evstar", "info", str(small)]}


def timed(argv, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True)
        times.append(time.perf_counter() - t)
    return times


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, cmd in commands(folder).items():
            timed(cmd, 1)  # warm the file cache
            t = timed(cmd, args.repeat)
            rows.append({"command": name, "median_s": statistics.median(t), "min_s": min(t),
                         "max_s": max(t)})
    write_results(RESULTS, rows, {"repeat": args.repeat})
    print(table(rows, COLUMNS))


if __name__ == "__main__":
    main()
