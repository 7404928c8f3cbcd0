"""An `evstar calibrate` file from a simulated star field on a sinusoid with its IMU, for
study_field.py's `--set estimate.pixel_lag_file=PATH`.

    python perf/calibrate_field.py OUT.json [--camera evk4:16] [--pointing 305,40]
        [--rate 25] [--sensor dark-sky] [--noise 0.1] [--seed 300]

The twenty-second session's check: a Cygnus EVK4 16 mm dark-sky field on a 1 Hz sinusoid
peaking at 25 °/s (these defaults) calibrated the held-out Lyra pans
(`perf/study_field.py --camera evk4:16 --pointing 280,38 --seeds 222 --motion pan --sensor
dark-sky --rates 10,20,30 --set estimate.pixel_lag_file=OUT.json`) worse than the lag the
pipeline measures itself (docs/measurements.md, the twenty-second session).
"""
import argparse

from evstar import sim
from evstar.calibration import calibrate

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--camera", default="evk4:16")
    ap.add_argument("--pointing", default="305,40")
    ap.add_argument("--rate", type=float, default=25.0)
    ap.add_argument("--sensor", default="dark-sky")
    ap.add_argument("--noise", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=300)
    a = ap.parse_args()
    name, focal = a.camera.split(":")
    ra, dec = (float(v) for v in a.pointing.split(","))
    scene = sim.field_scenario(sim.camera_preset(name, float(focal)), ra, dec, a.rate, 1.0,
                               motion="sine", sensor=a.sensor, noise_hz=a.noise)
    run = sim.simulate(scene, seed=a.seed)
    lag = calibrate(run.events, run.imu, run.camera)
    lag.save(a.out)
    print(f"wrote {a.out}: pairs {lag.pairs.tolist()}, speeds {lag.speed_px_s.round(0).tolist()} px/s")
