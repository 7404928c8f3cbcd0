"""Denoising throughput (events/s) per filter and backend, with dv-processing in the same run.

Scenes (simulated with evstar.sim, 640x480 DVXplorer, 10 ms frames):
  star   about 10 M events: 2 Hz/pixel background (~6 k events per 10 ms frame over 307 k
         pixels), a magnitude-3 star on a 10° / 0.5 Hz sinusoid, 5 hot pixels
  dense  the worst case for the density filters: 100 Hz/pixel background, ~1 event per
         pixel per frame (~300 k events per frame), same length

The table gives each row's median throughput and its range over the runs.

Rows: ClassicalFilter (k=1, dt 10 ms), NDSEF (radius 5, auto threshold), MR-NDSEF (radii
3..11, auto thresholds); backends taichi-cpu (lanes: the CPU form), taichi-cpu-events (the
event-parallel GPU form run on the CPU), reference (numpy, on the first 1 M events) and
dv-processing's BackgroundActivityNoiseFilter (dt 10 ms). Medians of --repeats runs after
one warm-up; the first call (kernel compilation into a cold cache, on the first two
frames) is reported apart. CPU time per call (all threads) is reported too: the machine's
two cores are shared, and other jobs disturb wall time more than CPU time.
Extra memory: the peak of the numpy arrays one call allocates (tracemalloc; outputs,
temporaries and the filter's scratch grids), against the input's bytes; not measured for
dv-processing (C++ allocations).

    python perf/bench_denoise.py [--events 1e7] [--repeats 5] [--scenes star,dense]

Writes perf/results/denoise.json (+ denoise.md, the table; --out renames) and prints the table.
"""
from __future__ import annotations

import argparse
import datetime
import gc
import os
import pathlib
import tempfile
import time
import tracemalloc

import numpy as np

from evstar import backends, denoise, profiling

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
CACHE = pathlib.Path(tempfile.gettempdir()) / "evstar-bench-denoise"
REFERENCE_EVENTS = 1_000_000
SCENES = {"star": 2.0, "dense": 100.0}  # background Hz / pixel


def simulate(name, n_events, seed=0):
    """The scene's first n_events events (cached between runs: simulating takes seconds)."""
    import evstar
    from evstar import sim

    path = CACHE / f"{name}-{n_events}-{seed}.npz"
    if path.exists():
        z = np.load(path)
        return evstar.Events._trusted(z["t"], z["x"], z["y"], z["p"], int(z["w"]), int(z["h"]))
    rate = SCENES[name]
    duration = 1.05 * n_events / (rate * 640 * 480)
    scn = sim.paper_sinusoid(10.0, 0.5, duration_s=duration, camera="dvxplorer",
                             sensor=sim.SensorSpec(noise_hz=rate))
    ev = sim.simulate(scn, seed=seed).events[:n_events].copy()
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(path, t=ev.t, x=ev.x, y=ev.y, p=ev.p, w=ev.width, h=ev.height)
    return ev


def extra_memory(fn, flt=None):
    """Peak bytes of the numpy arrays fn() allocates (tracemalloc), the filter's reusable
    scratch grids included (released first so the call allocates them again)."""
    if flt is not None:
        flt.release()
    gc.collect()
    tracemalloc.start()
    try:
        out = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    del out
    return peak


def dv_store(events):
    """The events as a dv.EventStore, through an AEDAT4 file dv reads natively."""
    import dv_processing as dv
    from evstar import io

    path = CACHE / f"dv-{len(events)}-{int(events.t[-1])}.aedat4"
    if not path.exists():
        CACHE.mkdir(parents=True, exist_ok=True)
        io.write(path, events)
    rec = dv.io.MonoCameraRecording(str(path))
    store = dv.EventStore()
    while (batch := rec.getNextEventBatch()) is not None:
        store.add(batch)
    return store


def dv_runner(events, dt_us):
    import dv_processing as dv

    store = dv_store(events)
    size = (events.width, events.height)

    def run():
        flt = dv.noise.BackgroundActivityNoiseFilter(size, datetime.timedelta(microseconds=dt_us))
        flt.accept(store)
        return flt.generateEvents()
    return run


FILTERS = {
    "classical": lambda **kw: denoise.ClassicalFilter(10_000, 1, **kw),
    "ndsef": lambda **kw: denoise.NDSEF(10_000, 5, "auto", **kw),
    "mr-ndsef": lambda **kw: denoise.MRNDSEF(10_000, (3, 5, 7, 9, 11), "auto", **kw),
}
BACKENDS = {
    "taichi-cpu": dict(backend="taichi", schedule="lanes"),
    "taichi-cpu-events": dict(backend="taichi", schedule="events"),
    "reference": dict(backend="reference"),
}


def bench_row(scene, name, backend, events, run_fn, repeats, compile_fn=None, flt=None):
    first = None
    if compile_fn is not None:
        t0 = time.perf_counter()
        compile_fn()
        first = time.perf_counter() - t0
    reps = 1 if backend == "reference" else repeats
    if backend != "reference":
        run_fn()  # warm-up
    walls, cpus = [], []
    for _ in range(reps):
        w0, c0 = time.perf_counter(), time.process_time()
        run_fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    timing = {"median_s": float(np.median(walls)), "runs_s": walls}
    cpu = float(np.median(cpus))
    mem = None if backend == "dv-processing" else extra_memory(run_fn, flt)
    med = timing["median_s"]
    row = dict(scene=scene, filter=name, backend=backend, events=len(events),
               input_mb=events.nbytes / 1e6, median_s=med, mev_s=len(events) / med / 1e6,
               runs_s=timing["runs_s"], first_call_s=first, cpu_s=cpu,
               # the runs' throughput range (slowest–fastest): the shared cores swing 2x
               mev_s_range=f"{len(events) / max(walls) / 1e6:.1f}–{len(events) / min(walls) / 1e6:.1f}",
               mev_per_cpu_s=len(events) / cpu / 1e6,
               extra_mb=None if mem is None else mem / 1e6,
               extra_x_input=None if mem is None else mem / events.nbytes)
    print(f"  {scene:5s} {name:9s} {backend:18s} {row['mev_s']:8.1f} M ev/s  "
          f"median {med * 1e3:8.1f} ms  first {first if first is None else round(first, 2)} s  "
          f"extra {row['extra_x_input'] if mem is None else round(row['extra_x_input'], 2)}x input  "
          f"cpu {row['cpu_s']:.3f} s", flush=True)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=float, default=1e7)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenes", default="star,dense")
    ap.add_argument("--filters", default=",".join(FILTERS))
    ap.add_argument("--backends", default=",".join(BACKENDS) + ",dv")
    ap.add_argument("--out", default="denoise", help="results name: perf/results/NAME.json and NAME.md")
    args = ap.parse_args(argv)
    cold = tempfile.mkdtemp(prefix="evstar-kernel-cache-")
    backends.configure(cache_dir=cold)  # compile into an empty cache: first_call_s is a real compile
    ti = backends.taichi("cpu")
    threads = ti.lang.impl.current_cfg().cpu_max_num_threads
    scenes = {name: simulate(name, int(args.events)) for name in args.scenes.split(",")}
    for name, events in scenes.items():
        frames = denoise.ref.frame_offsets(events.t, 10_000).size - 1
        print(f"{name}: {events}, {len(events) / frames:.0f} events per 10 ms frame", flush=True)
    rows = []
    # the fast rows first (the CPU kernels and dv-processing), then the slow ones
    order = sorted(args.backends.split(","), key=lambda b: b not in ("taichi-cpu", "dv"))
    for backend in order:
        for scene, events in scenes.items():
            small = events[:int(denoise.ref.frame_offsets(events.t, 10_000)[2])]  # two frames
            for name in args.filters.split(","):
                if backend == "dv":
                    if name == "classical":
                        rows.append(bench_row(scene, "classical", "dv-processing", events,
                                              dv_runner(events, 10_000), args.repeats))
                    continue
                flt = FILTERS[name](**BACKENDS[backend])
                ev = events[:REFERENCE_EVENTS] if backend == "reference" else events
                compile_fn = None if backend == "reference" else (lambda: flt.apply(small))
                rows.append(bench_row(scene, name, backend, ev, lambda: flt.apply(ev), args.repeats,
                                      compile_fn, flt))
    rank = {b: i for i, b in enumerate(["taichi-cpu", "taichi-cpu-events", "reference", "dv-processing"])}
    rows.sort(key=lambda r: (list(scenes).index(r["scene"]), list(FILTERS).index(r["filter"]),
                             rank[r["backend"]]))
    meta = dict(dt_us=10_000, taichi_cpu_threads=threads, reference_events=REFERENCE_EVENTS,
                load_average=os.getloadavg(),
                scenes={k: f"{v} Hz/pixel background, 640x480" for k, v in SCENES.items()},
                note="medians after one warm-up; first_call_s = compile into an empty kernel cache "
                     "+ first run on the first two frames; cpu_s = median process CPU time per call "
                     "(all threads), "
                     "M events/CPU-s is the throughput per core-second, which other jobs sharing the "
                     "machine's 2 cores disturb less than wall time")
    RESULTS.mkdir(exist_ok=True)
    profiling.write_results(RESULTS / f"{args.out}.json", rows, meta)
    cols = [("scene", "scene", ""), ("filter", "filter", ""), ("backend", "backend", ""),
            ("events", "events", ","), ("mev_s", "M events/s", ".1f"), ("mev_s_range", "range", ""),
            ("median_s", "median s", ".3f"),
            ("mev_per_cpu_s", "M events/CPU-s", ".1f"), ("first_call_s", "first call s", ".2f"),
            ("extra_x_input", "extra mem / input", ".2f")]
    text = profiling.table(rows, cols)
    (RESULTS / f"{args.out}.md").write_text(text + "\n")
    print(text)
    return rows


if __name__ == "__main__":
    main()
