"""Centroid tables (``evstar.extract.CENTROID_DTYPE``) as CSV, HDF5 or NPZ, chosen by extension.

CSV: header ``t,x,y,track,n_events,frame`` (t µs) then the other columns; HDF5: the compound
dataset ``/centroids``; NPZ: the structured array ``centroids``.
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
CENTROID_FORMATS = {".csv": "csv", ".h5": "hdf5", ".hdf5": "hdf5", ".npz": "npz"}


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


def read_centroids(path):
    fmt = check_centroid_path(path)
    check_readable(path)
    with decoder_errors(path, f"centroid {fmt} file", H5PY_ERRORS if fmt == "hdf5" else ()):
        columns = {"csv": _csv_columns, "hdf5": _hdf5_columns, "npz": _npz_columns}[fmt](path)
        return _table(path, columns)


def _csv_columns(path):
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise FormatError(path, "file is empty") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    dup = sorted({c for c in frame.columns if f"{c}.1" in frame.columns})
    if dup:
        raise FormatError(path, f"column(s) {dup} appear more than once in the header")
    return {k: frame[k].to_numpy() for k in frame.columns}


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


def _table(path, columns):
    """A CENTROID_DTYPE array from name -> values, every value checked against its field."""
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise FormatError(path, f"missing centroid column(s) {missing}")
    dtype = _dtype()
    n = len(columns["t"])
    out = np.zeros(n, dtype)
    for k in dtype.names:
        if k in columns:
            out[k] = _field(path, k, columns[k], dtype[k], n)
    i = check_time_range(out["t"])
    if i is not None:
        raise FormatError(path, f"row {i}: column 't' = {out['t'][i]} is outside ±{T_LIMIT_US} µs")
    bad = np.flatnonzero((out["n_on"] < 0) | (out["n_on"] > np.maximum(out["n_events"], 0)))
    if len(bad):   # the ON events are some of the cluster's events
        i = int(bad[0])
        raise FormatError(path, f"row {i}: column 'n_on' = {out['n_on'][i]} is not in 0..n_events "
                                f"({out['n_events'][i]})")
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


def _text_field(path, name, values):
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
        raise FormatError(path, f"row {i}: column '{name}' holds {values[i]!r}, not one of {SOURCES}")
    return text


def _field(path, name, values, dtype, n):
    values = np.asarray(values)
    if values.shape != (n,):
        raise FormatError(path, f"column '{name}' has shape {values.shape}, expected ({n},)")
    if dtype.kind == "U":
        return _text_field(path, name, values)
    raw = values
    if values.dtype.kind in "OUS":  # CSV text: numbers, or True/False for the flags
        text = pd.Series(values).astype(str).str.strip()
        values = pd.to_numeric(text.replace({"True": "1", "False": "0"}), errors="coerce").to_numpy(np.float64)
        bad = np.isnan(values) & ~text.str.lower().isin(["nan"]).to_numpy()
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise FormatError(path, f"row {i}: column '{name}' holds a non-numeric value {raw[i]!r}")
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
        raise FormatError(path, f"row {i}: column '{name}' holds an invalid value {raw[i]!r} "
                                f"(expected {dtype} in {lo}..{hi})")
    return values.astype(dtype)
