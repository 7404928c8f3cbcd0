"""The attitude on the EVK4 (12 mm, f ≈ 2469 px) with the pipeline's positions corrected by
a pixel-lag calibration instead of a truth-measured centroid delay.

`evstar.calibration.calibrate` runs on a separate recording of the same sensor (a 20-star
field at another pointing, 10°/0.5 Hz sinusoid, 4 s, IMU; no truth used); then the study's
Orion scenes (perf/study_attitude.py: 1 s, mag ≤ 6) at 10, 20, 30 °/s and the 10°/1 Hz
sinusoid go through the pipeline without and with `estimate.pixel_lag_file` (and, for the
IMU rows, also with motion.compensate = "imu"), and the attitude filter with and without
the IMU (centroid_delay_us 0).

    python perf/study_attitude_lag.py

Writes perf/results/study_attitude_lag.json and .md.
"""
import pathlib
import sys
import tempfile

import numpy as np

import evstar
from evstar import profiling, sim
from evstar.calibration import calibrate

sys.path.insert(0, str(pathlib.Path(__file__).parent))
import study_attitude as sa  # noqa: E402

RESULTS = pathlib.Path(__file__).parent / "results"
COLUMNS = [("motion", "°/s", ""), ("positions", "positions", ""), ("imu", "IMU", ""),
           ("cross_rms_px", "cross RMS px", ".4f"), ("cross_max_px", "cross max px", ".3f"),
           ("about_rms_px", "about RMS px (edge)", ".4f")]


def lag_file(cam):
    motion = sim.Sinusoid(10.0, 0.5, axis=(0.0, -1.0, 0.0), R0=sim.attitude_from_radec(100.0, 20.0))
    stars = sim.hipparcos_field_along(cam, motion, 4.0, mag_limit=6.5, max_stars=20)
    cal = sim.simulate(sim.Scenario(cam, stars, motion, 4.0), seed=5)
    path = pathlib.Path(tempfile.mkdtemp()) / "pixel_lag_evk4.json"
    calibrate(cal.events, cal.imu, cal.camera).save(path)
    return str(path)


def main():
    cam = sim.camera_preset("evk4", sa.CAMERAS["evk4"])
    lag = lag_file(cam)
    rows = []
    for motion in ("10", "20", "30", "sine"):
        traj = sa.trajectory(motion)
        stars = sim.hipparcos_field_along(cam, traj, sa.DURATION_S, mag_limit=sa.MAG_LIMIT)
        run = sim.simulate(sim.Scenario(cam, stars, traj, sa.DURATION_S), seed=1)
        for name, path in (("as they come", None), ("lag-calibrated", lag)):
            # without and with the pipeline compensating with the gyro (IMU rows only)
            for comp, imus in (("none", (None, run.imu)), ("imu", (run.imu,))):
                cfg = evstar.Config().replace(**{"estimate.pixel_lag_file": path,
                                                 "motion.compensate": comp})
                res = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera)
                for imu in imus:
                    r = sa.event_attitude(res.centroids, run.truth, imu)
                    rows.append({"motion": motion, "positions": name + (", IMU-compensated" if
                                                                         comp == "imu" else ""),
                                 "imu": imu is not None,
                                 **{k: r.get(k, np.nan) for k in ("cross_rms_px", "cross_max_px",
                                                                  "about_rms_px")}})
                    print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    pathlib.Path(lag).unlink()
    return rows


if __name__ == "__main__":
    rows = main()
    profiling.write_results(RESULTS / "study_attitude_lag.json", rows)
    text = profiling.table(rows, COLUMNS)
    (RESULTS / "study_attitude_lag.md").write_text(text + "\n")
    print(text)
