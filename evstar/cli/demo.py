"""`evstar demo`: simulate the default scene (a magnitude-3 star at 20 °/s, biased IMU),
run the whole pipeline with particle-filter compensation and write results and plots; then
a Hipparcos star field (Orion, DAVIS346 behind 16 mm, the same rate) through the pipeline to
the inertial attitude (OUTDIR/field/, with attitude.csv; its events give the pooled fallback).

Any --rate within ±3600 °/s runs: where the particle filter finds no star to follow (a rate
near 0, where a still camera sees no star, or one so fast that no track forms) the demo
says so and compensates with the IMU alone. Files are written only once the pipeline ran."""
from __future__ import annotations

import pathlib

from .. import parameters as P
from .options import add_options, checked



def add_arguments(p):
    p.add_argument("-o", "--output", default="out/demo", metavar="OUTDIR", help="(out/demo)")
    p.add_argument("--rate", type=checked(float, -P.MAX_SLEW_DPS, P.MAX_SLEW_DPS), default=20.0,
                   help=f"slew rate, °/s, at most {P.MAX_SLEW_DPS} in size (20)")
    add_options(p, P.GLOBAL, ["device", "seed"], device={"default": "cpu"}, seed={"default": 1})
    add_options(p, P.MOTION, ["compensate"], section="", compensate={"default": "pf"})


def run(args):
    import numpy as np

    from .. import Config, sim
    from ..pipeline import Pipeline
    from .. import io, outputs
    from ..errors import DataError

    from ..io.atomic import check_output_dir

    from .. import backends

    out = pathlib.Path(args.output)
    check_output_dir(out)
    _check_replaceable(out)
    backends.require(args.device)   # a missing GPU before the simulation
    bias = tuple(np.radians([0.3, -0.2, 0.25]))   # a realistic MEMS gyro bias, °/s -> rad/s
    scenario = sim.paper_preset(args.rate, imu=sim.ImuSpec(gyro_bias=bias))
    run_ = sim.simulate(scenario, seed=args.seed)
    print(f"simulated     {run_.events!r}, IMU {len(run_.imu)} samples, magnitude-3 star at "
          f"{args.rate:g} °/s")
    cfg = Config(device=args.device, seed=args.seed).replace(**{"motion.compensate": args.compensate})
    try:
        result = Pipeline(cfg).run(run_.events, run_.imu, run_.camera, truth=run_.truth)
    except DataError:   # the scene's own data: only the particle filter can find too little
        if args.compensate != "pf":
            raise
        print(f"note          particle filter not run (no star tracked at {args.rate:g} °/s); "
              "compensating with the IMU alone")
        cfg = cfg.replace(**{"motion.compensate": "imu"})
        result = Pipeline(cfg).run(run_.events, run_.imu, run_.camera, truth=run_.truth)
    out.mkdir(parents=True, exist_ok=True)   # files only once the pipeline ran
    io.write(out / "events.h5", run_.events, imu=run_.imu, camera=run_.camera)
    io.write_imu(out / "imu.csv", run_.imu)
    io.write_camera(out / "camera.json", run_.camera)
    sim.save_truth(out / "truth.npz", run_.truth)
    outputs.write_run(out, result, cfg, run_.truth)
    steady = Pipeline(cfg).run(run_.events, run_.imu, run_.camera)  # kernels ready: steady state
    if "pf_final_bias_dps" in result.metrics:
        est = np.round(result.metrics["pf_final_bias_dps"], 3).tolist()
        print(f"gyro bias     true {[0.3, -0.2, 0.25]} °/s, particle filter {est} °/s")
    print(outputs.summary_text(result, out, steady=steady))
    _field(out / "field", args)


def _check_replaceable(out):
    """OutputError before anything is simulated where OUTDIR or OUTDIR/field holds a file the
    demo would write that no evstar command wrote there (simulate's recording files, known
    by its truth.npz; a run's, by .evstar-owned)."""
    from ..outputs import RUN_FILES, check_owned
    from .simulate import check_replaceable

    check_replaceable(out, "events.h5")
    for folder in (out, out / "field"):
        check_owned(folder, RUN_FILES)


def _field(out, args):
    """A star field through the whole pipeline to the camera -> ICRS attitude, its error
    against the truth printed."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from .. import Config, outputs, sim
    from ..attitude import rotation
    from ..pipeline import Pipeline
    from ..runs import attitude_rows

    cam = sim.camera_preset("davis346", 16.0)
    motion = sim.ConstantRate(args.rate, R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(cam, motion, 0.5, mag_limit=6.0)
    run_ = sim.simulate(sim.Scenario(cam, stars, motion, 0.5), seed=args.seed)
    cfg = Config(device=args.device)
    result = Pipeline(cfg).run(run_.events, run_.imu, run_.camera, truth=run_.truth)
    rows = attitude_rows(result, run_.camera, run_.imu, run_.events, cfg)  # + pooled fallback
    outputs.write_run(out, result, cfg, run_.truth, attitude=rows)
    print(f"star field    {len(stars)} Hipparcos stars (Orion), DAVIS346 16 mm, "
          f"{args.rate:g} °/s: {result.metrics['tracks']} tracks")
    if not len(rows):  # e.g. --rate 0: a still event camera sees no star
        print(f"attitude      none: no frame could be identified; wrote {out}/")
        return
    R_ic = rotation(np.stack([rows[k] for k in ("qw", "qx", "qy", "qz")], 1))
    err = Rotation.from_matrix(run_.truth.rotation_at(rows["t"]) @ R_ic).as_rotvec()
    cross_px = np.hypot(err[:, 0], err[:, 1]) * cam.fx
    print(f"attitude      first fix at {(rows['t'][0] - run_.events.t[0]) / 1000:.0f} ms, "
          f"{len(rows)} rows every 10 ms; cross-boresight error RMS "
          f"{np.sqrt(np.mean(cross_px ** 2)):.3f} px, max {cross_px.max():.3f} px "
          f"(ra {rows['ra_deg'][-1]:.3f}°, dec {rows['dec_deg'][-1]:.3f}°)")
    print(f"wrote         {out}/ (attitude.csv: t,qw,qx,qy,qz,... camera -> ICRS)")
