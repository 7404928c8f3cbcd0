"""The sensor's OFF/ON threshold ratio as `crossings.threshold_ratio_of` measures it, every
passage charged the ½ of an unknown reference phase (the sixth to tenth sessions) or only
each pixel's first (since the eleventh), against the simulator's setting, on scenes whose
pixels see one passage (a steady pan) or several (star fields, sinusoids).

    python perf/study_threshold_ratio.py

Writes perf/results/study_threshold_ratio.json and .md.
"""
import pathlib

import study_attitude as sat
from evstar import Config, Pipeline, profiling, sim
from evstar.crossings import _change_runs, first_of_pixel, threshold_ratio_of
from evstar.estimation import _near_kept
from evstar.sim.sensor import SensorSpec

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
COLUMNS = [("scene", "scene", ""), ("sensor", "sensor", ""), ("true", "true r", ".3f"),
           ("first_share", "first passages", ".2f"), ("every", "every passage ½", ".4f"),
           ("first", "first passages ½", ".4f")]
SENSORS = {"ideal": SensorSpec.ideal, "default": SensorSpec,
           "ON 0.25 / OFF 0.15": lambda: SensorSpec(threshold_on=0.25, threshold_off=0.15),
           "ideal, ON 0.15 / OFF 0.25": lambda: SensorSpec.ideal(threshold_on=0.15, threshold_off=0.25)}


def field(camera, motion, sensor):
    cam = sim.camera_preset(camera, sat.CAMERAS[camera])
    traj = sat.trajectory(motion)
    stars = sim.hipparcos_field_along(cam, traj, sat.DURATION_S, mag_limit=sat.MAG_LIMIT)
    return sim.Scenario(cam, stars, traj, sat.DURATION_S, sensor=sensor)


SCENES = [
    ("DAVIS346 field, 20 °/s", lambda sp: field("davis346", "20", sp), ("ideal", "default")),
    ("DAVIS346 field, 10°/1 Hz sinusoid", lambda sp: field("davis346", "sine", sp), ("default",)),
    ("EVK4 field, 20 °/s", lambda sp: field("evk4", "20", sp), ("default",)),
    ("one star, 8 °/s", lambda sp: sim.paper_preset(8.0, magnitude=4.0, sensor=sp), ("default",)),
    ("one star, 10°/1 Hz sinusoid", lambda sp: sim.paper_sinusoid(magnitude=3.0, sensor=sp),
     ("ideal", "default", "ON 0.25 / OFF 0.15", "ideal, ON 0.15 / OFF 0.25")),
]


def measure(scenario, seed=2):
    run = sim.simulate(scenario, seed=seed)
    res = Pipeline(Config()).run(run.events, run.imu, run.camera)
    (ts, keys, ps), _ = _near_kept(run.events, res.keep, Config().estimate.crossing_radius_px)
    _, (change, on_before, off_after) = _change_runs(ts, keys, ps, "numpy")
    first = first_of_pixel(keys[change])
    return (float(first.mean()), threshold_ratio_of(on_before, off_after),
            threshold_ratio_of(on_before, off_after, first=first))


def main():
    rows = []
    for scene, make, sensors in SCENES:
        for name in sensors:
            spec = SENSORS[name]()
            share, every, first = measure(make(spec))
            rows.append(dict(scene=scene, sensor=name, true=spec.threshold_off / spec.threshold_on,
                             first_share=share, every=every, first=first))
            print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    text = profiling.table(rows, COLUMNS)
    profiling.write_results(RESULTS / "study_threshold_ratio.json", rows, {})
    (RESULTS / "study_threshold_ratio.md").write_text(
        "# OFF/ON threshold ratio measured from the runs\n\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
