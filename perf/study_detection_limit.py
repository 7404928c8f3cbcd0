"""The faintest slow star the pipeline finds: a magnitude sweep per rate, background and PSF.

Each scene is the paper's one-star turntable run (DVXplorer Lite, 12 mm) for 1 s with the
default sensor at the given background; the star's magnitude steps through --mags. Per
scene: the star's events per 10 ms frame, the fraction of frames with a position (the
pipeline's rows matched to the star within 3 px, accuracy.detection), the matched rows'
mean error and the rows matching nothing (false). Per rate, background and PSF the
table's last columns give the faintest magnitude found in >= 90 % and >= 50 % of frames.

    python perf/study_detection_limit.py [--rates 0.5,1,2] [--noise 0.1,1] [--psf 1.0,1.8]
        [--mags 5.5,5.75,6,6.25,6.5,6.75,7] [--seed 3] [--name detection_limit]

Writes perf/results/study_<name>.json and .md and prints the table. Run an older evstar on
PYTHONPATH (from its worktree) for the before.
"""
from __future__ import annotations

import argparse
import json
import pathlib

import numpy as np

from evstar import Config, Pipeline, accuracy, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"


def run_scene(rate_dps, noise_hz, psf_px, mag, seed):
    sensor = sim.sensor_model("default", noise_hz=noise_hz)
    run = sim.simulate(sim.paper_preset(rate_dps, magnitude=mag, sensor=sensor,
                                        psf_sigma_px=psf_px, duration_s=1.0), seed=seed)
    cfg = Config()
    rows = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
    ev = run.events
    n = int((ev.t[-1] - ev.t[0]) // cfg.dt_us) + 1
    frame_t = ev.t[0] + (np.arange(n) + 0.5) * cfg.dt_us
    det, _ = accuracy.detection(rows, run.truth.star_position, np.arange(n), frame_t,
                                ev.width, ev.height)
    star, err = accuracy.match(rows, run.truth.star_position)
    ok = star >= 0
    return {"rate_dps": rate_dps, "noise_hz": noise_hz, "psf_px": psf_px, "mag": mag,
            "events_per_frame": float((run.truth.labels >= 0).sum() / n),
            "frames": float(det), "mean_px": float(err[ok].mean()) if ok.any() else None,
            "false_rows": int((~ok).sum())}


def faintest(rows, share):
    found = [r["mag"] for r in rows if r["frames"] >= share]
    return max(found) if found else None


def markdown(rows, mags):
    head = ["°/s", "noise Hz", "PSF σ"] + [f"mag {m:g}" for m in mags] + ["faintest ≥ 90 %", "≥ 50 %"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    keys = sorted({(r["rate_dps"], r["noise_hz"], r["psf_px"]) for r in rows})
    for k in keys:
        part = [r for r in rows if (r["rate_dps"], r["noise_hz"], r["psf_px"]) == k]
        cells = [f"{100 * r['frames']:.0f} %, {r['mean_px']:.2f} px ({r['events_per_frame']:.1f} ev)"
                 if r["mean_px"] is not None else f"0 % ({r['events_per_frame']:.1f} ev)"
                 for r in sorted(part, key=lambda r: r["mag"])]
        lim = [faintest(part, s) for s in (0.9, 0.5)]
        lines.append(f"| {k[0]:g} | {k[1]:g} | {k[2]:g} | " + " | ".join(cells) + " | "
                     + " | ".join("—" if v is None else f"{v:g}" for v in lim) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    floats = lambda s: [float(v) for v in s.split(",")]   # noqa: E731
    ap.add_argument("--rates", type=floats, default=[0.5, 1.0, 2.0])
    ap.add_argument("--noise", type=floats, default=[0.1, 1.0])
    ap.add_argument("--psf", type=floats, default=[1.0, 1.8])
    ap.add_argument("--mags", type=floats, default=[5.5, 5.75, 6.0, 6.25, 6.5, 6.75, 7.0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--name", default="detection_limit")
    a = ap.parse_args(argv)
    rows = []
    for rate in a.rates:
        for noise in a.noise:
            for psf in a.psf:
                for mag in a.mags:
                    rows.append(run_scene(rate, noise, psf, mag, a.seed))
                    r = rows[-1]
                    print(f"{rate:g} °/s, {noise:g} Hz, σ {psf:g}, mag {mag:g}: "
                          f"{r['events_per_frame']:.1f} ev/frame, {100 * r['frames']:.0f} % of frames",
                          flush=True)
    RESULTS.mkdir(exist_ok=True)
    text = markdown(rows, a.mags)
    title = (f"# Faintest star found (paper camera, 1 s, seed {a.seed}): per magnitude, the "
             f"frames with a position, the mean error and the star's events per frame\n\n")
    (RESULTS / f"study_{a.name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"study_{a.name}.md").write_text(title + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
