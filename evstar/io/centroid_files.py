"""Centroid tables (``evstar.extract.CENTROID_DTYPE``) as CSV, HDF5 or NPZ, chosen by extension.

CSV: header ``t,x,y,track,n_events,frame`` (t µs) then the other columns; HDF5: the compound
dataset ``/centroids``; NPZ: the structured array ``centroids``. Reading checks every value:
x, y finite, n_events >= 0, and when the centroids are to be used with a camera
(``sensor=(width, height)``) x, y on its sensor (within half a pixel of its edges) and sigma
> 0 or NaN (unknown); errors name the row (CSV: also its line).
"""
from __future__ import annotations

import pathlib

import numpy as np
import pandas as pd

from ..errors import FormatError, ParameterTypeError
from ..events import T_LIMIT_US, check_time_range
from .atomic import atomic_path
from .guard import H5PY_ERRORS, check_h5_numeric, check_path_type, check_readable, decoder_errors

COLUMNS = ["t", "x", "y", "track", "n_events", "frame"]
#: px a position may lie beyond the sensor's edge: a star whose centre has left the sensor
#: still has events on it, and `evstar run` reports its estimate (up to ~2 px out on a
#: DAVIS346 field); another camera's centroids lie far beyond
OFF_SENSOR_PX = 8.0
CENTROID_FORMATS = {".csv": "csv", ".h5": "hdf5", ".hdf5": "hdf5", ".npz": "npz"}
#: what a centroid file needs, for the messages of files without it
NEEDS = ("a centroid file is a table like `evstar run`'s centroids.csv: comma-separated, "
         "header t,x,y,track,n_events,frame (then optional spread,border,split,sigma,source,n_on)")


def check_centroid_path(path):
    """The centroid format for `path` ('csv', 'hdf5', 'npz'); FormatError for any other
    extension. Cheap: call it before the work that produces the centroids."""
    check_path_type(path)
    ext = pathlib.Path(path).suffix.lower()
    if ext not in CENTROID_FORMATS:
        raise FormatError(path, f"unknown centroid file extension {ext!r}; use .csv, .h5, .hdf5 or .npz")
    return CENTROID_FORMATS[ext]


def _dtype():
    from ..extract import CENTROID_DTYPE  # late: extract imports the compute stack
    return CENTROID_DTYPE


def write_centroids(path, centroids):
    fmt = check_centroid_path(path)
    names = getattr(getattr(centroids, "dtype", None), "names", None) or ()
    missing = [c for c in COLUMNS if c not in names]
    if not isinstance(centroids, np.ndarray) or missing:
        raise ParameterTypeError(f"write_centroids: argument 'centroids' must be a structured array "
                                 f"with fields {COLUMNS} (CENTROID_DTYPE), got {type(centroids).__name__}")
    if fmt == "csv":
        frame = pd.DataFrame({k: centroids[k] for k in names})
        rest = [c for c in frame.columns if c not in COLUMNS]
        with atomic_path(path) as tmp:
            frame[COLUMNS + rest].to_csv(tmp, index=False, float_format="%.4f", na_rep="nan")
    elif fmt == "hdf5":
        import h5py
        with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
            f.create_dataset("centroids", data=_coded(centroids))
    else:
        with atomic_path(path, suffix=".tmp.npz") as tmp:
            np.savez_compressed(tmp, centroids=centroids)


def read_centroids(path, sensor=None):
    """The CENTROID_DTYPE table of `path`. With sensor=(width, height), the measurements of
    that camera: every x, y on its sensor (pixel centres 0..width-1, 0..height-1, give or
    take half a pixel) and every sigma > 0 or NaN (unknown)."""
    fmt = check_centroid_path(path)
    check_readable(path)
    with decoder_errors(path, f"centroid {fmt} file", H5PY_ERRORS if fmt == "hdf5" else ()):
        if fmt == "csv":
            columns, lines = _csv_columns(path)
        else:
            columns, lines = {"hdf5": _hdf5_columns, "npz": _npz_columns}[fmt](path), None
        return _table(path, columns, lines, sensor)


def _csv_columns(path):
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise FormatError(path, "file is empty") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    if len(frame.columns) == 1 and ";" in frame.columns[0]:
        raise FormatError(path, f"the header {frame.columns[0]!r} is semicolon-separated; {NEEDS}")
    dup = sorted({c for c in frame.columns if f"{c}.1" in frame.columns})
    if dup:
        raise FormatError(path, f"column(s) {dup} appear more than once in the header")
    return {k: frame[k].to_numpy() for k in frame.columns}, _data_lines(path, len(frame))


def _data_lines(path, n):
    """The file line number (1-based) of each of the n rows pandas read (it skips blank
    lines), or None when they cannot be told apart (quoted line breaks)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = [i for i, ln in enumerate(f, 1) if ln.strip()][1:]
    return np.array(lines) if len(lines) == n else None


def _hdf5_columns(path):
    import h5py
    with h5py.File(path, "r") as f:
        ds = f.get("centroids")
        if not isinstance(ds, h5py.Dataset) or ds.dtype.names is None:
            raise FormatError(path, "no compound dataset '/centroids'")
        check_h5_numeric(path, f, "centroids")
        arr = ds[()]
    return {k: np.atleast_1d(arr[k]) for k in arr.dtype.names}


def _npz_columns(path):
    with np.load(path, allow_pickle=False) as data:
        if "centroids" not in data.files:
            raise FormatError(path, f"no array 'centroids' (has {data.files})")
        arr = data["centroids"]
    if arr.dtype.names is None or arr.ndim != 1:
        raise FormatError(path, "'centroids' must be a one-dimensional structured array")
    return {k: arr[k] for k in arr.dtype.names}


def _table(path, columns, lines=None, sensor=None):
    """A CENTROID_DTYPE array from name -> values, every value checked against its field;
    lines: the file line of each row (CSV), for the messages."""
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise FormatError(path, f"missing centroid column(s) {missing} (has {list(columns)}); {NEEDS}")
    dtype = _dtype()
    n = len(columns["t"])
    out = np.zeros(n, dtype)

    def at(i):
        return f"row {i}" if lines is None else f"line {lines[i]}, row {i}"

    for k in dtype.names:
        if k in columns:
            out[k] = _field(path, k, columns[k], dtype[k], n, at)

    def fail(bad, message):
        i = int(np.flatnonzero(bad)[0])
        raise FormatError(path, f"{at(i)}: " + message(i))

    shown = lambda k, i: str(columns[k][i]).strip() if k in columns else out[k][i]  # noqa: E731
    i = check_time_range(out["t"])
    if i is not None:
        raise FormatError(path, f"{at(i)}: column 't' = {out['t'][i]} is outside ±{T_LIMIT_US} µs")
    for k in ("x", "y"):
        if not np.isfinite(out[k]).all():
            fail(~np.isfinite(out[k]), lambda i: f"column '{k}' = {shown(k, i)} is not a finite position")
    if sensor is not None:
        for k, size in zip(("x", "y"), sensor):
            lo, hi = -0.5 - OFF_SENSOR_PX, size - 0.5 + OFF_SENSOR_PX
            off = (out[k] < lo) | (out[k] > hi)
            if off.any():
                fail(off, lambda i: f"column '{k}' = {shown(k, i)} is off the camera's "
                                    f"{sensor[0]}x{sensor[1]} sensor ({k} must be in {lo:g}..{hi:g}, "
                                    f"{OFF_SENSOR_PX:g} px beyond its edges): centroids of another camera?")
    if sensor is not None and "sigma" in columns:   # measurements: NaN is unknown (the
        # estimator's default applies); 0 is left to tables made with np.zeros otherwise
        bad = (out["sigma"] <= 0) | np.isinf(out["sigma"])
        if bad.any():
            fail(bad, lambda i: f"column 'sigma' = {shown('sigma', i)} must be > 0 px (or nan: unknown)")
    if (out["n_events"] < 0).any():
        fail(out["n_events"] < 0, lambda i: f"column 'n_events' = {shown('n_events', i)} is negative")
    bad = (out["n_on"] < 0) | (out["n_on"] > np.maximum(out["n_events"], 0))
    if bad.any():   # the ON events are some of the cluster's events
        fail(bad, lambda i: f"column 'n_on' = {out['n_on'][i]} is not in 0..n_events ({out['n_events'][i]})")
    return out


def _coded(centroids):
    """A copy whose text fields (source) hold their index in SOURCES: HDF5 keeps numbers."""
    from ..extract import SOURCES

    text = [n for n in centroids.dtype.names if centroids.dtype[n].kind == "U"]
    if not text:
        return centroids
    dtype = np.dtype([(n, np.int8 if n in text else centroids.dtype[n]) for n in centroids.dtype.names])
    out = np.zeros(len(centroids), dtype)
    for n in centroids.dtype.names:
        # an unset source (np.zeros rows) is a measured centroid
        out[n] = [SOURCES.index(v or SOURCES[0]) for v in centroids[n]] if n in text else centroids[n]
    return out


def _text_field(path, name, values, at):
    """source: a name of SOURCES, or its index (HDF5)."""
    from ..extract import SOURCES

    if values.dtype.kind in "iu":
        bad = (values < 0) | (values >= len(SOURCES))
        text = np.array(SOURCES)[np.clip(values, 0, len(SOURCES) - 1)]
    else:
        text = np.char.strip(values.astype(str))
        text = np.where(text == "", SOURCES[0], text)   # unset: measured
        bad = ~np.isin(text, SOURCES)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise FormatError(path, f"{at(i)}: column '{name}' holds {values[i]!r}, not one of {SOURCES}")
    return text


def _field(path, name, values, dtype, n, at):
    values = np.asarray(values)
    if values.shape != (n,):
        raise FormatError(path, f"column '{name}' has shape {values.shape}, expected ({n},)")
    if dtype.kind == "U":
        return _text_field(path, name, values, at)
    raw = values
    if values.dtype.kind in "OUS":  # CSV text: numbers, or True/False for the flags
        text = pd.Series(values).astype(str).str.strip()
        values = pd.to_numeric(text.replace({"True": "1", "False": "0"}), errors="coerce").to_numpy(np.float64)
        bad = np.isnan(values) & ~text.str.lower().isin(["nan"]).to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise FormatError(path, f"{at(i)}: column '{name}' holds a non-numeric value {raw[i]!r}")
    if values.dtype.kind not in "biuf":
        raise FormatError(path, f"column '{name}' must be numeric, got dtype {values.dtype}")
    if dtype.kind == "f":
        return values.astype(dtype)
    lo, hi = (0, 1) if dtype.kind == "b" else (max(np.iinfo(dtype).min, -2 ** 62), min(np.iinfo(dtype).max, 2 ** 62))
    ok = (values >= lo) & (values <= hi)
    if values.dtype.kind == "f":
        ok &= np.isfinite(values) & (values == np.round(values))
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        raise FormatError(path, f"{at(i)}: column '{name}' holds an invalid value {raw[i]!r} "
                                f"(expected {dtype} in {lo}..{hi})")
    return values.astype(dtype)
