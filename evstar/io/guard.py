"""Input checks shared by the readers: a path must be a readable file, and whatever a
decoding library (numpy, pandas, h5py, faery) raises on corrupt bytes becomes FormatError."""
from __future__ import annotations

import contextlib
import os
import re
import stat
import tokenize
import zipfile
import zlib

import numpy as np

from ..errors import EvstarError, FormatError, ParameterTypeError
from ..events import T_LIMIT_US, check_time_range

# what the libraries raise on corrupt, truncated or hostile content
# (numpy parses .npy headers with tokenize/ast; zipfile raises RuntimeError for encrypted
# members and NotImplementedError, a RuntimeError, for zip versions it lacks; .npz members
# inflate with zlib)
LIBRARY_ERRORS = (OSError, ValueError, EOFError, OverflowError, MemoryError, UnicodeError,
                  RuntimeError, zipfile.BadZipFile, zlib.error, tokenize.TokenError, SyntaxError)
# h5py reports corrupt object headers and links as KeyError or TypeError too
H5PY_ERRORS = (KeyError, TypeError)


def check_path_type(path):
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterTypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")


def check_readable(path):
    """FormatError unless `path` is an existing, readable, non-empty plain file (a named
    pipe is refused as one: the readers open a file more than once, and the second open of a
    pipe waits for a writer that is gone)."""
    check_path_type(path)
    if not os.path.exists(path):
        raise FormatError(path, "no such file")
    if os.path.isdir(path):
        raise FormatError(path, "is a folder, not a file")
    if not os.access(path, os.R_OK):
        raise FormatError(path, "permission denied")
    if stat.S_ISFIFO(os.stat(path).st_mode):
        raise FormatError(path, "is a named pipe; evstar reads files: save the stream to a file "
                                "first")
    if os.path.isfile(path) and os.path.getsize(path) == 0:
        raise FormatError(path, "file is empty")


def plain_numeric(dtype):
    """True for dtypes that h5py reads without risk: bool, int or float of at most 8 bytes,
    or compounds of those whose fields do not overlap (corrupt files can declare overlapping
    or exotic fields, and reading those has crashed the interpreter)."""
    if dtype.names is None:
        return dtype.kind in "biuf" and dtype.itemsize <= 8 and dtype.subdtype is None
    fields = [dtype.fields[n][:2] for n in dtype.names]
    spans = sorted((off, off + dt.itemsize) for dt, off in fields)
    return (all(plain_numeric(dt) for dt, _ in fields) and spans[-1][1] <= dtype.itemsize
            and all(a[1] <= b[0] for a, b in zip(spans, spans[1:])))


def check_h5_numeric(path, obj, name):
    """FormatError unless dataset or attribute `name` of the h5py object `obj` is plain numeric."""
    import h5py

    item = obj.get_id(name) if isinstance(obj, h5py.AttributeManager) else obj[name]
    if not plain_numeric(item.dtype):
        raise FormatError(path, f"'{name}' has an unsupported HDF5 type {item.dtype}")


def int64_times(path, t):
    """Decoded timestamps as int64; FormatError for any outside ±T_LIMIT_US (checked before
    the cast, which would wrap huge unsigned values into plausible ones)."""
    i = check_time_range(t)
    if i is not None:
        raise FormatError(path, f"timestamp {t[i]} (event {i} of a packet) is outside the valid "
                                f"range ±{T_LIMIT_US} µs")
    return t.astype(np.int64)


def stored_size(path, stored, option):
    """The sensor size of a file that states its own (`stored`, or None where it does not):
    the `option` (sensor_size, from --sensor-size or --camera) is for files that do not say,
    so one that disagrees is an error rather than a silent override."""
    if stored is None:
        return None if option is None else tuple(int(v) for v in option)
    stored = tuple(stored)  # as the file has it: Events checks that these are sizes
    if option is not None and tuple(option) != stored:
        raise FormatError(path, f"the file's sensor is {stored[0]}x{stored[1]} px but sensor_size "
                                f"{option[0]}x{option[1]} was given (--sensor-size, or the --camera's "
                                "width and height, is only for files that do not say)")
    return stored


# pandas' C parser: a row with more fields than the header (its text spans two lines)
_FIELD_COUNT = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def csv_parser_error(path, exc, what):
    """FormatError for a pandas ParserError, one line; a wrong field count names its line."""
    m = _FIELD_COUNT.search(str(exc))
    if m:
        want, line, saw = m.groups()
        return FormatError(path, f"line {line} has {saw} fields, expected {want}")
    return FormatError(path, f"not a readable {what} ({one_line(exc)})")


def check_no_implicit_index(path, frame, line, header_fields):
    """pandas makes the leading columns an index (shifting every field) when the first row
    has more fields than the header: FormatError naming that row, `line` of the file."""
    import pandas as pd

    if not isinstance(frame.index, pd.RangeIndex):
        saw = frame.index.nlevels + frame.shape[1]
        raise FormatError(path, f"line {line} has {saw} fields but the header has {header_fields}")


def one_line(exc):
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:200]


def is_rust_panic(exc):
    """faery is Rust: a panic arrives as pyo3_runtime.PanicException, a BaseException."""
    return type(exc).__name__ == "PanicException"


@contextlib.contextmanager
def decoder_errors(path, what, extra=()):
    """Re-raise library errors (and `extra` types) inside the block as FormatError."""
    try:
        yield
    except EvstarError:
        raise
    except LIBRARY_ERRORS + tuple(extra) as exc:
        raise FormatError(path, f"not a readable {what} ({type(exc).__name__}: {one_line(exc)})") from None
    except BaseException as exc:
        if not is_rust_panic(exc):
            raise
        raise FormatError(path, f"not a readable {what} (decoder panic: {one_line(exc)})") from None
