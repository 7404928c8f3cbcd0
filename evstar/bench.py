"""Throughput per stage and backend: simulate -> compensate -> denoise -> extract -> track.

Shared by `evstar bench` and perf/bench_pipeline.py. Each stage is timed on the same
simulated scene (the paper's camera and star at a given rate, repeated until the stream
holds about `n_events`), medians of `repeats` runs after one warm-up call whose time
(compilation included) is reported separately.
"""
from __future__ import annotations

import numpy as np

from .profiling import table, time_call

COLUMNS = [("stage", "stage", ""), ("backend", "backend", ""), ("events", "events", ","),
           ("median_s", "median s", ".4f"), ("first_s", "first call s", ".3f"),
           ("meps", "M events/s", ".2f"), ("note", "note", "")]


def scene(n_events, rate_dps=20.0, seed=0):
    """A paper scene long enough for ~n_events events (1.5 Hz/pixel noise + one star)."""
    from . import sim

    probe = sim.simulate(sim.paper_preset(rate_dps, duration_s=0.5), seed=seed)
    duration = max(0.5, 0.5 * n_events / max(len(probe.events), 1))
    # a slow sinusoid keeps the star in view however long the stream is
    scn = sim.paper_sinusoid(duration_s=duration) if duration > 1 else sim.paper_preset(rate_dps, duration_s=duration)
    return sim.simulate(scn, seed=seed)


def run(n_events=1_000_000, device="cpu", repeats=3, seed=0, progress=print):
    """Rows of {stage, backend, events, median_s, first_s, meps, note}."""
    import time

    from . import Config, Pipeline, backends, denoise
    from .motion import compensate

    backends.require(device)  # before minutes of work, not after
    t = time.perf_counter()
    run_ = scene(n_events, seed=seed)
    sim_s = time.perf_counter() - t
    ev, imu, cam = run_.events, run_.imu, run_.camera
    n = len(ev)
    rows = [_row("simulate", "numpy", n, {"median_s": sim_s, "first_s": sim_s}, "one run")]
    progress(f"scene: {n:,} events over {ev.duration_us / 1e6:.1f} s")
    for backend, dev in (("reference", "cpu"), ("warp", device), ("taichi", device)):  # numpy: the spec
        r = time_call(lambda: compensate(ev, imu, cam, 10_000, "imu", backend=backend, device=dev),
                      repeats=repeats)
        rows.append(_row("compensate (imu)", backend, n, r))
    for name, make in (("classical", lambda: denoise.ClassicalFilter(device=device)),
                       ("ndsef", lambda: denoise.NDSEF(device=device)),
                       ("mr-ndsef", lambda: denoise.MRNDSEF(device=device))):
        flt = make()
        r = time_call(lambda: flt.apply(ev), repeats=repeats)
        rows.append(_row(f"denoise {name}", f"taichi-{device}", n, r))
    pipe = Pipeline(Config(device=device))
    keep = denoise.MRNDSEF(device=device).apply(ev)
    kept = ev[keep]
    ex = pipe.make_extractor(int(ev.t[0]))
    r = time_call(lambda: ex.centroids(kept), repeats=repeats)
    cents = ex.centroids(kept)
    clustering = "scikit-learn" if ex.clustering == "sklearn" else f"taichi-{device} grid"
    rows.append(_row("extract (DBSCAN)", clustering, len(kept), r,
                     f"{len(cents) / r['median_s']:,.0f} centroids/s"))
    r = time_call(lambda: pipe.make_tracker().link(cents), repeats=repeats)
    rows.append(_row("track", "numpy/scipy", len(kept), r, f"{len(cents) / r['median_s']:,.0f} centroids/s"))
    for mode in ("none", "imu", "pf"):
        p = Pipeline(Config(device=device).replace(**{"motion.compensate": mode}))
        r = time_call(lambda: p.run(ev, imu, cam), repeats=max(1, repeats - 1))
        rows.append(_row(f"whole pipeline ({mode})", device, n, r))
    return rows


def _row(stage, backend, n, timing, note=""):
    med = timing["median_s"]
    return {"stage": stage, "backend": backend, "events": int(n), "median_s": med,
            "first_s": timing["first_s"], "meps": n / med / 1e6 if med > 0 else float("nan"),
            "note": note}


def markdown(rows):
    return table(rows, COLUMNS)


# -- whole pipeline on a simulated star field ---------------------------------------------
FIELD_COLUMNS = [("scene", "scene", ""), ("mode", "compensate", ""), ("events", "events", ","),
                 ("median_s", "median s", ".3f"), ("range_s", "range s", ""),
                 ("first_s", "first call s", ".2f"), ("realtime", "x real time", ".2f"),
                 ("meps", "M events/s", ".2f"), ("cpu_s", "CPU s", ".3f"),
                 ("stages", "stage medians s", "")]


def field_scene(argv):
    """A simulated recording described by `evstar simulate` options (a list of strings, e.g.
    ["--preset", "evk4", "--stars", "50", "--rate", "10", "--noise-hz", "1", "--duration", "4"])."""
    import argparse

    from . import sim
    from .cli import simulate as cli_sim

    p = argparse.ArgumentParser()
    cli_sim.add_arguments(p)
    args = p.parse_args(["-", *argv])
    return sim.simulate(cli_sim.scenario_from(args), seed=args.seed)


def field_run(argv, modes=("none", "imu", "pf"), device="cpu", repeats=3, progress=print):
    """Rows of {scene, mode, events, median_s, range_s, first_s, realtime, meps, stages}:
    the whole pipeline per compensation mode, the first call (kernels compiled or loaded)
    apart from the steady-state runs."""
    from . import Config, Pipeline

    run_ = field_scene(argv)
    ev, imu, cam = run_.events, run_.imu, run_.camera
    span_s = ev.duration_us / 1e6
    progress(f"scene {' '.join(argv)}: {len(ev):,} events over {span_s:.1f} s")
    rows = []
    for mode in modes:
        pipe = Pipeline(Config(device=device).replace(**{"motion.compensate": mode}))
        stages = []
        timing = time_call(lambda: stages.append(pipe.run(ev, imu, cam).timings_s), repeats=repeats)
        med = timing["median_s"]
        steady = stages[1:]
        rows.append({"scene": " ".join(argv), "mode": mode, "events": len(ev), "median_s": med,
                     "range_s": f"{min(timing['runs_s']):.3f}–{max(timing['runs_s']):.3f}",
                     "first_s": timing["first_s"], "realtime": span_s / med,
                     "meps": len(ev) / med / 1e6,
                     # CPU time (both cores): wall time can fall no lower than this / cores
                     "cpu_s": timing["cpu_median_s"],
                     "stages": ", ".join(f"{k} {np.median([s[k] for s in steady]):.3f}"
                                         for k in steady[0])})
        progress(table(rows[-1:], FIELD_COLUMNS).splitlines()[-1])
    return rows
