"""Pixel-lag calibration across sensor settings: star positions at constant slew rates under
a dark sky, without and with the lag `evstar calibrate` measured on a calibration recording
of the same sensor (a 20-star field, 10°/0.5 Hz sinusoid, 4 s, DAVIS346 optics, IMU).

    python perf/study_calibration.py [--seeds 1]

The test scenes (one star, the paper's DVXplorer Lite optics, 0.5 s, compensate none) use a
camera, rates and magnitudes the calibration never saw. Sensor "dark-sky" is the setting
the method was developed on; the others were held out (never run before the code was
fixed). Writes perf/results/study_calibration.json and .md.
"""
import argparse
import pathlib
import time

import numpy as np

import evstar
from evstar import profiling, sim
from evstar.calibration import calibrate

RESULTS = pathlib.Path(__file__).parent / "results"
SENSORS = {  # name: (SensorSpec.dark_sky overrides, PSF sigma px, held out)
    "dark-sky": ({}, 1.0, False),
    "slow 15 Hz / 1 kHz, θ 0.25": (dict(cutoff_hz_background=15.0, cutoff_hz_max=1000.0,
                                        threshold_on=0.25, threshold_off=0.25), 1.0, True),
    "fast 60 Hz / 4 kHz, θ 0.15": (dict(cutoff_hz_background=60.0, cutoff_hz_max=4000.0,
                                        threshold_on=0.15, threshold_off=0.15), 1.0, True),
    "dark-sky, PSF σ 1.3": ({}, 1.3, True),
}
RATES, MAGS = (4.0, 8.0, 12.0, 20.0), (3.0, 4.0, 5.0)


def cached_lag_file(name, recording, _done={}):
    """`evstar calibrate`'s file of the recording `recording()` returns (a run with events,
    imu and camera), made once per `name` in the temporary folder (the accuracy studies
    calibrate each sensor once for all their scenes)."""
    if name not in _done:
        import tempfile

        run = recording()
        path = pathlib.Path(tempfile.gettempdir()) / f"evstar-study-lag_{name}.json"
        calibrate(run.events, run.imu, run.camera).save(str(path))
        _done[name] = str(path)
    return _done[name]


def calibration_run(spec, psf, seed):
    cam = sim.camera_preset("davis346")
    motion = sim.Sinusoid(10.0, 0.5, axis=(0.0, -1.0, 0.0), R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(cam, motion, 4.0, mag_limit=6.5, max_stars=20)
    return sim.simulate(sim.Scenario(cam, stars, motion, 4.0, sensor=spec, psf_sigma_px=psf),
                        seed=seed)


def errors(run, lag_file):
    cfg = evstar.Config().replace(**{"estimate.pixel_lag_file": lag_file})
    r = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera, truth=run.truth)
    e = r.metrics["centroid_error_px"]
    return e["mean"], e["max"], e["n"]


def main(seeds):
    rows = []
    for name, (over, psf, held_out) in SENSORS.items():
        spec = sim.SensorSpec.dark_sky(**over)
        for seed in range(seeds):
            t = time.perf_counter()
            cal = calibration_run(spec, psf, seed)
            lag = calibrate(cal.events, cal.imu, cal.camera)
            lag_file = str(RESULTS / f".lag_{len(rows)}.json")
            lag.save(lag_file)
            print(f"{name} seed {seed}: calibrated in {time.perf_counter() - t:.0f} s "
                  f"({lag.meta['crossings']:,} crossings, lag {lag.lag_us.min() / 1e3:.2f}–"
                  f"{lag.lag_us.max() / 1e3:.2f} ms)", flush=True)
            for rate in RATES:
                for mag in MAGS:
                    scn = sim.paper_preset(rate, magnitude=mag, sensor=spec, psf_sigma_px=psf)
                    run = sim.simulate(scn, seed=100 + seed)
                    raw, cal_e = errors(run, None), errors(run, lag_file)
                    rows.append({"sensor": name, "held_out": held_out, "seed": seed, "rate": rate,
                                 "mag": mag, "frames": raw[2], "raw_mean": raw[0],
                                 "raw_max": raw[1], "cal_mean": cal_e[0], "cal_max": cal_e[1]})
                    print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
            pathlib.Path(lag_file).unlink()
    return rows


COLUMNS = [("sensor", "sensor", ""), ("held_out", "held out", ""), ("seed", "seed", ""),
           ("rate", "°/s", ".0f"), ("mag", "mag", ".0f"), ("frames", "rows", ""),
           ("raw_mean", "raw mean px", ".3f"), ("raw_max", "raw max px", ".2f"),
           ("cal_mean", "calibrated mean px", ".3f"), ("cal_max", "calibrated max px", ".2f")]


def summary(rows):
    out = []
    for name in SENSORS:
        r = [x for x in rows if x["sensor"] == name]
        out.append({"sensor": name, "held_out": r[0]["held_out"], "scenes": len(r),
                    "raw": f"{np.median([x['raw_mean'] for x in r]):.3f} "
                           f"({min(x['raw_mean'] for x in r):.3f}–{max(x['raw_mean'] for x in r):.3f})",
                    "cal": f"{np.median([x['cal_mean'] for x in r]):.3f} "
                           f"({min(x['cal_mean'] for x in r):.3f}–{max(x['cal_mean'] for x in r):.3f})",
                    "cal_max": max(x["cal_max"] for x in r)})
    return out


SUMMARY = [("sensor", "sensor", ""), ("held_out", "held out", ""), ("scenes", "scenes", ""),
           ("raw", "raw mean px: median (range)", ""), ("cal", "calibrated mean px: median (range)", ""),
           ("cal_max", "calibrated max px", ".2f")]

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=1)
    a = ap.parse_args()
    rows = main(a.seeds)
    profiling.write_results(RESULTS / "study_calibration.json", rows, vars(a))
    text = profiling.table(summary(rows), SUMMARY) + "\n\n" + profiling.table(rows, COLUMNS)
    (RESULTS / "study_calibration.md").write_text(text + "\n")
    print(text)
