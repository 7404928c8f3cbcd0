"""Events: the validated structure-of-arrays container every stage of evstar consumes."""
from __future__ import annotations

import threading

import numpy as np

from .errors import DataError, ParameterError, ParameterTypeError

#: the widest sensor side (px): x, y are stored as uint16
MAX_SENSOR_SIDE = 65536
#: The structured-array convention of tonic / Metavision (field names x, y, t, p).
STRUCTURED_DTYPE = np.dtype([("x", "<u2"), ("y", "<u2"), ("t", "<i8"), ("p", "<i1")])

#: Valid timestamps lie in [-T_LIMIT_US, T_LIMIT_US] (2**61 µs, about 73,000 years): far
#: inside int64, so differences of timestamps and t + any duration cannot overflow.
T_LIMIT_US = 2 ** 61

#: The hint every "unsorted" error gives: the API option and the command-line flag.
SORT_HINT = "pass sort=True (command line: --sort) to order them by time"


#: timestamps whose gaps are all multiples of a step this coarse (µs) or more are on a
#: lattice (time_lattice_us): a sensor stamping each readout, or a file written in ms
MIN_LATTICE_US = 20
#: ... judged on at least this many gaps between distinct timestamps
MIN_LATTICE_GAPS = 100


def time_lattice_us(t):
    """The step (µs) of the lattice the timestamps `t` (sorted) lie on: the greatest common
    divisor of the gaps between consecutive distinct ones; 0 where it is under
    MIN_LATTICE_US or fewer than MIN_LATTICE_GAPS gaps tell. Taken block by block: a
    divisor only shrinks, so 1 µs stamps are told in the first block (all 1.25 M of a
    field's gaps cost 19 ms)."""
    t = np.asarray(t, np.int64)
    step = n_gaps = 0
    for i in range(0, len(t) - 1, _LATTICE_BLOCK):
        gaps = np.diff(t[i:i + _LATTICE_BLOCK + 1])
        step = int(np.gcd.reduce(gaps, initial=step))   # gcd(0, g) = g: ties add nothing
        if 0 < step < MIN_LATTICE_US:
            return 0
        n_gaps += int(np.count_nonzero(gaps))
    return step if n_gaps >= MIN_LATTICE_GAPS and step >= MIN_LATTICE_US else 0


_LATTICE_BLOCK = 1 << 12


def check_time_range(values):
    """Index of the first timestamp outside ±T_LIMIT_US, or None (values: any numeric array)."""
    if not len(values):
        return None
    bad = (values > T_LIMIT_US) | (values < -T_LIMIT_US)
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def is_integer_value(v):
    """Whether v is one whole number (int, numpy integer, or a float such as 5.0): not a bool,
    a string, an array, NaN or inf."""
    if isinstance(v, (bool, np.bool_, str, bytes)) or np.ndim(v) != 0:
        return False
    try:
        return int(v) == v
    except (TypeError, ValueError, OverflowError):   # None, NaN, inf, other objects
        return False


def as_int_array(name, values, n=None, kind="events"):
    """values as a 1-D integer-valued array (floats must hold whole numbers); errors name
    `kind` field `name` (Imu checks its t with kind="IMU")."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:  # ragged lists and the like
        raise DataError(f"{kind} field '{name}' is not an array ({exc})") from None
    if arr.dtype != bool and not (np.issubdtype(arr.dtype, np.integer)
                                  or np.issubdtype(arr.dtype, np.floating)):
        raise DataError(f"{kind} field '{name}' must be numeric, got dtype {arr.dtype}")
    if arr.ndim != 1:
        raise DataError(f"{kind} field '{name}' must be one-dimensional, got shape {arr.shape}")
    if n is not None and len(arr) != n:
        raise DataError(f"{kind} field '{name}' has {len(arr)} entries, expected {n} (as t)")
    if arr.dtype == bool:
        return arr.astype(np.int64)
    if not np.issubdtype(arr.dtype, np.integer):
        if arr.size and not np.all(np.isfinite(arr)):
            raise DataError(f"{kind} field '{name}' holds non-finite values")
        if arr.size and np.any(arr != np.round(arr)):
            bad = arr[arr != np.round(arr)][0]
            raise DataError(f"{kind} field '{name}' holds a non-integer value {bad.item()!r}")
    return arr


def _sensor_dims(width, height):
    if not (is_integer_value(width) and is_integer_value(height)):
        raise DataError(f"sensor size must be two integers, got {width!r}x{height!r}")
    return int(width), int(height)


def _check_times(t):
    i = check_time_range(t)
    if i is not None:
        raise DataError(f"events field 't' = {t[i]} at index {i} is outside the valid range "
                        f"±{T_LIMIT_US} µs (±2**61)")


#: selections of at least this many events gather their first array on a second thread
PARALLEL_GATHER = 1 << 20


def gather(arrays, index):
    """[a.take(index) for a in arrays], the first on a helper thread for long selections
    (numpy's take releases the GIL: a 3.7 M-event selection's four gathers took ~70 ms on one
    core, ~35 ms on two). A thread per call, not a pool: nothing to go stale across a fork."""
    if len(index) < PARALLEL_GATHER or len(arrays) < 2:
        return [a.take(index) for a in arrays]
    out, error = [None] * len(arrays), []

    def first():
        try:
            out[0] = arrays[0].take(index)
        except BaseException as e:          # raised again in the caller
            error.append(e)

    helper = threading.Thread(target=first, name="evstar-gather")
    helper.start()
    try:
        for i in range(1, len(arrays)):
            out[i] = arrays[i].take(index)
    finally:
        helper.join()
    if error:
        raise error[0]
    return out


class Events:
    """Time-sorted events of one sensor as contiguous arrays.

    t: int64 µs (non-decreasing) within ±T_LIMIT_US (2**61 µs, so that t plus any duration
    stays inside int64), x, y: uint16 pixel indices, p: int8 (1 ON, 0 OFF).
    Construction validates everything; pass ``sort=True`` to order unsorted input
    (stable, by time) — unsorted input is otherwise an error, never reordered silently.
    """

    __slots__ = ("t", "x", "y", "p", "width", "height")

    def __init__(self, t, x, y, p, width, height, *, sort=False):
        width, height = _sensor_dims(width, height)
        if not (0 < width <= MAX_SENSOR_SIDE and 0 < height <= MAX_SENSOR_SIDE):
            raise DataError(f"sensor size must be positive and <= {MAX_SENSOR_SIDE}, got {width}x{height}")
        t = as_int_array("t", t)
        _check_times(t)
        n = len(t)
        x, y, p = (as_int_array(k, v, n) for k, v in (("x", x), ("y", y), ("p", p)))
        for name, arr, limit in (("x", x, width), ("y", y, height)):
            if n and (arr.min() < 0 or arr.max() >= limit):
                i = int(np.flatnonzero((arr < 0) | (arr >= limit))[0])
                raise DataError(
                    f"events field '{name}' = {arr[i]} at index {i} is outside the "
                    f"{width}x{height} sensor (valid 0..{limit - 1})")
        if n and not np.all(np.isin(p, (-1, 0, 1))):
            bad = p[~np.isin(p, (-1, 0, 1))][0]
            raise DataError(f"events field 'p' must be 0/1 (or -1/1), got {bad}")
        self.t = np.ascontiguousarray(t, dtype=np.int64)
        self.x = np.ascontiguousarray(x, dtype=np.uint16)
        self.y = np.ascontiguousarray(y, dtype=np.uint16)
        self.p = np.ascontiguousarray(p > 0, dtype=np.int8)
        self.width, self.height = width, height
        if n > 1 and np.any(np.diff(self.t) < 0):
            if not sort:
                i = int(np.flatnonzero(np.diff(self.t) < 0)[0])
                raise DataError(
                    f"event timestamps decrease at index {i + 1} ({self.t[i]} -> {self.t[i + 1]} µs); "
                    + SORT_HINT)
            order = np.argsort(self.t, kind="stable")
            for k in ("t", "x", "y", "p"):
                setattr(self, k, np.ascontiguousarray(getattr(self, k)[order]))

    # -- construction helpers -------------------------------------------------------
    @classmethod
    def empty(cls, width, height):
        z = np.zeros(0, np.int64)
        return cls(z, z, z, z, width, height)

    @classmethod
    def _trusted(cls, t, x, y, p, width, height):
        """Wrap arrays already known to satisfy the invariants (slices of valid Events)."""
        ev = object.__new__(cls)
        ev.t, ev.x, ev.y, ev.p = (np.ascontiguousarray(a) for a in (t, x, y, p))
        ev.width, ev.height = width, height
        return ev

    @classmethod
    def from_structured(cls, arr, width, height, *, sort=False):
        """From a structured array with fields x, y, t, p (tonic / Metavision / faery)."""
        if not isinstance(getattr(arr, "dtype", None), np.dtype):
            raise ParameterTypeError(f"Events.from_structured: 'arr' must be a numpy structured "
                                     f"array with fields x, y, t, p, got {type(arr).__name__}")
        names = arr.dtype.names or ()
        missing = [k for k in ("x", "y", "t", "p") if k not in names]
        if missing:
            raise DataError(f"structured array lacks field(s) {missing}; has {list(names)}")
        return cls(arr["t"], arr["x"], arr["y"], arr["p"], width, height, sort=sort)

    def to_structured(self):
        out = np.empty(len(self), STRUCTURED_DTYPE)
        for k in ("x", "y", "t", "p"):
            out[k] = getattr(self, k)
        return out

    @staticmethod
    def concatenate(parts):
        """Join Events of one sensor in order; the result must stay time-sorted."""
        try:
            parts = list(parts)
        except TypeError:
            raise ParameterTypeError(f"Events.concatenate: 'parts' must be a sequence of Events, "
                                     f"got {type(parts).__name__}") from None
        if not parts:
            raise DataError("cannot concatenate an empty list of Events")
        bad = next((i for i, e in enumerate(parts) if not isinstance(e, Events)), None)
        if bad is not None:
            raise ParameterTypeError(f"Events.concatenate: 'parts'[{bad}] is a "
                                     f"{type(parts[bad]).__name__}, not Events")
        w, h = parts[0].width, parts[0].height
        if any((e.width, e.height) != (w, h) for e in parts):
            raise DataError("cannot concatenate Events of different sensor sizes")
        cat = {k: np.concatenate([getattr(e, k) for e in parts]) for k in ("t", "x", "y", "p")}
        if len(cat["t"]) > 1 and np.any(np.diff(cat["t"]) < 0):
            raise DataError("concatenated events are not time-sorted; pass them in time order")
        return Events._trusted(cat["t"], cat["x"], cat["y"], cat["p"], w, h)

    # -- access -----------------------------------------------------------------------
    def __len__(self):
        return len(self.t)

    def __getitem__(self, index):
        """Slice (positive step) or boolean mask / index array (order kept; fancy indices must
        be increasing). Checks are O(1), or vectorised over a given index array only."""
        if isinstance(index, slice):
            try:
                step = index.indices(len(self))[2]
            except TypeError:
                raise ParameterTypeError(f"Events slice {index!r} must hold integers or None") from None
            except ValueError:        # step 0
                raise ParameterError(f"Events slice {index!r} has step 0") from None
            if step < 0:              # a reversed view would break the time order
                raise ParameterError(f"Events slice {index!r} has a negative step; events stay "
                                     f"time-sorted, slice with a positive step")
            return Events._trusted(self.t[index], self.x[index], self.y[index], self.p[index],
                                   self.width, self.height)                   # views
        if isinstance(index, (int, np.integer)):
            raise ParameterTypeError("index Events with a slice or mask; use .t[i], .x[i] for one event")
        try:
            idx = np.asarray(index)
        except (TypeError, ValueError):   # ragged lists
            idx = None
        if idx is not None and idx.ndim == 1 and idx.size == 0:
            return self[:0]                # [] is float64 to numpy: selects nothing
        if idx is None or idx.ndim != 1 or not (idx.dtype == bool
                                                 or np.issubdtype(idx.dtype, np.integer)):
            what = (f"an array of dtype {index.dtype}, shape {index.shape}"
                    if isinstance(index, np.ndarray) else repr(index)[:80])
            raise ParameterTypeError(f"Events index must be a slice, a boolean mask or a 1-D integer "
                                     f"index array, got {what}")
        if idx.dtype == bool:          # a mask: its events found once for the four arrays
            if len(idx) != len(self):  # (~3x a mask each)
                raise ParameterError(f"Events boolean index has {len(idx)} entries for "
                                     f"{len(self)} events")
            return self.at_sorted(np.flatnonzero(idx))
        try:
            sel = self.at_sorted(idx)
        except IndexError as exc:      # from take: costs nothing unless raised
            raise ParameterError(f"Events index array: {exc}") from None
        if len(sel) > 1 and np.any(np.diff(sel.t) < 0):
            raise DataError("an index array must keep events in time order")
        return sel

    def at_sorted(self, index):
        """The events at the ascending indices `index` (np.flatnonzero of a mask the caller
        has found anyway): events[mask] without finding them again, nor checking the order.
        take: ~20 % quicker than fancy indexing of these long arrays."""
        t, x, y, p = gather([self.t, self.x, self.y, self.p], index)
        return Events._trusted(t, x, y, p, self.width, self.height)

    def time_window(self, t_start_us, t_stop_us):
        """Events with t_start_us <= t < t_stop_us (views of the arrays, no copy)."""
        i0, i1 = np.searchsorted(self.t, [t_start_us, t_stop_us], side="left")
        return self[i0:i1]

    @property
    def sensor_size(self):
        return (self.width, self.height)

    @property
    def duration_us(self):
        return int(self.t[-1] - self.t[0]) if len(self) else 0

    @property
    def nbytes(self):
        return sum(getattr(self, k).nbytes for k in ("t", "x", "y", "p"))

    def copy(self):
        return Events._trusted(self.t.copy(), self.x.copy(), self.y.copy(), self.p.copy(),
                               self.width, self.height)

    def __eq__(self, other):
        if not isinstance(other, Events):
            return NotImplemented
        return (self.sensor_size == other.sensor_size and len(self) == len(other)
                and all(np.array_equal(getattr(self, k), getattr(other, k)) for k in "txyp"))

    __hash__ = None

    def __repr__(self):
        span = f", {self.t[0]}..{self.t[-1]} µs" if len(self) else ""
        return f"Events(n={len(self)}, {self.width}x{self.height}{span})"
