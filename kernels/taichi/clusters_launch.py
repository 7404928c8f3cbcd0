"""Launch of grid DBSCAN and cluster moments: runs of frames, batches of planes, canonical
labels, scratch.

`dbscan` returns the labels of `evstar_kernels.reference.clusters.dbscan_events`, `moments`
the sums of `cluster_moments`. Module setting (tests shrink it to exercise many batches):
GRID_BYTES.
"""
import numpy as np

from . import clusters, launch

#: count + owner planes of one batch of frames
GRID_BYTES = 64 << 20
_I32 = (1 << 31) - 1
_EMPTY = {"n": (0, 2), "st": (0, 2), "sx": (0, 2), "sy": (0, 2), "sxx": (0, 2), "syy": (0, 2),
          "sxy": (0, 2), "box": (0, 4), "cells": 0, "cx": 0, "cy": 0}


def dbscan(ti, offsets, x, y, eps, min_samples, *, scratch, schedule="auto", on_launch=None):
    """(labels int64 (n,), first int64 (n,), roots int64 (k,)) of events in frame order:
    offsets[f] is frame f's first event (length n_frames + 1); x, y integer pixels (any
    range). first[e] is the first event of e's cell, roots[c] that of cluster c's first
    core cell (so its frame is the cluster's). schedule: "lanes" (CPU form), "events" (GPU
    form) or "auto" (by the Taichi arch)."""
    n = len(x)
    labels, first = np.full(n, -1, np.int64), np.zeros(n, np.int64)
    if n == 0:
        return labels, first, np.zeros(0, np.int64)
    # coordinates relative to their bounding box; the zero border holds the disk
    pad = int(np.floor(eps))
    xi, yi = (np.subtract(a, a.min(), dtype=np.int32) for a in (np.asarray(x), np.asarray(y)))
    stride = int(xi.max()) + 1 + 2 * pad
    plane = (int(yi.max()) + 1 + 2 * pad) * stride
    geo = (plane, stride, pad)
    with launch.RUNTIME_LOCK, scratch:
        arrays = launch.Arrays(ti)
        lanes = schedule == "lanes" or (schedule == "auto" and not arrays.on_device)
        if lanes:  # one private plane per thread
            planes = launch.cpu_threads(ti)
        else:
            planes = int(min(max(1, GRID_BYTES // (8 * plane)), len(offsets) - 1))
        if planes * plane > _I32:
            raise ValueError(f"clustering grid of {planes} x {plane} cells exceeds int32 indices")
        key = (geo, planes, arrays.on_device)
        count = scratch.array("cl-count", key,
                              lambda: arrays.put(np.zeros(planes * plane, np.int32)))
        owner = scratch.array("cl-owner", key,
                              lambda: arrays.put(np.full(planes * plane, clusters.NONE, np.int32)))
        kernels = clusters.cluster_kernels()
        full, half = (arrays.put(d) for d in clusters.disk(float(eps), stride))
        roots = []
        for f0, f1 in launch.frame_launches(offsets):
            e0, e1 = int(offsets[f0]), int(offsets[f1])
            local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
            run = _roots_lanes if lanes else _roots
            root = run(ti, arrays, kernels, xi[e0:e1], yi[e0:e1], local, geo, (full, half), planes,
                       min_samples, count, owner, first[e0:e1], on_launch)
            first[e0:e1] += e0
            roots.append(e0 + _canonical(root, xi[e0:e1], yi[e0:e1], local, stride,
                                         sum(map(len, roots)), labels[e0:e1]))
    return labels, first, np.concatenate(roots)


def _roots(ti, arrays, kernels, xi, yi, local, geo, disk, planes, min_samples, count, owner, first,
           on_launch):
    """Each event's root (launch-local index of its cluster's first core, -1 noise); fills
    `first` with the launch-local index of each event's cell owner."""
    bin_cells, core_cells, link_frames, _ = kernels
    plane, stride, pad = geo
    full, half = disk
    m = len(xi)
    x_d, y_d, off = arrays.put(xi), arrays.put(yi), arrays.put(local)
    core, parent = arrays.empty(m, np.uint8), arrays.empty(m, np.int32)
    first_d, root = arrays.empty(m, np.int32), arrays.empty(m, np.int32)
    threads = launch.cpu_threads(ti)
    n_frames = len(local) - 1
    for b0 in range(0, n_frames, planes):
        b1 = min(b0 + planes, n_frames)
        bin_cells(x_d, y_d, off, b0, b1, plane, stride, pad, count, owner)
        core_cells(x_d, y_d, off, b0, b1, plane, stride, pad, full, min_samples, count, owner, core,
                   parent, first_d)
        # one frame per work unit, spread so that every CPU thread gets some
        frames = np.arange(b0, b1 + 1, dtype=np.int32)
        lo, hi = (arrays.put(a) for a in launch.units(frames, threads))
        link_frames(lo, hi, x_d, y_d, off, b0, plane, stride, pad, full, half, count, owner, core,
                    parent, first_d, root)
        launch.launched(on_launch)
    out, first32 = np.empty(m, np.int32), np.empty(m, np.int32)
    arrays.get(root, out)
    arrays.get(first_d, first32)
    first[:] = first32
    return out


def _roots_lanes(ti, arrays, kernels, xi, yi, local, geo, disk, planes, min_samples, count,
                 owner, first, on_launch):
    """_roots in the CPU form: one launch, runs of frames balanced by events over the
    threads, each thread on its own plane."""
    plane, stride, pad = geo
    full, half = disk
    m = len(xi)
    core, parent = np.empty(m, np.uint8), np.empty(m, np.int32)
    first32, root = np.empty(m, np.int32), np.empty(m, np.int32)
    lo, hi = _runs(local, planes)
    busy = np.zeros(planes, np.int32)
    kernels[3](lo, hi, xi, yi, local, plane, stride, pad, full, half, min_samples, count, owner,
               core, parent, first32, root, busy, planes)
    launch.launched(on_launch)
    first[:] = first32
    return root


def _runs(local, threads):
    """(lo, hi) of the lane loop: runs of frames balanced by events, 8 per thread."""
    return launch.units(launch.balanced_cuts(local, 8 * threads).astype(np.int32), threads)


def _canonical(root, xi, yi, local, stride, start, labels):
    """Number the roots in (frame, y, x) order from `start` into labels; the roots in that
    order."""
    roots = np.flatnonzero(root == np.arange(len(root)))
    frame = np.searchsorted(local, roots, side="right") - 1
    roots = roots[np.lexsort((yi[roots].astype(np.int64) * stride + xi[roots], frame))]
    ids = np.empty(len(root) + 1, np.int64)
    ids[roots] = start + np.arange(len(roots))
    ids[-1] = -1  # the sentinel: root -1 (noise) reads the last entry
    np.take(ids, root, out=labels, mode="wrap")  # -1 wraps to the sentinel; no bounds checks
    return roots.astype(np.int64)


def moments(ti, offsets, labels, first, xf, yf, t, p, frame_t0, n_clusters, on_launch=None):
    """Sums of every cluster's events (reference: cluster_moments): dict n, st, sx, sy, sxx,
    syy, sxy ((k, 2) per polarity OFF, ON), box ((k, 4)), cells ((k,)), cx, cy ((k,)).
    `first` as dbscan returns it; xf, yf: the coordinates summed (any real dtype);
    frame_t0: the time each frame's t is summed from."""
    k = int(n_clusters)
    if k == 0:
        return {name: np.zeros(shape, np.int64 if name in ("n", "st", "cells") else np.float64)
                for name, shape in _EMPTY.items()}
    box0 = np.empty((k, 4))
    box0[:, 0::2], box0[:, 1::2] = np.inf, -np.inf
    with launch.RUNTIME_LOCK:
        arrays = launch.Arrays(ti)
        n, st = arrays.put(np.zeros((k, 2), np.int64)), arrays.put(np.zeros((k, 2), np.int64))
        sums, box = arrays.put(np.zeros((k, 10))), arrays.put(box0)
        cells, csum = arrays.put(np.zeros(k, np.int64)), arrays.put(np.zeros((k, 2)))
        threads = launch.cpu_threads(ti)
        for f0, f1 in launch.frame_launches(offsets):
            e0, e1 = int(offsets[f0]), int(offsets[f1])
            local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
            lo, hi = (arrays.put(a) for a in _runs(local, threads))
            clusters.moments(lo, hi, arrays.put(local), arrays.put(labels[e0:e1].astype(np.int32)),
                             arrays.put(xf[e0:e1]), arrays.put(yf[e0:e1]), arrays.put(t[e0:e1]),
                             arrays.put(frame_t0[f0:f1]), arrays.put(p[e0:e1]),
                             arrays.put((first[e0:e1] - e0).astype(np.int32)), n, st, sums, box,
                             cells, csum)
            launch.launched(on_launch)
        out = {name: np.empty(shape, dtype) for name, shape, dtype in
               (("n", (k, 2), np.int64), ("st", (k, 2), np.int64), ("sums", (k, 10), np.float64),
                ("box", (k, 4), np.float64), ("cells", k, np.int64), ("csum", (k, 2), np.float64))}
        for name, dev in (("n", n), ("st", st), ("sums", sums), ("box", box), ("cells", cells),
                          ("csum", csum)):
            arrays.get(dev, out[name])
    sums = out.pop("sums").reshape(k, 2, 5)
    for j, name in enumerate(("sx", "sy", "sxx", "syy", "sxy")):
        out[name] = np.ascontiguousarray(sums[:, :, j])
    csum = out.pop("csum")
    out["cx"], out["cy"] = csum[:, 0].copy(), csum[:, 1].copy()
    return out


def peak_screen(ti, offsets, labels, x, y, p, box, screened, polarities, rtol=1e-9,
                peaks=False):
    """(maybe, both) bools per cluster. maybe: False where the cluster is not `screened` or
    where two_peaks of its events is certainly None; both: False unless maybe and
    `polarities` and neither polarity's two_peaks is certainly None (reference:
    maybe_two_peaks). x, y: the events' pixels, p their polarity; box: the clusters'
    (x min, x max, y min, y max) as cluster_moments gives it.

    peaks=True: also (maybe, both, peaks), peaks int64 (k, 3, 5): for all the cluster's
    events, its OFF and its ON events, (status, ax, ay, bx, by) of
    reference.clusters.certain_two_peaks from the screen's images: status 0 (two_peaks is
    None), 1 (two_peaks is ((ax, ay), (bx, by))) or 2 (not decided: near ties, or not
    looked at — where maybe is False, or both for the polarities)."""
    k = len(screened)
    unsure = np.zeros((k, 3, 5), np.int64)
    unsure[:, :, 0] = clusters.UNSURE
    if not screened.any():
        out = np.zeros(k, bool), np.zeros(k, bool)
        return (*out, unsure) if peaks else out
    # each image holds the cluster's pixel box and a 2-pixel zero border
    lo = np.floor(box[:, 0::2] + 0.5).astype(np.int64) - 2
    size = np.floor(box[:, 1::2] + 0.5).astype(np.int64) - lo + 3
    area = np.where(screened, size[:, 0] * size[:, 1], 0)
    ends = np.cumsum(area)
    if ends[-1] > _I32:  # far beyond any star image: every one goes to the exact test
        out = screened.copy(), screened & polarities
        return (*out, unsure) if peaks else out
    base = np.where(screened, ends - area, -1).astype(np.int32)
    geom = np.column_stack([lo, size]).astype(np.int32)
    with launch.RUNTIME_LOCK:
        arrays = launch.Arrays(ti)
        img, tmp = arrays.put(np.zeros((3, ends[-1]))), arrays.empty(ends[-1], np.float64)
        base_d, geom_d = arrays.put(base), arrays.put(geom)
        threads = launch.cpu_threads(ti)
        for f0, f1 in launch.frame_launches(offsets):
            e0, e1 = int(offsets[f0]), int(offsets[f1])
            local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
            lo_d, hi_d = (arrays.put(a) for a in _runs(local, threads))
            clusters.peak_images(lo_d, hi_d, arrays.put(local),
                                 arrays.put(labels[e0:e1].astype(np.int32)), arrays.put(x[e0:e1]),
                                 arrays.put(y[e0:e1]), arrays.put(p[e0:e1]), base_d, geom_d, img)
        maybe, found = arrays.put(np.zeros((k, 2), np.uint8)), arrays.empty((k, 9), np.int32)
        clusters.peak_screen(base_d, geom_d, arrays.put(polarities.astype(np.uint8)), img, tmp,
                             rtol, maybe, found)
        out = np.empty((k, 2), np.uint8)
        arrays.get(maybe, out)
        flat = np.empty((k, 9), np.int32)
        arrays.get(found, flat)
    maybe, both = out[:, 0].astype(bool), out[:, 1].astype(bool)
    if not peaks:
        return maybe, both
    flat = flat.reshape(k, 3, 3).astype(np.int64)
    res = np.empty((k, 3, 5), np.int64)
    res[:, :, 0] = flat[:, :, 0]
    w = size[:, 0, None]
    for col, at in ((1, flat[:, :, 1]), (3, flat[:, :, 2])):  # flat pixel -> (x, y)
        res[:, :, col] = lo[:, 0, None] + at % w
        res[:, :, col + 1] = lo[:, 1, None] + at // w
    res[res[:, :, 0] != 1, 1:] = 0
    return maybe, both, res


def two_means(ti, pts, starts, stops, a, b, iterations=10, p=None):
    """2-means labels (int64 per point) of every cluster pts[starts[j]:stops[j]] from the
    centres a[j], b[j] (reference: evstar.splitting.two_means_many with integral=False).
    p (0/1 per point): also the halves' sizes and ON counts, int64 (k, 4): points labelled
    0, labelled 1, ON points labelled 0, labelled 1."""
    pts = np.asarray(pts, np.float64)
    return two_means_at(ti, np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]),
                        np.arange(len(pts)), starts, stops, a, b, iterations, p)


def two_means_at(ti, x, y, at, starts, stops, a, b, iterations=10, p=None):
    """two_means of the points (x[at[i]], y[at[i]]) (x, y: any numbers, e.g. every event's
    pixels or float coordinates; at: the clusters' members, cluster by cluster), read in
    place: no gathered copy of the points; p: 0/1 per member."""
    k = len(starts)
    halves = np.zeros((k, 4), np.int64)
    if not k:
        lab = np.zeros(len(at), np.int64)
        return lab if p is None else (lab, halves)
    with launch.RUNTIME_LOCK:
        arrays = launch.Arrays(ti)
        lab, halves_d = arrays.empty(len(at), np.int32), arrays.empty((k, 4), np.int64)
        q = np.zeros(len(at), np.int8) if p is None else np.asarray(p, np.int8)
        clusters.two_means(arrays.put(x), arrays.put(y), arrays.put(np.asarray(at, np.int32)),
                           arrays.put(np.asarray(starts, np.int32)),
                           arrays.put(np.asarray(stops, np.int32)),
                           arrays.put(np.column_stack([a, b]).astype(np.float64)),
                           int(iterations), lab, arrays.put(q), halves_d)
        out = np.empty(len(at), np.int32)
        arrays.get(lab, out)
        arrays.get(halves_d, halves)
    out = out.astype(np.int64)
    return out if p is None else (out, halves)
