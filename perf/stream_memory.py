"""Streaming a recording larger than memory: peak RSS and events/s of `evstar run`.

Builds an HDF5 file of about --events events (a simulated 640x480 scene, 2 Hz/pixel
background and a magnitude-3 star on a 10°/1 Hz sinusoid, tiled in time and appended
chunk by chunk so building it needs little memory either), then runs
`evstar run FILE --stream-above-mb 0` in a child process and reads its peak RSS.
Goal (issue 7): 100 M events with peak RSS < 2 GB.

    python perf/stream_memory.py [--events 100000000] [--keep]

Writes perf/results/stream_memory.json and prints a table.
"""
import argparse
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

import h5py

from evstar import profiling, sim

RESULTS = pathlib.Path(__file__).parent / "results"


def build(path, n_events, seed=0):
    scn = sim.paper_sinusoid(duration_s=4.0, camera="dvxplorer",
                             sensor=sim.SensorSpec(noise_hz=2.0))
    tile = sim.simulate(scn, seed=seed).events
    span = int(tile.t[-1]) + 1
    with h5py.File(path, "w") as f:
        g = f.create_group("events")
        g.attrs["width"], g.attrs["height"] = tile.width, tile.height
        ds = {k: g.create_dataset(k, shape=(0,), maxshape=(None,), dtype=getattr(tile, k).dtype,
                                  chunks=(1 << 20,)) for k in "txyp"}
        written, k = 0, 0
        while written < n_events:
            n = min(len(tile), n_events - written)
            for name, d in ds.items():
                d.resize((written + n,))
                d[written:] = (tile.t[:n] + k * span) if name == "t" else getattr(tile, name)[:n]
            written, k = written + n, k + 1
    return written


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--events", type=int, default=100_000_000)
    ap.add_argument("--keep", action="store_true", help="keep the generated file")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(dir=".") as d:
        path = pathlib.Path(d) / "big.h5"
        t = time.perf_counter()
        n = build(path, a.events)
        build_s = time.perf_counter() - t
        size_mb = path.stat().st_size / 1e6
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "evstar", "run", str(path), "-o", str(pathlib.Path(d) / "out"),
                               "--stream-above-mb", "0", "--no-progress"], capture_output=True, text=True)
        run_s = time.perf_counter() - t
        if proc.returncode:
            sys.exit(proc.stderr)
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        row = {"events": n, "file_mb": size_mb, "build_s": build_s, "run_s": run_s,
               "meps": n / run_s / 1e6, "peak_rss_mb": peak_mb, "goal_met": bool(peak_mb < 2048)}
        if a.keep:
            path.rename(RESULTS / "big.h5")
    profiling.write_results(RESULTS / "stream_memory.json", [row], vars(a))
    print(profiling.table([row], [("events", "events", ","), ("file_mb", "file MB", ".0f"),
                                  ("run_s", "run s", ".1f"), ("meps", "M events/s", ".2f"),
                                  ("peak_rss_mb", "peak RSS MB", ".0f"), ("goal_met", "< 2 GB", "")]))
    print(proc.stdout)


if __name__ == "__main__":
    main()
