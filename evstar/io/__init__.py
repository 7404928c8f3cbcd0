"""Readers and writers of event, IMU and camera files.

``read(path)`` returns a :class:`~evstar.Recording`; the format comes from the extension
unless ``format=`` names it. ``write(path, events, imu=None, camera=None)`` likewise.
``windows(path, window_us)`` streams a file by time window with bounded memory.
"""
from __future__ import annotations

import pathlib
import warnings
from importlib import import_module

import numpy as np

from ..camera import Camera
from ..errors import DataError, EvstarWarning, FormatError, ParameterError, ParameterTypeError
from ..events import Events
from ..imu import Imu
from ..recording import Recording
from .camera_json import read_camera, write_camera
from .centroid_files import check_centroid_path, read_centroids, write_centroids
from .guard import check_path_type, check_readable, decoder_errors
from .imu_csv import read_imu, write_imu

# format name -> (module, extensions, can write)
FORMATS = {
    "csv": ("text", (".csv", ".txt"), True),
    "npz": ("numpy_files", (".npz", ".npy"), True),
    "hdf5": ("hdf5", (".h5", ".hdf5"), True),
    "aedat4": ("aedat4", (".aedat4",), True),
    "raw": ("prophesee", (".raw",), False),
    "dat": ("prophesee", (".dat",), False),
}

__all__ = ["FORMATS", "read", "write", "windows", "format_of", "read_imu", "write_imu",
           "read_camera", "write_camera", "read_centroids", "write_centroids", "check_centroid_path"]


def format_of(path, format=None):
    """The format name for `path` (from its extension unless `format` is given)."""
    check_path_type(path)
    if format is not None:
        if format not in FORMATS:
            raise FormatError(path, f"unknown format {format!r}; known: {sorted(FORMATS)}")
        return format
    ext = pathlib.Path(path).suffix.lower()
    for name, (_, exts, _) in FORMATS.items():
        if ext in exts:
            return name
    known = sorted(e for _, exts, _ in FORMATS.values() for e in exts)
    raise FormatError(path, f"unknown extension {ext!r}; known: {', '.join(known)} "
                            "(or pass format=)")


def _module(name):
    return import_module(f".{FORMATS[name][0]}", __name__)


def _options(options):
    """Check the read options (sensor_size=(W, H), sort=bool) before any file is opened."""
    unknown = sorted(set(options) - {"sensor_size", "sort"})
    if unknown:
        raise ParameterError(f"read: unknown option(s) {unknown}; known: sensor_size, sort")
    size = options.get("sensor_size")
    if size is not None:
        try:
            w, h = (int(v) for v in size)
            ok = (w, h) == tuple(size) and w > 0 and h > 0
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise ParameterError(f"read: sensor_size must be two positive integers (W, H), got {size!r}")
        options["sensor_size"] = (w, h)
    return options


def read(path, format=None, **options):
    """Read a recording. Options: sensor_size=(W, H) where the file lacks it, sort=True to
    order unsorted timestamps (otherwise an error). Any unreadable input (missing, a folder,
    unreadable, corrupt, out-of-range values) raises FormatError naming the file."""
    fmt = format_of(path, format)
    options = _options(options)
    check_readable(path)
    # the reader's warnings (an inferred sensor size, rounded timestamps) only once the file
    # proved readable: a file that fails ends in its error alone
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with decoder_errors(path, f"{fmt} file"):
            rec = _module(fmt).read(path, **options)
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    return rec


def _recording_parts(data, imu, camera):
    """(events, imu, camera) from an Events or a Recording (explicit imu/camera win)."""
    if isinstance(data, Recording):
        imu = data.imu if imu is None else imu
        camera = data.camera if camera is None else camera
        data = data.events
    for name, value, cls in (("events", data, Events), ("imu", imu, Imu), ("camera", camera, Camera)):
        if not isinstance(value, cls) and (value is not None or name == "events"):
            want = "evstar.Events or evstar.Recording" if name == "events" else f"evstar.{cls.__name__} or None"
            raise ParameterTypeError(f"write: argument '{name}' must be {want}, got {type(value).__name__}")
    return data, imu, camera


def write(path, events, imu=None, camera=None, format=None):
    """Write events (an Events, or a Recording with its IMU and camera) atomically; the IMU
    and camera go where the format holds them."""
    events, imu, camera = _recording_parts(events, imu, camera)
    fmt = format_of(path, format)
    if not FORMATS[fmt][2]:
        raise FormatError(path, f"writing {fmt} is not supported; write csv, npz, hdf5 or aedat4")
    if fmt == "npz" and str(path).lower().endswith(".npy"):
        raise FormatError(path, "a .npy file holds one array, not a recording: write .npz")
    calibrated = imu is not None and (imu.time_offset_us != 0 or not np.allclose(imu.R_cam_imu, np.eye(3)))
    lost = [n for n, held, ok in (("IMU", imu is not None, fmt != "csv"),
                                  ("camera", camera is not None, fmt not in ("csv", "aedat4")),
                                  ("IMU's R_cam_imu and time offset", calibrated, fmt != "aedat4"))
            if held and not ok]
    if lost:  # never drop data silently
        warnings.warn(f"{path}: the {fmt} format holds no {' or '.join(lost)}; write it separately "
                      "(write_imu / write_camera)", EvstarWarning, stacklevel=2)
    _module(fmt).write(path, events, imu=imu, camera=camera)


def extras(path, format=None):
    """(Imu or None, Camera or None) that the recording at `path` holds, without its events
    (what a streamed run uses where no --imu or --camera is given)."""
    return _without_events(path, format, "extras", (None, None))  # None: no IMU or camera


def event_count(path, format=None):
    """The number of events in the recording at `path` where its format tells it without
    decoding the events (HDF5, NumPy), else None (a progress bar's total)."""
    return _without_events(path, format, "count", None)


def _without_events(path, format, name, default):
    """The format module's `name`(path), read without the events, or `default` for formats
    without one; decoder errors as FormatError naming the file."""
    fmt = format_of(path, format)
    check_readable(path)
    mod = _module(fmt)
    if not hasattr(mod, name):
        return default
    with decoder_errors(path, f"{fmt} file"):
        return getattr(mod, name)(path)


def packets(path, format=None, sensor_size=None):
    """(width, height, iterator of (t, x, y, p) packets) without loading the whole file."""
    fmt = format_of(path, format)
    sensor_size = _options({"sensor_size": sensor_size})["sensor_size"]
    check_readable(path)
    mod = _module(fmt)
    if fmt == "csv":
        from .guard import stored_size
        from .text import header_sensor_size, sensor_size_from
        sensor_size = stored_size(path, header_sensor_size(path), sensor_size)
        if sensor_size is None:  # one bounded pass to find the extent
            ext = [0, 0]
            for _, x, y, _ in mod.packets(path):
                ext = [max(ext[0], int(x.max(initial=0))), max(ext[1], int(y.max(initial=0)))]
            sensor_size = sensor_size_from(path, (np.array(ext[:1]), np.array(ext[1:])), None)
        return (*sensor_size, mod.packets(path))
    with decoder_errors(path, f"{fmt} file"):
        return mod.packets(path, sensor_size=sensor_size)


def windows(path, window_us, format=None, sensor_size=None, t_origin_us=None):
    """Yield (k, Events) per time window k of `window_us`, holding one window in memory."""
    from .. import parameters as P
    from .chunks import windows as _windows

    window_us = P.GLOBAL.check("dt_us", window_us, "window_us")      # whole µs, as frames
    t_origin_us = P.KERNEL.check("t0_us", t_origin_us, "t_origin_us")
    w, h, gen = packets(path, format, sensor_size)
    try:
        yield from _windows(gen, w, h, window_us, t_origin_us)
    except DataError as exc:     # name the file, as read() does
        if isinstance(exc, FormatError) or str(path) in str(exc):
            raise
        raise FormatError(path, str(exc)) from None
