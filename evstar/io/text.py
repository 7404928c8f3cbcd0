"""CSV / TXT events in two layouts.

- A header naming the columns (any order, names in ``ALIASES``, each field once), t in µs.
- Headerless ``t x y p`` rows, t in seconds (RPG layout).

evstar's own CSV output has the comment line ``# width=W height=H`` right after the header
(pandas ``read_csv(comment="#")`` and numpy ``genfromtxt(names=True)`` / ``loadtxt(skiprows=1)``
skip it); the reader takes the sensor size from such a line before the first row. Timestamps must lie
within ±``evstar.events.T_LIMIT_US``. Fractional µs (header layout) or sub-µs digits (seconds
layout) are rounded to whole µs with an ``EvstarWarning`` saying how many values changed and
by how much at most.
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pandas as pd

from ..errors import DataError, EvstarWarning, FormatError
from ..events import MAX_SENSOR_SIDE, T_LIMIT_US, Events, check_time_range
from ..recording import Recording
from .atomic import atomic_path
from .guard import check_no_implicit_index, csv_parser_error, one_line, stored_size

# accepted header names for each field (lower case)
ALIASES = {"t": ("t", "timestamp", "ts", "time", "t_us"), "x": ("x",), "y": ("y",),
           "p": ("p", "polarity", "pol", "on")}
SIZE_LINE = re.compile(r"#\s*width\s*=\s*(\d+)\s+height\s*=\s*(\d+)\s*$")
SIZE_HINT = re.compile(r"#\s*width\s*=")    # a comment meant as the size line
COORD_LIMIT = 2 ** 31  # x, y, p beyond this cannot be pixel indices (and would not fit a cast)


def _sniff(path):
    """(header names or None, separator, sensor size from a `# width= height=` line or None,
    line number of the first row). The size line may come before the first row or right
    after the header."""
    size, line, names, number = None, "", None, 0
    try:
        with open(path, "r", encoding="utf-8-sig", errors="replace") as f:  # -sig: drop a BOM
            for number, ln in enumerate(f, 1):
                if ln.startswith("#"):
                    m = SIZE_LINE.match(ln.strip())
                    if SIZE_HINT.match(ln) and not (m and int(m.group(1)) and int(m.group(2))):
                        raise FormatError(path, f"line {number}: {ln.strip()!r} is no sensor "
                                                "size (# width=W height=H, positive integers)")
                    size = size or (m and (int(m.group(1)), int(m.group(2))))
                elif ln.strip():
                    if line:  # the first row after the header: no more size lines
                        break
                    line = ln
                    if not _is_header(ln):
                        break
            else:
                number += 1
    except OSError as exc:
        raise FormatError(path, f"cannot open: {exc.strerror or exc}") from None
    if not line:
        raise FormatError(path, "file is empty")
    sep = "," if "," in line else (";" if ";" in line else r"\s+")
    if _is_header(line):
        names = line.split() if sep == r"\s+" else line.split(sep)
    return names, sep, size, number


def _is_header(line):
    return any(c.isalpha() and c not in "eE" for c in line)


def first_row_line(path):
    """The line number of the first data row (after the header and comment lines)."""
    return _sniff(path)[3]


def header_sensor_size(path):
    """The sensor size a `# width=W height=H` comment line gives, or None."""
    return _sniff(path)[2]


def _clean(name):
    return str(name).strip().strip("\"'").strip()


def _columns(path, header_names):
    """field -> column name; each field must appear exactly once."""
    names = [_clean(c).lower() for c in header_names]
    cols = {}
    for field, aliases in ALIASES.items():
        hit = [c for c in names if c in aliases]
        if not hit:
            raise FormatError(path, f"missing column '{field}' (header has {names}; "
                                    f"accepted names: {', '.join(aliases)})")
        if len(hit) > 1:
            raise FormatError(path, f"column '{field}' appears {len(hit)} times in the header "
                                    f"({', '.join(repr(h) for h in hit)}); keep one")
        cols[field] = _clean(header_names[names.index(hit[0])])
    return cols


def _numeric(path, frame, column, name, offset):
    """Column `column` of the chunk as numbers; `name` is how messages call it."""
    values = pd.to_numeric(frame[column], errors="coerce").to_numpy()
    if values.dtype.kind not in "iuf":  # pandas gives object for mixed huge numbers
        values = values.astype(np.float64)
    bad = np.flatnonzero(np.isnan(values)) if values.dtype.kind == "f" else []
    if len(bad):
        i = int(bad[0])
        raise FormatError(path, f"line {offset + i}: column {name} holds a non-numeric "
                                f"value {frame[column].iloc[i]!r}")
    return values


def _integers(path, frame, column, name, offset):
    v = _numeric(path, frame, column, name, offset)
    f = v.astype(np.float64)
    for bad, what in ((f != np.round(f), "a non-integer"), (np.abs(f) > COORD_LIMIT, "an out-of-range")):
        if bad.any():  # inf counts as out of range (inf == round(inf))
            i = int(np.flatnonzero(bad)[0])
            raise FormatError(path, f"line {offset + i}: column {name} holds {what} value "
                                    f"{frame[column].iloc[i].strip()}")
    return v.astype(np.int64)


def _check_values(path, label, offset, x, y, p):
    """FormatError naming the line of the first x or y that is no pixel index of any sensor
    (negative, or beyond MAX_SENSOR_SIDE) and of the first p other than 0, 1 or -1: said
    here, before a sensor size is inferred from such values."""
    for k, v, bad, want in (("x", x, (x < 0) | (x >= MAX_SENSOR_SIDE), f"0..{MAX_SENSOR_SIDE - 1}"),
                            ("y", y, (y < 0) | (y >= MAX_SENSOR_SIDE), f"0..{MAX_SENSOR_SIDE - 1}"),
                            ("p", p, (p != 0) & (p != 1) & (p != -1), "0, 1 or -1")):
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise FormatError(path, f"line {offset + i}: column {label[k]} = {v[i]} is not "
                                    f"{'a pixel index' if k != 'p' else 'a polarity'} ({want})")


class _Rounding:
    """Counts timestamps rounded to whole µs, to warn once per file."""

    def __init__(self):
        self.count, self.largest = 0, 0.0

    def add(self, exact_us, rounded_us, changed):
        if changed.any():
            self.count += int(changed.sum())
            self.largest = max(self.largest, float(np.abs(exact_us - rounded_us)[changed].max()))


def _unit_hint(v, seconds):
    """Why the times `v` (a file's first rows) may be in the other unit, or None: whole
    numbers past 10⁴ where a headerless file's t is in seconds (µs read as s: hours long),
    or values all fractional and under 10⁴ where a header's t is in µs (seconds read as
    µs: rounded to a few whole µs)."""
    if not len(v):
        return None
    if seconds and v.dtype.kind != "f" and np.abs(v).max() >= _UNIT_HINT:
        return (f"holds whole numbers up to {np.abs(v).max():,}: a headerless file's t is in "
                "seconds; if these are µs, give the file a header line t,x,y,p")
    if not seconds and looks_like_seconds(v):
        return ("holds fractional values all under 10⁴: a header's t is in µs; if these are "
                "seconds, multiply them by 10⁶ (or drop the header: headerless t x y p rows "
                "are read in seconds)")
    return None


#: _unit_hint's bound: 10⁴ s is ~3 h, 10⁴ µs 10 ms
_UNIT_HINT = 10_000


def looks_like_seconds(t):
    """Are times taken as µs in fact seconds: mostly fractional, all under 10⁴ (rounded to
    µs they collapse onto a few)?"""
    return (np.asarray(t).dtype.kind == "f" and len(t) > 0 and np.abs(t).max() < _UNIT_HINT
            and np.mean(t != np.round(t)) > 0.5)


def _times(path, frame, column, name, offset, seconds, rounding, first=False):
    """Timestamps in µs: range-checked, rounded to whole µs (counted in `rounding`); the
    file's `first` rows' unit checked (_unit_hint: a warning)."""
    v = _numeric(path, frame, column, name, offset)
    hint = _unit_hint(v, seconds) if first else None
    if hint:
        warnings.warn(f"{path}: column {name} {hint}", EvstarWarning, stacklevel=4)
    us = v * 1e6 if seconds else v
    i = check_time_range(us)
    if i is not None:
        raise FormatError(path, f"line {offset + i}: column {name} = {frame[column].iloc[i]} is "
                                f"outside the valid time range ±{T_LIMIT_US} µs (±2**61)")
    if v.dtype.kind != "f":
        return us.astype(np.int64)
    whole = np.round(us)
    # seconds: exact µs values survive whole/1e6 unchanged, so a difference means sub-µs digits
    rounding.add(us, whole, (whole / 1e6 != v) if seconds else (whole != us))
    return whole.astype(np.int64)


def _reader(path, names, sep, chunk_rows):
    kw = dict(sep=sep, dtype=str, comment="#", skipinitialspace=True, chunksize=chunk_rows,
              engine="c", keep_default_na=False, encoding="utf-8-sig")
    if names is None:
        kw.update(header=None, names=["t", "x", "y", "p"], usecols=[0, 1, 2, 3])
    return pd.read_csv(path, **kw)


def packets(path, chunk_rows=1_000_000):
    """Yield (t µs, x, y, p) arrays chunk by chunk."""
    names, sep, _, line = _sniff(path)
    seconds = names is None  # headerless RPG layout: t in seconds
    if seconds:
        cols = {k: k for k in "txyp"}
        label = {"t": "1 (t, seconds)", "x": "2 (x)", "y": "3 (y)", "p": "4 (p)"}
    else:
        cols = _columns(path, names)
        label = {k: repr(c) for k, c in cols.items()}
    rounding, first = _Rounding(), line
    try:
        with _reader(path, names, sep, chunk_rows) as reader:   # closed on an error too
            for frame in reader:
                if not seconds:
                    check_no_implicit_index(path, frame, line, len(names))
                frame.columns = [_clean(c) for c in frame.columns]
                missing = [c for c in cols.values() if c not in frame.columns]
                if missing:
                    raise FormatError(path, f"cannot find column(s) {missing} in the rows")
                t = _times(path, frame, cols["t"], label["t"], line, seconds, rounding,
                           line == first)
                xyp = [_integers(path, frame, cols[k], label[k], line) for k in "xyp"]
                _check_values(path, label, line, *xyp)
                line += len(frame)
                yield (t, *xyp)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, OverflowError) as exc:
        if isinstance(exc, FormatError):
            raise
        if isinstance(exc, pd.errors.ParserError):
            raise csv_parser_error(path, exc, "CSV/TXT event file") from None
        raise FormatError(path, f"not a readable CSV/TXT event file ({one_line(exc)})") from None
    if rounding.count:
        what = "sub-µs digits" if seconds else "fractional µs"
        warnings.warn(f"{path}: column {label['t']} has {rounding.count} value(s) with {what}, "
                      f"rounded to whole µs (largest change {rounding.largest:.3g} µs)",
                      EvstarWarning, stacklevel=2)


def sensor_size_from(path, arrays, sensor_size):
    if sensor_size is not None:
        return tuple(int(v) for v in sensor_size)
    x, y = (np.asarray(a) for a in arrays)
    for name, a in (("x", x), ("y", y)):
        if a.dtype.kind not in "biuf" or (a.dtype.kind == "f" and not np.all(np.isfinite(a))):
            raise FormatError(path, f"events field '{name}' must hold finite numbers (dtype {a.dtype}) "
                                    "to infer the sensor size; pass sensor_size=(W, H)")
        bad = (a < 0) | (a >= MAX_SENSOR_SIDE)   # no size to infer from these: say which
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise FormatError(path, f"events field '{name}' = {a[i]} at index {i} is not a pixel "
                                    f"index (0..{MAX_SENSOR_SIDE - 1})")
    size = (int(x.max()) + 1 if len(x) else 1, int(y.max()) + 1 if len(y) else 1)
    warnings.warn(f"{path}: no sensor size given; inferred {size[0]}x{size[1]} from the "
                  "largest coordinates (pass sensor_size=(W, H) or a camera)", EvstarWarning,
                  stacklevel=3)
    return size


def read(path, sensor_size=None, sort=False):
    size = stored_size(path, header_sensor_size(path), sensor_size)
    parts = list(packets(path))
    cols = [np.concatenate(c) for c in zip(*parts)] if parts else [np.zeros(0, np.int64)] * 4
    w, h = sensor_size_from(path, (cols[1], cols[2]), size)
    try:
        return Recording(Events(*cols, w, h, sort=sort))
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def write(path, events, imu=None, camera=None):
    """Events, the sensor size in a `# width=W height=H` comment line after the header."""
    frame = pd.DataFrame({"t": events.t, "x": events.x, "y": events.y, "p": events.p})
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as f:
            f.write(f"t,x,y,p\n# width={events.width} height={events.height}\n")
            frame.to_csv(f, index=False, header=False)
