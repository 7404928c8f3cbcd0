"""HDF5 events `/events/{t,x,y,p}` (attrs width, height), optional `/imu` and `/camera` groups (h5py)."""
from __future__ import annotations

import h5py
import numpy as np

from ..camera import Camera
from ..errors import DataError, FormatError
from ..events import Events
from ..imu import Imu
from ..recording import Recording
from .atomic import atomic_path
from .guard import H5PY_ERRORS, check_h5_numeric, decoder_errors, int64_times, stored_size
from .text import sensor_size_from


def _open(path):
    try:
        return h5py.File(path, "r")
    except FileNotFoundError:
        raise FormatError(path, "no such file") from None
    except OSError as exc:
        raise FormatError(path, f"not a readable HDF5 file ({exc})") from None


def _datasets(path, f):
    if "events" not in f:
        raise FormatError(path, f"no '/events' group (top-level keys: {list(f.keys())})")
    g = f["events"]
    if not isinstance(g, h5py.Group):
        raise FormatError(path, "'/events' is not a group")
    missing = [k for k in "txyp" if k not in g]
    if missing:
        raise FormatError(path, f"missing dataset(s) {['/events/' + k for k in missing]}")
    odd = [k for k in "txyp" if not isinstance(g[k], h5py.Dataset) or g[k].ndim != 1]
    if odd:
        raise FormatError(path, f"{['/events/' + k for k in odd]} must be one-dimensional datasets")
    for k in "txyp":
        check_h5_numeric(path, g, k)
    n = {k: g[k].shape[0] for k in "txyp"}
    if len(set(n.values())) != 1:
        raise FormatError(path, f"datasets under /events have different lengths {n}")
    return g


def _size(path, g, sensor_size):
    stored = None
    if "width" in g.attrs and "height" in g.attrs:
        stored = _attr(path, g, "width"), _attr(path, g, "height")
    size = stored_size(path, stored, sensor_size)
    return size or sensor_size_from(path, (g["x"][:], g["y"][:]), None)


def _attr(path, obj, name, default=None):
    """A numeric attribute (an array, or a scalar as a Python number)."""
    if name not in obj.attrs:
        return default
    check_h5_numeric(path, obj.attrs, name)
    v = np.asarray(obj.attrs[name])
    return v.item() if v.size == 1 else v


def _group(path, f, name):
    """The optional group `/name` (None where absent); a dataset there is a FormatError."""
    if name not in f:
        return None
    if not isinstance(f[name], h5py.Group):
        raise FormatError(path, f"'/{name}' is a {type(f[name]).__name__.lower()}, expected a group")
    return f[name]


def _array(path, group, name):
    if not isinstance(group.get(name), h5py.Dataset):
        raise FormatError(path, f"missing dataset '{group.name}/{name}'")
    check_h5_numeric(path, group, name)
    return group[name][()]


def read(path, sensor_size=None, sort=False):
    with decoder_errors(path, "HDF5 file", H5PY_ERRORS), _open(path) as f:
        g = _datasets(path, f)
        try:
            w, h = _size(path, g, sensor_size)
            rec = Recording(Events(*(g[k][:] for k in "txyp"), w, h, sort=sort))
            rec.imu, rec.camera = _extras(path, f)
        except DataError as exc:
            raise FormatError(path, str(exc)) from None
    return rec


def extras(path):
    """(Imu or None, Camera or None) the file holds, without reading its events."""
    with decoder_errors(path, "HDF5 file", H5PY_ERRORS), _open(path) as f:
        try:
            return _extras(path, f)
        except DataError as exc:
            raise FormatError(path, str(exc)) from None


def _extras(path, f):
    imu = camera = None
    if (i := _group(path, f, "imu")) is not None:
        imu = Imu(*(_array(path, i, k) for k in ("t", "gyro", "accel")),
                  R_cam_imu=_attr(path, i, "R_cam_imu"),
                  time_offset_us=_attr(path, i, "time_offset_us", 0))
    if (c := _group(path, f, "camera")) is not None:
        camera = Camera(**{k: _attr(path, c, k) for k in c.attrs})
    return imu, camera


def count(path):
    """The number of events in the file (its datasets' length; nothing read)."""
    with _open(path) as f:
        return int(_datasets(path, f)["t"].shape[0])


def packets(path, sensor_size=None, chunk_events=1_000_000):
    """(width, height, iterator) reading `chunk_events` rows at a time."""
    f = _open(path)
    g = _datasets(path, f)
    w, h = _size(path, g, sensor_size)

    def gen():
        with f, decoder_errors(path, "HDF5 file", H5PY_ERRORS):
            for i in range(0, g["t"].shape[0], chunk_events):
                t, x, y, p = (g[k][i:i + chunk_events] for k in "txyp")
                yield int64_times(path, t), x, y, p
    return w, h, gen()


def write(path, events, imu=None, camera=None):
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        g = f.create_group("events")
        g.attrs["width"], g.attrs["height"] = events.width, events.height
        for k in "txyp":
            g.create_dataset(k, data=getattr(events, k), chunks=len(events) > 0 or None,
                             compression="gzip" if len(events) else None, shuffle=len(events) > 0)
        if imu is not None:
            i = f.create_group("imu")
            for k in ("t", "gyro", "accel"):
                i.create_dataset(k, data=getattr(imu, k))
            i.attrs["R_cam_imu"] = imu.R_cam_imu
            i.attrs["time_offset_us"] = imu.time_offset_us
        if camera is not None:
            c = f.create_group("camera")
            for k, v in camera.to_dict().items():
                c.attrs[k] = v
