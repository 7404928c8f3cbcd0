"""`evstar batch` on 2 worker processes against `evstar run` in a loop (in-process), side by
side on the same simulated recordings.

    python perf/bench_batch.py [--recordings 8] [--duration-s 1.0] [--workers 2] [--repeat 3]

Each mode runs over all recordings once "cold" (what a fresh start pays: Taichi / Warp start
and kernel-cache loads; for the batch also starting the LocalCluster), then --repeat times
"warm" (everything started; median and best reported, as the cores may be shared with
other work). A third mode, as many plain processes as workers each looping over its share
without Dask (warm only), shows what the machine itself allows at that moment. The batch
runs on batch.local_client, as `evstar batch --workers N` does (one kernel thread per
worker); the serial loop uses the default threads. Writes perf/results/batch.json and
batch.md. Target (the batch issue): warm ratio >= 1.7 on 2 cores.
"""
from __future__ import annotations

import argparse
import contextlib
import io as _io
import os
import pathlib
import statistics
import tempfile
import time

from evstar import Config, batch, io, sim
from evstar.cli import main as cli
from evstar.profiling import table, write_results

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "batch.json"
COLUMNS = [("mode", "mode", ""), ("pass", "pass", ""), ("recordings", "recordings", "d"),
           ("wall_s", "wall s", ".2f"), ("per_recording_s", "s / recording", ".3f"),
           ("speedup", "speed-up vs serial", ".2f")]


def recordings(folder, n, duration_s):
    paths = []
    for seed in range(n):
        run = sim.simulate(sim.paper_preset(16.0, duration_s=duration_s), seed=seed)
        paths.append(pathlib.Path(folder) / f"rec{seed}.h5")
        io.write(paths[-1], run.events, imu=run.imu, camera=run.camera)
    return paths


def serial(paths, out):
    """`evstar run` on each file, one after the other, in this process."""
    t = time.perf_counter()
    with contextlib.redirect_stdout(_io.StringIO()):
        for p in paths:
            assert cli(["run", str(p), "-o", str(out / p.stem), "--no-progress"]) == 0
    return time.perf_counter() - t


def plain(pool, paths, out, workers):
    """The machine's ceiling: plain processes (no Dask), each running the serial loop on its
    share; the wall time of the slowest."""
    return max(pool.map(serial, [paths[i::workers] for i in range(workers)], [out] * workers))


def _batch(paths, out, client):
    t = time.perf_counter()
    table_ = batch.run_many(paths, Config(), out, client=client, force=True)
    assert (table_["status"] == "ok").all(), table_["error"].tolist()
    return time.perf_counter() - t


def measure(folder, paths, workers, repeat):
    """{mode: (cold, [warm...])}; the warm passes of the modes alternate, so that load from
    outside (shared cores) falls on all of them alike."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    out = {m: folder / m for m in ("serial", "batch", "plain")}
    cold_serial = serial(paths, out["serial"])
    t = time.perf_counter()
    with batch.local_client(workers) as client, \
            ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
        cold_batch = time.perf_counter() - t + _batch(paths, out["batch"], client)
        plain(pool, paths[:workers], out["plain"], workers)  # warm-up: one run each
        warm = [(serial(paths, out["serial"]), _batch(paths, out["batch"], client),
                 plain(pool, paths, out["plain"], workers)) for _ in range(repeat)]
    s, b, p = zip(*warm)
    return {"serial": (cold_serial, s), "batch": (cold_batch, b), "plain": (None, p)}


def passes(cold, warm):
    return {"cold": cold, "warm median": statistics.median(warm), "warm best": min(warm)}


def _row(mode, kind, wall, serial_wall, n):
    return {"mode": mode, "pass": kind, "recordings": n, "wall_s": wall,
            "per_recording_s": wall / n, "speedup": serial_wall / wall}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=8)
    ap.add_argument("--duration-s", type=float, default=1.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        folder = pathlib.Path(folder)
        paths = recordings(folder, args.recordings, args.duration_s)
        times = measure(folder, paths, args.workers, args.repeat)
        for p in paths:  # every mode wrote the same results
            for f in ("centroids.csv", "metrics.json"):
                want = (folder / "serial" / p.stem / f).read_bytes()
                assert want == (folder / "batch" / p.stem / f).read_bytes(), (p, f)
                assert want == (folder / "plain" / p.stem / f).read_bytes(), (p, f)
    serial_s = passes(*times["serial"])
    names = {"serial": "serial (evstar run loop)", "batch": f"evstar batch, {args.workers} workers",
             "plain": f"{args.workers} plain processes, no Dask (ceiling)"}
    rows = [_row(names[m], k, v, serial_s[k], args.recordings)
            for m in names for k, v in passes(*times[m]).items() if v is not None]
    meta = {**vars(args), "cpu_count": os.cpu_count()}
    write_results(RESULTS, rows, meta)
    text = table(rows, COLUMNS)
    title = "# evstar batch vs evstar run loop"
    RESULTS.with_suffix(".md").write_text(f"{title}\n\n{meta}\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
