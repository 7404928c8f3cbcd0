"""Pipeline configuration: one validated object, serialisable to JSON and TOML.

Every bad value raises ``ValueError`` naming its key as ``section.key``.
"""
from __future__ import annotations

import dataclasses
import json
import math
import pathlib
import sys
from dataclasses import asdict, dataclass, field, fields

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

METHODS = ("none", "classical", "ndsef", "mr-ndsef")
COMPENSATIONS = ("none", "imu", "pf")


def _check(cond, key, value, what):
    if not cond:
        raise ValueError(f"config key '{key}' {what}, got {value!r}")


def _positive(key, v, integer=False):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
    _check(ok and (not integer or int(v) == v), key, v,
           "must be a positive " + ("integer" if integer else "number"))


@dataclass
class DenoiseConfig:
    method: str = "mr-ndsef"
    radius: int = 5                       # NDSEF
    threshold: int | None = None          # NDSEF density threshold; None: auto
    radii: list = field(default_factory=lambda: [3, 5, 7, 9, 11])
    thresholds: object = "auto"           # MR-NDSEF: "auto" or one integer per radius
    alpha: float = 1e-3                   # false-alarm probability of auto thresholds
    k: int = 1                            # classical: supporting neighbours

    def validate(self, s="denoise"):
        _check(self.method in METHODS, f"{s}.method", self.method, f"must be one of {METHODS}")
        _positive(f"{s}.radius", self.radius, integer=True)
        if self.threshold is not None:
            _positive(f"{s}.threshold", self.threshold, integer=True)
        _check(isinstance(self.radii, (list, tuple)) and len(self.radii) > 0, f"{s}.radii",
               self.radii, "must be a non-empty list of radii")
        for r in self.radii:
            _positive(f"{s}.radii", r, integer=True)
        _check(list(self.radii) == sorted(set(self.radii)), f"{s}.radii", self.radii,
               "must be strictly increasing")
        if self.thresholds != "auto":
            _check(isinstance(self.thresholds, (list, tuple)) and len(self.thresholds) == len(self.radii),
                   f"{s}.thresholds", self.thresholds, "must be 'auto' or one integer per radius")
            for t in self.thresholds:
                _positive(f"{s}.thresholds", t, integer=True)
        _check(isinstance(self.alpha, float) and 0 < self.alpha < 1, f"{s}.alpha", self.alpha,
               "must be a probability in (0, 1)")
        _check(self.k in range(1, 9), f"{s}.k", self.k, "must be an integer from 1 to 8")


@dataclass
class ExtractConfig:
    eps: float = 2.5
    min_samples: int = 5
    min_cluster_size: int | None = None
    weighting: str = "events"
    time_ref: str = "mean"

    def validate(self, s="extract"):
        from .extract import TIME_REFS, WEIGHTINGS

        _positive(f"{s}.eps", self.eps)
        _positive(f"{s}.min_samples", self.min_samples, integer=True)
        if self.min_cluster_size is not None:
            _positive(f"{s}.min_cluster_size", self.min_cluster_size, integer=True)
        _check(self.weighting in WEIGHTINGS, f"{s}.weighting", self.weighting, f"must be one of {WEIGHTINGS}")
        _check(self.time_ref in TIME_REFS, f"{s}.time_ref", self.time_ref, f"must be one of {TIME_REFS}")


@dataclass
class TrackConfig:
    gate_px: float = 6.0
    init_gate_px: float = 40.0
    max_gap: int = 3
    min_length: int = 3

    def validate(self, s="track"):
        _positive(f"{s}.gate_px", self.gate_px)
        _positive(f"{s}.init_gate_px", self.init_gate_px)
        _check(isinstance(self.max_gap, int) and self.max_gap >= 0, f"{s}.max_gap", self.max_gap,
               "must be a non-negative integer")
        _positive(f"{s}.min_length", self.min_length, integer=True)


@dataclass
class MotionConfig:
    compensate: str = "none"              # none | imu | pf
    n_particles: int = 4096
    causal: bool = False                  # pf: bias known up to each time (True) or final (False)

    def validate(self, s="motion"):
        _check(self.compensate in COMPENSATIONS, f"{s}.compensate", self.compensate,
               f"must be one of {COMPENSATIONS}")
        _positive(f"{s}.n_particles", self.n_particles, integer=True)
        _check(isinstance(self.causal, bool), f"{s}.causal", self.causal, "must be true or false")


@dataclass
class Config:
    device: str = "cpu"
    dt_us: int = 10_000
    seed: int = 0
    chunk_frames: int = 200               # frames per streaming chunk
    denoise: DenoiseConfig = field(default_factory=DenoiseConfig)
    extract: ExtractConfig = field(default_factory=ExtractConfig)
    track: TrackConfig = field(default_factory=TrackConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)

    def __post_init__(self):
        self.validate()

    def validate(self):
        _check(isinstance(self.device, str) and self.device.split(":")[0] in ("cpu", "cuda"),
               "device", self.device, "must be 'cpu' or 'cuda'")
        _positive("dt_us", self.dt_us, integer=True)
        _check(isinstance(self.seed, int) and self.seed >= 0, "seed", self.seed, "must be a non-negative integer")
        _positive("chunk_frames", self.chunk_frames, integer=True)
        for f in ("denoise", "extract", "track", "motion"):
            getattr(self, f).validate(f)
        return self

    # -- serialisation -----------------------------------------------------------------
    def to_dict(self):
        return asdict(self)

    @classmethod
    def from_dict(cls, data):
        if not isinstance(data, dict):
            raise ValueError(f"config must be a mapping, got {type(data).__name__}")
        kwargs = {}
        for key, value in data.items():
            if key in _SECTIONS:
                kwargs[key] = _section(key, value)
            elif key in {f.name for f in fields(cls)}:
                kwargs[key] = value
            else:
                raise ValueError(f"unknown config key '{key}' (known: "
                                 f"{sorted(f.name for f in fields(cls))})")
        return cls(**kwargs)

    def to_json(self):
        return json.dumps(self.to_dict(), indent=2)

    def to_toml(self):
        import tomli_w

        return tomli_w.dumps(_drop_none(self.to_dict()))

    @classmethod
    def load(cls, path):
        """Read a .toml or .json configuration file."""
        from .errors import FormatError

        path = pathlib.Path(path)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise FormatError(path, "no such file") from None
        try:
            data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
        except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
            raise FormatError(path, f"cannot parse configuration ({exc})") from None
        try:
            return cls.from_dict(data)
        except ValueError as exc:
            raise FormatError(path, str(exc)) from None

    def replace(self, **changes):
        """A copy with top-level or dotted keys changed, e.g. replace(**{"denoise.method": "ndsef"})."""
        data = self.to_dict()
        for key, value in changes.items():
            section, _, name = key.rpartition(".")
            (data[section] if section else data)[name] = value
        return Config.from_dict(data)


_SECTIONS = {"denoise": DenoiseConfig, "extract": ExtractConfig, "track": TrackConfig,
             "motion": MotionConfig}


def _section(name, value):
    cls = _SECTIONS[name]
    if not isinstance(value, dict):
        raise ValueError(f"config key '{name}' must be a table of settings, got {value!r}")
    known = {f.name for f in dataclasses.fields(cls)}
    for key in value:
        if key not in known:
            raise ValueError(f"unknown config key '{name}.{key}' (known: {sorted(known)})")
    return cls(**value)


def _drop_none(d):
    return {k: _drop_none(v) if isinstance(v, dict) else v for k, v in d.items() if v is not None}
