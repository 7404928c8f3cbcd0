"""Pipeline configuration: one validated object, serialisable to JSON and TOML.

Its sections and keys are generated from the declarations in :mod:`evstar.parameters`
(the same ones the stage classes and the command line check with), so a bad value raises
:class:`evstar.ParameterError` naming its key as ``section.key`` here, and nowhere later.
"""
from __future__ import annotations

import functools
import json
import os
import pathlib
import sys
from dataclasses import asdict, dataclass, field, fields, make_dataclass

from . import parameters as P
from .errors import FormatError, ParameterError, ParameterTypeError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

METHODS, COMPENSATIONS = P.METHODS, P.COMPENSATIONS


def _key(section, name):
    return f"config key '{section + '.' if section else ''}{name}'"


def _check_keys(keys, cls, section=""):
    known = sorted(f.name for f in fields(cls))
    for key in keys:
        if key not in known:
            raise ParameterError(f"unknown {_key(section, key)} (known: {known})")


def _known_keys_only(cls, section=""):
    """cls, its constructor refusing an unknown keyword as ParameterError (as from_dict does)
    instead of the dataclass's TypeError."""
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        _check_keys(kwargs, cls, section)
        init(self, *args, **kwargs)

    cls.__init__ = __init__
    return cls


def _check_section(obj, params):
    """Check and normalise every field of `obj` against `params` (in place)."""
    for name, param in params.items():
        setattr(obj, name, param.check(getattr(obj, name), _key(params.section, name)))


def _default(value):
    return field(default_factory=lambda: list(value)) if isinstance(value, list) else field(default=value)


def _section_class(class_name, params, extra_check=None):
    def validate(self):
        _check_section(self, params)
        if extra_check:
            extra_check(self)
        return self

    return _known_keys_only(make_dataclass(
        class_name, [(n, object, _default(p.default)) for n, p in params.items()],
        namespace={"validate": validate, "__doc__": _doc(params)}), params.section)


def _doc(params):
    return f"[{params.section}] settings:\n" + "\n".join(
        f"    {n}: {p.doc} ({p.expected()}; default {p.default!r})" for n, p in params.items())


def _denoise_check(d):
    P.check_thresholds_per_radius(d.thresholds, d.radii, _key("denoise", "thresholds"))


DenoiseConfig = _section_class("DenoiseConfig", P.DENOISE, _denoise_check)
ExtractConfig = _section_class("ExtractConfig", P.EXTRACT)
TrackConfig = _section_class("TrackConfig", P.TRACK)
MotionConfig = _section_class("MotionConfig", P.MOTION)
EstimateConfig = _section_class("EstimateConfig", P.ESTIMATE)
HotPixelsConfig = _section_class("HotPixelsConfig", P.HOTPIXELS)
AttitudeFilterConfig = _section_class("AttitudeFilterConfig", P.ATTITUDE_FILTER)
_SECTIONS = {"denoise": DenoiseConfig, "extract": ExtractConfig, "track": TrackConfig,
             "motion": MotionConfig, "estimate": EstimateConfig, "hotpixels": HotPixelsConfig,
             "attitude_filter": AttitudeFilterConfig}


@_known_keys_only
@dataclass
class Config:
    device: str = P.GLOBAL["device"].default
    dt_us: int = P.GLOBAL["dt_us"].default
    seed: int = P.GLOBAL["seed"].default
    chunk_frames: int = P.GLOBAL["chunk_frames"].default
    denoise: DenoiseConfig = field(default_factory=DenoiseConfig)
    extract: ExtractConfig = field(default_factory=ExtractConfig)
    track: TrackConfig = field(default_factory=TrackConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)
    estimate: EstimateConfig = field(default_factory=EstimateConfig)
    hotpixels: HotPixelsConfig = field(default_factory=HotPixelsConfig)
    attitude_filter: AttitudeFilterConfig = field(default_factory=AttitudeFilterConfig)

    def __post_init__(self):
        self.validate()

    def validate(self):
        _check_section(self, P.GLOBAL)
        for name, cls in _SECTIONS.items():
            section = getattr(self, name)
            if not isinstance(section, cls):
                raise ParameterError(f"{_key('', name)} must be a {cls.__name__}, got {section!r}")
            section.validate()
        return self

    def input_files(self):
        """The files the settings name as inputs (a pixel_lag_file): an output may not be one
        of them (evstar.io.atomic.check_outputs)."""
        return [getattr(getattr(self, name), p.name) for name, params in P.SECTIONS.items()
                for p in params.values() if p.checker is P.check_path
                and getattr(getattr(self, name), p.name) is not None]

    def attitude_options(self):
        """[attitude_filter] as the keywords of evstar.attitude.estimate / AttitudeEstimator,
        and motion.repair_gyro: what `evstar run`, `evstar batch` and `evstar attitude` all
        estimate with."""
        return {**asdict(self.attitude_filter), "repair_gyro": self.motion.repair_gyro}

    # -- serialisation -----------------------------------------------------------------
    def to_dict(self):
        return asdict(self)

    @classmethod
    def from_dict(cls, data):
        if not isinstance(data, dict):
            raise ParameterError(f"config must be a mapping, got {type(data).__name__}")
        _check_keys(data, cls)
        return cls(**{key: _section(key, value) if key in _SECTIONS else value
                      for key, value in data.items()})

    def to_json(self):
        return json.dumps(self.to_dict(), indent=2)

    def to_toml(self):
        import tomli_w

        return tomli_w.dumps(_drop_none(self.to_dict()))

    @classmethod
    def load(cls, path):
        """Read a .toml or .json configuration file."""
        if not isinstance(path, (str, os.PathLike)):
            raise ParameterTypeError(f"config path must be a str or os.PathLike, got {path!r}")
        path = pathlib.Path(path)
        kind = path.suffix.lower()
        if path.is_dir():
            raise FormatError(path, "is a folder, not a configuration file")
        if kind not in (".toml", ".json"):   # the format is the extension's: no guessing
            raise FormatError(path, f"a configuration file is .toml or .json, got "
                                    f"{repr(path.suffix) if path.suffix else 'no extension'}")
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise FormatError(path, "no such file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise FormatError(path, f"cannot read configuration ({exc})") from None
        if kind == ".json" and not text.strip():
            raise FormatError(path, "the file is empty; an empty JSON configuration is {}")
        try:
            data = tomllib.loads(text) if kind == ".toml" else \
                json.loads(text, object_pairs_hook=_unique_keys)
        except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
            raise FormatError(path, f"cannot parse configuration ({exc})") from None
        except _DuplicateKey as exc:      # TOML refuses these itself; json keeps the last
            raise FormatError(path, f"cannot parse configuration (key {exc.args[0]!r} appears "
                                    "twice in one object)") from None
        except RecursionError:
            raise FormatError(path, "cannot parse configuration (nested too deeply)") from None
        try:
            config = cls.from_dict(data)
        except ParameterError as exc:
            raise ParameterError(f"{path}: {exc}") from None
        lag = config.estimate.pixel_lag_file
        if lag is not None and not os.path.isabs(lag):   # beside the file that names it
            config = config.replace(**{"estimate.pixel_lag_file": str(path.parent / lag)})
        return config

    def replace(self, **changes):
        """A copy with top-level or dotted keys changed, e.g. replace(**{"denoise.method": "ndsef"})."""
        data = self.to_dict()
        for key, value in changes.items():
            section, _, name = key.rpartition(".")
            if section and section not in _SECTIONS:
                raise ParameterError(f"unknown config section '{section}' in '{key}'")
            (data[section] if section else data)[name] = value
        return Config.from_dict(data)


class _DuplicateKey(ValueError):
    pass


def _unique_keys(pairs):
    """json's object_pairs_hook: a dict, refusing a key given twice."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def _section(name, value):
    cls = _SECTIONS[name]
    if not isinstance(value, dict):
        raise ParameterError(f"config key '{name}' must be a table of settings, got {value!r}")
    _check_keys(value, cls, name)
    return cls(**value).validate()


def _drop_none(d):
    return {k: _drop_none(v) if isinstance(v, dict) else v for k, v in d.items() if v is not None}
