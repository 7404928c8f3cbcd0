"""tetra3rs against cedar-solve on the same simulated centroid fields (docs/attitude.md).

Fields: Hipparcos stars to magnitude 6 projected at random pointings (uniform sky, random
roll) on davis346 behind 16 mm and evk4 behind 12 mm, a quarter of the stars dropped,
Gaussian centroid noise (0.3 and 1 px) and 8 spurious centroids. Both solvers get the same
Hipparcos stars (magnitude <= 6, positions at J1991.25), the same field of view range
(narrow..wide side of the sensor), and the same match radius and pattern tolerance. A solve
counts when its boresight is within 0.1° of the truth.

cedar-solve 0.5.1 pins numpy<2 and Pillow<9, which evstar's stack (pandas 3 needs numpy 2)
cannot take, so it runs in its own virtual environment:

    python3 -m venv /tmp/cedar-venv && /tmp/cedar-venv/bin/pip install cedar-solve==0.5.1
    python perf/compare_solvers.py --cedar-python /tmp/cedar-venv/bin/python

Writes perf/results/solver_comparison.json and prints a table.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
CAMERAS = {"davis346": 16.0, "evk4": 12.0}
NOISE_PX = (0.3, 1.0)
MATCH_RADIUS_PX, PATTERN_ERROR, TIMEOUT_MS = 3.0, 0.01, 1000


def make_fields(n, folder):
    """Centroid fields per camera and noise, saved for the cedar run: {key: path}."""
    from evstar import sim

    paths = {}
    for name, focal in CAMERAS.items():
        cam = sim.camera_preset(name, focal)
        for noise in NOISE_PX:
            rng = np.random.default_rng([n, int(noise * 10), len(name)])
            fields, truth = [], []
            for _ in range(n):
                ra, dec, roll = sim.random_pointing(rng)
                R_cw = sim.attitude_from_radec(ra, dec, roll)
                stars = sim.hipparcos_field(cam, R_cw, mag_limit=6.0)
                xy = cam.project(stars.directions @ R_cw.T)
                xy = xy[rng.random(len(xy)) > 0.25]
                xy = xy + rng.normal(0, noise, xy.shape)
                fake = rng.uniform([0, 0], [cam.width, cam.height], (8, 2))
                fields.append(np.concatenate([xy, fake]))   # brightest first, spurious last
                truth.append(R_cw)
            key = f"{name}/{noise:g}"
            path = os.path.join(folder, f"{name}-{noise:g}.npz")
            np.savez(path, xy=np.array(fields, dtype=object), R_cw=np.array(truth),
                     camera=np.array([cam.width, cam.height, cam.fx, cam.cx, cam.cy]))
            paths[key] = path
    return paths


def boresight_error_deg(ra, dec, R_cw):
    z = R_cw[2]
    u = np.array([math.cos(math.radians(dec)) * math.cos(math.radians(ra)),
                  math.cos(math.radians(dec)) * math.sin(math.radians(ra)), math.sin(math.radians(dec))])
    return math.degrees(math.acos(min(1.0, float(u @ z))))


def run_tetra3rs(paths, folder):
    from evstar import sim
    from evstar.attitude import Solver, catalog, wahba
    from evstar.attitude import solver as solver_module

    out, built = {}, {}
    settings = dict(cache_dir=os.path.join(folder, "tetra3rs"), match_radius_px=MATCH_RADIUS_PX,
                    pattern_error=PATTERN_ERROR, timeout_ms=TIMEOUT_MS)
    for key, path in paths.items():
        name = key.split("/")[0]
        cam = sim.camera_preset(name, CAMERAS[name])
        if name not in built:
            t = time.perf_counter()
            Solver.for_camera(cam, **settings)
            build_s = time.perf_counter() - t
            solver_module.clear_cache()
            t = time.perf_counter()
            Solver.for_camera(cam, **settings)
            built[name] = build_s, time.perf_counter() - t
        build_s, load_s = built[name]
        solver = Solver.for_camera(cam, **settings)
        d = np.load(path, allow_pickle=True)
        ok, times = 0, []
        for xy, R_cw in zip(d["xy"], d["R_cw"]):
            rays = cam.unproject(xy)
            t = time.perf_counter()
            found = solver.solve(rays, cam)
            times.append((time.perf_counter() - t) * 1e3)
            if found is not None:
                local, hip, _ = found
                R = wahba(rays[local], catalog.directions(hip))
                ok += math.degrees(math.acos(min(1.0, R[:, 2] @ R_cw[2]))) < 0.1
        out[key] = dict(solver="tetra3rs", fields=len(times), success=ok / len(times),
                        solve_ms=_stats(times), database_build_s=build_s, database_load_s=load_s,
                        database_mb=os.path.getsize(solver.path) / 1e6)
    return out


def run_cedar(paths, folder):
    """Runs inside the cedar-solve environment (numpy < 2)."""
    import tetra3

    from_hip = os.path.join(folder, "hip_main.dat")
    with open(from_hip, "w") as f:  # the few hip_main.dat fields tetra3 reads: 1 HIP, 5 mag, 8/9 RA/Dec deg
        for h, ra, dec, mag in np.load(os.path.join(folder, "hip.npy")):
            f.write("|".join(["H", str(int(h)), "", "", "", f"{mag:.3f}", "", "", f"{ra:.8f}",
                              f"{dec:.8f}", "", "", " ", " "]) + "\n")
    out, dbs = {}, {}
    for key, path in paths.items():
        name = key.split("/")[0]
        d = np.load(path, allow_pickle=True)
        width, height, f, cx, cy = d["camera"]
        hfov = math.degrees(2 * math.atan(width / 2 / f))
        vfov = math.degrees(2 * math.atan(height / 2 / f))
        if name not in dbs:
            t3 = tetra3.Tetra3(load_database=None)
            t = time.perf_counter()
            t3.generate_database(max_fov=max(hfov, vfov), min_fov=min(hfov, vfov), star_catalog=from_hip,
                                 star_max_magnitude=6.0, epoch_proper_motion=1991.25,
                                 save_as=os.path.join(folder, f"cedar-{name}"))
            build_s = time.perf_counter() - t
            t = time.perf_counter()
            t3 = tetra3.Tetra3(load_database=os.path.join(folder, f"cedar-{name}.npz"))
            dbs[name] = (t3, build_s, time.perf_counter() - t,
                         os.path.getsize(os.path.join(folder, f"cedar-{name}.npz")) / 1e6)
        t3, build_s, load_s, mb = dbs[name]
        ok, times = 0, []
        for xy, R_cw in zip(d["xy"], d["R_cw"]):
            yx = np.stack([xy[:, 1] - cy + height / 2, xy[:, 0] - cx + width / 2], axis=1)
            t = time.perf_counter()
            r = t3.solve_from_centroids(yx, (height, width), fov_estimate=hfov, fov_max_error=0.02 * hfov,
                                        match_radius=MATCH_RADIUS_PX / width, match_threshold=1e-5,
                                        solve_timeout=TIMEOUT_MS, match_max_error=PATTERN_ERROR,
                                        distortion=0)
            times.append((time.perf_counter() - t) * 1e3)
            if r.get("RA") is not None:
                ok += boresight_error_deg(r["RA"], r["Dec"], R_cw) < 0.1
        out[key] = dict(solver="cedar-solve", fields=len(times), success=ok / len(times),
                        solve_ms=_stats(times), database_build_s=build_s, database_load_s=load_s,
                        database_mb=mb)
    return out


def _stats(v):
    return dict(median=float(np.median(v)), min=float(np.min(v)), max=float(np.max(v)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fields", type=int, default=50)
    ap.add_argument("--cedar-python", help="python of a virtual environment with cedar-solve")
    ap.add_argument("--cedar-worker", help=argparse.SUPPRESS)   # folder: run the cedar half here
    args = ap.parse_args()
    if args.cedar_worker:
        paths = json.loads(pathlib.Path(args.cedar_worker, "paths.json").read_text())
        pathlib.Path(args.cedar_worker, "cedar.json").write_text(json.dumps(run_cedar(paths, args.cedar_worker)))
        return
    from evstar.sim import hipparcos

    with tempfile.TemporaryDirectory() as folder:
        paths = make_fields(args.fields, folder)
        hip, ra, dec, mag = hipparcos.load()
        keep = (mag <= 6.0) & np.isfinite(ra)
        np.save(os.path.join(folder, "hip.npy"), np.stack([hip[keep], np.degrees(ra[keep]),
                                                           np.degrees(dec[keep]), mag[keep]], axis=1))
        results = {"tetra3rs": run_tetra3rs(paths, folder)}
        if args.cedar_python:
            pathlib.Path(folder, "paths.json").write_text(json.dumps(paths))
            subprocess.run([args.cedar_python, __file__, "--cedar-worker", folder], check=True)
            results["cedar-solve"] = json.loads(pathlib.Path(folder, "cedar.json").read_text())
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "solver_comparison.json").write_text(json.dumps(results, indent=1))
    print("| solver | camera / noise px | fields | success | solve ms median (range) | database build s | load s | MB |")
    print("|---|---|---|---|---|---|---|---|")
    for solver, rows in results.items():
        for key, r in rows.items():
            s = r["solve_ms"]
            print(f"| {solver} | {key} | {r['fields']} | {100 * r['success']:.0f} % | {s['median']:.1f} "
                  f"({s['min']:.1f}–{s['max']:.1f}) | {r['database_build_s']:.1f} | {r['database_load_s']:.3f} "
                  f"| {r['database_mb']:.1f} |")


if __name__ == "__main__":
    sys.exit(main())
