"""NPZ / NPY events: a structured array (fields x, y, t, p) or separate arrays t, x, y, p."""
from __future__ import annotations

import zipfile

import numpy as np

from ..errors import DataError, FormatError
from ..imu import Imu
from ..recording import Recording
from .atomic import atomic_path
from .guard import int64_times, one_line, stored_size
from .text import sensor_size_from
from ..camera import Camera
from ..events import Events


# what a .npz holding a file starts with (a zip's local file header)
ZIP_MAGIC = b"PK\x03\x04"
# what a .npy / .npz starts with: numpy's magic, or a zip entry (an empty zip's end record)
MAGIC = (b"\x93NUMPY", ZIP_MAGIC, b"PK\x05\x06")


def _load(path):
    try:
        with open(path, "rb") as f:
            head = f.read(6)
        if head.startswith(MAGIC):  # anything else np.load would call pickled data
            return np.load(path, allow_pickle=False, mmap_mode="r" if str(path).endswith(".npy") else None)
    except FileNotFoundError:
        raise FormatError(path, "no such file") from None
    except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
        raise FormatError(path, f"not a readable NumPy file ({one_line(exc)})") from None
    raise FormatError(path, "not an evstar/NumPy events archive (neither a .npz zip nor a .npy array)")


def _columns(path, data):
    if isinstance(data, np.ndarray):
        names = data.dtype.names or ()
        src = data
    else:
        names = data.files
        if "events" in names:  # a structured array stored under 'events'
            src = data["events"]
            names = src.dtype.names or ()
        else:
            src = data
    missing = [k for k in "txyp" if k not in names]
    if missing:
        raise FormatError(path, f"missing field(s) {missing}; found {list(names)}")
    cols = [np.asarray(src[k]) for k in "txyp"]
    odd = [k for k, c in zip("txyp", cols) if c.ndim != 1]
    if odd:
        raise FormatError(path, f"field(s) {odd} must be one-dimensional arrays, got shapes "
                                f"{[cols['txyp'.index(k)].shape for k in odd]}")
    return cols


def _integers(path, data, name, sizes):
    """Array `name` of an npz as Python ints; FormatError unless it has one of `sizes` entries."""
    a = data[name]
    if a.ndim > 1 or a.size not in sizes or a.dtype.kind not in "iuf" or not np.all(np.isfinite(a)):
        raise FormatError(path, f"'{name}' must hold {' or '.join(map(str, sizes))} finite numbers, got {a!r}"[:300])
    return a.reshape(-1).tolist()


def _size(path, data, cols, sensor_size):
    stored = None
    if not isinstance(data, np.ndarray) and "sensor_size" in data.files:
        stored = _integers(path, data, "sensor_size", (2,))
        if any(v != int(v) for v in stored):   # a 4.5 px side is no size: not cut to 4
            raise FormatError(path, f"'sensor_size' must hold whole numbers, got {stored}")
    return sensor_size_from(path, (cols[1], cols[2]), stored_size(path, stored, sensor_size))


def read(path, sensor_size=None, sort=False):
    data = _load(path)
    try:
        cols = _columns(path, data)
        w, h = _size(path, data, cols, sensor_size)
        rec = Recording(Events(*cols, w, h, sort=sort))
        rec.imu, rec.camera = _extras(path, data)
        return rec
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def extras(path):
    """(Imu or None, Camera or None) the file holds, without reading its events (an .npz
    loads each array on access)."""
    try:
        return _extras(path, _load(path))
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def _extras(path, data):
    imu = camera = None
    if isinstance(data, np.ndarray):
        return imu, camera
    if "imu_t" in data.files:
        missing = [k for k in ("imu_gyro", "imu_accel", "imu_R_cam_imu", "imu_time_offset_us")
                   if k not in data.files]
        if missing:
            raise FormatError(path, f"'imu_t' without {missing}")
        imu = Imu(data["imu_t"], data["imu_gyro"], data["imu_accel"],
                  R_cam_imu=data["imu_R_cam_imu"],
                  time_offset_us=_integers(path, data, "imu_time_offset_us", (1,))[0])
    if "camera" in data.files:
        camera = Camera(*_integers(path, data, "camera", (6, 7, 8)))
    return imu, camera


def count(path):
    """The number of events in a .npy file (memory-mapped: nothing read); None for a .npz
    archive (its columns are decompressed whole to be counted)."""
    if not str(path).endswith(".npy"):
        return None
    return int(len(_columns(path, _load(path))[0]))


def packets(path, sensor_size=None, chunk_events=1_000_000):
    """(width, height, iterator): .npy files are memory-mapped, so chunks stay bounded."""
    data = _load(path)
    cols = _columns(path, data)
    w, h = _size(path, data, cols, sensor_size)

    def gen():
        for i in range(0, len(cols[0]), chunk_events):
            t, x, y, p = (np.asarray(c[i:i + chunk_events]) for c in cols)
            yield int64_times(path, t), x, y, p
    return w, h, gen()


def write(path, events, imu=None, camera=None):
    arrays = dict(t=events.t, x=events.x, y=events.y, p=events.p,
                  sensor_size=np.array(events.sensor_size))
    if imu is not None:
        arrays.update(imu_t=imu.t, imu_gyro=imu.gyro, imu_accel=imu.accel,
                      imu_R_cam_imu=imu.R_cam_imu, imu_time_offset_us=imu.time_offset_us)
    if camera is not None:
        c = camera
        arrays["camera"] = np.array([c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.k1, c.k2])
    with atomic_path(path, suffix=".tmp.npz") as tmp:
        np.savez_compressed(tmp, **arrays)
