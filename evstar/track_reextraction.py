"""Adaptive integration of faint tracks: re-extract a track's events along its trajectory.

A faint or slow star gives a few events per frame, too few for DBSCAN's min_samples, so
many of its frames have no centroid at all although its events are there. Knowing the
track (the smoother's positions, :mod:`evstar.smoothing`), the events within
``gather_radius_px`` of the predicted position at each event's own time are the star's;
their offsets from the prediction (the events motion-compensated along the track) are
pooled over consecutive frames until a window holds ``gather_min_events`` (at most
``gather_max_frames`` frames), and each window gives one centroid: the prediction at the
members' mean time plus their mean offset. Feed the result to the smoother again for
positions in frames that had none.

The radius trades two biases: events are whole pixels, so a circle cutting through the
PSF's wings keeps more pixels on one side of a sub-pixel position than the other (slow
stars: the pixel phase changes slowly, and the smoother cannot average it out), while a
fast star's leading ON / trailing OFF events are not symmetric about its position (a wide
circle takes more of them). On the simulator (PSF σ 1 px) 4 px is best at 2 °/s and 3 px
at 8 °/s, where re-extraction is not needed (the per-frame centroids are rich).
"""
from __future__ import annotations

import numpy as np

from .extract import CENTROID_DTYPE
from .parameters import REEXTRACT


def reextract_tracks(events, estimates, dt_us, t0_us, *, gather_radius_px=4.0,
                     gather_min_events=3, gather_max_frames=5):
    """CENTROID_DTYPE rows (track filled, time-sorted) re-extracted from `events`
    (time-sorted evstar.Events, e.g. the denoised ones) along every track of `estimates`
    (ESTIMATE_DTYPE rows from TrackSmoother.smooth); frames as the smoother's (dt_us, t0_us)."""
    radius = REEXTRACT.check("gather_radius_px", gather_radius_px)
    min_events = REEXTRACT.check("gather_min_events", gather_min_events)
    max_frames = REEXTRACT.check("gather_max_frames", gather_max_frames)
    rows = []
    for tr in np.unique(estimates["track"]):
        est = estimates[estimates["track"] == tr]
        est = est[np.argsort(est["t"], kind="stable")]
        rows += _track_rows(events, est, int(tr), dt_us, t0_us, radius, min_events, max_frames)
    out = np.array(rows, CENTROID_DTYPE) if rows else np.zeros(0, CENTROID_DTYPE)
    return out[np.argsort(out["t"], kind="stable")]


def _track_rows(events, est, track, dt_us, t0_us, radius, min_events, max_frames):
    a, b = np.searchsorted(events.t, [est["t"][0] - dt_us // 2, est["t"][-1] + dt_us // 2])
    t = events.t[a:b]
    px, py = np.interp(t, est["t"], est["x"]), np.interp(t, est["t"], est["y"])
    dx, dy = events.x[a:b] - px, events.y[a:b] - py
    near = np.hypot(dx, dy) <= radius
    t, dx, dy, p = t[near], dx[near], dy[near], events.p[a:b][near]
    frames = (t - t0_us) // dt_us
    rows = []
    for members in _windows(frames, min_events, max_frames):
        tm = t[members].mean()
        ox, oy = dx[members].mean(), dy[members].mean()
        spread = float(np.sqrt(((dx[members] - ox) ** 2 + (dy[members] - oy) ** 2).mean()))
        x = np.interp(tm, est["t"], est["x"]) + ox
        y = np.interp(tm, est["t"], est["y"]) + oy
        frame = int((int(round(tm)) - t0_us) // dt_us)
        rows.append((int(round(tm)), x, y, track, len(members), frame, spread, False, False,
                     np.nan, "measured", int(np.count_nonzero(p[members]))))
    return rows


def _windows(frames, min_events, max_frames):
    """Index arrays of consecutive-frame windows holding >= min_events events, each at most
    max_frames frames long (frames: sorted frame of each event); a window that reaches
    max_frames with too few events is dropped and the next one starts after it."""
    if not len(frames):
        return []
    ids, starts = np.unique(frames, return_index=True)
    stops = np.r_[starts[1:], len(frames)]
    out, first, begin = [], None, None
    for f, a, b in zip(ids, starts, stops):
        if first is not None and f - first >= max_frames:
            first = None                            # too sparse: start afresh at this frame
        if first is None:
            first, begin = f, a
        if b - begin >= min_events:
            out.append(np.arange(begin, b))
            first = None
    return out
