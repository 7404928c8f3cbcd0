"""Raw-IMU motion compensation: evstar versus dv-processing's MotionCompensator.

Same simulated scene, same raw (biased, noisy) gyro, same attitude: the gyro is integrated
once on SO(3) (evstar.motion.AttitudeTrack) and dv receives it as camera poses
(Transformationf, T_world<-camera, one per IMU sample) -- so only the warping differs.
Every 10 ms pseudo-frame is warped to its mid-time; then the same denoising (MR-NDSEF auto),
DBSCAN extraction (centroid time = frame mid-time) and tracking as evstar.Pipeline.

Variants:
- evstar (float): evstar.Pipeline with motion.compensate='imu' -- centroids from the float warped
  coordinates (the product);
- evstar (rounded): the same warp, coordinates rounded to the nearest pixel centre;
- dv: MotionCompensator.generateEvents(frame mid-time), integer pixels as dv returns them
  (PixelMotionPredictor casts the float position to int16, i.e. truncates toward zero);
- dv + 0.5 px: dv's centroids shifted by half a pixel in x and y (undoes the truncation on
  average, under the pixel-centre convention of docs/design.md);
- none: no compensation, centroid at the events' mean time (evstar's default), for reference.

Throughput: events per second of the compensation alone, median of --repeats runs after a
warm-up: evstar.motion.compensate (numpy and Warp CPU backends; the gyro integration
included) and dv (pose pushing + accept + generateEvents per frame; one thread; the
EventStore is built beforehand and not timed).

    python perf/compare_dv_motion.py [--seeds 2] [--repeats 5] [--quick]

Writes perf/results/dv_motion.json and dv_motion.md.
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from paper_fig8_motion import REALISTIC_BIAS_DPS, REALISTIC_IMU, centroid_errors  # noqa: E402

import evstar  # noqa: E402
from evstar import accuracy, motion, profiling, sim  # noqa: E402
from evstar.interop import to_dv_store  # noqa: E402
from evstar.config import Config  # noqa: E402
from evstar.events import Events  # noqa: E402
from evstar_kernels.reference import so3  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
DT_US = 10_000


def scenes(quick):
    out = [("20 °/s", lambda seed: sim.paper_preset(20.0).replace(imu=REALISTIC_IMU))]
    if not quick:
        out.insert(0, ("4 °/s", lambda seed: sim.paper_preset(4.0).replace(imu=REALISTIC_IMU)))
        out.append(("sinusoid 10°/1 Hz, 1 s", lambda seed: sim.paper_sinusoid().replace(imu=REALISTIC_IMU)))
    return out


# -- dv-processing --------------------------------------------------------------------------
def dv_poses(attitude):
    """dv poses T_world<-camera (rotation R_cw^T, no translation) at the attitude's nodes."""
    import dv_processing as dv

    R_wc = np.transpose(so3.quat_to_matrix(attitude.q_cw), (0, 2, 1)).astype(np.float32)
    zero = np.zeros(3, np.float32)
    return [dv.kinematics.Transformationf(int(t), zero, R) for t, R in zip(attitude.t_us, R_wc)]


def dv_compensate(store, poses, camera, t0_us, n_frames):
    """dv's MotionCompensator, frame by frame: compensated events (structured numpy array).

    Its pose buffer holds 1000 poses, so poses are pushed as the frames advance."""
    import dv_processing as dv

    geom = dv.camera.CameraGeometry(camera.fx, camera.fy, camera.cx, camera.cy, (camera.width, camera.height))
    mc = dv.kinematics.MotionCompensator(geom)
    pose_t = np.array([p.getTimestamp() for p in poses])
    pushed, out = 0, []
    for k in range(n_frames):
        start, mid = t0_us + k * DT_US, t0_us + k * DT_US + DT_US // 2
        upto = int(np.searchsorted(pose_t, start + DT_US + 25_000, side="right"))
        for p in poses[pushed:upto]:
            mc.accept(p)
        pushed = max(pushed, upto)
        mc.accept(store.sliceTime(start, start + DT_US))
        out.append(mc.generateEvents(mid).numpy())
    return np.concatenate(out)


# -- shared stages --------------------------------------------------------------------------
def stages_on(events, pipeline, t0_us, rate):
    """The pipeline's denoise -> extract (mid-time) -> track on already-compensated events."""
    flt = pipeline.make_filter(t0_us, rate)
    keep = flt.apply(events)
    cents = pipeline.make_extractor(t0_us, compensated=True).centroids(events[keep])
    return pipeline.make_tracker().link(cents)


def error_row(variant, cents, truth, shift=0.0):
    c = cents.copy()
    c["x"] += shift
    c["y"] += shift
    err, unmatched, _, _ = centroid_errors(c, truth, DT_US)
    bias = _mean_offset(c, truth)
    return dict(variant=variant, **{f"err_{k}_px": v for k, v in accuracy.summary(err).items()},
                unmatched=unmatched, offset_x_px=bias[0], offset_y_px=bias[1])


def _mean_offset(cents, truth):
    star, _ = accuracy.match(cents, truth.star_position, 10.0)
    ok = star >= 0
    xy = truth.star_position(cents["t"][ok])[np.arange(ok.sum()), star[ok]]
    return (float(np.mean(cents["x"][ok] - xy[:, 0])), float(np.mean(cents["y"][ok] - xy[:, 1])))


def accuracy_rows(run):
    ev, truth = run.events, run.truth
    t0 = int(ev.t[0])
    n_frames = int((ev.t[-1] - t0) // DT_US) + 1
    pipe = evstar.Pipeline(Config().replace(**{"motion.compensate": "imu"}))
    rate = pipe.calibration_rate(ev, t0)
    rows = [error_row("evstar (float)", pipe.run(ev, run.imu, run.camera).centroids, truth)]
    comp = motion.compensate(ev, run.imu, run.camera, DT_US, "imu", t0_us=t0)
    rows.append(error_row("evstar (rounded)", stages_on(comp.events()[0], pipe, t0, rate), truth))
    attitude = motion.AttitudeTrack.from_imu(run.imu)
    a = dv_compensate(to_dv_store(ev), dv_poses(attitude), run.camera, t0, n_frames)
    dv_ev = Events(a["timestamp"], a["x"].astype(np.uint16), a["y"].astype(np.uint16),
                   a["polarity"].astype(np.int8), ev.width, ev.height, sort=True)
    dv_cents = stages_on(dv_ev, pipe, t0, rate)
    rows.append(error_row("dv", dv_cents, truth))
    rows.append(error_row("dv + 0.5 px", dv_cents, truth, shift=0.5))
    none = evstar.Pipeline(Config()).run(ev, run.imu, run.camera).centroids
    rows.append(error_row("none (mean time)", none, truth))
    return rows, len(dv_ev)


def throughput_rows(run, repeats):
    ev, t0 = run.events, int(run.events.t[0])
    n_frames = int((ev.t[-1] - t0) // DT_US) + 1
    rows = []
    for backend in ("reference", "warp"):
        t = profiling.time_call(lambda: motion.compensate(ev, run.imu, run.camera, DT_US, "imu", t0_us=t0,
                                                          backend=backend), repeats=repeats)
        rows.append(dict(variant=f"evstar compensate ({backend}, CPU)", median_s=t["median_s"],
                         events_per_s=len(ev) / t["median_s"]))
    store, poses = to_dv_store(ev), dv_poses(motion.AttitudeTrack.from_imu(run.imu))
    t = profiling.time_call(lambda: dv_compensate(store, poses, run.camera, t0, n_frames), repeats=repeats)
    rows.append(dict(variant="dv MotionCompensator", median_s=t["median_s"], events_per_s=len(ev) / t["median_s"]))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="20 °/s only, one seed, 3 repeats")
    args = ap.parse_args(argv)
    seeds, repeats = (1, 3) if args.quick else (args.seeds, args.repeats)
    acc, speed = [], []
    for name, scenario in scenes(args.quick):
        for seed in range(seeds):
            run = sim.simulate(scenario(seed), seed=seed)
            rows, n_dv = accuracy_rows(run)
            for r in rows:
                acc.append(dict(scene=name, seed=seed, events=len(run.events), **r))
                print(f"{name} seed {seed} {r['variant']:18s} mean {r['err_mean_px']:.3f} px, max "
                      f"{r['err_max_px']:.3f} px, offset ({r['offset_x_px']:+.3f}, {r['offset_y_px']:+.3f}) px",
                      flush=True)
            if seed == 0:
                for r in throughput_rows(run, repeats):
                    speed.append(dict(scene=name, events=len(run.events), **r))
                    print(f"{name} {r['variant']}: {r['events_per_s'] / 1e6:.2f} M events/s", flush=True)
    summary = []
    for name in dict.fromkeys(r["scene"] for r in acc):
        for variant in dict.fromkeys(r["variant"] for r in acc):
            rs = [r for r in acc if r["scene"] == name and r["variant"] == variant]
            summary.append(dict(scene=name, variant=variant, seeds=len(rs),
                                err_mean_px=float(np.mean([r["err_mean_px"] for r in rs])),
                                err_max_px=float(max(r["err_max_px"] for r in rs)),
                                offset_x_px=float(np.mean([r["offset_x_px"] for r in rs])),
                                offset_y_px=float(np.mean([r["offset_y_px"] for r in rs])),
                                centroids=int(sum(r["err_n_px"] for r in rs))))
    meta = dict(imu=f"gyro bias {REALISTIC_BIAS_DPS} °/s + white noise (ImuSpec default density), 1 kHz",
                dt_us=DT_US, seeds=seeds, repeats=repeats, summary=summary, throughput=speed)
    RESULTS.mkdir(exist_ok=True)
    profiling.write_results(RESULTS / "dv_motion.json", acc, meta)
    acc_tab = profiling.table(summary, [
        ("scene", "scene", ""), ("variant", "compensation", ""), ("err_mean_px", "mean px", ".3f"),
        ("err_max_px", "max px", ".3f"), ("offset_x_px", "mean dx px", "+.3f"),
        ("offset_y_px", "mean dy px", "+.3f"), ("centroids", "centroids", "d")])
    speed_tab = profiling.table(speed, [("scene", "scene", ""), ("variant", "compensation", ""),
                                        ("events", "events", "d"), ("median_s", "median s", ".4f"),
                                        ("events_per_s", "events/s", ".3g")])
    (RESULTS / "dv_motion.md").write_text(
        "# Raw-IMU motion compensation: evstar vs dv-processing MotionCompensator\n\n"
        f"Conditions: {meta['imu']}; the same integrated attitude for both; 10 ms frames warped to "
        "their mid-times; MR-NDSEF auto + DBSCAN (eps 2.5) + tracking on the result; errors against the "
        "true star position at the centroid's time (the frame mid-time; none: its events' mean time); "
        f"{seeds} seed(s). dv truncates warped coordinates to "
        "int16 (toward zero), hence its -0.5 px mean offset per axis.\n\n"
        f"{acc_tab}\n\n## Throughput of the compensation alone (median of {repeats}, after a warm-up)\n\n"
        f"{speed_tab}\n")
    print(acc_tab, "\n\n", speed_tab)


if __name__ == "__main__":
    main()
