"""Centroid accuracy against ground truth: errors, detection rate, false tracks.

`positions(t_us)` is the truth: an array (len(t_us), n_stars, 2) of true pixel positions
(the simulator's ``truth.star_position``). A centroid is matched to the nearest true
star at the centroid's own timestamp, within ``match_px``.
"""
from __future__ import annotations

import numpy as np

from .errors import DataError, ParameterTypeError


def match(centroids, positions, match_px=3.0):
    """(star index or -1, error px) per centroid."""
    if len(centroids) == 0:
        return np.zeros(0, np.int64), np.zeros(0)
    xy = positions(centroids["t"]).transpose(1, 0, 2)   # (S, N, 2)
    d = np.hypot(xy[..., 0] - centroids["x"], xy[..., 1] - centroids["y"])
    d = np.where(np.isfinite(d), d, np.inf)
    star = np.argmin(d, axis=0)
    err = d[star, np.arange(len(centroids))]
    return np.where(err <= match_px, star, -1), err


def common_error(frame, star, dxy, min_stars=5):
    """The error all stars share, frame by frame: per frame with at least `min_stars`
    matched rows of distinct stars, the median of their error vectors (dxy: (n, 2) estimate
    less truth, px; frame, star: per row). A rigid field fit (one camera rotation per frame)
    cannot remove it, and it is what a star tracker's attitude inherits; independent
    per-star errors leave it near 0. Returns (frames, (k, 2) medians, RMS length px; NaN
    when no frame qualifies)."""
    from .frames import groups

    frame, star, dxy = np.asarray(frame), np.asarray(star), np.asarray(dxy, float)
    ids, rows = groups(frame)
    enough = [len(np.unique(star[r])) >= min_stars for r in rows]
    if not any(enough):
        return np.zeros(0, np.int64), np.zeros((0, 2)), float("nan")
    med = np.array([np.median(dxy[r], axis=0) for r, ok in zip(rows, enough) if ok])
    return ids[np.array(enough)], med, float(np.sqrt(np.mean((med ** 2).sum(1))))


def summary(errors):
    """mean, median, p95 and max of an error array (NaN when empty)."""
    e = np.asarray(errors, dtype=float)
    if len(e) == 0:
        return {"mean": float("nan"), "median": float("nan"), "p95": float("nan"), "max": float("nan"), "n": 0}
    return {"mean": float(e.mean()), "median": float(np.median(e)),
            "p95": float(np.percentile(e, 95)), "max": float(e.max()), "n": int(len(e))}


def detection(centroids, positions, frame_ids, frame_t_us, width, height, match_px=3.0,
              margin_px=2.0):
    """Fraction of (frame, star) pairs with the star inside the sensor (frames `frame_ids`
    with mid-times `frame_t_us`) that have a matched centroid; and the same per star."""
    frame_ids, frame_t_us = np.asarray(frame_ids), np.asarray(frame_t_us)
    xy = positions(frame_t_us).transpose(1, 0, 2)       # (S, F, 2) at frame mid-times
    inside = ((xy[..., 0] >= margin_px) & (xy[..., 0] <= width - 1 - margin_px)
              & (xy[..., 1] >= margin_px) & (xy[..., 1] <= height - 1 - margin_px))
    star, _ = match(centroids, positions, match_px)
    found = np.zeros_like(inside)
    col = np.searchsorted(frame_ids, centroids["frame"])
    ok = (star >= 0) & (col < len(frame_ids))
    ok[ok] &= frame_ids[col[ok]] == centroids["frame"][ok]
    found[star[ok], col[ok]] = True
    per_star = np.where(inside.sum(1) > 0, (found & inside).sum(1) / np.maximum(inside.sum(1), 1), np.nan)
    total = (found & inside).sum() / max(inside.sum(), 1)
    return float(total), per_star


def false_tracks(centroids, positions, duration_s, match_px=3.0):
    """Confirmed tracks (id >= 0) whose centroids mostly match no true star, per second."""
    star, _ = match(centroids, positions, match_px)
    ids = np.unique(centroids["track"][centroids["track"] >= 0])
    bad = sum(np.mean(star[centroids["track"] == i] < 0) > 0.5 for i in ids)
    return bad / duration_s if duration_s > 0 else float("nan")


def check_truth(truth, n_events, width, height, t_span_us):
    """DataError unless `truth` (evstar.sim Truth) belongs to these events: one label per
    event (n_events; None = not known yet), the same sensor size, attitude covering the
    event times t_span_us (None = not checked)."""
    from .sim.truth import Truth

    if not isinstance(truth, Truth):
        raise ParameterTypeError(f"truth must be an evstar.sim Truth (evstar.sim.load_truth), "
                                 f"got {type(truth).__name__}")
    if n_events is not None and len(truth.labels) != n_events:
        raise DataError(f"the truth labels {len(truth.labels):,} events but the recording has "
                        f"{n_events:,}: a truth file of another recording")
    cam = truth.camera
    if (cam.width, cam.height) != (width, height):
        raise DataError(f"the truth is of a {cam.width}x{cam.height} px sensor but the events' "
                        f"is {width}x{height} px: a truth file of another recording")
    if t_span_us is not None and len(truth.t_us):
        lo, hi = int(np.min(t_span_us)), int(np.max(t_span_us))
        if lo < truth.t_us[0] or hi > truth.t_us[-1]:
            raise DataError(f"the truth covers {truth.t_us[0]}..{truth.t_us[-1]} µs but the events "
                            f"span {lo}..{hi} µs: a truth file of another recording")
