"""Attitude study: the event-based MEKF against an APS-like baseline, versus angular rate.

For each camera preset (DAVIS346 behind 16 mm, f ≈ 865 px; EVK4 behind 12 mm, f ≈ 2469 px),
each motion (constant pan 0, 5, 10, 20, 30 °/s about the image's up axis, and the paper's
10°/1 Hz sinusoid) over a Hipparcos field (Orion, mag <= 6, ICRS), the simulator's events go
through evstar.Pipeline (defaults, told the sensor's 100 µs refractory period; "events-imu"
rows: motion.compensate = "imu" as well) and evstar.attitude.estimate (smoothed, the
default), with and without the IMU;
identification is evstar.attitude.identify (the plate solver). "events-cal" rows set
centroid_delay_us to the time by which the pipeline's centroids lead their timestamps,
measured against the truth on a separate run (20 °/s, seed 2) per camera, as a sensor's
latency is calibrated on a turntable. Errors against the simulator's true attitude at every
10 ms output: cross-boresight (arcsec; px = angle x focal length) and about-boresight
(arcsec; px = angle x half the sensor diagonal), time to first fix, fraction of frames
after the first fix with an attitude.

APS-like baseline: a frame camera with the same optics, one 100 ms exposure per fix
(10 Hz); each star's centroid is that of its streak (the mean of its true image positions
over the exposure) plus noise growing with the streak length, a star being detected while
its peak pixel signal (flux spread along the streak) stays above a threshold; the fix is
the Wahba solution at mid-exposure, held (no IMU) or carried by the gyro (IMU) until the
next one; errors at the same 10 ms outputs.

    python perf/study_attitude.py [--quick]

Writes perf/results/study_attitude.json, .md and .png; prints the table.
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import os
import pathlib
import pickle
import time

import numpy as np
from scipy.spatial.transform import Rotation

import evstar
from evstar import sim
from evstar.attitude import AttitudeEstimator, Solver, identify, rotation
from evstar.motion import AttitudeTrack

RESULTS = pathlib.Path(__file__).parent / "results"
CACHE = pathlib.Path(os.environ.get("EVSTAR_STUDY_CACHE", "/tmp/evstar_study_attitude"))
CAMERAS = {"davis346": 16.0, "evk4": 12.0}          # preset -> focal length, mm
MOTIONS = ("0", "5", "10", "20", "30", "sine")
POINTING = (83.8, -5.4)                              # Orion: ra, dec (deg)
MAG_LIMIT = 6.0
DURATION_S = 1.0
ARCSEC = math.pi / 180 / 3600


def trajectory(motion):
    R0 = sim.attitude_from_radec(*POINTING)
    if motion == "sine":
        return sim.Sinusoid(10.0, 1.0, R0=R0)
    return sim.ConstantRate(float(motion), R0=R0)


@functools.cache
def _code_digest():
    """A digest of evstar's and its kernels' sources: a cached run is reused only by the
    code that made it (a cache keyed on the scene alone had served an older estimator's
    centroids to a newer one)."""
    import hashlib

    import evstar_kernels

    h = hashlib.sha1()
    for pkg in (evstar, evstar_kernels):
        root = pathlib.Path(pkg.__file__).parent
        for f in sorted(root.rglob("*.py")):
            h.update(f.read_bytes())
    return h.hexdigest()[:12]


def scene(camera_name, motion, seed=1, compensate="none"):
    """(centroids, truth, imu) of one simulated run through the pipeline with
    motion.compensate = `compensate`, cached on disk."""
    path = CACHE / f"{camera_name}-{motion}-{seed}-{compensate}-{_code_digest()}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    cam = sim.camera_preset(camera_name, CAMERAS[camera_name])
    traj = trajectory(motion)
    stars = sim.hipparcos_field_along(cam, traj, DURATION_S, mag_limit=MAG_LIMIT)
    scn = sim.Scenario(cam, stars, traj, DURATION_S)
    run = sim.simulate(scn, seed=seed)
    # the sensor's refractory period is a bias setting the user knows: the pipeline is told
    cfg = evstar.Config().replace(**{"motion.compensate": compensate,
                                     "estimate.refractory_us": scn.sensor.refractory_us})
    res = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera)
    out = (res.centroids, run.truth, run.imu)
    CACHE.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(out))
    return out



# -- errors ----------------------------------------------------------------------------------
def attitude_errors(t_us, R_ic, truth):
    """(cross, about) boresight errors in arcsec of camera -> ICRS rotations (n, 3, 3)."""
    rv = Rotation.from_matrix(truth.rotation_at(t_us) @ R_ic).as_rotvec()   # R_cw,true · R_ic
    return np.hypot(rv[:, 0], rv[:, 1]) / ARCSEC, np.abs(rv[:, 2]) / ARCSEC


def summarise(t_us, R_ic, truth, t_first, grid_us=10_000):
    cam = truth.camera
    n_frames = int((DURATION_S * 1e6 - 1 - t_first) // grid_us) + 1 if t_first is not None else 0
    out = dict(first_fix_ms=None if t_first is None else t_first / 1000,
               frames_with_attitude=0.0 if not n_frames else min(1.0, len(t_us) / n_frames))
    if not len(t_us):
        return out
    cross, about = attitude_errors(t_us, R_ic, truth)
    f_px, edge_px = cam.fx * ARCSEC, math.hypot(cam.width, cam.height) / 2 * ARCSEC
    for name, e, scale in (("cross", cross, f_px), ("about", about, edge_px)):
        out[f"{name}_rms_arcsec"] = float(np.sqrt(np.mean(e ** 2)))
        out[f"{name}_max_arcsec"] = float(e.max())
        out[f"{name}_rms_px"] = out[f"{name}_rms_arcsec"] * scale
        out[f"{name}_max_px"] = out[f"{name}_max_arcsec"] * scale
    return out


# -- the event camera ----------------------------------------------------------------------
CALIBRATION = ("20", 2)     # motion and seed of the run that calibrates the centroid delay


def centroid_delay_us(cam_name):
    """The median time by which tracked centroids' positions lead their timestamps (µs),
    measured against the truth on a separate run (CALIBRATION), as a sensor's latency would
    be calibrated on a turntable."""
    from evstar import accuracy

    c, truth, _ = scene(cam_name, *CALIBRATION)
    c = c[(c["source"] == "measured") & (c["track"] >= 0)]
    star, _ = accuracy.match(c, truth.star_position, 3.0)
    c, star = c[star >= 0], star[star >= 0]
    i = np.arange(len(c))
    p0, p1 = truth.star_position(c["t"])[i, star], truth.star_position(c["t"] + 1000)[i, star]
    v = (p1 - p0) / 1e-3
    speed = np.linalg.norm(v, axis=1)
    ahead = np.sum((np.stack([c["x"], c["y"]], 1) - p0) * v, axis=1) / np.maximum(speed, 1e-9) ** 2
    return float(np.median(ahead[speed > 50]) * 1e6)


def event_attitude(c, truth, imu, delay_us=0.0):
    est = AttitudeEstimator(truth.camera, imu, centroid_delay_us=delay_us)
    start = time.perf_counter()
    rows = est.run(c)
    seconds = time.perf_counter() - start
    R = rotation(np.stack([rows[k] for k in ("qw", "qx", "qy", "qz")], 1)) if len(rows) else np.zeros((0, 3, 3))
    res = summarise(rows["t"], R, truth, int(rows["t"][0]) if len(rows) else None)
    res.update(n_stars_median=float(np.median(rows["n_stars"])) if len(rows) else 0.0,
               identifications=len(est.fixes), seconds=round(seconds, 2))
    return res


# -- the APS-like baseline -------------------------------------------------------------------
APS = dict(exposure_ms=100.0, e_mag6=3000.0, sky_e=20.0, read_e=10.0, psf_px=1.0,
           detect_snr=5.0, floor_px=0.02)


def aps_fix(truth, t_mid_us, rng, solver):
    """(R_ic or None, stars used) of one exposure centred on t_mid_us (APS dict)."""
    a, cam = APS, truth.camera
    half = a["exposure_ms"] * 500
    ts = np.arange(t_mid_us - half, t_mid_us + half + 1, 1000)
    xy = truth.star_position(ts)                                   # (n_t, stars, 2)
    m = 3
    inside = np.all((xy[..., 0] >= m) & (xy[..., 0] <= cam.width - 1 - m) &
                    (xy[..., 1] >= m) & (xy[..., 1] <= cam.height - 1 - m), axis=0)
    mean = xy.mean(0)
    L = np.nansum(np.linalg.norm(np.diff(xy, axis=0), axis=2), axis=0)
    S = a["e_mag6"] * 10 ** (-0.4 * (truth.stars.magnitudes - 6.0))
    s = a["psf_px"]
    peak = S / (math.sqrt(2 * math.pi) * s * np.sqrt(L ** 2 + 2 * math.pi * s * s))
    noise_px = a["sky_e"] + a["read_e"] ** 2
    seen = inside & (peak / np.sqrt(peak + noise_px) >= a["detect_snr"])
    if seen.sum() < 4:
        return None, int(seen.sum())
    n_pix = (L + 4 * s) * 4 * s
    snr = S / np.sqrt(S + n_pix * noise_px)
    along = np.sqrt(s * s + L ** 2 / 12) / snr
    across = s / snr
    d = xy[-1] - xy[0]
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    u = np.where(norm > 1e-6, d / np.maximum(norm, 1e-6), [1.0, 0.0])   # along the streak (any when still)
    noise = (rng.standard_normal(len(S))[:, None] * np.hypot(along, a["floor_px"])[:, None] * u
             + rng.standard_normal(len(S))[:, None] * np.hypot(across, a["floor_px"])[:, None]
             * np.stack([-u[:, 1], u[:, 0]], 1))
    meas = (mean + noise)[seen]
    fix = identify(meas, cam, int(t_mid_us), solver=solver, weight=S[seen])
    if not fix.ok:
        return None, int(seen.sum())
    return fix.R_icrs_cam, fix.n_matches


def aps_attitude(truth, imu, seed=0):
    """The baseline's attitude at the 10 ms outputs: the latest fix, held or carried by the
    raw gyro (bias not estimated)."""
    rng = np.random.default_rng(seed)
    solver = Solver.for_camera(truth.camera)
    period = int(APS["exposure_ms"] * 1000)
    fixes = []
    for k in range(int(DURATION_S * 1e6) // period):
        R, n = aps_fix(truth, k * period + period // 2, rng, solver)
        if R is not None:
            fixes.append((k * period + period // 2, R, n))
    if not fixes:
        return summarise(np.zeros(0, np.int64), np.zeros((0, 3, 3)), truth, None) | dict(fixes=0)
    t_out = np.arange(fixes[0][0], int(DURATION_S * 1e6), 10_000)
    tf = np.array([f[0] for f in fixes])
    k = np.searchsorted(tf, t_out, side="right") - 1
    R = np.stack([fixes[i][1] for i in k])
    if imu is not None:
        track = AttitudeTrack.from_imu(imu)                          # R_cw increments from the gyro
        q_out, q_fix = track.at(t_out), track.at(tf[k])
        R_cw_rel = Rotation.from_quat(q_out) * Rotation.from_quat(q_fix).inv()   # R_cw(t) R_cw(fix)ᵀ
        R = R @ R_cw_rel.as_matrix().transpose(0, 2, 1)
    res = summarise(t_out, R, truth, int(tf[0]))
    at_fix = summarise(tf, np.stack([f[1] for f in fixes]), truth, int(tf[0]))   # the fixes alone
    res.update(fixes=len(fixes), n_stars_median=float(np.median([f[2] for f in fixes])),
               fix_cross_rms_px=at_fix["cross_rms_px"], fix_about_rms_px=at_fix["about_rms_px"])
    return res


# -- the study ---------------------------------------------------------------------------------
def study(cameras, motions):
    rows = []
    delays = {}
    for cam_name in cameras:
        delays[cam_name] = delay = centroid_delay_us(cam_name)
        for motion in motions:
            c, truth, imu = scene(cam_name, motion)
            for with_imu in (False, True):
                use = imu if with_imu else None
                # with a gyro, also the pipeline compensating with it ("events-imu"): its
                # velocity prior carries the smoother through the sinusoid's turnarounds
                methods = ("events", "events-cal") + (("events-imu",) if with_imu else ()) + ("aps",)
                for method in methods:
                    if method == "aps":
                        res = aps_attitude(truth, use)
                    elif method == "events-imu":
                        res = event_attitude(scene(cam_name, motion, compensate="imu")[0], truth, use)
                    else:
                        res = event_attitude(c, truth, use, delay if method == "events-cal" else 0.0)
                    rows.append(dict(camera=cam_name, f_px=round(truth.camera.fx, 1), motion=motion,
                                     imu=with_imu, method=method, **res))
                    print(table_row(rows[-1]), flush=True)
    return rows, delays


def fmt(v, spec=".3f"):
    return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


HEADER = ("| camera | motion °/s | IMU | method | first fix ms | frames with attitude | cross RMS px | "
          "cross max px | about RMS px (edge) | about max px | cross RMS \" | about RMS \" | "
          "APS at its fixes: cross / about RMS px |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|")


def table_row(r):
    return (f"| {r['camera']} | {r['motion']} | {'yes' if r['imu'] else 'no'} | {r['method']} | "
            f"{fmt(r['first_fix_ms'], '.0f')} | {100 * r['frames_with_attitude']:.1f} % | "
            f"{fmt(r.get('cross_rms_px'), '.4f')} | {fmt(r.get('cross_max_px'))} | "
            f"{fmt(r.get('about_rms_px'), '.4f')} | {fmt(r.get('about_max_px'))} | {fmt(r.get('cross_rms_arcsec'), '.1f')} | "
            f"{fmt(r.get('about_rms_arcsec'), '.1f')} | "
            f"{fmt(r.get('fix_cross_rms_px'), '.4f')} / {fmt(r.get('fix_about_rms_px'), '.4f')} |")


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cameras = sorted({r["camera"] for r in rows})
    motions = list(dict.fromkeys(r["motion"] for r in rows))
    keys = [("cross_rms_px", "cross-boresight RMS (px)"), ("about_rms_px", "about-boresight RMS (px, edge)"),
            ("frames_with_attitude", "frames with an attitude")]
    fig, axes = plt.subplots(len(cameras), 3, figsize=(15, 4 * len(cameras)), squeeze=False)
    for i, cam in enumerate(cameras):
        for j, (key, label) in enumerate(keys):
            ax = axes[i, j]
            for method, imu, style in (("events", False, "o-"), ("events", True, "s-"),
                                       ("events-cal", False, "^-"), ("events-cal", True, "v-"), ("events-imu", True, "D-"),
                                       ("aps", False, "o--"), ("aps", True, "s--")):
                sel = {r["motion"]: r for r in rows if r["camera"] == cam and r["method"] == method and r["imu"] == imu}
                y = [sel[m].get(key, np.nan) if m in sel else np.nan for m in motions]
                y = [np.nan if v is None else v for v in y]
                ax.plot(range(len(motions)), y, style, label=f"{method}{' + IMU' if imu else ''}")
            ax.set_xticks(range(len(motions)), [m if m != "sine" else "10°/1 Hz" for m in motions])
            ax.set_xlabel("pan rate (°/s)")
            ax.set_title(f"{cam}: {label}")
            if key != "frames_with_attitude":
                ax.set_yscale("log")
                ax.set_ylim(1e-3, 1e3)
                ax.axhline(0.05 if key == "cross_rms_px" else 0.1, color="k", lw=0.8, ls=":")
            ax.grid(alpha=0.3)
        axes[i, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="DAVIS346, 10 °/s and the sinusoid only")
    args = ap.parse_args()
    cameras, motions = (["davis346"], ["10", "sine"]) if args.quick else (list(CAMERAS), list(MOTIONS))
    start = time.time()
    print(HEADER)
    rows, delays = study(cameras, motions)
    RESULTS.mkdir(exist_ok=True)
    meta = dict(pointing_radec_deg=POINTING, mag_limit=MAG_LIMIT, duration_s=DURATION_S,
                cameras={k: f"{v} mm" for k, v in CAMERAS.items()}, aps_model=APS,
                centroid_delay_us=delays, calibration_run=dict(motion=CALIBRATION[0], seed=CALIBRATION[1]),
                targets=dict(frames_with_attitude=0.99, cross_rms_px=0.05, about_rms_px=0.1, worst_px=0.5),
                runtime_s=round(time.time() - start, 1))
    (RESULTS / "study_attitude.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=1) + "\n")
    (RESULTS / "study_attitude.md").write_text("# Attitude study\n\n" + __doc__.split("\n\n", 1)[1].split("    python")[0]
                                               + "\n" + HEADER + "\n" + "\n".join(table_row(r) for r in rows) + "\n")
    plot(rows, RESULTS / "study_attitude.png")
    print(f"wrote {RESULTS}/study_attitude.json, .md, .png in {time.time() - start:.0f} s")


if __name__ == "__main__":
    main()
