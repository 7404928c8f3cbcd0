"""Options and helpers shared by several sub-commands."""
from __future__ import annotations

import argparse
import os
import re

from ..errors import ParameterError
from ..events import MAX_SENSOR_SIDE
from .options import checked



def add_input_options(p):
    p.add_argument("--format", type=format_name,
                   help="input format, overriding the extension (csv, npz, hdf5, aedat4, raw, dat)")
    p.add_argument("--sensor-size", nargs=2, type=checked(int, 1, MAX_SENSOR_SIDE), metavar=("W", "H"),
                   help="sensor size when the file does not say")
    p.add_argument("--camera", help="camera JSON (width, height, fx, fy, cx, cy)")
    p.add_argument("--imu", help="IMU CSV t,gx,gy,gz,ax,ay,az (µs, rad/s, m/s²)")
    from ..runs import MAX_IMU_OFFSET_US

    p.add_argument("--imu-offset-us", type=checked(int, -MAX_IMU_OFFSET_US, MAX_IMU_OFFSET_US),
                   default=0,
                   metavar="ΜS", help="add this to the IMU's time offset, t_camera = t_imu + "
                   "offset (the IMU of --imu or of the file; `evstar run` measures it where the "
                   "rate changes and prints it)")
    p.add_argument("--sort", action="store_true",
                   help="order unsorted timestamps by time (otherwise they are an error)")


def add_force_option(p):
    """--force: replace an existing output file (refused without it: nothing is lost)."""
    p.add_argument("--force", action="store_true", help="replace the output file if it exists")


def add_output_format_option(p, help_text):
    """--to: the output's format, overriding its extension (a format evstar can write)."""
    p.add_argument("--to", dest="out_format", type=writable_format_name, metavar="FORMAT", help=help_text)


def format_name(text):
    """argparse `type` of --format: a format evstar reads (evstar.io.FORMATS, imported only
    when the option is given)."""
    from ..io import FORMATS

    if text not in FORMATS:
        raise argparse.ArgumentTypeError(f"must be one of {', '.join(sorted(FORMATS))}, got {text!r}")
    return text


def _writable_formats():
    """The formats evstar writes (evstar.io.FORMATS), sorted."""
    from ..io import FORMATS

    return sorted(n for n, (_, _, can_write) in FORMATS.items() if can_write)


def writable_format_name(text):
    """argparse `type` of --to: a format evstar writes."""
    names = _writable_formats()
    if text not in names:
        raise argparse.ArgumentTypeError(f"must be one of {', '.join(names)}, got {text!r}")
    return text


def check_events_output(path, out_format, option="OUT", override="--to FORMAT"):
    """ParameterError (a usage error, exit 2) unless evstar can write events to `path`
    (format from --to or the extension), checked before any work."""
    from .. import io
    from ..errors import FormatError

    names = _writable_formats()
    try:
        fmt = io.format_of(path, out_format)
    except FormatError:
        ext = os.path.splitext(str(path))[1]
        # (.npy reads as a one-array npz but holds no recording to write)
        known = sorted(e for n in names for e in io.FORMATS[n][1] if e != ".npy")
        raise ParameterError(f"{option} {path}: {f'unknown extension {ext!r}' if ext else 'no extension'}; give one of "
                             f"{', '.join(known)}" + (f" (or {override})" if override else "")) from None
    if not io.FORMATS[fmt][2]:
        raise ParameterError(f"{option} {path}: evstar reads {fmt} files but cannot write them; "
                             f"write {', '.join(names[:-1])} or {names[-1]}")
    if fmt == "npz" and str(path).lower().endswith(".npy"):   # io.write refuses it, after the work
        raise ParameterError(f"{option} {path}: a .npy file holds one array, not a recording; "
                             f"give a .npz name")
    return fmt


def check_output_suffix(path, option, suffixes, what):
    """ParameterError (a usage error, exit 2) unless `path` ends in one of `suffixes` (any
    case): the format a command writes `option` in, checked before any work. what: the
    format's name in the message, e.g. "JSON"."""
    ext = os.path.splitext(str(path))[1]
    if ext.lower() not in suffixes:
        names = ", ".join(suffixes[:-1]) + (" or " if len(suffixes) > 1 else "") + suffixes[-1]
        raise ParameterError(f"{option} {path}: this output is {what}; give a {names} name, not "
                             f"{repr(ext) if ext else 'one without an extension'}")
    return ext.lower()


def load(args):
    """Read the input recording with the camera / IMU files the user passed."""
    from ..runs import read_recording

    return read_recording(args.input, format=args.format, sensor_size=args.sensor_size,
                          camera=getattr(args, "camera", None), imu=getattr(args, "imu", None),
                          sort=bool(getattr(args, "sort", False)),
                          imu_offset_us=getattr(args, "imu_offset_us", 0))


#: the library's wording of a remedy (Python keywords, functions) -> the command line's
_CLI_WORDS = [
    (re.compile(r"pass sensor_size=\(W, H\) or a camera"), "pass --sensor-size W H or --camera"),
    (re.compile(r"pass sensor_size=\(W, H\)"), "pass --sensor-size W H"),
    (re.compile(r"\(or pass format=\)"), "(or pass --format)"),
    (re.compile(r"; write it separately \(write_imu / write_camera\)"),
     "; an .h5 or .npz output keeps them"),
    (re.compile(r"sensor_size must be two positive integers \(W, H\)"),
     "--sensor-size must be two positive integers W H"),
    (re.compile(r"\(motion\.compensate = 'imu' uses the gyro alone\)"),
     "(--compensate imu uses the gyro alone)"),
]


def cli_wording(message):
    """An error or warning of the library as the command line says it: options instead of
    the Python arguments the library's messages name."""
    message = str(message)
    for pattern, text in _CLI_WORDS:
        message = pattern.sub(text, message)
    return message
