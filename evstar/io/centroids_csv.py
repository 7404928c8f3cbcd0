"""Centroid tables as CSV: header `t,x,y,track,n_events,frame` (t µs) plus extra columns."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import FormatError
from .atomic import atomic_path

COLUMNS = ["t", "x", "y", "track", "n_events", "frame"]


def write_centroids(path, centroids):
    frame = pd.DataFrame({k: centroids[k] for k in centroids.dtype.names})
    rest = [c for c in frame.columns if c not in COLUMNS]
    with atomic_path(path) as tmp:
        frame[COLUMNS + rest].to_csv(tmp, index=False, float_format="%.4f")


def read_centroids(path):
    from ..extract import CENTROID_DTYPE

    try:
        frame = pd.read_csv(path)
    except FileNotFoundError:
        raise FormatError(path, "no such file") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise FormatError(path, f"not a readable centroid CSV ({exc})") from None
    missing = [c for c in COLUMNS if c not in frame.columns]
    if missing:
        raise FormatError(path, f"missing centroid column(s) {missing}")
    out = np.zeros(len(frame), CENTROID_DTYPE)
    for k in CENTROID_DTYPE.names:
        if k in frame.columns:
            out[k] = frame[k].to_numpy()
    return out
