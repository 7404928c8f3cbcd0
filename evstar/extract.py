"""Target extraction: DBSCAN per pseudo-frame on the kept events -> sub-pixel centroids.

Conventions: pixel (i, j) has its centre at (x=i, y=j). A centroid's time is either the
mean time of its member events (``time_ref="mean"``, the default: for a moving target it
is the time at which the star actually was at the centroid) or the frame's mid-time
(``time_ref="mid"``, the paper's pseudo-frame view). Tracks are linked by
:mod:`evstar.tracking`.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from sklearn.cluster import DBSCAN

from . import parameters as P
from .errors import ParameterError, ParameterTypeError
from .events import Events
from .frames import check_dt, frame_bounds, frame_ids

#: one row per centroid; t in µs (the time x, y refer to); flags: border (touches the sensor
#: edge), split (separated from a DBSCAN cluster that held two targets); sigma: per-axis
#: uncertainty in px (NaN until an estimator sets it); source: "measured" (this frame's
#: events) or "coasted" (a frame of a track without a centroid, from the track's motion)
CENTROID_DTYPE = np.dtype([("t", "<i8"), ("x", "<f8"), ("y", "<f8"), ("track", "<i8"),
                           ("n_events", "<i4"), ("frame", "<i8"), ("spread", "<f8"),
                           ("border", "?"), ("split", "?"), ("sigma", "<f8"), ("source", "<U8")])
E = P.EXTRACT
WEIGHTINGS, TIME_REFS = P.WEIGHTINGS, P.TIME_REFS
SOURCES = ("measured", "coasted")   # values of the `source` field (HDF5 stores their index)
# frames are kept apart in one DBSCAN call by a third coordinate this far apart (>> eps)
_FRAME_GAP = 1e6


class Extractor:
    """Per-frame DBSCAN clustering and sub-pixel centroids (scikit-learn style parameters).

    weighting: "events" (every member event counts once: the paper's mean), "pixels" (each
    distinct pixel once, so a hot spot cannot pull the centroid) or "polarity" (mean of
    the ON and OFF sub-centroids, cancelling the leading-ON / trailing-OFF bias of a
    moving star when the two counts differ).
    split_valley: a cluster whose event profile along the line joining its two k-means
    halves dips, between them, below split_valley times the lower of the two peaks is two
    targets closer than eps: they are reported apart (flag ``split``), not merged. A
    single smeared streak has a flat profile and halves as wide as their separation allows,
    and a moving star's leading ON and trailing OFF lobes differ in polarity, so both stay
    whole. None disables the check.
    """

    def __init__(self, dt_us=P.GLOBAL["dt_us"].default, eps=E["eps"].default,
                 min_samples=E["min_samples"].default, min_cluster_size=None,
                 weighting=E["weighting"].default, time_ref=E["time_ref"].default,
                 split_valley=E["split_valley"].default, t_origin_us=None):
        self.dt_us = check_dt(dt_us)
        self.eps = float(E.check("eps", eps))
        self.min_samples = E.check("min_samples", min_samples)
        self.min_cluster_size = E.check("min_cluster_size", min_cluster_size) or self.min_samples
        self.weighting = E.check("weighting", weighting)
        self.time_ref = E.check("time_ref", time_ref)
        self.split_valley = E.check("split_valley", split_valley)
        self.t_origin_us = P.KERNEL.check("t0_us", t_origin_us, "t_origin_us")

    def labels(self, events, xy=None):
        """(frame id, DBSCAN label) per event; label -1 is noise. `xy` overrides coordinates
        (e.g. motion-compensated floats; clustered at their rounded pixels)."""
        if not isinstance(events, Events):
            raise ParameterTypeError(f"events must be evstar.Events, got {type(events).__name__}")
        frames = frame_ids(events.t, self.dt_us, self.t_origin_us)
        # membership is decided on the pixel grid (float, e.g. warped, coordinates are
        # rounded as the filters round them); centroids use the floats
        xy = np.floor(_coords(events, xy) + 0.5).astype(np.int64)
        if len(events) == 0:
            return frames, np.zeros(0, np.int64)
        # events repeat at a pixel (a star fires ~30 per pixel it crosses): cluster the
        # distinct (frame, pixel) cells weighted by multiplicity — the same core test, far
        # fewer neighbours. One int64 key per cell keeps the de-duplication a 1-D sort.
        lo = xy.min(0)
        w, h = xy.max(0) - lo + 1
        key = ((frames - frames[0]) * h + (xy[:, 1] - lo[1])) * w + (xy[:, 0] - lo[0])
        cells, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        pts = np.column_stack([cells % w, (cells // w) % h, (cells // (w * h)) * _FRAME_GAP])
        labels = DBSCAN(eps=self.eps, min_samples=self.min_samples).fit_predict(
            pts.astype(np.float64), sample_weight=counts)
        return frames, labels[inverse.ravel()]

    def centroids(self, events, xy=None):
        """Centroids of every cluster of every frame, in time order (track = -1 until linked)."""
        frames, labels = self.labels(events, xy)
        xy = _coords(events, xy)
        keep = labels >= 0
        if not keep.any():
            return np.zeros(0, CENTROID_DTYPE)
        # group member events by cluster (labels are unique across frames)
        idx = np.flatnonzero(keep)
        order = idx[np.argsort(labels[idx], kind="stable")]
        _, starts, stops = frame_bounds(labels[order])
        rows = []
        for a, b in zip(starts, stops):
            members = order[a:b]
            if len(members) < self.min_cluster_size:
                continue
            rows.extend(self._describe(events, xy, frames, members))
        out = np.array(rows, CENTROID_DTYPE)
        return out[np.lexsort((out["x"], out["t"]))]

    # -- one cluster ----------------------------------------------------------------------
    def _describe(self, events, xy, frames, members):
        parts = self._split(xy[members], events.p[members]) if self.split_valley else None
        groups = [members] if parts is None else [members[parts == k] for k in (0, 1)]
        return [self._row(events, xy, frames, g, split=parts is not None) for g in groups]

    def _split(self, pts, p):
        """Labels 0/1 when the cluster holds two separable targets, else None.

        First on all events; a moving star fires ON at its leading edge and OFF at its
        trailing edge, so halves that differ in polarity are the two lobes of one target.
        Then on each polarity alone, where one target is one lobe: that finds a faint star
        beside a bright one, whose lobes dominate the first split. Both polarities must
        show the pair; their halves are matched by their order along the pair's axis."""
        if len(pts) < 2 * self.min_cluster_size:
            return None
        seeds = _two_peaks(pts)
        if seeds is None:  # one peak: one target (the common case, decided cheaply)
            return None
        lab = self._halves(pts, seeds)
        if lab is not None and abs(p[lab == 0].mean() - p[lab == 1].mean()) <= 0.5:
            return lab
        on, off = p == 1, p == 0
        lab_on = self._halves(pts[on])
        lab_off = None if lab_on is None else self._halves(pts[off])
        if lab_off is None:
            return None
        c_on = np.array([pts[on][lab_on == k].mean(0) for k in (0, 1)])
        c_off = np.array([pts[off][lab_off == k].mean(0) for k in (0, 1)])
        axis = c_on[1] - c_on[0]
        if (c_off[1] - c_off[0]) @ axis < 0:  # OFF halves in the opposite order
            lab_off = 1 - lab_off
        out = np.empty(len(pts), np.int64)
        out[on], out[off] = lab_on, lab_off
        return out

    def _halves(self, pts, seeds=None):
        """Labels 0/1 when `pts` hold two compact targets with a clear valley between them,
        else None. The seeds are the two highest peaks of the smoothed count image, so a
        faint star beside a bright one is found (2-means would halve the bright one)."""
        if len(pts) < 2 * self.min_cluster_size:
            return None
        seeds = _two_peaks(pts) if seeds is None else seeds
        if seeds is None:
            return None
        lab = _two_means(pts, *seeds)
        if np.bincount(lab, minlength=2).min() < self.min_cluster_size:
            return None
        c0, c1 = pts[lab == 0].mean(0), pts[lab == 1].mean(0)
        sep = np.linalg.norm(c1 - c0)
        if sep < 2:  # closer than two pixels: not resolvable on the pixel grid
            return None
        proj = (pts - c0) @ ((c1 - c0) / sep)
        # a uniform streak cut in two has sep / axial std = 2·sqrt(3) ≈ 3.5 (more by chance
        # with few events: + 8 / sqrt(n) bounds 99.9 % of simulated streaks); two compact
        # targets have far more
        axial = np.mean([proj[lab == 0].std(), (proj[lab == 1] - sep).std()])
        n_min = np.bincount(lab).min()
        if sep < (2 * np.sqrt(3) + 8 / np.sqrt(n_min)) * max(axial, 0.25):
            return None
        # 1-px profile of the events along the axis c0 -> c1 (c0 at 0, c1 at sep): it must
        # dip between the two; a lopsided blob stays whole
        lo = np.floor(proj.min() - 0.5)
        hist = np.bincount(np.floor(proj - lo).astype(int))
        b0, b1 = int(np.floor(-lo)), int(np.floor(sep - lo))
        peaks = min(hist[max(b0 - 1, 0):b0 + 2].max(), hist[b1 - 1:b1 + 2].max())
        valley = hist[b0 + 1:b1].min() if b1 > b0 + 1 else peaks
        return lab if valley <= self.split_valley * peaks else None

    def _row(self, events, xy, frames, m, split):
        pts = xy[m]
        cx, cy = self._centre(pts, events.p[m])
        if self.time_ref == "mean":
            t = int(np.round(events.t[m].mean()))
        else:
            t0 = int(events.t[0]) if self.t_origin_us is None else int(self.t_origin_us)
            t = t0 + int(frames[m[0]]) * self.dt_us + self.dt_us // 2
        spread = float(np.sqrt(((pts - (cx, cy)) ** 2).sum(1).mean()))
        border = bool(pts[:, 0].min() < 1 or pts[:, 1].min() < 1
                      or pts[:, 0].max() > events.width - 2 or pts[:, 1].max() > events.height - 2)
        return (t, cx, cy, -1, len(m), frames[m[0]], spread, border, split, np.nan, "measured")

    def _centre(self, pts, p):
        if self.weighting == "pixels":
            pts = np.unique(np.round(pts, 6), axis=0)
        elif self.weighting == "polarity" and 0 < p.sum() < len(p):
            return tuple((pts[p > 0].mean(0) + pts[p == 0].mean(0)) / 2)
        return tuple(pts.mean(0))


_SMOOTH = np.exp(-0.5 * (np.arange(-2, 3) / 0.7) ** 2)  # Gaussian, sigma 0.7 px


def _two_peaks(pts):
    """(x, y) of the two highest local maxima, at least 2 px apart, of the events' count
    image smoothed by a Gaussian of 0.7 px; None when there is one."""
    ij = np.floor(pts + 0.5).astype(np.int64)
    origin = ij.min(0) - 2
    w, h = ij.max(0) - origin + 3
    flat = (ij[:, 1] - origin[1]) * w + (ij[:, 0] - origin[0])
    img = np.bincount(flat, minlength=w * h).reshape(h, w).astype(np.float64)
    img = ndimage.correlate1d(ndimage.correlate1d(img, _SMOOTH, 0, mode="constant"), _SMOOTH, 1,
                              mode="constant")
    is_max = (img == ndimage.maximum_filter(img, size=3)) & (img > 0)
    yx = np.argwhere(is_max)[np.argsort(-img[is_max], kind="stable")]
    far = [q for q in yx[1:] if np.hypot(*(q - yx[0])) >= 2]
    if not far:
        return None
    return (yx[0][::-1] + origin).astype(float), (far[0][::-1] + origin).astype(float)


def _two_means(pts, a, b, iterations=10):
    """Lloyd's 2-means started from the centres a and b (deterministic; a per-cluster
    scikit-learn KMeans costs ~10 ms of overhead, this ~50 µs)."""
    c = np.array([a, b], float)
    lab = None
    for _ in range(iterations):
        new = (((pts - c[1]) ** 2).sum(1) < ((pts - c[0]) ** 2).sum(1)).astype(np.int64)
        if (lab is not None and np.array_equal(new, lab)) or new.min() == new.max():
            return new
        lab = new
        c = np.array([pts[lab == 0].mean(0), pts[lab == 1].mean(0)])
    return lab


def _coords(events, xy):
    if xy is None:
        return np.column_stack([events.x, events.y]).astype(np.float64)
    xy = np.asarray(xy, dtype=np.float64)
    if xy.shape != (len(events), 2):
        raise ParameterError(f"xy must have shape ({len(events)}, 2), got {xy.shape}")
    return xy
