"""Faint stars' second look: the events the frame filter rejected, pooled over longer frames.

A star that gives a few events per frame passes neither the density filter's per-frame
thresholds nor DBSCAN's min_samples in most frames, though its events are there. All events
are filtered again in frames ``extract.pool_frames`` times as long (thresholds for that
length: the noise per frame grows k-fold, but so does the star's count, and a slow star
stays compact), and those the frame filter had dropped but this one keeps are clustered in
the long frames. A pooled centroid's ``t`` is its members' mean
time (where a linearly moving star was at its position), its ``frame`` the frame of that
time and its ``source`` "pooled". One within ``track.gate_px`` of a frame centroid of the
same long frame is dropped (that star was seen there already); the tracker links the rest
with the frame centroids, and the estimator drops pooled centroids no track took (noise
that once pooled into a cluster).
"""
from __future__ import annotations

import numpy as np

from .extract import CENTROID_DTYPE
from .parameters import MAX_DT_US

# long frames are kept apart in one nearest-neighbour search by a coordinate this far apart
_FRAME_GAP = 1e6


def pooled_centroids(config, events, rejected, t0_us, rate_hz, frame_centroids):
    """CENTROID_DTYPE rows (source "pooled") of the `rejected` events (mask over `events`,
    the chunk's raw events) in frames config.extract.pool_frames times config.dt_us long,
    aligned to t0_us, less those a frame centroid (frame_centroids) already covers."""
    from .pipeline import Pipeline

    k = config.extract.pool_frames
    if k <= 1 or config.dt_us * k > MAX_DT_US or not rejected.any():
        return np.zeros(0, CENTROID_DTYPE)
    long = Pipeline(config.replace(dt_us=config.dt_us * k))
    flt = long.make_filter(t0_us, rate_hz)
    if flt is not None:  # the density of all events (a faint star's kept ones too) decides
        rejected = rejected & flt.apply(events)
    if not rejected.any():
        return np.zeros(0, CENTROID_DTYPE)
    cents = long.make_extractor(t0_us).centroids(events[rejected])
    cents["frame"] = (cents["t"] - t0_us) // config.dt_us
    cents["source"] = "pooled"
    return cents


def _seen(pooled, frame_centroids, k, radius):
    """Per pooled centroid (its frame counted in long frames): whether a frame centroid of
    the same long frame lies within `radius`."""
    from scipy.spatial import cKDTree

    if not len(pooled) or not len(frame_centroids):
        return np.zeros(len(pooled), bool)
    def pts(c, long_frame):
        return np.column_stack([c["x"], c["y"], long_frame * _FRAME_GAP])
    tree = cKDTree(pts(frame_centroids, frame_centroids["frame"] // k))
    d, _ = tree.query(pts(pooled, pooled["frame"]), distance_upper_bound=radius)
    return np.isfinite(d)
