"""argparse options built from the declarations in evstar.parameters.

An option's value is checked by its declaration while the command line is parsed, so a bad
value ends in argparse's one-line usage error (exit 2) before any work starts. Options left
unset keep the configuration file's value (or the declared default).
"""
from __future__ import annotations

import argparse
import math

from .. import parameters as P
from ..errors import EvstarError, ParameterError

#: every Config parameter set, by config section (an option's dest names its key)
CONFIG = {"": P.GLOBAL, **P.SECTIONS}
#: the stages' parameter sets that `evstar extract` and `evstar run` expose, by config section
PIPELINE = {k: v for k, v in CONFIG.items() if v is not P.ATTITUDE_FILTER}


def add_options(p, params, names=None, section=None, option=None, **overrides):
    """One option per parameter of `params` (or of `names` only). The dest is the config key
    ("denoise.radius"), so a Namespace maps onto Config.replace directly. `option` names a
    parameter's option (default its declared one). `overrides` are argparse keywords per
    name, e.g. method={"required": True}. Options of several calls with the same section
    share one help group."""
    section = params.section if section is None else section
    title = f"[{section}] options" if section else "general options"
    group = next((g for g in p._action_groups if g.title == title), None) \
        or p.add_argument_group(title)
    for name in names or params:
        param = params[name]
        kw = dict(dest=f"{section}.{name}" if section else name, default=None,
                  help=_help(param), metavar=_metavar(param))
        if param.kind is bool:
            kw.update(action=argparse.BooleanOptionalAction)
            kw.pop("metavar")
        else:
            kw.update(type=_parser(param), nargs="+" if param.many else None)
            if param.choices:
                kw.update(choices=param.choices, metavar=None, type=str)
        kw.update(overrides.get(name, {}))
        if "default" in overrides.get(name, {}) and "help" not in overrides[name]:
            kw["help"] = _help(param, kw["default"])  # the help names the default used
        group.add_argument(option(param) if option else param.option, **kw)


def add_pipeline_options(p, attitude=False):
    """--config plus every parameter of every stage; --auto sets both threshold kinds to auto.
    attitude: also [attitude_filter]'s, as --attitude-* (for the commands that write the
    attitude after the pipeline)."""
    p.add_argument("--config", help="configuration file (.toml or .json); options override it")
    for section, params in PIPELINE.items():
        add_options(p, params, section=section)
    if attitude:
        add_options(p, P.ATTITUDE_FILTER, option=P.run_option)
    p.add_argument("--auto", action="store_true", help="auto thresholds (the default)")


def config_from_args(args, base=None):
    """The Config of --config (or `base`, or the defaults) with every option given applied."""
    from ..config import Config

    cfg = Config.load(args.config) if getattr(args, "config", None) else (base or Config())
    changes = {k: _param(k).check(v, _param(k).option) for k, v in vars(args).items()
               if v is not None and _param(k) is not None}
    if getattr(args, "auto", False):
        changes["denoise.thresholds"] = changes["denoise.threshold"] = P.AUTO
    try:
        return cfg.replace(**changes)
    except ParameterError as exc:  # a check across values (e.g. thresholds per radius)
        raise ParameterError(f"invalid options: {exc}") from None


def checked(kind, low=None, high=None, open_low=False):
    """argparse `type` for an option that is not a stage parameter (kind, inclusive range)."""
    return _parser(P.Param("", kind, None, "", low=low, high=high, open_low=open_low))


def _param(dest):
    """The declaration behind an option's dest (a config key), None for other options."""
    section, _, name = dest.rpartition(".")
    return CONFIG.get(section, {}).get(name)


def _parser(param):
    """argparse `type`: the option's text -> the parameter's value, checked element-wise."""
    scalar = P.Param(**{**param.__dict__, "many": False, "increasing": False})

    def parse(text):
        if param.auto and text == P.AUTO:
            return P.AUTO
        if param.optional and text.lower() == "none":
            return None
        try:
            value = _number(text, param.kind)
            if param.cli_scale == 1:
                return scalar.check(value, param.name)
            if not math.isfinite(value):  # inf, 1e400, nan: no µs count (the range error below)
                raise ParameterError(f"{param.name} must be finite, got {text}")
            return scalar.check(round(value * param.cli_scale), param.name)  # --dt-ms 2.5 -> 2500 µs
        except (ValueError, EvstarError) as exc:
            if param.cli_scale == 1 or isinstance(exc, ValueError) and "number" in str(exc):
                raise argparse.ArgumentTypeError(str(exc).strip()) from None
            span = P._span(param.low / param.cli_scale, param.high / param.cli_scale, False, False)
            raise argparse.ArgumentTypeError(f"must be a number{span} {param.cli_unit}, "
                                             f"got {text}") from None

    parse.__name__ = param.kind.__name__  # argparse names it in "invalid int value"
    return parse


def _number(text, kind):
    if kind is str:
        return text
    try:
        return int(text) if text.lstrip("-").isdigit() else float(text)
    except ValueError:
        raise ValueError(f"not a number: {text!r}") from None


def _metavar(param):
    if param.kind is str:
        return "NAME"
    return (param.cli_unit or param.unit or "N").upper().replace("/", "_").replace("µ", "U")


def _help(param, default=None):
    """The option's help: its doc, unit and default (the declared one unless the command
    overrides it)."""
    unit = param.cli_unit or param.unit
    default = param.default if default is None else default
    if param.cli_scale != 1 and isinstance(default, (int, float)):
        default = f"{default / param.cli_scale:g}"
    return (f"{param.doc}{f', {unit}' if unit and param.kind is not str else ''} "
            f"(default {default if default is not None else 'none'})").replace("%", "%%")
