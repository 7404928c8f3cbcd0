"""CSV / TXT events: a header naming the columns (t in µs), or headerless `t x y p` (t in s, RPG layout)."""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import EvstarWarning, FormatError
from ..events import Events
from ..recording import Recording
from .atomic import atomic_path

# accepted header names for each field (lower case)
ALIASES = {"t": ("t", "timestamp", "ts", "time", "t_us"), "x": ("x",), "y": ("y",),
           "p": ("p", "polarity", "pol", "on")}


def _sniff(path):
    """Return (has_header, separator) from the first non-empty line."""
    try:
        with open(path, "r", errors="replace") as f:
            line = next((ln for ln in f if ln.strip() and not ln.startswith("#")), "")
    except OSError as exc:
        raise FormatError(path, f"cannot open: {exc.strerror}") from None
    if not line:
        raise FormatError(path, "file is empty")
    sep = "," if "," in line else (";" if ";" in line else r"\s+")
    has_header = any(c.isalpha() and c not in "eE" for c in line)
    return has_header, sep


def _columns(path, header_names):
    names = [str(c).strip().lower() for c in header_names]
    cols = {}
    for field, aliases in ALIASES.items():
        hit = [c for c in aliases if c in names]
        if not hit:
            raise FormatError(path, f"missing column '{field}' (header has {names}; "
                                    f"accepted names: {', '.join(aliases)})")
        cols[field] = header_names[names.index(hit[0])]
    return cols


def _numeric(path, frame, column, offset):
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy()
    bad = np.flatnonzero(np.isnan(values))
    if len(bad):
        i = int(bad[0])
        raise FormatError(path, f"line {offset + i}: column '{column}' holds a non-numeric "
                                f"value {frame[column].iloc[i]!r}")
    return values


def _reader(path, chunk_rows):
    has_header, sep = _sniff(path)
    kw = dict(sep=sep, dtype=str, comment="#", skipinitialspace=True, chunksize=chunk_rows,
              engine="c")
    if not has_header:
        kw.update(header=None, names=["t", "x", "y", "p"], usecols=[0, 1, 2, 3])
    return has_header, pd.read_csv(path, **kw)


def packets(path, chunk_rows=1_000_000):
    """Yield (t µs, x, y, p) arrays chunk by chunk."""
    try:
        has_header, reader = _reader(path, chunk_rows)
        line = 2 if has_header else 1
        cols = None
        for frame in reader:
            cols = cols or (_columns(path, list(frame.columns)) if has_header
                            else {k: k for k in "txyp"})
            t = _numeric(path, frame, cols["t"], line)
            t = t if has_header else t * 1e6  # headerless RPG layout: seconds
            out = [np.round(t).astype(np.int64)]
            for k in "xyp":
                v = _numeric(path, frame, cols[k], line)
                if np.any(v != np.round(v)):
                    i = int(np.flatnonzero(v != np.round(v))[0])
                    raise FormatError(path, f"line {line + i}: column '{cols[k]}' holds a "
                                            f"non-integer value {v[i]}")
                out.append(v.astype(np.int64))
            line += len(frame)
            yield tuple(out)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        if isinstance(exc, FormatError):
            raise
        raise FormatError(path, f"not a readable CSV/TXT event file ({exc})") from None


def sensor_size_from(path, arrays, sensor_size):
    if sensor_size is not None:
        return tuple(int(v) for v in sensor_size)
    x, y = arrays
    size = (int(x.max()) + 1 if len(x) else 1, int(y.max()) + 1 if len(y) else 1)
    warnings.warn(f"{path}: no sensor size given; inferred {size[0]}x{size[1]} from the "
                  "largest coordinates (pass sensor_size=(W, H) or a camera)", EvstarWarning,
                  stacklevel=3)
    return size


def read(path, sensor_size=None, sort=False):
    parts = list(packets(path))
    cols = [np.concatenate(c) for c in zip(*parts)] if parts else [np.zeros(0, np.int64)] * 4
    w, h = sensor_size_from(path, (cols[1], cols[2]), sensor_size)
    try:
        return Recording(Events(*cols, w, h, sort=sort))
    except Exception as exc:
        raise FormatError(path, str(exc)) from None


def write(path, events, imu=None, camera=None):
    frame = pd.DataFrame({"t": events.t, "x": events.x, "y": events.y, "p": events.p})
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)
