"""First attitude fix from 50 ms of events, over random pointings (issue 14).

For each setting (camera preset x slew rate x motion compensation) and each of N random
pointings (uniform on the sphere, random roll, random rotation axis; seeded), the simulator
renders the Hipparcos stars to magnitude 7 for the first 50 ms only (so nothing later can
leak into the answer), the real pipeline runs (MR-NDSEF, DBSCAN, tracking, crossing-time
estimator; compensation none or imu), and the product's first fix is taken: the attitude
estimator (evstar.attitude.AttitudeEstimator) over the window's centroids, which searches
its frames as it does for any recording and, when none has identified within the 50 ms,
the window's raw events pooled (evstar.attitude.identify_events, a window-adaptive detection
threshold; warped by the gyro with compensation imu). A pointing succeeds when that
fix names the stars right: at least 80 % of its matched catalogue stars project, with the
true attitude at each centroid's time, within 3 px of their centroids (and the attitude is
within 1°). A verified fix that fails this is a false fix. The attitude error of the
successful fixes (rotation angle between fitted and true attitude, dominated by roll about
the boresight) is reported separately. As a check of its false fixes on every row,
identify_events also runs alone on each pointing's whole window ("pooled alone"); --no-pooled
leaves both out (frame centroids only: pooled_window_ms 0).

    python perf/study_identify.py [--pointings 50] [--presets davis346 evk4] [--rates 0 5 10 20]
                                  [--dt-ms 10] [--no-pooled] [--out perf/results/identify.json]

Writes perf/results/identify.json (per setting: success fraction, false fixes, how much of
the window the first fix needs (the end of its 10 ms frame, or of the pooled window) and the
time its centroids refer to, solve time median / range over all searches, matched stars, RMS
residual, attitude error, how many fixes came from the pooled window, the pooled-alone success and false
fixes, and per failure the rate across the boresight) and prints a table. The pipeline and
simulation of one pointing are shared by both compensation modes.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import time

import numpy as np

from evstar import Config, Pipeline, sim
from evstar.attitude import AttitudeEstimator, Solver, catalog, identify_events

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
# davis346 behind 16 mm: 346 x 260 px, f ≈ 865 px (22.6° x 17.1°); evk4 behind 12 mm:
# 1280 x 720 px, f ≈ 2469 px (29.1° x 16.6°)
CAMERAS = {"davis346": 16.0, "evk4": 12.0}
RATES = (0.0, 5.0, 10.0, 20.0)
COMPENSATIONS = ("none", "imu")
WINDOW_US = 50_000
DT_US = Config().dt_us   # pseudo-frame length (10 ms)
SIM_MAG_LIMIT = 7.0
NAMED_RIGHT_FRACTION, NAMED_WITHIN_PX, TRUE_WITHIN_DEG = 0.8, 3.0, 1.0


def random_pointing(rng):
    ra, dec = rng.uniform(0, 360), math.degrees(math.asin(rng.uniform(-1, 1)))
    roll = rng.uniform(0, 360)
    axis = rng.normal(size=3)
    return ra, dec, roll, axis / np.linalg.norm(axis)


def angle_deg(R_icrs_cam, R_cw):
    c = (np.trace(R_icrs_cam @ R_cw) - 1) / 2
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))


def judge(fix, xy, t_us, cam, truth):
    """(named right, attitude error °, fraction named right) of a verified fix whose matched
    centroids are at pixels xy (n, 2) and times t_us (n,)."""
    err = angle_deg(fix.R_icrs_cam, truth.rotation_at([fix.t_us])[0])
    true_cam = np.einsum("nij,nj->ni", truth.rotation_at(t_us), catalog.directions(fix.hip))
    named = float(np.mean(np.hypot(*(cam.project(true_cam) - xy).T) <= NAMED_WITHIN_PX))
    return named >= NAMED_RIGHT_FRACTION and err <= TRUE_WITHIN_DEG, err, named


def first_fix(cents, cam, solver, truth, t0, events, imu, pooled=True):
    """The product's first verified fix: evstar.attitude.AttitudeEstimator over the window's
    centroids (their frames as it identifies them) and, pooled, its events (identify_events
    once no frame has identified for the 50 ms); no rows are needed, only its searches."""
    est = AttitudeEstimator(cam, imu, solver=solver, frame_us=DT_US,
                            pooled_window_ms=WINDOW_US / 1e3 if pooled else 0)
    est.run(cents, events if pooled else None)
    tried = [fix.solve_ms for fix, *_ in est.searches]
    for fix, xy, t_us, source in est.searches:
        if not fix.ok:
            continue
        # the fix needs events up to its frame's end (pooled: its window's end)
        end = fix.t_us + WINDOW_US // 2 if source == "pooled" else t0 + ((int(t_us[0]) - t0) // DT_US + 1) * DT_US
        right, err, named = judge(fix, xy, t_us, cam, truth)
        return dict(ok=bool(right), false=not right, err_arcsec=err * 3600, named_right=named,
                    data_ms=(end - t0) / 1e3, t_fix_ms=(fix.t_us - t0) / 1e3, solve_ms=fix.solve_ms,
                    all_solve_ms=tried, source=source, matches=fix.n_matches,
                    residual_arcsec=fix.residual_arcsec, status=fix.status)
    last = est.fixes[-1][1].removeprefix("pooled ") if est.fixes else "none"
    return dict(ok=False, false=False, all_solve_ms=tried, status=last)


def pooled_alone(events, imu, cam, solver, truth, t0):
    """identify_events on the whole window alone (a check of its false fixes on every row)."""
    fix, found = identify_events(events, cam, t0, t0 + WINDOW_US, imu=imu, solver=solver)
    if not fix.ok:
        return dict(ok=False, false=False, status=fix.status)
    xy = found[fix.centroid_index]
    right, err, _ = judge(fix, xy, np.full(len(xy), fix.t_us), cam, truth)
    return dict(ok=bool(right), false=not right, status=fix.status, err_arcsec=err * 3600)


def one_pointing(preset, rate, seed, solvers, pooled=True):
    cam = sim.camera_preset(preset, CAMERAS[preset])
    rng = np.random.default_rng([seed, int(rate * 10), len(preset)])
    ra, dec, roll, axis = random_pointing(rng)
    motion = sim.ConstantRate(rate, axis=axis, R0=sim.attitude_from_radec(ra, dec, roll))
    duration = WINDOW_US / 1e6
    stars = sim.hipparcos_field_along(cam, motion, duration, mag_limit=SIM_MAG_LIMIT)
    t = time.perf_counter()
    run = sim.simulate(sim.Scenario(cam, stars, motion, duration), seed=seed)
    sim_s = time.perf_counter() - t
    out = {}
    for comp in COMPENSATIONS:
        t = time.perf_counter()
        cfg = Config().replace(**{"motion.compensate": comp, "dt_us": DT_US})
        res = Pipeline(cfg).run(run.events, run.imu, run.camera)
        pipe_s = time.perf_counter() - t
        t0 = int(run.events.t[0]) if len(run.events) else 0
        imu = run.imu if comp == "imu" else None
        r = first_fix(res.centroids, cam, solvers[preset], run.truth, t0, run.events, imu, pooled)
        r.update(ra=ra, dec=dec, roll=roll, stars_mag6=int((stars.magnitudes <= 6).sum()),
                 cross_rate=rate * math.sqrt(max(0.0, 1 - axis[2] ** 2)), sim_s=sim_s, pipeline_s=pipe_s)
        if pooled:   # the same call as first_fix's last try when that one was pooled
            r["pooled_alone"] = ({k: r[k] for k in ("ok", "false", "status")} if r.get("source") == "pooled"
                                 or (not r["ok"] and not r["false"])
                                 else pooled_alone(run.events, imu, cam, solvers[preset], run.truth, t0))
        out[comp] = r
    return out


def summarise(rows):
    ok = [r for r in rows if r["ok"]]
    solve = [s for r in rows for s in r["all_solve_ms"]]
    def stats(v):
        return dict(median=float(np.median(v)), min=float(np.min(v)), max=float(np.max(v))) if v else None
    return dict(pointings=len(rows), success=len(ok) / len(rows) if rows else math.nan,
                false_fixes=sum(r["false"] for r in rows),
                pooled_fixes=sum(r.get("source") == "pooled" for r in ok),
                pooled_alone=dict(success=float(np.mean([r["pooled_alone"]["ok"] for r in rows])),
                                  false_fixes=sum(r["pooled_alone"]["false"] for r in rows))
                if rows and "pooled_alone" in rows[0] else None,
                t_fix_ms=stats([r["t_fix_ms"] for r in ok]), data_ms=stats([r["data_ms"] for r in ok]),
                solve_ms=stats(solve),
                first_fix_solve_ms=stats([r["solve_ms"] for r in ok]),
                matches=stats([r["matches"] for r in ok]),
                residual_arcsec=stats([r["residual_arcsec"] for r in ok]),
                err_arcsec=stats([r["err_arcsec"] for r in ok]),
                err_arcsec_p95=float(np.percentile([r["err_arcsec"] for r in ok], 95)) if ok else None,
                failures=[dict(status=r["status"], false=r["false"], ra=r["ra"], dec=r["dec"],
                               stars_mag6=r["stars_mag6"], cross_rate=r["cross_rate"], err_arcsec=r.get("err_arcsec"),
                               named_right=r.get("named_right")) for r in rows if not r["ok"]])


def table(summary):
    lines = ["| camera | rate °/s | comp | pointings | success | false | events needed ms (median, max) | "
             "solve ms (median, range) | matches (median) | residual \" (median) | error \" (median, max) | "
             "pooled fixes | pooled alone: success, false |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, s in summary.items():
        preset, rate, comp = key.split("/")
        f = lambda d, k="median": f"{d[k]:.1f}" if d else "—"
        lines.append(f"| {preset} | {rate} | {comp} | {s['pointings']} | {100 * s['success']:.1f} % | "
                     f"{s['false_fixes']} | {f(s['data_ms'])}, {f(s['data_ms'], 'max')} | "
                     f"{f(s['solve_ms'])} ({f(s['solve_ms'], 'min')}–{f(s['solve_ms'], 'max')}) | "
                     f"{f(s['matches'])} | {f(s['residual_arcsec'])} | {f(s['err_arcsec'])}, "
                     f"{f(s['err_arcsec'], 'max')} | {s.get('pooled_fixes', 0)} | "
                     + (f"{100 * s['pooled_alone']['success']:.1f} %, {s['pooled_alone']['false_fixes']} |"
                        if s.get("pooled_alone") else "— |"))
    return "\n".join(lines)


def main():
    global DT_US
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pointings", type=int, default=50)
    ap.add_argument("--presets", nargs="+", default=list(CAMERAS), choices=list(CAMERAS))
    ap.add_argument("--rates", nargs="+", type=float, default=list(RATES))
    ap.add_argument("--dt-ms", type=float, default=DT_US / 1e3,
                    help="pseudo-frame length (10; longer frames gather more events of slow stars)")
    ap.add_argument("--no-pooled", dest="pooled", action="store_false",
                    help="frame centroids only (no pooled-window identification, as before issue 14's fix)")
    ap.add_argument("--out", default=str(RESULTS / "identify.json"))
    args = ap.parse_args()
    DT_US = int(round(args.dt_ms * 1e3))
    solvers = {p: Solver.for_camera(sim.camera_preset(p, CAMERAS[p])) for p in args.presets}
    rows = {}
    started = time.perf_counter()
    for preset in args.presets:
        for rate in args.rates:
            for seed in range(args.pointings):
                for comp, r in one_pointing(preset, rate, seed, solvers, args.pooled).items():
                    rows.setdefault(f"{preset}/{rate:g}/{comp}", []).append(r)
            summary = {k: summarise(v) for k, v in rows.items()}
            out = dict(window_ms=WINDOW_US / 1e3, frame_ms=DT_US / 1e3, sim_mag_limit=SIM_MAG_LIMIT,
                       solver_mag_limit=solvers[preset].mag_limit, named_right_fraction=NAMED_RIGHT_FRACTION,
                       named_within_px=NAMED_WITHIN_PX, true_within_deg=TRUE_WITHIN_DEG,
                       cameras={p: dict(focal_length_mm=CAMERAS[p], **sim.camera_preset(p, CAMERAS[p]).to_dict())
                                for p in args.presets},
                       wall_s=time.perf_counter() - started, summary=summary)
            pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
            pathlib.Path(args.out).write_text(json.dumps(out, indent=1))
            print(table({k: v for k, v in summary.items() if k.startswith(f"{preset}/{rate:g}/")}),
                  flush=True)
    print(table(summary))


if __name__ == "__main__":
    main()
