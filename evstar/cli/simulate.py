"""`evstar simulate OUT_DIR`: a simulated turntable run written as files.

OUT_DIR receives the events (events.h5 by default; the format follows --events-name's
extension: .h5 .npz .csv .aedat4), imu.csv (samples as measured: IMU frame and clock),
camera.json, and truth.npz (per-event labels in event order, star table, attitude and
star positions over time, IMU biases and calibration; read it with evstar.sim.load_truth).

A rerun into the same folder replaces these files; it never replaces a file an earlier
`evstar simulate` did not write there (truth.npz records the events file's name), and
--events-name must differ from imu.csv, camera.json and truth.npz.
"""
from __future__ import annotations

import math
import os

from .. import parameters as P
from ..errors import DataError, OutputError, ParameterError
from .common import check_events_output
from .options import checked

#: the most simulation time steps a run may take: the simulator holds several arrays of one
#: entry per step (about 40 bytes a step at its peak, so 2e8 steps ≈ 8 GB)
MAX_GRID_STEPS = 2e8
#: the most background and hot-pixel events a run may expect (each costs the simulator some
#: 60 bytes at its peak, measured: 7.7e7 events took 4.8 GB; so 1e8 events ≈ 6 GB)
MAX_NOISE_EVENTS = 1e8
#: the widest half-angle (°, corner to centre) a simulated pinhole camera may see: towards
#: 90° every star of the sky falls on a few central pixels (--focal-length 1e-6 mm ran for
#: over 15 minutes)
MAX_HALF_FOV_DEG = 75.0
#: the files simulate writes besides the events (fixed names)
OTHER_FILES = ("imu.csv", "camera.json", "truth.npz")
DEFAULT_EVENTS_NAME = "events.h5"
#: the constant rate without --rate or --sine (°/s)
DEFAULT_RATE_DPS = 10.0


def add_arguments(p):
    from ..sim.presets import SENSOR_MODELS, SENSORS

    p.add_argument("out_dir", metavar="OUT_DIR")
    p.add_argument("--preset", default="dvxplorer-lite", metavar="CAMERA",
                   help=f"camera: {', '.join(SENSORS)} (default: dvxplorer-lite, the paper's)")
    p.add_argument("--focal-length", type=checked(float, 0, open_low=True), default=12.0, metavar="MM",
                   help="lens focal length (12)")
    motion = p.add_mutually_exclusive_group()
    motion.add_argument("--rate", type=checked(float, -P.MAX_SLEW_DPS, P.MAX_SLEW_DPS), metavar="DPS",
                        help=f"constant turntable rate, °/s, at most {P.MAX_SLEW_DPS} in size "
                             f"(default {DEFAULT_RATE_DPS:g})")
    motion.add_argument("--sine", type=checked(float, 0), nargs=2, metavar=("AMP_DEG", "FREQ_HZ"),
                        help="sinusoidal motion, e.g. 10 1 (the paper's); its peak rate "
                             f"2π·FREQ_HZ·AMP_DEG at most {P.MAX_SLEW_DPS} °/s")
    p.add_argument("--axis", type=checked(float), nargs=3, default=(0.0, -1.0, 0.0), metavar=("X", "Y", "Z"),
                   help="rotation axis in the camera frame (default 0 -1 0: camera up)")
    p.add_argument("--jitter", type=checked(float, 0), nargs=2, metavar=("AMP_DEG", "FREQ_HZ"),
                   help="a platform's vibration on top of the motion, e.g. 0.05 20: a sinusoidal "
                        "turn about the image-plane axis across --axis (the x axis for a roll)")
    p.add_argument("--magnitude", type=checked(float, -30, 30), default=3.0, help="single star's magnitude (3)")
    p.add_argument("--stars", type=checked(int, 1, 100_000), default=1, metavar="N",
                   help="1: the paper's single-star simulator (default); N > 1: the N brightest "
                        "Hipparcos stars that come into view during the run, starting at --pointing")
    p.add_argument("--pointing", nargs="+", default=["83.8", "-5.4"], metavar=("RA", "DEC"),
                   help="boresight for --stars > 1: RA DEC in degrees (default: Orion, 83.8 -5.4), or "
                        "'random': uniform over the sky with a random roll, drawn from --seed")
    p.add_argument("--roll", type=checked(float, -360, 360), metavar="DEG",
                   help="camera roll about the boresight, degrees (0: image up points north; "
                        "default 0, random with --pointing random)")
    p.add_argument("--mag-limit", type=checked(float, -30, 30), default=6.5, help="faintest catalogue magnitude (6.5)")
    p.add_argument("--sensor", type=str, choices=SENSOR_MODELS, default="default",
                   help="sensor model: default (no pixel bandwidth limit) or dark-sky (photoreceptor "
                        "low-pass 30 Hz at the sky background up to 2 kHz, 0.1 Hz leak)")
    p.add_argument("--noise-hz", type=checked(float, 0, 1e6), default=1.5, help="background activity, events/pixel/s (1.5)")
    p.add_argument("--noise-growth", type=checked(float, 0, 1e3, open_low=True),
                   metavar="RATIO", help="stray light: the background at the end over that at "
                   "the start, changing linearly (1: steady; the sensor model's if not given)")
    p.add_argument("--hot-pixels", type=checked(int, 0, 10**7), default=5, metavar="N",
                   help="number of hot pixels, at most the camera's pixel count (5)")
    p.add_argument("--threshold", type=checked(float, 0, 10, open_low=True), default=0.2, help="ON/OFF contrast threshold, log units (0.2)")
    p.add_argument("--psf-sigma", type=checked(float, 0, 100, open_low=True), default=1.0, metavar="PX", help="PSF sigma in pixels (1.0)")
    p.add_argument("--duration", type=checked(float, 0, 3600, open_low=True), metavar="S",
                   help="seconds (default 0.5 for --rate, 1.0 for --sine, as the paper)")
    p.add_argument("--imu-rate", type=checked(float, 0, 1e6, open_low=True), default=1000.0, metavar="HZ", help="IMU sample rate (1000)")
    p.add_argument("--ideal-imu", action="store_true", help="IMU without noise or bias")
    p.add_argument("--seed", type=checked(int, 0, 2**32 - 1), default=0)
    p.add_argument("--events-name", default=DEFAULT_EVENTS_NAME, metavar="NAME",
                   help="events file name in OUT_DIR; its extension picks the format: .h5 .npz "
                        ".csv .aedat4 (events.h5)")


def scenario_from(args):
    """The Scenario the command-line options describe (ValueError on bad values).

    With one star this is the paper's setup (evstar.sim.paper_preset / paper_sinusoid for the
    default axis): the star crosses the image centre mid-run (constant rate) or at the
    sinusoid's zero crossing.
    """
    from .. import sim

    check_motion(args)
    if not any(args.axis):
        raise ParameterError(f"--axis must be a non-zero 3-vector, got {' '.join(f'{v:g}' for v in args.axis)}")
    big = max(abs(v) for v in args.axis)       # only the direction counts: 1e308 1e308 1e308
    args.axis = tuple(v / big for v in args.axis)  # would overflow its norm
    try:
        cam = sim.camera_preset(args.preset, args.focal_length)
    except DataError as exc:   # a lens no camera has: the option's, not an input's, error
        raise ParameterError(f"--focal-length {args.focal_length:g} mm on the {args.preset}: "
                             f"{exc}") from None
    check_lens(args, cam)   # before the sky is searched for the stars it would see
    if args.hot_pixels > cam.width * cam.height:
        raise ParameterError(f"--hot-pixels must be at most the {args.preset} sensor's "
                             f"{cam.width * cam.height:,} pixels ({cam.width}x{cam.height}), "
                             f"got {args.hot_pixels:,}")
    sensor = sim.sensor_model(args.sensor, threshold_on=args.threshold, threshold_off=args.threshold,
                              noise_hz=args.noise_hz, hot_pixels=args.hot_pixels,
                              **({} if args.noise_growth is None
                                 else {"noise_growth": args.noise_growth}))
    imu = (sim.ImuSpec.ideal if args.ideal_imu else sim.ImuSpec)(rate_hz=args.imu_rate)
    duration = args.duration if args.duration is not None else (1.0 if args.sine else 0.5)
    if args.stars == 1:
        motion = _motion(sim, args)
        t_centre = 0.0 if args.sine else duration / 2
        stars = sim.star_at_pixel(cam, motion.rotation(t_centre)[0], (cam.cx, cam.cy), args.magnitude)
    else:
        R0 = sim.attitude_from_radec(*pointing(args))
        motion = _motion(sim, args, R0)
        stars = sim.hipparcos_field_along(cam, motion, duration, mag_limit=args.mag_limit,
                                          max_stars=args.stars)
    scenario = sim.Scenario(cam, stars, motion, duration, sensor=sensor, imu=imu,
                            psf_sigma_px=args.psf_sigma)
    check_grid(args, scenario)
    return scenario


def check_lens(args, cam):
    """ParameterError where the lens gives the sensor more than 2 x MAX_HALF_FOV_DEG across
    its diagonal, naming the shortest focal length that does not."""
    tan_half = math.hypot(cam.width, cam.height) / 2 / min(cam.fx, cam.fy)
    half_fov = math.degrees(math.atan(tan_half))
    if half_fov > MAX_HALF_FOV_DEG:
        shortest = args.focal_length * tan_half / math.tan(math.radians(MAX_HALF_FOV_DEG))
        raise ParameterError(
            f"--focal-length {args.focal_length:g} mm gives this {args.preset} sensor a field of "
            f"view {2 * half_fov:.4g}° across its diagonal (a pinhole sees at most "
            f"{2 * MAX_HALF_FOV_DEG:g}° here); give at least {shortest:.3g} mm")


def check_grid(args, scenario):
    """ParameterError when the simulation would make more than MAX_NOISE_EVENTS noise events
    or take more than MAX_GRID_STEPS time steps:
    the simulator steps so that no star moves more than grid_step_px (half the PSF sigma)
    per step, at least one step per ms, so a tiny --psf-sigma or --focal-length, or a long
    fast run, needs more memory than any machine has (it was killed, not refused)."""
    cam = scenario.camera
    rate_dps = (_peak(args.sine) if args.sine else abs(constant_rate(args))) + _peak(args.jitter)
    f = max(cam.fx, cam.fy)
    widen = 1 + (math.hypot(cam.width, cam.height) / 2 / f) ** 2   # off-axis stars move faster
    px_per_s = math.radians(rate_dps) * f * widen
    steps_per_s = max(1e3, px_per_s / scenario.grid_step_px)
    steps = steps_per_s * max(scenario.duration_s, 0.01)
    spec, pixels = scenario.sensor, cam.width * cam.height
    noise = (spec.noise_hz * max(spec.noise_growth, 1) * pixels
             + spec.hot_pixels * spec.hot_pixel_hz) * scenario.duration_s
    if noise > MAX_NOISE_EVENTS:
        raise ParameterError(
            f"the simulation would make about {noise:.3g} noise events (at most {MAX_NOISE_EVENTS:g}): "
            f"--noise-hz {args.noise_hz:g} on {pixels:,} pixels and {spec.hot_pixels} hot pixels "
            f"for {scenario.duration_s:g} s; lower --duration or --noise-hz")
    if steps > MAX_GRID_STEPS:
        raise ParameterError(
            f"the simulation would take {steps:.3g} time steps (at most {MAX_GRID_STEPS:g}): stars "
            f"move {px_per_s:.3g} px/s on this {args.preset} sensor and {args.focal_length:g} mm lens "
            f"and are stepped every {scenario.grid_step_px:.3g} px (half the --psf-sigma "
            f"{args.psf_sigma:g}); lower --duration or the rate, or raise --psf-sigma or --focal-length")


def check_motion(args):
    """ParameterError when --sine's or --jitter's peak rate 2π·f·A exceeds the bound of --rate."""
    for option, pair in (("--jitter", args.jitter), ("--sine", args.sine)):
        if _peak(pair) > P.MAX_SLEW_DPS:
            amp, freq = pair
            raise ParameterError(f"{option} {amp:g} {freq:g}: peak rate 2π·FREQ_HZ·AMP_DEG = "
                                 f"{_peak(pair):.4g} °/s exceeds {P.MAX_SLEW_DPS} °/s (the bound of --rate); "
                                 "lower the amplitude or the frequency")


def pointing(args):
    """(ra, dec, roll) in degrees from --pointing and --roll (ParameterError when malformed)."""
    from ..sim import random_pointing

    if args.pointing == ["random"]:
        ra, dec, roll = random_pointing(args.seed)
        return ra, dec, roll if args.roll is None else args.roll
    try:
        ra, dec = (float(v) for v in args.pointing)
    except ValueError:
        raise ParameterError(f"--pointing must be RA DEC in degrees or 'random', got {' '.join(args.pointing)!r}") from None
    if not (-360 <= ra <= 360 and -90 <= dec <= 90):
        raise ParameterError(f"--pointing must be RA in [-360, 360] and DEC in [-90, 90] degrees, "
                             f"got {ra:g} {dec:g}")
    return ra, dec, 0.0 if args.roll is None else args.roll


def _motion(sim, args, R0=None):
    base = (sim.Sinusoid(*args.sine, axis=args.axis, R0=R0) if args.sine
            else sim.ConstantRate(constant_rate(args), axis=args.axis, R0=R0))
    if not _peak(args.jitter):
        return base
    across = (-args.axis[1], args.axis[0], 0.0)    # the boresight × axis
    return sim.Jitter(base, *args.jitter, across if any(across) else (1.0, 0.0, 0.0))


def _peak(pair):
    """The peak rate 2π·f·A (°/s) of --sine's or --jitter's (AMP_DEG, FREQ_HZ); 0 without it."""
    return 2 * math.pi * pair[0] * pair[1] if pair else 0.0


def constant_rate(args):
    """--rate, or DEFAULT_RATE_DPS where it is not given (°/s)."""
    return DEFAULT_RATE_DPS if args.rate is None else args.rate


def run(args):
    from .. import io
    from ..sim import save_truth, simulate

    if os.path.exists(args.out_dir) and not os.path.isdir(args.out_dir):
        raise OutputError(args.out_dir, "exists and is not a folder")
    events_path = os.path.join(args.out_dir, check_events_name(args.events_name))
    fmt = check_events_output(events_path, None, option="--events-name", override=None)
    check_replaceable(args.out_dir, args.events_name)
    pointing(args)   # malformed, it is refused with --stars 1 too (where no field is drawn)
    try:
        scenario = scenario_from(args)
    except ValueError as exc:  # the simulator's own checks of a combination of options
        raise ParameterError(str(exc)) from None
    result = simulate(scenario, seed=args.seed)
    if args.stars > 1:
        ra, dec, roll = pointing(args)
        result.truth.meta["pointing_deg"] = dict(ra=ra, dec=dec, roll=roll)
        print(f"pointing RA {ra:.3f}°, Dec {dec:.3f}°, roll {roll:.3f}° (truth.npz quat_icrs_cam: "
              "camera -> ICRS over time)")
    result.truth.meta["events_name"] = args.events_name   # a rerun may replace it
    os.makedirs(args.out_dir, exist_ok=True)
    save_truth(os.path.join(args.out_dir, "truth.npz"), result.truth)  # first: it says what is ours
    io.write(events_path, result.events, imu=result.imu if fmt != "csv" else None,
             camera=result.camera if fmt not in ("csv", "aedat4") else None)
    io.write_imu(os.path.join(args.out_dir, "imu.csv"), result.imu)
    io.write_camera(os.path.join(args.out_dir, "camera.json"), result.camera)
    labels = result.truth.labels
    if not len(scenario.stars):
        print("note: no star lies in view (--mag-limit, --pointing)")
    elif not (labels >= 0).any():   # which of these, the options say; each alone suffices
        print("note: the star(s) gave no events: a star that does not move changes no pixel "
              f"(--rate, --sine), one of magnitude {args.magnitude:g} may be too faint for this "
              "sensor and threshold, or the recording too short (--duration)")
    print(f"wrote {len(result.events):,} events ({int((labels >= 0).sum()):,} from "
          f"{len(scenario.stars)} star(s), {int((labels == -1).sum()):,} noise, "
          f"{int((labels == -2).sum()):,} hot-pixel) to {events_path}")
    print(f"wrote {len(result.imu):,} IMU samples, camera.json and truth.npz to {args.out_dir}")


def check_events_name(name):
    """--events-name: a file name in OUT_DIR that is none of simulate's other files."""
    if not name or os.path.basename(name) != name or name in (".", "..") \
            or (os.altsep and os.altsep in name):
        raise ParameterError(f"--events-name must be a file name in OUT_DIR (no folder), got {name!r}")
    # compared ignoring case: one file on case-insensitive file systems
    if name.lower() in OTHER_FILES:
        raise ParameterError(f"--events-name {name} is the name of simulate's {name.lower()}; "
                             f"choose another name (simulate also writes {', '.join(OTHER_FILES)})")
    return name


def check_replaceable(out_dir, events_name):
    """OutputError if a file simulate would write exists in `out_dir` but no earlier
    `evstar simulate` wrote it: simulate's files are known by truth.npz, which records the
    events file's name (a truth file without that record: the default events.h5)."""
    existing = [n for n in (events_name, *OTHER_FILES) if os.path.lexists(os.path.join(out_dir, n))]
    if not existing:
        return
    ours = _earlier_files(out_dir)
    foreign = [n for n in existing if n not in ours]
    if foreign:
        raise OutputError(os.path.join(out_dir, foreign[0]),
                          "exists and was not written by evstar simulate; simulate never "
                          "replaces other files: choose another OUT_DIR or --events-name")


def _earlier_files(out_dir):
    """The names an earlier simulate wrote into `out_dir` (empty without its truth.npz)."""
    import json
    import zipfile

    import numpy as np

    path = os.path.join(out_dir, "truth.npz")
    if not os.path.isfile(path):
        return set()
    try:
        with np.load(path, allow_pickle=False) as z:
            if "format_version" not in z.files or "meta" not in z.files:
                return set()
            meta = json.loads(str(z["meta"]))
    except (OSError, ValueError, zipfile.BadZipFile):
        return set()
    if not isinstance(meta, dict):
        return set()
    name = meta.get("events_name", DEFAULT_EVENTS_NAME)
    return {*OTHER_FILES, *([name] if isinstance(name, str) else [])}
