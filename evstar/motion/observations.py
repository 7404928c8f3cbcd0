"""StarObservations: tracked star centroids (t, track, x, y), what the particle filter consumes.

Extraction's centroids (columns t, x, y, track, ...) convert with :meth:`StarObservations.from_any`.
x, y are image pixel coordinates (pixel centres at integers, lens distortion included).
"""
from __future__ import annotations

import numpy as np

from ..errors import DataError

_T_NAMES = ("t_us", "t")


class StarObservations:
    """Centroids sorted by time: t_us int64, track int64, x, y float64 (equal lengths)."""

    __slots__ = ("t_us", "track", "x", "y")

    def __init__(self, t_us, track, x, y):
        arrays = [np.asarray(a) for a in (t_us, track, x, y)]
        names = ("t_us", "track", "x", "y")
        for name, a in zip(names, arrays):
            if a.ndim != 1 or len(a) != len(arrays[0]):
                raise DataError(f"observation field '{name}' must be 1-D with {len(arrays[0])} "
                                f"entries, got shape {a.shape}")
            if a.size and not np.all(np.isfinite(a.astype(np.float64))):
                raise DataError(f"observation field '{name}' holds non-finite values")
        order = np.lexsort((arrays[1], arrays[0]))
        self.t_us = np.ascontiguousarray(np.round(arrays[0][order]), dtype=np.int64)
        self.track = np.ascontiguousarray(arrays[1][order], dtype=np.int64)
        self.x = np.ascontiguousarray(arrays[2][order], dtype=np.float64)
        self.y = np.ascontiguousarray(arrays[3][order], dtype=np.float64)
        dup = (np.diff(self.t_us) == 0) & (np.diff(self.track) == 0)
        if dup.any():
            i = int(np.flatnonzero(dup)[0])
            raise DataError(f"track {self.track[i]} is observed twice at t = {self.t_us[i]} µs")

    @classmethod
    def from_any(cls, obj):
        """From StarObservations, an object with attributes, a mapping, a DataFrame or a
        structured array holding t (or t_us), track, x, y."""
        if isinstance(obj, cls):
            return obj

        def field(name):
            try:
                return obj[name] if not hasattr(obj, name) else getattr(obj, name)
            except (KeyError, ValueError, IndexError, TypeError):
                return None

        t = next((v for v in map(field, _T_NAMES) if v is not None), None)
        cols = [t] + [field(k) for k in ("track", "x", "y")]
        if any(c is None for c in cols):
            raise DataError("observations need fields t (or t_us), track, x and y; got "
                            f"{type(obj).__name__}")
        return cls(*(np.asarray(c) for c in cols))

    def __len__(self):
        return len(self.t_us)

    def groups(self):
        """(t_us, slice) for each distinct observation time, in time order."""
        if not len(self):
            return
        starts = np.flatnonzero(np.r_[True, np.diff(self.t_us) != 0])
        ends = np.r_[starts[1:], len(self)]
        for s, e in zip(starts, ends):
            yield int(self.t_us[s]), slice(int(s), int(e))

    def __repr__(self):
        span = f", {self.t_us[0]}..{self.t_us[-1]} µs" if len(self) else ""
        return f"StarObservations(n={len(self)}, tracks={len(np.unique(self.track))}{span})"
