"""Start-up time of the command line: `evstar --help`, `python -c "import evstar"` and
`evstar info` on a small file, and a warm first kernel call (import, a 0.1 s simulated
scene, one MR-NDSEF call, Taichi's offline cache warm) with Taichi's source excerpts short
(evstar's default) and full (EVSTAR_TAICHI_SOURCE_INFO=full). Whole processes, so
interpreter start-up is included; the commands are run in turn, repeat after repeat.

    python perf/bench_startup.py [--repeat 9]

Writes perf/results/startup.json and prints a table (median, min, max of the repeats).
Target (the throughput issue): `evstar --help` and `import evstar` under 1 s.
"""
from __future__ import annotations

import argparse
import os
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


FIRST_CALL = ("import evstar; from evstar import sim; "
              "run = sim.simulate(sim.paper_preset(20.0, duration_s=0.1), seed=1); "
              "evstar.denoise.MRNDSEF(dt_us=10_000).apply(run.events)")


def commands(folder):
    """name -> (argv, extra environment)."""
    small = pathlib.Path(folder) / "small.csv"
    small.write_text("t,x,y,p\n0,1,1,1\n10,2,2,0\n")
    return {"evstar --help": ([sys.executable, "-m", "evstar", "--help"], {}),
            "import evstar": ([sys.executable, "-c", "import evstar"], {}),
            "evstar info small.csv": ([sys.executable, "-m", "evstar", "info", str(small)], {}),
            "first MR-NDSEF call, short source info": ([sys.executable, "-c", FIRST_CALL], {}),
            "first MR-NDSEF call, full source info": ([sys.executable, "-c", FIRST_CALL],
                                                      {"EVSTAR_TAICHI_SOURCE_INFO": "full"})}


def timed(argv, env):
    t = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True, env={**os.environ, **env})
    return time.perf_counter() - t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        cmds = commands(folder)
        times = {name: [] for name in cmds}
        for name, (argv, env) in cmds.items():
            timed(argv, env)  # warm the file and kernel caches
        for _ in range(args.repeat):
            for name, (argv, env) in cmds.items():
                times[name].append(timed(argv, env))
        for name, t in times.items():
            rows.append({"command": name, "median_s": statistics.median(t), "min_s": min(t),
                         "max_s": max(t)})
    write_results(RESULTS, rows, {"repeat": args.repeat})
    print(table(rows, COLUMNS))


if __name__ == "__main__":
    main()
