"""Throughput of motion compensation: particle-filter IMU steps/s and event warping events/s.

The CPU prediction is also timed on one thread (one launch: the parallel launches over
particle ranges against it). Goals (issue 6): 4,096 particles at >= 2,000 IMU steps/s on the CPU (twice real time at
1 kHz); 100,000 particles at >= 1,000 steps/s on a GPU. The filter is timed end to end
(ParticleFilter.run: prediction, star-likelihood updates at 100 Hz with 10 stars, weights,
resampling, estimates) and its prediction kernel alone. Writes perf/results/motion.json and
prints a table; CUDA rows are skipped with the reason when no GPU is present.

    python perf/bench_motion.py [--repeats 3] [--quick]
"""
from __future__ import annotations

import argparse
import math
import pathlib
import sys

import numpy as np

from evstar import Camera, Events, Imu, backends
from evstar.motion import ParticleFilter, StarObservations, compensate
from evstar.motion.pf_engines import make_engine
from evstar.profiling import table, time_call, write_results
from evstar_kernels.reference import particle_filter as ref
from evstar_kernels.reference import so3

DEG = math.pi / 180
CAMERA = Camera.from_fov(640, 480, 30)
OUT = pathlib.Path(__file__).parent / "results" / "motion.json"


def scene(duration_s, n_stars=10, rate_dps=10.0, seed=0):
    """1 kHz biased gyro and centroids of n_stars stars every 10 ms (constant-rate slew)."""
    rng = np.random.default_rng(seed)
    omega = np.array([0.3, -1.0, 0.2]) / np.linalg.norm([0.3, -1.0, 0.2]) * rate_dps * DEG
    t_imu = np.arange(0, int(duration_s * 1e6) + 1, 1000)
    gyro = omega + 0.3 * DEG + rng.normal(size=(len(t_imu), 3)) * 0.005 * DEG * math.sqrt(1000)
    t_obs = np.arange(0, int(duration_s * 1e6) + 1, 10_000)
    uv = rng.uniform([100, 100], [540, 380], (len(t_obs), n_stars, 2))  # positions: timing only
    track = np.broadcast_to(np.arange(n_stars), uv.shape[:2])
    obs = StarObservations(np.repeat(t_obs, n_stars), track.ravel(), uv[..., 0].ravel(),
                           uv[..., 1].ravel())
    return Imu(t_imu, gyro), obs


def bench_filter(n, device, backend, duration_s, repeats):
    imu, obs = scene(duration_s)
    pf = ParticleFilter(n, seed=0, device=device, backend=backend)
    r = time_call(lambda: pf.run(imu, obs, CAMERA), repeats=repeats)
    steps = len(imu) - 1
    return dict(stage="particle filter (run)", backend=backend, device=device, n=n, steps=steps,
                median_s=r["median_s"], first_s=r["first_s"], rate=steps / r["median_s"],
                unit="IMU steps/s")


def bench_predict(n, device, steps, repeats, threads=None):
    """threads: CPU threads of the launches (None: the engine's default, every core).
    The filter's prediction: `steps` IMU steps in blocks of 10 (observations at 100 Hz),
    preintegrated (block_motions) and applied block by block."""
    engine = make_engine("warp", device, so3.quat_identity(n), np.zeros((n, 3)))
    if threads is not None:
        from evstar_kernels.warp.particle_launch import WarpParticles

        engine = WarpParticles(so3.quat_identity(n), np.zeros((n, 3)), device=engine.device,
                               threads=threads)
    omega, dt = np.full((steps, 3), 0.1), np.full(steps, 1e-3)
    ends = np.arange(10, steps + 1, 10)

    def run():
        motions = zip(*ref.block_motions(omega, dt, ends - 10, ends))
        for end, motion in zip(ends, motions):
            engine.predict(*motion, gyro_noise=1e-4, bias_walk=1e-4, seed=0, step=int(end) - 1)
        engine.host()  # waits for the device

    r = time_call(run, repeats=repeats)
    stage = "PF prediction kernel" + ("" if threads is None else f", {threads} thread(s)")
    return dict(stage=stage, backend="warp", device=device, n=n, steps=steps,
                median_s=r["median_s"], first_s=r["first_s"], rate=steps / r["median_s"],
                unit="IMU steps/s")


def bench_warping(n_events, repeats, backend="reference", device="cpu"):
    rng = np.random.default_rng(1)
    duration = 1_000_000
    t = np.sort(rng.integers(0, duration, n_events))
    ev = Events(t, rng.integers(0, 640, n_events), rng.integers(0, 480, n_events),
                rng.integers(0, 2, n_events), 640, 480)
    t_imu = np.arange(0, duration + 1, 1000)
    imu = Imu(t_imu, np.tile([0.05, -0.17, 0.03], (len(t_imu), 1)))
    r = time_call(lambda: compensate(ev, imu, CAMERA, 10_000, mode="imu", backend=backend,
                                     device=device), repeats=repeats)
    return dict(stage="warping (compensate 'imu')", backend=backend, device=device, n=n_events,
                steps=None, median_s=r["median_s"], first_s=r["first_s"],
                rate=n_events / r["median_s"], unit="events/s")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="shorter runs (smoke test)")
    args = ap.parse_args(argv)
    k = 0.2 if args.quick else 1.0
    rows = []
    devices = ["cpu"] + (["cuda"] if backends.available()["cuda"] else [])
    for device in devices:
        rows.append(bench_predict(4096, device, int(2000 * k), args.repeats))
        if device == "cpu":  # the launches over particle ranges against one launch
            rows.append(bench_predict(4096, device, int(2000 * k), args.repeats, threads=1))
        rows.append(bench_predict(100_000, device, int(200 * k) if device == "cpu" else 2000,
                                  args.repeats))
        rows.append(bench_filter(4096, device, "warp", 2.0 * k, args.repeats))
        rows.append(bench_filter(100_000, device, "warp", 0.3 * k if device == "cpu" else 2.0,
                                 args.repeats))
        rows.append(bench_warping(int(10_000_000 * k), args.repeats, "warp", device))
    if "cuda" not in devices:
        for n in (4096, 100_000):
            rows.append(dict(stage="particle filter (run)", backend="warp", device="cuda", n=n,
                             skipped="no CUDA GPU on this machine"))
        rows.append(dict(stage="warping (compensate 'imu')", backend="warp", device="cuda",
                         skipped="no CUDA GPU on this machine"))
    rows.append(bench_filter(4096, "cpu", "reference", 0.5 * k, args.repeats))
    rows.append(bench_warping(int(10_000_000 * k), args.repeats))
    meta = {"goal": "4096 particles >= 2000 IMU steps/s (CPU); 100k >= 1000 steps/s (GPU)",
            "scene": "1 kHz IMU, 10 stars observed every 10 ms", "repeats": args.repeats}
    write_results(OUT, rows, meta)
    print(table(rows, [("stage", "stage", ""), ("backend", "backend", ""), ("device", "device", ""),
                       ("n", "particles / events", ","), ("steps", "steps", ""),
                       ("median_s", "median s", ".3f"), ("rate", "rate", ",.0f"),
                       ("unit", "unit", ""), ("skipped", "skipped", "")]))
    print(f"\nwritten {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
