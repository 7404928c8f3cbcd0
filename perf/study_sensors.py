"""Star positions on sensor models the estimators were not written on: one change at a time
from the simulator's default sensor (ON/OFF 0.2, mismatch 0.02, refractory 100 µs, jitter
20 µs, 1.5 Hz of background, 5 hot pixels at 100 Hz), on four scenes (4 °/s magnitude 4
σ 1.2 px, 12 °/s magnitude 5, the 10°/1 Hz sinusoid magnitude 4, 1.5 °/s magnitude 4 σ 1.3;
no IMU; seed 51). The default crossings estimator, told nothing about the sensor.

The fourteenth session ran it once before changing anything; of its variants only "leak2"
(and the default) were then looked at while writing the run's stray-event rule
(evstar.crossings.without_strays); the others are held out.

    python perf/study_sensors.py [--variants base,leak2,...] [--seed 51]

Writes perf/results/study_sensors.json and .md: per variant and scene the star's events per
frame, mean / max error (px), frames with a position (%), false rows per 100 frames.
"""
import argparse
import pathlib

import study_accuracy as sa
import study_seeds as ss

from evstar import profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
#: one setting changed from the default sensor each
VARIANTS = {
    "base": {},
    "refr1ms": dict(refractory_us=1000.0),
    "mismatch06": dict(threshold_mismatch=0.06),
    "jitter200": dict(jitter_us=200.0),
    "dropout30": dict(dropout=0.3),
    "noise10": dict(noise_hz=10.0),
    "shot": dict(shot_noise_hz=2.0),
    "leak2": dict(leak_hz=2.0),
    "hot200": dict(hot_pixels=200, hot_pixel_hz=300.0),
    "coarse04": dict(threshold_on=0.4, threshold_off=0.4),
    "fine01": dict(threshold_on=0.1, threshold_off=0.1),
}
#: (motion °/s or "sine", magnitude, PSF σ px)
SCENES = [(4.0, 4.0, 1.2), (12.0, 5.0, 1.0), ("sine", 4.0, 1.0), (1.5, 4.0, 1.3)]
COLUMNS = [("variant", "sensor", ""), ("scene", "scene", ""),
           ("events_per_frame", "events/frame", ".0f"), ("mean", "mean px", ".3f"),
           ("max", "max px", ".2f"), ("frames_pct", "frames %", ".0f"),
           ("false_per_100", "false /100", ".1f")]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--seed", type=int, default=51)
    a = ap.parse_args()
    rows = []
    for name in a.variants.split(","):
        sa.SENSORS[name] = lambda o=VARIANTS[name]: sim.sensor_model("default", **o)
        for motion, mag, psf in SCENES:
            r = ss.run_seed(dict(motion=motion, mag=mag, psf=psf, sensor=name, comp="none",
                                 seed=a.seed))
            scene = f"{motion}{'' if motion == 'sine' else ' °/s'} mag {mag:g} σ {psf:g}"
            rows.append({"variant": name, "scene": scene, **r})
            print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    text = profiling.table(rows, COLUMNS)
    profiling.write_results(RESULTS / "study_sensors.json", rows, vars(a))
    (RESULTS / "study_sensors.md").write_text(f"# {vars(a)}\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
