"""Readers and writers of event, IMU and camera files.

``read(path)`` returns a :class:`~evstar.Recording`; the format comes from the extension
unless ``format=`` names it. ``write(path, events, imu=None, camera=None)`` likewise.
``windows(path, window_us)`` streams a file by time window with bounded memory.
"""
from __future__ import annotations

import os
import pathlib
import warnings
from importlib import import_module

from ..errors import EvstarWarning, FormatError
from .camera_json import read_camera, write_camera
from .centroids_csv import read_centroids, write_centroids
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
           "read_camera", "write_camera", "read_centroids", "write_centroids"]


def format_of(path, format=None):
    """The format name for `path` (from its extension unless `format` is given)."""
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


def _check_exists(path):
    if not os.path.exists(path):
        raise FormatError(path, "no such file")
    if os.path.isdir(path):
        raise FormatError(path, "is a folder, not a file")


def read(path, format=None, **options):
    """Read a recording. Options: sensor_size=(W, H) where the file lacks it, sort=True to
    order unsorted timestamps (otherwise an error)."""
    fmt = format_of(path, format)
    _check_exists(path)
    return _module(fmt).read(path, **options)


def write(path, events, imu=None, camera=None, format=None):
    """Write events (+ IMU and camera where the format holds them) atomically."""
    fmt = format_of(path, format)
    if not FORMATS[fmt][2]:
        raise FormatError(path, f"writing {fmt} is not supported; write csv, npz, hdf5 or aedat4")
    lost = [n for n, v, ok in (("IMU", imu, fmt != "csv"), ("camera", camera, fmt not in ("csv", "aedat4")))
            if v is not None and not ok]
    if lost:  # never drop data silently
        warnings.warn(f"{path}: the {fmt} format holds no {' or '.join(lost)}; write it separately "
                      "(write_imu / write_camera)", EvstarWarning, stacklevel=2)
    _module(fmt).write(path, events, imu=imu, camera=camera)


def packets(path, format=None, sensor_size=None):
    """(width, height, iterator of (t, x, y, p) packets) without loading the whole file."""
    fmt = format_of(path, format)
    _check_exists(path)
    mod = _module(fmt)
    if fmt == "csv":
        from .text import sensor_size_from
        if sensor_size is None:  # one bounded pass to find the extent
            ext = [0, 0]
            for _, x, y, _ in mod.packets(path):
                ext = [max(ext[0], int(x.max(initial=0))), max(ext[1], int(y.max(initial=0)))]
            sensor_size = (ext[0] + 1, ext[1] + 1)
        return (*sensor_size_from(path, None, sensor_size), mod.packets(path))
    return mod.packets(path, sensor_size=sensor_size)


def windows(path, window_us, format=None, sensor_size=None, t_origin_us=None):
    """Yield (k, Events) per time window k of `window_us`, holding one window in memory."""
    from .chunks import windows as _windows

    w, h, gen = packets(path, format, sensor_size)
    yield from _windows(gen, w, h, window_us, t_origin_us)
