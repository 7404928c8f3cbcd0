"""Every tunable parameter of evstar, declared once: type, range, choices, default, doc.

The stage classes (filters, Extractor, Tracker, ParticleFilter), :class:`evstar.Config` and
the command line (argparse options are built from these declarations) all check values
with :meth:`Param.check`, so a value one layer accepts the others accept too, and a bad
one raises :class:`evstar.ParameterError` naming it, whichever layer it came through.

This module imports nothing heavy: ``evstar --help`` builds its options from it.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Set
from dataclasses import dataclass

from .errors import ParameterError

AUTO = "auto"


def is_auto(value):
    """value is the string "auto" (never compared as an array is: elementwise)."""
    return isinstance(value, str) and value == AUTO


@dataclass(frozen=True)
class Param:
    """One parameter. kind: int | float | str | bool; `many`: a non-empty list of kind
    (strictly increasing when `increasing`); `auto`: the string "auto" is allowed too;
    `optional`: None is allowed. low/high bound numbers (inclusive unless open_low/open_high).
    cli: the option name (default --name); cli_scale: option value x scale = parameter value
    (e.g. --dt-ms in ms for dt_us), cli_unit: the unit the option is given in."""

    name: str
    kind: type
    default: object
    doc: str
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    choices: tuple | None = None
    many: bool = False
    increasing: bool = False
    auto: bool = False
    optional: bool = False
    unit: str = ""
    cli: str | None = None
    cli_scale: float = 1
    cli_unit: str | None = None
    checker: object = None  # a function (value, key) -> value replacing the type/range test
    valid: str | None = None  # the checker's rule in words

    def check(self, value, key=None):
        """The value normalised (integral floats to int, tuples to lists), or ParameterError
        naming `key` (default: the parameter's name)."""
        key = key or self.name
        if value is None and self.optional:
            return None
        if self.auto and is_auto(value):
            return AUTO
        if not self.many:
            return self._one(value, key)
        # a list is ordered and one-dimensional: not a string, mapping, set or 0-d array
        if isinstance(value, (str, bytes, Mapping, Set)) or not isinstance(value, Iterable) \
                or getattr(value, "ndim", 1) != 1:
            raise ParameterError(f"{key} must be {self.expected()}, got {value!r}")
        values = [self._one(v, key) for v in value]
        if not values:
            raise ParameterError(f"{key} must be {self.expected()}, got an empty list")
        if self.increasing and any(b <= a for a, b in zip(values, values[1:])):
            raise ParameterError(f"{key} must be strictly increasing, got {values}")
        return values

    def _one(self, value, key):
        if self.checker is not None:
            return self.checker(value, key)
        v = _convert(self.kind, value)
        if v is None or (self.choices is not None and v not in self.choices) \
                or not self._in_range(v):
            raise ParameterError(f"{key} must be {self.expected()}, got {value!r}")
        return v

    def _in_range(self, v):
        if self.kind not in (int, float):
            return True
        low_ok = self.low is None or (v > self.low if self.open_low else v >= self.low)
        high_ok = self.high is None or (v < self.high if self.open_high else v <= self.high)
        return low_ok and high_ok

    def expected(self):
        """What a valid value looks like, in words."""
        if self.valid:
            return self.valid
        if self.choices is not None:
            what = "one of " + ", ".join(repr(c) for c in self.choices)
        elif self.kind is bool:
            what = "true or false"
        else:
            what = {int: "an integer", float: "a number", str: "a string"}[self.kind]
            what += _span(self.low, self.high, self.open_low, self.open_high)
        if self.many:
            plural = what.replace("an integer", "integers").replace("a number", "numbers")
            what = f"a non-empty list of {plural}"
        if self.auto:
            what = f"'auto' or {what}"
        if self.optional:
            what += " (or none)"
        return what

    @property
    def option(self):
        return self.cli or "--" + self.name.replace("_", "-")


def _convert(kind, value):
    """value as `kind`, or None when it is not one (bools are never numbers)."""
    if kind is bool:
        return value if isinstance(value, bool) else None
    if kind is str:
        return value if isinstance(value, str) else None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    if not math.isfinite(float(value)):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)  # an integer stays one, also where numbers are allowed
    if kind is int:
        return int(value) if float(value).is_integer() else None
    return float(value)


def _span(low, high, open_low, open_high):
    if low is not None and high is not None:
        a, b = ("(" if open_low else "["), (")" if open_high else "]")
        return f" in {a}{_num(low)}, {_num(high)}{b}"
    if low is not None:
        return f" {'>' if open_low else '>='} {_num(low)}"
    if high is not None:
        return f" {'<' if open_high else '<='} {_num(high)}"
    return ""


def _num(v):
    return f"{v:g}" if isinstance(v, float) else f"{v:,}".replace(",", "_") if abs(v) >= 10**5 else str(v)


class Params(dict):
    """The parameters of one stage, by name."""

    def __init__(self, section, *params):
        super().__init__((p.name, p) for p in params)
        self.section = section

    def check(self, name, value, key=None):
        return self[name].check(value, key)


# -- the declarations -------------------------------------------------------------------------
DEVICES = ("cpu", "cuda")
METHODS = ("none", "classical", "ndsef", "mr-ndsef")
COMPENSATIONS = ("none", "imu", "pf")
WEIGHTINGS = ("events", "pixels", "polarity")
#: grid: Taichi grid DBSCAN on each frame's cells (evstar_kernels.taichi.clusters);
#: sklearn: scikit-learn's DBSCAN on the same cells (the reference; identical labels)
CLUSTERINGS = ("grid", "sklearn")
TIME_REFS = ("mean", "mid")
#: "taichi"/"warp": the accelerated kernels; "reference": their numpy specification
DENOISE_BACKENDS = ("taichi", "reference")
#: auto: per-frame choice on CPU; sparse/dense: force direct cell reads / row prefix sums
STRATEGIES = ("auto", "sparse", "dense")
#: lanes: CPU form (lane-parallel, private grids, no per-event atomics);
#: events: GPU form (event-parallel with atomics); auto: lanes on CPU, events on CUDA
SCHEDULES = ("auto", "lanes", "events")
MAX_RADIUS = 64          # px; the counting kernels' disk tables stop here
#: px; every disk radius up to 1 px holds its centre pixel alone (far below this one, r²
#: underflows to 0 and the disk is empty)
MIN_RADIUS = 0.5
MAX_DT_US = 3_600_000_000  # one hour: frames longer than that are a unit mistake
#: pseudo-frames of one stream: its per-frame arrays (int64 offsets: 0.8 GB) must fit, and
#: 1e8 frames are 11.6 days of the default 10 ms frames (a longer span is a corrupt timestamp)
MAX_FRAMES = 10**8
#: pixels of a sensor the dense kernels take (8192 x 8192): each per-pixel grid of int64 is
#: 0.5 GB there, and the largest event sensors have ~1.2 million (a header's 65536 x 65536,
#: a legal side each, asked for 32 GB)
MAX_GRID_PIXELS = 2**26
#: largest density threshold: the counting kernels count in int32
MAX_THRESHOLD = 2**31 - 1
_INT32 = " (below 2**31: the kernels count in int32)"
#: smallest false-alarm probability of a Poisson count test: its quantile is computed from
#: 1 − alpha in double precision (as scipy's), exact to 1e-4 of alpha at 1e-12, NaN below ~1e-16
MIN_ALPHA = 1e-12
_TAIL = f" (at least {MIN_ALPHA:g}: the Poisson quantile is computed from 1 − alpha)"
MAX_PARTICLES = 1 << 22  # 4 M particles ≈ 0.5 GB of state and scratch
MAX_PIXEL_RATE_HZ = 1e6  # events/pixel/s: a pixel's refractory period is ~1 µs or more
#: the attitude filter's noise densities and prior spreads (in their units): beyond, its
#: covariances overflow (1e300: OverflowError) or turn singular (1e-300)
MIN_SPREAD, MAX_SPREAD = 1e-12, 1e12
#: °/s: the fastest slew the simulator and demo take (constant rate, or a sinusoid's peak
#: rate 2π·f·A), ten turns a second; faster slews only cost time (the simulator's steps
#: follow the star across the image) and no star sensor tracks them
MAX_SLEW_DPS = 3600


def check_path(value, key):
    """A non-empty path string (whether the file is there is the reader's to say)."""
    if not isinstance(value, str) or not value.strip():
        raise ParameterError(f"{key} must be a file path, got {value!r}")
    return value


def check_device(device, key="device"):
    """'cpu', 'cuda' or 'cuda:N'."""
    ok = isinstance(device, str) and device.split(":")[0] in DEVICES
    if ok and ":" in device:
        ok = device.startswith("cuda:") and device[5:].isdigit()
    if not ok:
        raise ParameterError(f"{key} must be 'cpu' or 'cuda' (or 'cuda:N'), got {device!r}")
    return device


GLOBAL = Params(
    "",
    Param("device", str, "cpu", "compute device: cpu, cuda or cuda:N", checker=check_device,
          valid="'cpu', 'cuda' or 'cuda:N'"),
    Param("dt_us", int, 10_000, "pseudo-frame length", low=1, high=MAX_DT_US, unit="µs",
          cli="--dt-ms", cli_scale=1000, cli_unit="ms"),
    Param("seed", int, 0, "random seed (particle filter)", low=0, high=2**32 - 1),
    Param("chunk_frames", int, 200, "frames of the calibration window of the background "
          "rate, and per streaming chunk (there rounded up to whole extract.pool_frames)",
          low=1, high=10**7),
)

DENOISE = Params(
    "denoise",
    Param("method", str, "mr-ndsef", "denoising filter", choices=METHODS),
    Param("radius", float, 5, "NDSEF disk radius", low=MIN_RADIUS, high=MAX_RADIUS, unit="px"),
    Param("threshold", int, AUTO, "NDSEF density threshold (events in the disk)", low=1,
          high=MAX_THRESHOLD, auto=True, valid=f"'auto' or an integer >= 1{_INT32}"),
    Param("radii", float, [3, 5, 7, 9, 11], "MR-NDSEF radii, increasing", low=MIN_RADIUS,
          high=MAX_RADIUS, many=True, increasing=True, unit="px"),
    Param("thresholds", int, AUTO, "MR-NDSEF thresholds, one per radius", low=1,
          high=MAX_THRESHOLD, many=True, auto=True,
          valid=f"'auto' or a non-empty list of integers >= 1{_INT32}"),
    Param("alpha", float, 1e-3, "false-alarm probability of auto thresholds" + _TAIL,
          low=MIN_ALPHA, high=1, open_high=True),
    Param("rate_hz", float, None, "background rate for auto thresholds (default: measured; "
          f"at most {MAX_PIXEL_RATE_HZ:g}: no pixel fires faster than about one event per µs)",
          low=0, high=MAX_PIXEL_RATE_HZ, optional=True, unit="events/pixel/s"),
    Param("k", int, 1, "classical filter: supporting neighbours needed (1 = dv's filter)",
          low=1, high=8),
)

EXTRACT = Params(
    "extract",
    Param("eps", float, 2.5, "DBSCAN radius", low=MIN_RADIUS, high=MAX_RADIUS, unit="px"),
    Param("min_samples", int, 5, "DBSCAN min_samples (weighted events within eps)", low=1,
          high=10**6),
    Param("clustering", str, "grid", "DBSCAN backend: Taichi grid kernels or scikit-learn "
          "(identical clusters)", choices=CLUSTERINGS),
    Param("min_cluster_size", int, None, "smallest cluster reported (default min_samples)",
          low=1, optional=True),
    Param("weighting", str, "events", "centroid weighting", choices=WEIGHTINGS),
    Param("time_ref", str, "mean", "centroid time: members' mean or frame mid-time",
          choices=TIME_REFS),
    Param("split_valley", float, 0.35, "close-pair split: profile dip below this x the lower "
          "peak (none: never split)", low=0, high=1, open_low=True, open_high=True,
          optional=True),
    Param("lobe_gap_px", float, 8.0, "an ON-only and an OFF-only cluster of one frame closer "
          "than this are one slow star's two lobes, joined; an OFF-only cluster behind a "
          "moving star is dropped as its trail (none: never join, keep all)", low=0,
          open_low=True, optional=True, unit="px"),
    Param("pool_frames", int, 4, "the events no frame centroid used (the filter rejected them, "
          "or no reported cluster holds them) are filtered and clustered again in frames this "
          "many times longer, for faint stars (1: no second look)",
          low=1, high=1000),
)

TRACK = Params(
    "track",
    Param("gate_px", float, 6.0, "largest jump of a track between frames", low=0,
          open_low=True, unit="px"),
    Param("init_gate_px", float, 40.0, "largest jump between a track's first two centroids "
          "while no track is confirmed (after that a new track moves with the field's flow)",
          low=0, open_low=True, unit="px"),
    Param("max_gap", int, 3, "frames a track survives without a centroid (the pipeline "
          "raises it to 2·extract.pool_frames − 1 for pooled centroids)", low=0, high=10**6),
    Param("min_length", int, 3, "centroids a track needs to be confirmed", low=1, high=10**6),
)

MOTION = Params(
    "motion",
    Param("compensate", str, "none", "motion compensation (imu, pf need an IMU and a camera)",
          choices=COMPENSATIONS),
    Param("n_particles", int, 4096, "particle-filter size", low=2, high=MAX_PARTICLES,
          cli="--particles"),
    Param("causal", bool, False, "pf: bias known up to each time (true) or final (false)"),
    Param("extrapolate_us", int, 5000, "events this far outside the IMU's span use its end "
          "samples' rates (held); further out is an error", low=0, high=10_000_000, unit="µs"),
    Param("measure_clock", bool, True, "imu, pf: measure the IMU clock's offset from the "
          "camera's on the stars' pixel crossings where the rate changes, and move the gyro's "
          "velocity prior by it (evstar.clock); false: its timestamps as they are"),
    Param("repair_gyro", bool, True, "imu, pf and the attitude filter: remove the gyro's "
          "spike samples and fill its gaps of over 5 sample intervals before use "
          "(evstar.gyro_repair); false: the record as it is, linear between samples"),
)

_DEG = math.pi / 180
#: the particle filter's model (evstar.motion.ParticleFilter); not part of Config
PARTICLE_FILTER = Params(
    "particle_filter",
    Param("backend", str, "warp", "particle kernels: Warp, or their numpy specification",
          choices=("warp", "reference")),
    Param("gyro_noise", float, 0.02 * _DEG, "gyro white noise", low=0, unit="rad/s"),
    Param("bias_walk", float, 0.02 * _DEG, "gyro bias random walk", low=0, unit="rad/s/√s"),
    Param("attitude_prior", float, 0.0, "initial attitude spread", low=0, unit="rad"),
    Param("pixel_sigma", float, 0.3, "centroid noise of the likelihood", low=0, open_low=True,
          unit="px"),
    Param("gate", float, 5.0, "likelihood gate, in pixel_sigma", low=0, open_low=True),
    Param("resample_threshold", float, 0.5, "resample below this effective sample fraction",
          low=0, high=1),
    Param("star_refine", int, 10, "centroids averaged into a star's direction", low=1,
          high=10**6),
)
#: where the event warping runs: Taichi or Warp kernels, or the numpy specification
WARP_BACKENDS = ("reference", "taichi", "warp")

#: options of the kernels themselves (how to compute, never what): not part of Config
KERNEL = Params(
    "kernel",
    Param("backend", str, "taichi", "denoise kernels: Taichi, or their numpy specification",
          choices=DENOISE_BACKENDS),
    Param("strategy", str, "auto", "disk counting: per-frame choice, direct reads, row prefix sums",
          choices=STRATEGIES),
    Param("schedule", str, "auto", "lanes (CPU form) or events (GPU form); auto: by device",
          choices=SCHEDULES),
    Param("t0_us", int, None, "frame origin (default: the first event's time)",
          low=-(1 << 62), high=1 << 62, optional=True),
)

ESTIMATORS = ("crossings", "track", "mean")

ESTIMATE = Params(
    "estimate",
    Param("estimator", str, "crossings", "star positions: a track smoother fed with pixel "
          "crossing times (crossings), with centroids only (track), or per-frame means (mean)",
          choices=ESTIMATORS),
    Param("crossing_radius_px", float, 3.0, "crossings come from all events this close to a "
          "kept event (a filter drops a faint star's flank events)", low=0, high=MAX_RADIUS,
          unit="px"),
    Param("threshold_ratio", float, AUTO, "the sensor's OFF / ON contrast threshold, for "
          "pairing crossing levels (auto: measured from the ON and OFF runs of the data; where they "
          "are too few, the pixel_lag_file's, which evstar calibrate measured, else 1)",
          low=0.25, high=4, auto=True),
    Param("refractory_us", float, 0.0, "the pixels' refractory period (the sensor's bias "
          "setting), for pairing crossing levels: each event then stands for the levels its "
          "gap says the pixel skipped while blind (0: none); where a run measures a pixel "
          "low-pass lag it takes the crossings of a run told none (the lag model holds there)",
          low=0, high=100_000, unit="µs"),
    Param("pixel_lag_file", str, None, "pixel lag by brightness from `evstar calibrate` "
          "(JSON): each pixel crossing is moved back by its lag (none: no correction)",
          optional=True, checker=check_path, valid="a file path"),
    Param("measure_lag", bool, True, "without a pixel_lag_file, measure the pixels' "
          "low-pass lag from the crossings' level profiles (evstar.level_lag; used only where "
          "its model explains them)"),
    Param("lag_from_tracks", bool, True, "correct the measured lag of crossings of fewer "
          "than 5 level pairs to agree with the brighter crossings along the same tracks, "
          "and carry it to faint stars by each crossing's outer width "
          "(evstar.level_lag.track_consistent; only where the lag is measured)"),
    Param("speed_change", bool, True, "move each pixel crossing to when the star passed its "
          "pixel where the track speeds up or slows down (a level pair's flanks are equally "
          "far from the pixel, not equally long before and after): with an IMU velocity prior "
          "on every track, without one on the tracks that never reverse (the speed change "
          "read off their first fit with the crossings)"),
    Param("vibration", bool, True, "where no velocity prior carries a track, search each "
          "long track's centroids for a sinusoid across its motion (a platform's vibration, "
          "which the constant-velocity smoother flattens) and follow it where one is found "
          "beyond chance (evstar.vibration)"),
    Param("gyro_noise", float, AUTO, "with an IMU velocity prior, the gyro's white-noise "
          "density, whose integral the track smoother lets each track's positions wander by "
          "(auto: measured from the gyro's samples; set a datasheet value for a gyro filtered "
          "on chip)", low=0, auto=True, unit="rad/s/√Hz"),
    Param("along_weight", float, 0.1, "where crossings are used, a centroid's weight along the "
          "motion relative to across it (its mean is biased along the motion; below 1e-3 its "
          "σ overflows the smoother)", low=1e-3, high=1),
    Param("process_noise", float, AUTO, "track smoother: white-acceleration spectral density q "
          "(auto: estimated per track from its centroids)", low=0, auto=True, unit="px²/s³"),
    Param("process_noise_min", float, 1.0, "floor of an estimated q (a straight track's q "
          "estimate can be 0)", low=0, unit="px²/s³"),
    Param("coast_ms", float, 60.0, "report a frame without a centroid only within this of "
          "a measurement (before or after)", low=0, high=MAX_DT_US / 1000, unit="ms"),
    Param("coast_ends", bool, True, "coast also before a track's first and after its last "
          "centroid (within coast_ms)"),
    Param("coast_gyro_ms", float, 500.0, "where a gyro prior carries a track (motion.compensate "
          "imu or pf), coast before its first and after its last centroid within this instead, "
          "up to a readout stall (each such position's σ also holds a share of the gyro's "
          "displacement since that centroid, evstar.coasting, and coast_sigma_px bounds it); "
          "gaps inside a track keep coast_ms",
          low=0, high=MAX_DT_US / 1000, unit="ms"),
    Param("coast_sigma_px", float, 0.5, "a coasted position before a track's first or after "
          "its last measurement is reported only while its uncertainty is at most this",
          low=0, open_low=True, unit="px"),
    Param("max_sigma_px", float, 1.0, "a smoothed position (measured, pooled, or coasted "
          "between two measurements of its track) is reported only while its uncertainty is "
          "at most this (a sinusoid's turn: ~0.3 px; a crowded field's track that lost its "
          "star, or an outlier of a short track: up to tens of px)", low=0, open_low=True,
          unit="px"),
    Param("sigma_floor_px", float, 0.02, "smallest per-axis measurement sigma of a centroid",
          low=0, high=MAX_RADIUS, open_low=True, unit="px"),
    Param("psf_sigma_px", float, None, "measurement sigma = this / sqrt(events) (default: "
          "the centroid's spread / sqrt(2 events))", low=0, high=MAX_RADIUS, open_low=True,
          optional=True, unit="px"),
    Param("min_events", int, 8, "centroids of fewer events take their track's median spread",
          low=1, high=10**6),
    Param("outlier_sigma", float, 4.0, "a centroid farther than this x its sigma from the "
          "smoothed track is dropped and the track refitted (none: keep all)", low=0,
          open_low=True, optional=True),
    Param("untracked_alpha", float, 0.01, "an untracked centroid (of no confirmed track) "
          "is reported only where background alone would form a cluster of as many events "
          "somewhere in its frame with at most this probability (the measured background "
          "rate; none: report all)", low=MIN_ALPHA, high=1, optional=True),
    Param("field_min_stars", int, 4, "rigid-field refinement (evstar.field, needs the "
          "camera): in a frame with at least this many tracked stars, a star's position is "
          "the one the field's rotation and all its track's rows give (0: off)", low=0,
          high=10**6),
    Param("across_kernel_px", float, 1.5, "a track's position across its motion is the "
          "mode of all events near its path, pooled over the track (evstar.across): a "
          "mean-shift whose first pass weighs with a Gaussian of this σ and measures the "
          "profile's width, the second with a kernel matched to it (0: the centroids' own)",
          low=0, high=10,
          unit="px"),
    Param("split_pairs", bool, True, "a track whose pixel crossings spread across its "
          "motion far wider than the other tracks' (by brightness) is two stars closer than "
          "DBSCAN separates: reported as the two stars of a two-star fit (evstar.pairs; needs "
          "the crossings estimator and 3 other measured tracks)"),
    Param("along_blends", bool, True, "a track that keeps its direction and whose "
          "crossings' top level pairs stand off it along its motion is two stars passing each "
          "pixel in one pulse: moved onto the brighter (evstar.blends; needs the crossings "
          "estimator, 3 other measured tracks and no pixel lag)"),
)

HOTPIXELS = Params(
    "hotpixels",
    Param("alpha", float, 1e-6, "false-alarm probability per pixel of the Poisson count test"
          + _TAIL, low=MIN_ALPHA, high=1, open_high=True, cli="--hot-alpha"),
    Param("neighbour_ratio", float, 4.0, "a hot pixel's count is at least this x its "
          "second-brightest 8-neighbour's (a hot pair is found)", low=1),
    Param("remove", bool, True, "drop the events of hot pixels (found in the calibration "
          "window, the first chunk_frames frames) before extraction",
          cli="--remove-hot-pixels"),
)

#: library-only settings (not Config keys: the pipeline does not use them)
REEXTRACT = Params(
    "reextract",
    Param("gather_radius_px", float, 4.0, "re-extraction: events this close to a track's "
          "predicted position are its (>= 4 PSF sigmas: a cut through the PSF's wings at "
          "whole pixels biases)", low=0, high=MAX_RADIUS, open_low=True, unit="px"),
    Param("gather_min_events", int, 3, "re-extraction: frames are pooled until a window "
          "holds this many events", low=1, high=10**6),
    Param("gather_max_frames", int, 5, "re-extraction: longest window (a sparser stretch "
          "gives no centroid)", low=1, high=10**6),
)

HOTPIXEL_MAP = Params(
    "hotpixel_map",
    Param("window_us", int, 1_000_000, "HotPixelMap's running window (the pipeline counts "
          "its calibration window)", low=1, high=MAX_DT_US, unit="µs"),
    Param("max_spread_px", float, 0.5, "remove_hot_centroids: a centroid on a hot pixel is "
          "dropped when its spread is at most this", low=0, unit="px"),
)

#: star identification (evstar.attitude.identify); library-only, not part of Config
IDENTIFY = Params(
    "identify",
    Param("mag_limit", float, 6.0, "faintest catalogue star in the solver's database",
          low=-2, high=12),
    Param("min_matches", int, 4, "a solution needs at least this many matched stars", low=3,
          high=1000),
    Param("max_residual_px", float, 2.0, "a solution's RMS angle between matched centroid rays "
          "and catalogue stars may be at most this (in pixels of the camera)", low=0,
          open_low=True, unit="px"),
    Param("max_false_match", float, 1e-5, "largest false-match probability of a solution "
          "(the solver's verification)", low=0, high=1, open_low=True),
    Param("match_radius_px", float, 3.0, "a centroid this close to a projected catalogue star "
          "is matched to it", low=0, open_low=True, high=1000, unit="px"),
    Param("pattern_error", float, 0.01, "largest error of a 4-star pattern's edge ratios the "
          "search accepts (centroid error / star separation)", low=0, high=0.1, open_low=True),
    Param("max_patterns", int, 1000, "give up a lost-in-space search after testing this many "
          "4-star patterns: a bound by work, so a field solves or fails alike on every machine "
          "(a failed search of 24 or more centroids takes ~0.7 s at 1000 on a 2-core CPU; the "
          "fields tried solved within 450, nearly all within 25)", low=1, high=10_000_000),
    Param("timeout_ms", int, 10_000, "give up a lost-in-space search after this long even "
          "within max_patterns: a cap for very slow machines (where it ends a search first, the "
          "outcome depends on the machine)",
          low=1, high=600_000, unit="ms"),
    Param("pooled_alphas", float, [1e-6, 1e-4, 1e-3], "identify_events: false-alarm "
          "probabilities per pixel of the pooled-window star detection, tried in turn (strictest "
          "first) until one identifies", low=0, high=1, open_low=True, many=True),
)

# -- [attitude_filter]: the attitude MEKF (evstar.attitude.estimator) -----------------------
#: `evstar run` and `evstar batch` name these options with this prefix (--attitude-rate-hz):
#: their bare names (--rate-hz, --gyro-noise, --sigma-floor-px) are pipeline options there;
#: `evstar attitude`, which has no pipeline options, takes the bare names
ATTITUDE_PREFIX = "attitude-"
ATTITUDE_FILTER = Params(
    "attitude_filter",
    Param("rate_hz", float, 100.0, "attitude output rate (predictions between updates)",
          low=0, high=1000, open_low=True, unit="Hz"),
    Param("min_stars", int, 3, "identify again while fewer identified stars are tracked",
          low=1, high=1000),
    Param("reidentify_ms", float, 100.0, "least time between identifications while tracking",
          low=0, unit="ms"),
    Param("lost_retry_ms", float, 0.0, "while the attitude is lost, a failed full search of a "
          "frame is retried after this (0: the next frame), and a failed pooled window after "
          "max(this, pooled_window_ms)", low=0, unit="ms"),
    Param("gyro_noise", float, 2e-4, "filter's gyro white noise (with an IMU)", low=0,
          high=MAX_SPREAD, unit="rad/s/√Hz"),
    Param("bias_walk", float, 1e-4, "filter's gyro bias random walk (with an IMU)", low=0,
          high=MAX_SPREAD, unit="rad/s²/√Hz"),
    Param("bias_prior", float, 0.01, "initial gyro bias spread (with an IMU)", low=MIN_SPREAD,
          high=MAX_SPREAD, unit="rad/s"),
    Param("jerk_noise", float, 5.0, "white angular jerk of the constant-acceleration model "
          "(no IMU)", low=MIN_SPREAD, high=MAX_SPREAD, unit="rad/s³/√Hz"),
    Param("rate_prior", float, 1.0, "initial rate spread without track velocities (no IMU)",
          low=MIN_SPREAD, high=MAX_SPREAD, unit="rad/s"),
    Param("accel_prior", float, 1.0, "initial angular acceleration spread (no IMU)",
          low=MIN_SPREAD, high=MAX_SPREAD, unit="rad/s²"),
    Param("rate_prior_tracks", float, 0.005, "initial rate spread when the tracks' image "
          "velocities gave it (no IMU)", low=MIN_SPREAD, high=MAX_SPREAD, unit="rad/s"),
    Param("init_sigma_arcsec", float, 60.0, "attitude spread of a fix", low=MIN_SPREAD,
          high=MAX_SPREAD, unit="arcsec"),
    Param("sigma_px", float, 0.3, "centroid sigma where a centroid has none", low=0,
          open_low=True, unit="px"),
    Param("sigma_floor_px", float, 0.03, "smallest centroid sigma used", low=0, open_low=True,
          unit="px"),
    Param("sigma_scale", float, 1.0, "centroid sigmas are multiplied by this (smoothed "
          "centroids are correlated in time)", low=0, open_low=True),
    Param("centroid_delay_us", float, 0.0, "a centroid's position is the star's at its time "
          "plus this (a timing bias of the centroid estimator or sensor latency: calibrate "
          "it against a known motion)", low=-100_000, high=100_000, unit="µs"),
    Param("gate", float, 5.0, "an identified star's centroid farther than this many sigmas "
          "is left out", low=0, open_low=True),
    Param("max_misses", int, 5, "gated-out centroids in a row after which a track's "
          "identity is forgotten", low=1, high=10**6),
    Param("pooled_centroids", bool, False, "the pipeline's pooled centroids (source "
          "\"pooled\": a faint star's mean over extract.pool_frames frames) update the filter "
          "too; such a mean is off by α·var(t)/2 under an angular acceleration α (0.4 px at the "
          "10°/1 Hz sinusoid's turns on a DAVIS346), so by default they only identify"),
    Param("smooth", bool, True, "smooth over the whole recording (an RTS pass): each row "
          "uses the centroids after it too; false: the causal filter, each row from the "
          "centroids before it"),
    Param("lost_sigma_deg", float, 0.5, "the attitude is lost (rows stop) when its 1-sigma "
          "exceeds this", low=0, open_low=True, unit="deg"),
    Param("pooled_window_ms", float, 50.0, "when no frame's centroids have identified for this "
          "long while the attitude is lost (or fewer than min_stars identified tracks are seen "
          "and some are unnamed), this window's events pooled into one image are identified "
          "(identify_events; needs the events); 0: frames only", low=0, high=10_000, unit="ms"),
    Param("pooled_max_wait_ms", float, 1600.0, "after each failed pooled search in a row the "
          "wait before the next one doubles, up to this (a window without stars, e.g. a sensor "
          "at rest, spends the solver's whole timeout on its noise)", low=0, high=3_600_000,
          unit="ms"),
)

#: how the track smoother computes (never what): not part of Config
SMOOTHER = Params(
    "smoother",
    Param("engine", str, "taichi", "track smoother's Kalman filter: a Taichi kernel, a thread "
          "per track; numpy, all tracks at once (the kernel's specification); or filterpy, one "
          "track and step at a time (the reference; slow)", choices=("taichi", "numpy", "filterpy")),
)

#: the sections of evstar.Config: the pipeline's stages, and the attitude written after it
SECTIONS = {"denoise": DENOISE, "extract": EXTRACT, "track": TRACK, "motion": MOTION,
            "estimate": ESTIMATE, "hotpixels": HOTPIXELS, "attitude_filter": ATTITUDE_FILTER}


def run_option(param):
    """An [attitude_filter] parameter's option in `evstar run` / `evstar batch`."""
    return "--" + ATTITUDE_PREFIX + param.option[2:]


def check_thresholds_per_radius(thresholds, radii, key="thresholds"):
    """The rule across two declarations: explicit MR-NDSEF thresholds come one per radius."""
    if not is_auto(thresholds) and len(thresholds) != len(radii):
        raise ParameterError(f"{key} must be 'auto' or one integer per radius ({len(radii)}), "
                             f"got {thresholds!r}")
    return thresholds


def markdown():
    """docs/parameters.md: every declared parameter as a table per section (a test keeps the
    file equal to this text)."""
    library = (KERNEL, PARTICLE_FILTER, REEXTRACT, HOTPIXEL_MAP, IDENTIFY, SMOOTHER)
    config = ", ".join(f"`{k}`" for k in SECTIONS)
    lines = ["# Parameters", "", "Generated from `evstar/parameters.py` (`python -m evstar.parameters "
             "> docs/parameters.md`). The top level and the sections " + config + " are "
             "`evstar.Config` keys (`section.name`; tables of a `--config` TOML or JSON file); "
             "command-line option in the last column (`evstar extract`, `evstar run`; "
             "`evstar denoise` takes the denoise ones). "
             + ", ".join(f"`{p.section}`" for p in library) + " are library settings (keyword "
             "arguments of their classes, no Config keys). `attitude_filter` sets the attitude "
             "`evstar attitude` (options: the first name) and `evstar run` / `evstar batch` "
             f"(the second, prefixed `--{ATTITUDE_PREFIX}`) write; its keys are also the "
             "keywords of `evstar.attitude.estimate`.", ""]
    for params in (GLOBAL, *SECTIONS.values(), *library):
        title = params.section or "top level"
        lines += [f"## {title}", "", "| name | default | valid | unit | meaning | option |",
                  "|---|---|---|---|---|---|"]
        for name, p in params.items():
            cli = params not in library or (params is KERNEL and name == "backend")
            option = f"`{p.option}`" if cli else "—"
            if params is ATTITUDE_FILTER:
                option += f", `{run_option(p)}`"
            lines.append(f"| `{name}` | `{p.default!r}` | {p.expected()} | {p.unit or '—'} | "
                         f"{p.doc} | {option} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown(), end="")
