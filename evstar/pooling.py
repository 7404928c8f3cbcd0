"""Faint stars' second look: the events no frame centroid used, pooled over longer frames.

A star that gives a few events per frame passes neither the density filter's per-frame
thresholds nor DBSCAN's min_samples in most frames, though its events are there. The events
no frame centroid used are filtered again among themselves (NDSEF at ``denoise.radius``,
whatever the frame filter) in frames ``extract.pool_frames`` (k) times as long (its
threshold for that length: the noise per frame grows k-fold, but so does the star's count,
and a slow star stays compact), and those it keeps are clustered in the long frames; a
cluster needs k - 1 times the frame clusters' smallest size. "Not used" are the events the
frame filter dropped and those it kept that no reported cluster holds: on a quiet sensor
(no background, so every event passes the filter) a wide faint star's events fail DBSCAN
alone, and a look at the filter's rejects found nothing (1.5 °/s, magnitude 4.5, σ 1.8 px,
no noise: 32 % of frames, 1.6 px). The used events are left out of the density too: counted,
they let the background along a bright star's path pass, which pooled into a false track
beside the star (10 Hz of background, a sinusoid: 12-14 false rows per 100 frames). A pooled
centroid's ``t`` is its members' mean time (where a linearly moving star was at its
position), its ``frame`` the frame of that time and its ``source`` "pooled". One within
``track.gate_px`` of a frame centroid of its own frame is dropped (the tracker would see two
candidates for one star); the tracker links the rest with the frame centroids, and the
estimator drops pooled centroids no track took (noise that once pooled into a cluster).
"""
from __future__ import annotations

import numpy as np

from .denoise import NDSEF
from .extract import CENTROID_DTYPE
from .frames import nearest_in_frame
from .parameters import AUTO, MAX_DT_US


def pooled_centroids(config, events, unused, t0_us, rate_hz, frame_centroids, scratch=None):
    """CENTROID_DTYPE rows (source "pooled") of the `unused` events (mask over `events`,
    the chunk's raw events: those no frame centroid used) in frames
    config.extract.pool_frames times config.dt_us long, aligned to t0_us, less those a
    frame centroid (frame_centroids) already covers. scratch: a Scratch its filter shares
    (the caller's, kept between calls), None for its own."""
    from .pipeline import Pipeline

    k = config.extract.pool_frames
    if k <= 1 or config.dt_us * k > MAX_DT_US or not unused.any():
        return np.zeros(0, CENTROID_DTYPE)
    e = config.extract
    # a pooled cluster must hold (k - 1) frames' worth of the smallest cluster: a weaker one
    # is as often a noise clump (or a bright star's stray flank) as a faint star
    min_size = (k - 1) * (e.min_cluster_size or e.min_samples)
    long = Pipeline(config.replace(dt_us=config.dt_us * k,
                                   **{"extract.min_cluster_size": min_size}))
    d = config.denoise
    # one density test, NDSEF at denoise.radius with its threshold for the long frame (a
    # third of MR-NDSEF's cost, as good here), among the unused events alone (above)
    flt = NDSEF(long.config.dt_us, d.radius, AUTO, alpha=d.alpha,
                rate_hz=d.rate_hz if d.rate_hz is not None else rate_hz, t0_us=t0_us,
                device=config.device)
    if scratch is not None:
        flt.sharing(scratch)
    rest = events[flt.kept_among(events, unused)]
    if not len(rest):
        return np.zeros(0, CENTROID_DTYPE)
    cents = long.make_extractor(t0_us).centroids(rest)
    cents["frame"] = (cents["t"] - t0_us) // config.dt_us
    cents["source"] = "pooled"
    return cents[~_seen(cents, frame_centroids, config.track.gate_px)]


def _seen(pooled, frame_centroids, radius):
    """Per pooled centroid: whether a frame centroid of its own frame lies within `radius`
    (the tracker would have two candidates for one star there)."""
    if not len(pooled) or not len(frame_centroids):
        return np.zeros(len(pooled), bool)
    d, _ = nearest_in_frame(np.column_stack([frame_centroids["x"], frame_centroids["y"]]),
                            frame_centroids["frame"],
                            np.column_stack([pooled["x"], pooled["y"]]), pooled["frame"], radius)
    return np.isfinite(d)
