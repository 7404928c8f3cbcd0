"""Cost of the track smoother (evstar.smoothing) per centroid, and of the hot-pixel map per event.

Smoother rows: synthetic straight tracks (20 tracks of --length centroids, one per 10 ms
frame, 10 % of the frames missing and coasted), per setting: q estimated per track (auto),
q fixed (the filterpy filter + smoother alone), auto q with a velocity prior. Hot-pixel
rows: HotPixelMap.update on uniform events over a 640 x 480 sensor, in 10 ms batches, and
one derivation of its mask (done when .mask is read after an update).
Medians of --repeats runs after one warm-up; CPU time too (the machine's cores are shared).

    python perf/bench_smoothing.py [--length 50,500] [--repeats 5]

Writes perf/results/smoothing.json (+ smoothing.md, the table) and prints the table.
"""
from __future__ import annotations

import argparse
import datetime
import json
import pathlib
import time

import numpy as np

import evstar
from evstar.extract import CENTROID_DTYPE
from evstar.hotpixels import HotPixelMap
from evstar.smoothing import TrackSmoother

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
DT = 10_000
N_TRACKS = 20


def tracks(length, seed=0):
    rng = np.random.default_rng(seed)
    parts = []
    for k in range(N_TRACKS):
        frames = np.flatnonzero(rng.random(length) > 0.1)
        c = np.zeros(len(frames), CENTROID_DTYPE)
        c["frame"], c["track"], c["n_events"] = frames, k, 20
        c["t"] = frames * DT + DT // 2
        c["x"] = 10 + 30.0 * c["t"] * 1e-6 + rng.normal(0, 0.2, len(c))
        c["y"] = 10 + k * 5 + rng.normal(0, 0.2, len(c))
        c["spread"] = 1.2
        parts.append(c)
    return np.concatenate(parts)


def timed(fn, repeats):
    fn()
    wall, cpu = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall.append(time.perf_counter() - w0), cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.median(cpu)), out


def smoother_rows(length, repeats):
    cents = tracks(length)
    prior = lambda t, x, y: np.column_stack([np.full(len(t), 30.0), np.zeros(len(t))])  # noqa: E731
    settings = {"auto q": (dict(), None), "fixed q": (dict(process_noise=1.0), None),
                "auto q + prior": (dict(), prior)}
    rows = []
    for name, (params, vp) in settings.items():
        sm = TrackSmoother(DT, coast_ms=50, **params)
        wall, cpu, est = timed(lambda: sm.smooth(cents, t0_us=0, velocity_prior=vp), repeats)
        rows.append(dict(stage="smoother", setting=name, track_length=length, centroids=len(cents),
                         rows_out=len(est), wall_s=wall, cpu_s=cpu,
                         us_per_centroid=1e6 * wall / len(cents)))
    return rows


def hotpixel_rows(repeats, n_events=1_000_000, w=640, h=480):
    rng = np.random.default_rng(1)
    t = np.sort(rng.integers(0, 1_000_000, n_events))
    ev = evstar.Events(t, rng.integers(0, w, n_events), rng.integers(0, h, n_events),
                       rng.integers(0, 2, n_events), w, h)
    cuts = np.searchsorted(t, np.arange(0, 1_000_001, DT))
    batches = [ev[a:b] for a, b in zip(cuts[:-1], cuts[1:])]

    def run():
        m = HotPixelMap(w, h)
        for b in batches:
            m.update(b)
        return m

    wall, cpu, m = timed(run, repeats)
    rows = [dict(stage="hot-pixel map", setting=f"update, {w}x{h}, 10 ms batches", events=n_events,
                 batches=len(batches), wall_s=wall, cpu_s=cpu,
                 us_per_batch=1e6 * wall / len(batches), ns_per_event=1e9 * wall / n_events)]

    def derive():
        m._mask = None      # the cached mask dropped: time its derivation alone
        return m.mask

    wall, cpu, _ = timed(derive, repeats)
    rows.append(dict(stage="hot-pixel map", setting=f"mask, {w}x{h}", events=0, batches=1,
                     wall_s=wall, cpu_s=cpu, us_per_batch=1e6 * wall, ns_per_event=float("nan")))
    return rows


def table(rows):
    lines = ["| stage | setting | size | wall s | CPU s | cost |", "|---|---|---|---|---|---|"]
    for r in rows:
        if r["stage"] == "smoother":
            size = f"{r['centroids']} centroids ({N_TRACKS} tracks x {r['track_length']} frames)"
            cost = f"{r['us_per_centroid']:.0f} µs/centroid"
        else:
            size = f"{r['events']} events, {r['batches']} updates" if r["events"] else "one read"
            cost = f"{r['us_per_batch']:.0f} µs/call" + (
                f", {r['ns_per_event']:.0f} ns/event" if r["events"] else "")
        lines.append(f"| {r['stage']} | {r['setting']} | {size} | {r['wall_s']:.3f} | "
                     f"{r['cpu_s']:.3f} | {cost} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--length", default="50,500", help="track lengths (frames), comma-separated")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    rows = []
    for length in (int(v) for v in args.length.split(",")):
        rows += smoother_rows(length, args.repeats)
    rows += hotpixel_rows(args.repeats)
    RESULTS.mkdir(exist_ok=True)
    meta = dict(date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                repeats=args.repeats)
    (RESULTS / "smoothing.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=1))
    md = table(rows)
    (RESULTS / "smoothing.md").write_text(f"# Track smoother and hot-pixel map cost\n\n{md}\n")
    print(md)


if __name__ == "__main__":
    main()
