"""Target extraction: DBSCAN per pseudo-frame on the kept events -> sub-pixel centroids.

Conventions: pixel (i, j) has its centre at (x=i, y=j). A centroid's time is either the
mean time of its member events (``time_ref="mean"``, the default: for a moving target it
is the time at which the star actually was at the centroid) or the frame's mid-time
(``time_ref="mid"``, the paper's pseudo-frame view). Tracks are linked by
:mod:`evstar.tracking`.
"""
from __future__ import annotations

import numpy as np

from . import backends, lobes, parameters as P, splitting
from .errors import ParameterError, ParameterTypeError
from .events import Events
from .frames import FRAME_GAP, check_dt, frame_bounds, frame_offsets, ranks
from evstar_kernels.reference.clusters import PEAKS_UNSURE, cluster_moments, two_peaks
from evstar_kernels.taichi.scratch import Scratch

#: one row per centroid; t in µs (the time x, y refer to); flags: border (touches the sensor
#: edge), split (separated from a DBSCAN cluster that held two targets); sigma: per-axis
#: uncertainty in px (NaN until an estimator sets it); source: "measured" (this frame's
#: events), "pooled" (events of several frames: a faint star, evstar.pooling) or "coasted"
#: (a frame of a track without a centroid, from the track's motion)
CENTROID_DTYPE = np.dtype([("t", "<i8"), ("x", "<f8"), ("y", "<f8"), ("track", "<i8"),
                           ("n_events", "<i4"), ("frame", "<i8"), ("spread", "<f8"),
                           ("border", "?"), ("split", "?"), ("sigma", "<f8"), ("source", "<U8"),
                           ("n_on", "<i4")])  # n_on: the ON events of n_events
E = P.EXTRACT
WEIGHTINGS, TIME_REFS = P.WEIGHTINGS, P.TIME_REFS
SOURCES = ("measured", "coasted", "pooled")   # values of the `source` field (HDF5 stores their index)
# the grid kernels' planes, kept zeroed between calls (the pipeline makes an Extractor per
# chunk); Scratch serialises the calls
_SCRATCH = Scratch()
#: times a split cluster's half is split again at most (a cluster gives <= 2 ** (1 + this))
_RESPLITS = 2


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
    lobe_gap_px: an ON-only and an OFF-only cluster of one frame closer than this are a
    slow star's two lobes and are joined (evstar.lobes), and an OFF-only cluster behind a
    moving star is dropped as its trail (evstar.lobes.trails); None never joins, keeps all.
    clustering: "grid" (Taichi kernels on `device`: grid DBSCAN, per-cluster moments and a
    screen that leaves the split test only the clusters that may hold two peaks) or
    "sklearn" (scikit-learn's DBSCAN on the same weighted cells: the reference). Both give
    the same clusters and centroids (docs/kernels.md).
    """

    def __init__(self, dt_us=P.GLOBAL["dt_us"].default, eps=E["eps"].default,
                 min_samples=E["min_samples"].default, min_cluster_size=None,
                 weighting=E["weighting"].default, time_ref=E["time_ref"].default,
                 split_valley=E["split_valley"].default,
                 lobe_gap_px=E["lobe_gap_px"].default, t_origin_us=None,
                 clustering=E["clustering"].default, device=P.GLOBAL["device"].default):
        self.dt_us = check_dt(dt_us)
        self.eps = float(E.check("eps", eps))
        self.min_samples = E.check("min_samples", min_samples)
        self.min_cluster_size = E.check("min_cluster_size", min_cluster_size) or self.min_samples
        self.weighting = E.check("weighting", weighting)
        self.time_ref = E.check("time_ref", time_ref)
        self.split_valley = E.check("split_valley", split_valley)
        self.lobe_gap_px = E.check("lobe_gap_px", lobe_gap_px)
        self.t_origin_us = P.KERNEL.check("t0_us", t_origin_us, "t_origin_us")
        self.clustering = E.check("clustering", clustering)
        self.device = P.GLOBAL.check("device", device)

    def labels(self, events, xy=None):
        """(frame id, DBSCAN label) per event; label -1 is noise. `xy` overrides coordinates
        (e.g. motion-compensated floats): the events are clustered at their own pixels, which
        must be those floats rounded (pixel i covers [i − ½, i + ½); Compensation.events()
        gives them so), and centroids use the floats."""
        c = self._cluster(events, xy)
        return c.frames(), c.labels

    def _cluster(self, events, xy):
        """The events' frames, clusters and cells (_Clusters)."""
        if not isinstance(events, Events):
            raise ParameterTypeError(f"events must be evstar.Events, got {type(events).__name__}")
        coords = _coords(events, xy)
        t0 = self.t_origin_us
        if t0 is None:
            t0 = int(events.t[0]) if len(events) else 0
        f0, offsets = frame_offsets(events.t, self.dt_us, t0)
        # membership is decided on the pixel grid (the events' pixels: xy rounded, as the
        # filters round them); centroids use the floats
        c = _Clusters(t0, f0, offsets, coords, events.x, events.y)
        if len(events) == 0:
            c.labels, c.first, c.frame = (np.zeros(0, np.int64) for _ in range(3))
        elif self.clustering == "grid":
            from evstar_kernels.taichi import clusters_launch

            c.labels, c.first, roots = clusters_launch.dbscan(
                backends.taichi(self.device), offsets, c.px, c.py, self.eps, self.min_samples,
                scratch=_SCRATCH)
            c.frame = f0 + np.searchsorted(offsets, roots, side="right") - 1
        else:
            self._sklearn_labels(c)
        return c

    def _sklearn_labels(self, c):
        # events repeat at a pixel (a star fires ~30 per pixel it crosses): cluster the
        # distinct (frame, pixel) cells weighted by multiplicity — the same core test, far
        # fewer neighbours. One int64 key per cell keeps the de-duplication a 1-D sort.
        frames = c.frames()
        ij = np.column_stack([c.px, c.py]).astype(np.int64)
        lo = ij.min(0)
        w, h = ij.max(0) - lo + 1
        key = ((frames - frames[0]) * h + (ij[:, 1] - lo[1])) * w + (ij[:, 0] - lo[0])
        cells, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True,
                                                  return_counts=True)
        inverse = inverse.ravel()
        pts = np.column_stack([cells % w, (cells // w) % h, (cells // (w * h)) * FRAME_GAP])
        from sklearn.cluster import DBSCAN   # here: importing scikit-learn takes ~2 s

        labels = DBSCAN(eps=self.eps, min_samples=self.min_samples).fit_predict(
            pts.astype(np.float64), sample_weight=counts)
        c.labels, c.first = labels[inverse].astype(np.int64), first[inverse].astype(np.int64)
        c.frame = np.zeros(int(c.labels.max()) + 1, np.int64)
        c.frame[c.labels[c.labels >= 0]] = frames[c.labels >= 0]

    def centroids(self, events, xy=None):
        """Centroids of every cluster of every frame, in time order (track = -1 until linked)."""
        return self.centroids_and_members(events, xy)[0]

    def centroids_and_members(self, events, xy=None):
        """(centroids, per event whether it belongs to a cluster that gave a centroid row):
        the others are left for the pipeline's pooled second look (evstar.pooling)."""
        c = self._cluster(events, xy)
        k = len(c.frame)
        if k == 0:
            return np.zeros(0, CENTROID_DTYPE), np.zeros(len(events), bool)
        frame_t0 = c.t0 + np.arange(c.f0, c.f0 + len(c.offsets) - 1, dtype=np.int64) * self.dt_us
        m = self._moments(events, c, frame_t0, k)
        if self.lobe_gap_px is not None:
            m, k = self._join_lobes(c, m)
        if self.weighting == "pixels" and xy is not None:  # distinct float positions
            m["cells"], m["cx"], m["cy"] = _distinct_positions(c.labels, c.coords, k)
        out = self._table(m, c.frame, frame_t0[c.frame - c.f0], c.t0, events)
        order = np.arange(k) * 2  # ties in (t, x) keep cluster order (halves after it)
        keep = out["n_events"] >= self.min_cluster_size
        if self.lobe_gap_px is not None:
            keep &= ~lobes.trails(c.frame, m["n"], m["sx"], m["sy"])
        used = np.r_[keep, False][c.labels]  # label -1: the False; a split's halves use all
        if self.split_valley:
            maybe = keep & (out["n_events"] >= 2 * self.min_cluster_size)
            by_polarity, peaks = maybe.copy(), None
            if self.clustering == "grid":  # the reference looks at every cluster
                maybe, by_polarity, peaks = self._screen(events, c, m, maybe)
            out, order, keep = self._split_clusters(events, c, out, order, keep, maybe,
                                                    by_polarity, splitting.cluster_axes(m), peaks)
        out, order = out[keep], order[keep]
        return out[np.lexsort((order, out["x"], out["t"]))], used

    def _join_lobes(self, c, m):
        """A slow star's ON-only and OFF-only clusters joined into one (evstar.lobes):
        moments, c.labels and c.frame updated; (moments, number of clusters)."""
        a, b = lobes.pairs(c.frame, m["n"], m["sx"], m["sy"], self.lobe_gap_px)
        if len(a):
            m, c.frame, c.labels = lobes.join(m, c.frame, c.labels, a, b)
        return m, len(c.frame)

    def _moments(self, events, c, frame_t0, k):
        if self.clustering == "grid":
            from evstar_kernels.taichi import clusters_launch

            return clusters_launch.moments(backends.taichi(self.device), c.offsets, c.labels,
                                           c.first, *c.columns(events), events.t, events.p,
                                           frame_t0, k)
        coords = c.xy(events)
        return cluster_moments(c.labels, c.frames() - c.f0, coords[:, 0], coords[:, 1], events.t,
                               events.p, frame_t0, c.first == np.arange(len(c.first)))

    def _table(self, m, frame, frame_t0, t0, events):
        """One centroid row per cluster from its moments (no loop over clusters)."""
        n_by_p = m["n"]
        n = n_by_p.sum(1)
        sx, sy = m["sx"].sum(1), m["sy"].sum(1)
        cx, cy = sx / n, sy / n
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.weighting == "pixels":
                cx, cy = m["cx"] / m["cells"], m["cy"] / m["cells"]
            elif self.weighting == "polarity":
                both = (n_by_p[:, 1] > 0) & (n_by_p[:, 0] > 0)
                cx = np.where(both, (m["sx"] / n_by_p).sum(1) / 2, cx)
                cy = np.where(both, (m["sy"] / n_by_p).sum(1) / 2, cy)
        # mean squared distance to the centre, from the sums about the origin
        sq = (m["sxx"].sum(1) - 2 * cx * sx + n * cx * cx + m["syy"].sum(1) - 2 * cy * sy
              + n * cy * cy) / n
        out = np.zeros(len(n), CENTROID_DTYPE)
        if self.time_ref == "mean":
            out["t"] = np.round(frame_t0 + m["st"].sum(1) / n)
        else:
            out["t"] = t0 + frame * self.dt_us + self.dt_us // 2
        box = m["box"]
        out["x"], out["y"], out["track"], out["n_events"], out["frame"] = cx, cy, -1, n, frame
        out["n_on"] = n_by_p[:, 1]
        out["spread"] = np.sqrt(np.maximum(sq, 0))
        out["border"] = ((box[:, 0] < 1) | (box[:, 2] < 1) | (box[:, 1] > events.width - 2)
                         | (box[:, 3] > events.height - 2))
        out["sigma"], out["source"] = np.nan, "measured"
        return out

    def _screen(self, events, c, m, maybe):
        """(clusters whose smoothed image may hold two peaks, those of which each polarity's
        image may too, the peaks of those images where certain): Taichi passes over all
        clusters. The others cannot split: _split stops at two_peaks, and its per-polarity
        test needs both polarities split. peaks: clusters_launch.peak_screen's (k, 3, 5)
        (all events, OFF, ON; status 0 none, 1 found, 2 not decided)."""
        from evstar_kernels.taichi import clusters_launch

        polarities = np.all(m["n"] >= 2 * self.min_cluster_size, axis=1)  # else _halves: None
        maybe, both, peaks = clusters_launch.peak_screen(
            backends.taichi(self.device), c.offsets, c.labels, c.px, c.py, events.p, m["box"],
            maybe, polarities, peaks=True)
        # a polarity whose image certainly holds one peak: its _halves is None
        both &= (peaks[:, 1, 0] != 0) & (peaks[:, 2, 0] != 0)
        return maybe, both, peaks

    def _split_clusters(self, events, c, out, order, keep, candidates, by_polarity, axes,
                        peaks=None):
        """Replace every candidate cluster that holds two targets by its two halves (flag
        split); the others keep their row. by_polarity: clusters whose polarities may each
        split (the second test of _split); axes: splitting.cluster_axes of every cluster;
        peaks: the screen's certain peaks (_screen)."""
        labels = c.labels
        idx = np.flatnonzero(np.r_[candidates, False][labels])  # label -1: the False
        if self.clustering == "grid":  # a counting sort by cluster (Taichi)
            from evstar_kernels.taichi import sorting_launch

            members_all = idx[sorting_launch.stable_order(backends.taichi(self.device),
                                                          labels[idx], len(candidates))]
        else:
            members_all = idx[np.argsort(labels[idx], kind="stable")]
        ids, starts, stops = frame_bounds(labels[members_all])
        p_all = events.p[members_all]
        if self.clustering != "grid":  # the reference: cluster by cluster
            pts = c.xy(events, members_all)
            found = {}
            for n in range(len(ids)):
                j, a, b = ids[n], starts[n], stops[n]
                parts = self._split(pts[a:b], p_all[a:b], by_polarity[j],
                                    (None, None) if peaks is None else
                                    (_seeds(peaks[j, 1]), _seeds(peaks[j, 2])),
                                    (axes[0][j:j + 1], axes[1][j]))
                if parts is not None:
                    found[n] = parts
        else:
            first = self._first_halves(c.columns(events), members_all, p_all, starts, stops,
                                       None if peaks is None else peaks[ids, 0])
            # the rest looks only at the candidates the first test leaves open (after
            # motion compensation nearly every star shows two peaks, its lobes, which the
            # first test rejects): their points alone are gathered
            big = stops - starts >= 2 * self.min_cluster_size
            open_ = np.flatnonzero(~first.fails | (first.has & big & (axes[1][ids]
                                                                      | by_polarity[ids])))
            sel, bounds = _gather(starts[open_], stops[open_])
            first = _FirstTest(first.has[open_], first.lab[sel], first.fails[open_])
            ids, starts, stops = ids[open_], bounds[:-1], bounds[1:]
            members_all, p_all = members_all[sel], p_all[sel]
            pts = c.xy(events, members_all)
            found = self._split_many(pts, p_all, starts, stops, first, by_polarity[ids],
                                     None if peaks is None else peaks[ids],
                                     (axes[0][ids], axes[1][ids]))
        rows, keys = [], []
        # (candidate n, half, its points' indices into pts) of every split's halves
        halves = [(n, half, np.flatnonzero(parts == half) + starts[n])
                  for n, parts in sorted(found.items()) for half in (0, 1)]
        if self.clustering != "grid":  # the reference: half by half
            pieces = [(n, half, piece) for n, half, idx in halves
                      for piece in self._pieces(pts, p_all, idx, _RESPLITS)]
        else:
            pieces = self._pieces_many(pts, p_all, halves)
        for n, half, idx in pieces:
            j = ids[n]
            keep[j] = False
            rows.append(self._row(events, pts[idx], c.frame[j], members_all[idx], c.t0,
                                  split=True))
            keys.append(2 * j + half)
        if not rows:
            return out, order, keep
        return (np.concatenate([out, np.array(rows, CENTROID_DTYPE)]), np.r_[order, keys],
                np.r_[keep, np.ones(len(rows), bool)])

    def _split_many(self, pts, p, starts, stops, first, by_polarity, peaks, axes):
        """{candidate n: labels} of the candidates _split would split, all at once (the
        2-means in Taichi, the halves' tests batched: splitting.halves_many): the first
        test's halves where it does not certainly fail, kept when their polarities agree;
        then, where the candidate's polarities may each split, its ON and its OFF events
        apart, paired along the axis of the ON halves. peaks: the screen's (n, 3, 5); axes:
        the candidates' splitting.cluster_axes."""
        found = {}
        mcs, lab = self.min_cluster_size, first.lab
        along, wide = axes
        # not first.fails: two peaks and halves whose polarities agree (_first_halves)
        a_ = np.flatnonzero(~first.fails)
        if len(a_):
            idx, st = _gather(starts[a_], stops[a_])
            ok = splitting.halves_many(pts[idx], st[:-1], st[1:], lab[idx], mcs, self.split_valley,
                                       along[a_])
            for i in np.flatnonzero(ok):
                found[a_[i]] = lab[starts[a_[i]]:stops[a_[i]]]
        # two stars side by side (_split): all events, across the motion, where two peaks
        go = np.flatnonzero(first.has & (stops - starts >= 2 * mcs) & wide)
        go = go[~np.isin(go, list(found))]
        if len(go):
            sub, sub_st = _gather(starts[go], stops[go])
            q = pts[sub]
            lab_x = splitting.across_labels(q, sub_st[:-1], sub_st[1:], along[go])
            ok = splitting.halves_many(q, sub_st[:-1], sub_st[1:], lab_x, mcs, self.split_valley,
                                       along[go])
            for i in np.flatnonzero(ok):
                found[go[i]] = lab_x[sub_st[i]:sub_st[i + 1]]
        # the second test: where there are two peaks (first.has) and both polarities may split
        rest = np.flatnonzero(first.has & by_polarity & (stops - starts >= 2 * mcs))
        rest = rest[~np.isin(rest, list(found))]
        lab_on = self._polarity_halves(pts, p, starts, stops, rest, 1,
                                       None if peaks is None else peaks[rest, 2], along)
        both = [n for n in rest if n in lab_on]
        lab_off = self._polarity_halves(pts, p, starts, stops, np.array(both, np.int64), 0,
                                        None if peaks is None else peaks[both, 1], along)
        for n in both:
            if n not in lab_off:
                continue
            q = pts[starts[n]:stops[n]]
            on = p[starts[n]:stops[n]] == 1
            l_on, l_off = lab_on[n], lab_off[n]
            c_on, c_off = np.array(_half_means(q[on], l_on)), np.array(_half_means(q[~on], l_off))
            if (c_off[1] - c_off[0]) @ (c_on[1] - c_on[0]) < 0:  # OFF halves in the opposite order
                l_off = 1 - l_off
            out = np.empty(len(q), np.int64)
            out[on], out[~on] = l_on, l_off
            found[n] = out
        return found

    def _polarity_halves(self, pts, p, starts, stops, cand, pol, peaks, along):
        """{candidate n: 2-means labels of its events of polarity `pol`} where _halves keeps
        them (batched); peaks: the screen's (status, ax, ay, bx, by) of those events' image
        per candidate, or None (two_peaks for all); along: every candidate's motion axis
        (splitting.cluster_axes)."""
        if not len(cand):
            return {}
        from evstar_kernels.taichi import clusters_launch

        mine = [np.flatnonzero(p[starts[n]:stops[n]] == pol) + starts[n] for n in cand]
        sizes = np.array([len(m) for m in mine])
        idx = np.concatenate(mine)
        st = np.r_[0, np.cumsum(sizes)]
        q = pts[idx]
        has = np.ones(len(cand), bool)
        a, b = np.zeros((len(cand), 2)), np.zeros((len(cand), 2))
        known = np.zeros(len(cand), bool) if peaks is None else peaks[:, 0] == 1
        if known.any():
            a[known], b[known] = peaks[known, 1:3], peaks[known, 3:5]
        todo = np.flatnonzero(~known & (sizes >= 2 * self.min_cluster_size))
        if len(todo):
            sub, sub_st = _gather(st[todo], st[todo + 1])
            has[todo], a[todo], b[todo] = splitting.two_peaks_many(q[sub], sub_st[:-1], sub_st[1:])
        has &= sizes >= 2 * self.min_cluster_size
        go = np.flatnonzero(has)
        if not len(go):
            return {}
        sub, sub_st = _gather(st[go], st[go + 1])
        lab = clusters_launch.two_means(backends.taichi(self.device), q[sub], sub_st[:-1],
                                        sub_st[1:], a[go], b[go])
        ok = splitting.halves_many(q[sub], sub_st[:-1], sub_st[1:], lab, self.min_cluster_size,
                                   self.split_valley, along[cand[go]])
        return {int(cand[go[i]]): lab[sub_st[i]:sub_st[i + 1]] for i in np.flatnonzero(ok)}

    def _first_halves(self, columns, members, p, starts, stops, peaks):
        """The first test (_FirstTest: two peaks or not, 2-means labels, whether it fails
        whatever the rest of _halves says) of every candidate at once (grid clustering: the
        points (x[m], y[m]) of columns (x, y) for its members m = members[starts[j]:stops[j]],
        p their polarities; exact for integer
        coordinates, to the last bits of the 2-means centres for floats). The first test
        fails where a half has fewer than min_cluster_size events or the halves'
        polarities differ by more than 0.5 (a moving star's lobes: the common case).
        peaks: the screen's (status, ax, ay, bx, by) of each candidate's image (_screen);
        the seeds are computed here (splitting.two_peaks_many) only where it is undecided
        (None: for all, where nothing was screened)."""
        if peaks is None:
            peaks = np.zeros((len(starts), 5), np.int64)
            peaks[:, 0] = PEAKS_UNSURE
        has = peaks[:, 0] == 1
        a, b = peaks[:, 1:3].astype(np.float64), peaks[:, 3:5].astype(np.float64)
        todo = np.flatnonzero(peaks[:, 0] > 1)
        if len(todo):
            sizes = (stops - starts)[todo]
            sub = ranks(sizes, starts[todo])
            sub_stops = np.cumsum(sizes)
            m = members[sub]
            pts = np.column_stack([columns[0][m], columns[1][m]]).astype(np.float64)
            has[todo], a[todo], b[todo] = splitting.two_peaks_many(pts, sub_stops - sizes,
                                                                   sub_stops)
        # 2-means of all (the screen leaves few without two peaks): a Taichi thread per
        # cluster, reading the points in place (splitting.two_means_many is its numpy form)
        from evstar_kernels.taichi import clusters_launch

        lab, halves = clusters_launch.two_means_at(backends.taichi(self.device), *columns,
                                                   members, starts, stops, a, b, p=p)
        n, on = halves[:, :2], halves[:, 2:]  # sizes and ON counts of the halves
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_p = on / n  # as p[lab == k].mean(): a sum of 0/1 over a count
        fails = (n.min(1) < self.min_cluster_size) | ~(np.abs(mean_p[:, 0] - mean_p[:, 1]) <= 0.5)
        return _FirstTest(has, lab, fails)

    # -- one cluster, event by event (split candidates) ---------------------------------
    def _split(self, pts, p, by_polarity=True, polarity_seeds=(None, None), motion=None):
        """Labels 0/1 when the cluster holds two separable targets, else None.

        First on all events; a moving star fires ON at its leading edge and OFF at its
        trailing edge, so halves that differ in polarity are the two lobes of one target.
        Then on each polarity alone, where one target is one lobe: that finds a faint star
        beside a bright one, whose lobes dominate the first split. Both polarities must
        show the pair; their halves are matched by their order along the pair's axis.
        polarity_seeds: the OFF and the ON events' two_peaks when known; motion: the
        cluster's splitting.cluster_axes ((1, 2) axis, wider across), else from its pts' moments. The
        scikit-learn
        path's reference; grid clustering runs the same steps batched (_split_many)."""
        if len(pts) < 2 * self.min_cluster_size:
            return None
        seeds = two_peaks(pts)
        if seeds is None:  # one peak: one target (the common case, decided cheaply)
            return None
        if motion is None:   # a split cluster's half (_pieces): its own events' moments
            zero = np.zeros(len(pts), np.int64)
            m = cluster_moments(zero, zero, pts[:, 0], pts[:, 1], zero, p, np.zeros(1, np.int64))
            motion = splitting.cluster_axes(m)
        along, wide = motion
        lab = self._halves(pts, seeds, along=along)
        if lab is not None and abs(p[lab == 0].mean() - p[lab == 1].mean()) <= 0.5:
            return lab
        # two stars side by side: the halves above were one star's lobes, both stars' lobes
        # paired; across the motion all their events show the pair
        if np.all(wide):
            one = (np.array([0]), np.array([len(pts)]))
            lab = self._halves(pts, lab=splitting.across_labels(pts, *one, along), along=along)
            if lab is not None:
                return lab
        if not by_polarity:  # a polarity's events hold one peak: _halves would say None
            return None
        on, off = p == 1, p == 0
        pts_on, pts_off = pts[on], pts[off]
        seeds_off, seeds_on = polarity_seeds
        lab_on = self._halves(pts_on, seeds_on, along=along)
        lab_off = None if lab_on is None else self._halves(pts_off, seeds_off, along=along)
        if lab_off is None:
            return None
        c_on, c_off = np.array(_half_means(pts_on, lab_on)), np.array(_half_means(pts_off, lab_off))
        axis = c_on[1] - c_on[0]
        if (c_off[1] - c_off[0]) @ axis < 0:  # OFF halves in the opposite order
            lab_off = 1 - lab_off
        out = np.empty(len(pts), np.int64)
        out[on], out[off] = lab_on, lab_off
        return out

    def _halves(self, pts, seeds=None, lab=None, along=None):
        """Labels 0/1 when `pts` hold two compact targets with a clear valley between them,
        else None. The seeds are the two highest peaks of the smoothed count image, so a
        faint star beside a bright one is found (2-means would halve the bright one).
        along: splitting.cluster_axes' axis of the cluster ((1, 2)), or None (unknown)."""
        if len(pts) < 2 * self.min_cluster_size:
            return None
        if lab is None:
            seeds = two_peaks(pts) if seeds is None else seeds
            if seeds is None:
                return None
            lab = _two_means(pts, *seeds)
        n_min = np.bincount(lab, minlength=2).min()
        if n_min < self.min_cluster_size:
            return None
        c0, c1 = _half_means(pts, lab)
        sep = np.linalg.norm(c1 - c0)
        if sep < 2:  # closer than two pixels: not resolvable on the pixel grid
            return None
        proj = (pts - c0) @ ((c1 - c0) / sep)
        # a uniform streak cut in two has sep / axial std = 2·sqrt(3) ≈ 3.5, a blob (a star
        # cut across its motion) 2.65 (more by chance with few events: + 8 / sqrt(n) bounds
        # 99.9 % of simulated streaks); two compact targets have far more
        one = lab.astype(bool)
        axial = (proj[~one].std() + (proj[one] - sep).std()) / 2   # np.mean of the two
        ratio = splitting.streak_ratios((c1 - c0)[:, None] / sep, along)
        if sep < (float(np.squeeze(ratio)) + 8 / np.sqrt(n_min)) * max(axial, 0.25):
            return None
        # 1-px profile of the events along the axis c0 -> c1 (c0 at 0, c1 at sep): it must
        # dip between the two; a lopsided blob stays whole
        return lab if splitting._dips(proj, sep, self.split_valley) else None

    def _pieces(self, pts, p, idx, depth):
        """[indices into pts] of the targets in one half (pts[idx]) of a split cluster: the
        half is split again, `depth` times at most, while _split finds two targets in it
        (three stars a few px apart: DBSCAN merges them and one split leaves two of them in
        a half). p: the points' polarities."""
        parts = self._split(pts[idx], p[idx]) if depth > 0 else None
        if parts is None:
            return [idx]
        return [piece for half in (0, 1)
                for piece in self._pieces(pts, p, idx[parts == half], depth - 1)]

    def _pieces_many(self, pts, p, halves):
        """_pieces of every split's halves ((candidate, half, indices into pts)) at once:
        each level's open pieces split together (_split_each); [(candidate, half, indices)]
        in _pieces' order."""
        pieces = [(n, half, idx, True) for n, half, idx in halves]   # True: may split again
        for _ in range(_RESPLITS):
            todo = [i for i, piece in enumerate(pieces) if piece[3]]
            if not todo:
                break
            found = self._split_each(pts, p, [pieces[i][2] for i in todo])
            split = {todo[k]: lab for k, lab in found.items()}
            pieces = [new for i, (n, half, idx, _) in enumerate(pieces)
                      for new in ([(n, half, idx[split[i] == h], True) for h in (0, 1)]
                                  if i in split else [(n, half, idx, False)])]
        return [(n, half, idx) for n, half, idx, _ in pieces]

    def _split_each(self, pts, p, groups):
        """{g: labels} of the point sets pts[groups[g]] that _split (its defaults: both
        polarities tried, the motion from the set's own moments) splits, all at once: the
        batched steps of _split_many, unscreened."""
        sizes = np.array([len(g) for g in groups], np.int64)
        go = np.flatnonzero(sizes >= max(2 * self.min_cluster_size, 1))
        if not len(go):
            return {}
        idx = np.concatenate([groups[g] for g in go])
        q, pq = pts[idx], p[idx]
        stops = np.cumsum(sizes[go])
        starts = stops - sizes[go]
        # each set's moments as _split takes them (bincount sums each set in its order)
        seg = np.repeat(np.arange(len(go)), sizes[go])
        zero = np.zeros(len(idx), np.int64)
        m = cluster_moments(seg, zero, q[:, 0], q[:, 1], zero, pq, np.zeros(1, np.int64))
        first = self._first_halves((np.ascontiguousarray(q[:, 0]), np.ascontiguousarray(q[:, 1])),
                                   np.arange(len(q)), pq, starts, stops, None)
        found = self._split_many(q, pq, starts, stops, first, np.ones(len(go), bool), None,
                                 splitting.cluster_axes(m))
        return {int(go[k]): lab for k, lab in found.items()}

    def _row(self, events, pts, frame, m, t0, split):
        """A centroid row of the events m (at pts) of one frame."""
        cx, cy = self._centre(pts, events.p[m])
        if self.time_ref == "mean":
            t = int(np.round(events.t[m].mean()))
        else:
            t = t0 + int(frame) * self.dt_us + self.dt_us // 2
        spread = float(np.sqrt(((pts - (cx, cy)) ** 2).sum(1).mean()))
        border = bool(pts[:, 0].min() < 1 or pts[:, 1].min() < 1
                      or pts[:, 0].max() > events.width - 2 or pts[:, 1].max() > events.height - 2)
        return (t, cx, cy, -1, len(m), frame, spread, border, split, np.nan, "measured",
                int(np.count_nonzero(events.p[m])))

    def _centre(self, pts, p):
        if self.weighting == "pixels":
            pts = np.unique(np.round(pts, 6), axis=0)
        elif self.weighting == "polarity" and 0 < p.sum() < len(p):
            return tuple((pts[p > 0].mean(0) + pts[p == 0].mean(0)) / 2)
        return tuple(pts.mean(0))


class _FirstTest:
    """_first_halves' result for every candidate: has (two peaks: else _split stops there),
    lab (the 2-means labels per point) and fails (the first test fails whatever the rest of
    _halves says, or no two peaks)."""

    def __init__(self, has, lab, fails):
        self.has, self.lab, self.fails = has, lab, ~has | fails


def _gather(starts, stops):
    """(indices of the segments starts[i]:stops[i] concatenated, their offsets there)."""
    sizes = np.asarray(stops) - np.asarray(starts)
    return ranks(sizes, starts), np.r_[0, np.cumsum(sizes)]


def _seeds(peak):
    """two_peaks' seeds from the screen's (status, ax, ay, bx, by) where it found them; None
    (compute them) otherwise. Status 0 (no two peaks) never reaches a _halves."""
    return (peak[1:3].astype(float), peak[3:5].astype(float)) if peak[0] == 1 else None


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
        c = np.array(_half_means(pts, lab))
    return lab


def _half_means(pts, lab):
    """(pts[lab == 0].mean(0), pts[lab == 1].mean(0)) of 0/1 labels, both halves non-empty:
    the same bits (mean is the sum over the count) without mean's per-call overhead (the
    split tests call it for every candidate)."""
    one = lab.astype(bool)
    n1 = int(np.count_nonzero(one))
    return pts[~one].sum(0) / (len(pts) - n1), pts[one].sum(0) / n1


class _Clusters:
    """One call's clustering: frame f0 + j holds events offsets[j]:offsets[j + 1]; labels
    and first (the first event of its cell) per event; frame per cluster; coords: the
    float coordinates (None: the events' pixels), px, py: the pixels clustered."""

    def __init__(self, t0, f0, offsets, coords, px, py):
        self.t0, self.f0, self.offsets = t0, f0, offsets
        self.coords, self.px, self.py = coords, px, py
        self.labels = self.first = self.frame = None
        self._columns = None

    def columns(self, events):
        """(x, y) of every event as contiguous arrays: the events' pixels, or the float
        coordinates' columns (copied once)."""
        if self.coords is None:
            return events.x, events.y
        if self._columns is None:
            self._columns = tuple(np.ascontiguousarray(self.coords[:, k]) for k in (0, 1))
        return self._columns

    def frames(self):
        """Frame id per event."""
        return self.f0 + np.repeat(np.arange(len(self.offsets) - 1), np.diff(self.offsets))

    def xy(self, events, idx=slice(None)):
        """The float coordinates of the events idx."""
        if self.coords is None:
            return np.column_stack([events.x[idx], events.y[idx]]).astype(np.float64)
        # rows gathered by take: ~7x the fancy index's speed on an (n, 2) array
        return self.coords[idx] if isinstance(idx, slice) else np.take(self.coords, idx, axis=0)


def _distinct_positions(labels, coords, k):
    """Per cluster: number and coordinate sums of its distinct positions (to 1e-6 px)."""
    m = labels >= 0
    lab, r = labels[m], np.round(coords[m], 6)
    o = np.lexsort((r[:, 1], r[:, 0], lab))
    lab, r = lab[o], r[o]
    new = np.r_[True, (lab[1:] != lab[:-1]) | np.any(r[1:] != r[:-1], axis=1)]
    return (np.bincount(lab[new], minlength=k), np.bincount(lab[new], r[new, 0], minlength=k),
            np.bincount(lab[new], r[new, 1], minlength=k))


def _coords(events, xy):
    """xy checked as float coordinates of the events (None: the events' own pixels), which
    they must round to (pixel i covers [i − ½, i + ½)): on the sensor and finite at least —
    a NaN or a far-off value sent the kernels' images out of bounds (a segfault). Column
    minima and maxima only (NaN fails them): no per-event temporaries on the hot path."""
    if xy is None:
        return None
    try:
        xy = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterTypeError(f"xy must be an (n, 2) array of numbers, got {type(xy).__name__}") from None
    if xy.shape != (len(events), 2):
        raise ParameterError(f"xy must have shape ({len(events)}, 2), got {xy.shape}")
    if len(xy):
        size = np.array([events.width, events.height]) - 0.5
        # one pass for the lower bound, a strided one per column's upper (xy.min(axis=0)
        # took ~80 ms on 1.3 M rows, these ~4)
        hi = np.array([xy[:, 0].max(), xy[:, 1].max()])
        if not (xy.reshape(-1).min() >= -0.5 and np.all(hi < size)):
            with np.errstate(invalid="ignore"):
                i = int(np.flatnonzero(~np.all((xy >= -0.5) & (xy < size), axis=1))[0])
            raise ParameterError(f"xy[{i}] = ({xy[i, 0]:g}, {xy[i, 1]:g}) is not on the "
                                 f"{events.width}x{events.height} sensor: xy must be the events' "
                                 "coordinates, each within half a pixel of its own")
    return xy
