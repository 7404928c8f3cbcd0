"""The close-pair split's first steps for many clusters at once (numpy, no loop per cluster).

`two_peaks_many` and `two_means_many` give, for every cluster of a batch, exactly what the
per-cluster `evstar_kernels.reference.clusters.two_peaks` and `evstar.extract._two_means`
give (tests/test_clusters.py): the smoothing repeats scipy's symmetric correlation term by
term (c·w0 + (a₋₂ + a₊₂)·w2 + (a₋₁ + a₊₁)·w1, y then x), maxima and means are exact, and
the 2-means centres are exact for integer coordinates (sums of integers), which is why
`Extractor` uses them only then. Points come grouped by cluster: cluster j holds
pts[starts[j]:stops[j]].
"""
from __future__ import annotations

import numpy as np

from evstar_kernels.reference.clusters import SMOOTH


def _segments(starts, stops):
    sizes = stops - starts
    return np.repeat(np.arange(len(starts)), sizes), sizes


def _shifted(img, idx, r, q, h, w, dr, dq, fill):
    """img at (r + dr, q + dq) of each pixel's own image, `fill` outside it."""
    rr, qq = r + dr, q + dq
    inside = (rr >= 0) & (rr < h) & (qq >= 0) & (qq < w)
    out = np.full(len(idx), fill)
    out[inside] = img[(idx + dr * w + dq)[inside]]
    return out


def _correlate(img, idx, r, q, h, w, axis):
    """scipy.ndimage.correlate1d(img, SMOOTH, axis, mode="constant") of every image."""
    def at(d):
        return _shifted(img, idx, r, q, h, w, d if axis == 0 else 0, d if axis == 1 else 0, 0.0)

    out = img * SMOOTH[2]
    for d in (-2, -1):
        out = out + (at(d) + at(-d)) * SMOOTH[2 + d]
    return out


def images(pts, starts, stops):
    """Each cluster's count image (its pixel box and a 2-px border), all in one flat array
    (two_peaks_many's and two_means_many's)."""
    seg, _ = _segments(starts, stops)
    k = len(starts)
    ij = np.floor(pts + 0.5).astype(np.int64)
    lo = np.minimum.reduceat(ij, starts, axis=0) - 2
    w, h = (np.maximum.reduceat(ij, starts, axis=0) - lo + 3).T
    area = w * h
    base = np.cumsum(area) - area
    flat = base[seg] + (ij[:, 1] - lo[seg, 1]) * w[seg] + (ij[:, 0] - lo[seg, 0])
    counts = np.bincount(flat, minlength=int(area.sum()))
    pix = np.repeat(np.arange(k), area)  # each pixel's cluster
    local = np.arange(len(counts)) - base[pix]
    return dict(lo=lo, w=w[pix], h=h[pix], flat=flat, counts=counts, pix=pix,
                r=local // w[pix], q=local % w[pix])


def two_peaks_many(pts, starts, stops):
    """(has (k,) bool, a (k, 2), b (k, 2)): two_peaks of each cluster's points, has False
    where it is None."""
    k = len(starts)
    if not k:
        return np.zeros(0, bool), np.zeros((0, 2)), np.zeros((0, 2))
    im = images(pts, starts, stops)
    lo, pix, r, q, pw, ph = im["lo"], im["pix"], im["r"], im["q"], im["w"], im["h"]
    img = im["counts"].astype(np.float64)
    idx = np.arange(len(img))
    img = _correlate(_correlate(img, idx, r, q, ph, pw, 0), idx, r, q, ph, pw, 1)
    best = img.copy()  # 3 x 3 maximum (outside an image counts as nothing)
    for dr in (-1, 0, 1):
        for dq in (-1, 0, 1):
            best = np.maximum(best, _shifted(img, idx, r, q, ph, pw, dr, dq, -np.inf))
    m = np.flatnonzero((img == best) & (img > 0))
    # per cluster: maxima by value, ties in row-major order; the highest and the first
    # other one at least 2 px from it
    m = m[np.lexsort((m, -img[m], pix[m]))]
    c = pix[m]
    first = np.r_[True, c[1:] != c[:-1]]
    top = m[first][np.cumsum(first) - 1]
    far = ~first & ((r[m] - r[top]) ** 2 + (q[m] - q[top]) ** 2 >= 4)
    has = np.zeros(k, bool)
    a, b = np.zeros((k, 2)), np.zeros((k, 2))
    clusters, at = np.unique(c[far], return_index=True)
    has[clusters] = True
    tops = m[first]
    a[c[first]] = np.column_stack([q[tops], r[tops]]) + lo[c[first]]
    fars = m[far][at]
    b[clusters] = np.column_stack([q[fars], r[fars]]) + lo[clusters]
    return has, a, b


def two_means_many(pts, starts, stops, a, b, iterations=10, integral=True):
    """_two_means of each cluster's points started from a[j] and b[j] (labels 0/1 per
    point). integral: exact for integer coordinates, run on the distinct pixels weighted by
    their counts (the same distances, and the same centres: sums of integers are exact);
    else on the points themselves, whose centres are sums in another order than numpy's
    mean (equal to the last bits: a label can differ only on an exact tie)."""
    k = len(starts)
    if not k:
        return np.zeros(0, np.int64)
    if integral:
        im = images(pts, starts, stops)
        px = np.flatnonzero(im["counts"])
        weight = im["counts"][px].astype(np.float64)
        seg = im["pix"][px]
        cx, cy = im["q"][px] + im["lo"][seg, 0], im["r"][px] + im["lo"][seg, 1]
    else:
        seg, _ = _segments(starts, stops)
        weight, cx, cy = np.ones(len(pts)), pts[:, 0], pts[:, 1]
    n_cells = np.bincount(seg, minlength=k)
    c = np.stack([a, b], 1).astype(float)  # (k, 2 centres, xy)
    lab = np.zeros(len(seg), np.int64)
    out = np.zeros(len(seg), np.int64)
    active = np.ones(k, bool)
    for it in range(iterations):
        go = np.flatnonzero(active[seg])
        sg, x, y = seg[go], cx[go], cy[go]
        d0 = (x - c[sg, 0, 0]) ** 2 + (y - c[sg, 0, 1]) ** 2
        d1 = (x - c[sg, 1, 0]) ** 2 + (y - c[sg, 1, 1]) ** 2
        new = (d1 < d0).astype(np.int64)
        ones = np.bincount(sg, weights=new, minlength=k)
        done = active & ((ones == 0) | (ones == n_cells))
        if it:
            done |= active & (np.bincount(sg, weights=new != lab[go], minlength=k) == 0)
        lab[go] = new
        fin = done[sg]
        out[go[fin]] = new[fin]
        active &= ~done
        if not active.any():
            break
        # centres of the clusters still going: weighted sums of their halves / counts
        key = sg * 2 + new
        n = np.bincount(key, weights=weight[go], minlength=2 * k).reshape(k, 2)
        for axis, v in enumerate((x, y)):
            s = np.bincount(key, weights=weight[go] * v, minlength=2 * k).reshape(k, 2)
            with np.errstate(invalid="ignore", divide="ignore"):
                c[active, :, axis] = (s / n)[active]
    else:  # iterations used up: the last labels
        out[active[seg]] = lab[active[seg]]
    if not integral:
        return out
    cell_of = np.zeros(len(im["counts"]), np.int64)
    cell_of[px] = np.arange(len(px))
    return out[cell_of[im["flat"]]]


#: a star's halves, cut along its motion, are at most this many times their axial spread
#: apart: a uniform streak cut in two (sep = L/2, each half's std = L/(4·sqrt(3)))
STREAK_RATIO = 2 * np.sqrt(3)
#: ... and cut across it, where its events' profile is a blob: a Gaussian cut in two
#: (sep = 2·sqrt(2/pi)·σ, each half's std = sqrt(1 - 2/pi)·σ)
BLOB_RATIO = 2 * np.sqrt(2 / np.pi) / np.sqrt(1 - 2 / np.pi)
#: a cluster's ON and OFF means this far apart (px) give its motion's direction (a moving
#: star's lobes lie 2-3 px apart; closer, the direction is noise)
LOBE_GAP_PX = 1.0


def cluster_axes(m):
    """Per cluster, from its per-polarity moments `m` (cluster_moments' dict): (the unit
    vector from its OFF events' mean to its ON events' mean — a moving star fires ON ahead
    of its centre, OFF behind — NaN where a polarity is missing or the means lie closer
    than LOBE_GAP_PX, (k, 2); whether its events spread more across that axis than along
    it — one star's lobes and streak lie along it, a pair side by side across — (k,))."""
    n = m["n"].astype(np.float64)
    total = n.sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.stack([m["sx"][:, 1] / n[:, 1] - m["sx"][:, 0] / n[:, 0],
                      m["sy"][:, 1] / n[:, 1] - m["sy"][:, 0] / n[:, 0]], axis=1)
        gap = np.hypot(d[:, 0], d[:, 1])
        along = np.where((gap >= LOBE_GAP_PX)[:, None], d / gap[:, None], np.nan)
        mx, my = m["sx"].sum(1) / total, m["sy"].sum(1) / total
        cxx = m["sxx"].sum(1) / total - mx * mx
        cyy = m["syy"].sum(1) / total - my * my
        cxy = m["sxy"].sum(1) / total - mx * my
    ax, ay = along[:, 0], along[:, 1]
    var_along = ax * ax * cxx + 2 * ax * ay * cxy + ay * ay * cyy
    var_across = ay * ay * cxx - 2 * ax * ay * cxy + ax * ax * cyy
    return along, var_across > var_along


def across_labels(pts, starts, stops, along, iterations=10):
    """Per point, 0/1 halves of its cluster across the cluster's motion `along` ((k, 2)):
    1-D 2-means of the points' coordinate perpendicular to it, from the midpoint of their
    range (two stars side by side, whose lobes a 2-D split along the motion pairs up)."""
    seg, _ = _segments(starts, stops)
    k = len(starts)
    u = pts[:, 1] * along[seg, 0] - pts[:, 0] * along[seg, 1]
    cut = (np.minimum.reduceat(u, starts) + np.maximum.reduceat(u, starts)) / 2 if k else u[:0]
    for _ in range(iterations):
        up = u > cut[seg]
        n1 = np.bincount(seg, up, k)
        n0 = np.bincount(seg, minlength=k) - n1
        with np.errstate(invalid="ignore", divide="ignore"):
            new = (np.bincount(seg, u * ~up, k) / n0 + np.bincount(seg, u * up, k) / n1) / 2
        new = np.where((n0 > 0) & (n1 > 0), new, cut)
        if np.array_equal(new, cut):
            break
        cut = new
    return (u > cut[seg]).astype(np.int64)


def streak_ratios(axis, along):
    """Per cluster, the halves' smallest sep / axial spread for two targets before the chance
    margin: BLOB_RATIO where the split axis (unit, (2, k)) lies more than 60° from the
    motion `along` ((k, 2), NaN: unknown), else STREAK_RATIO."""
    if along is None:
        return STREAK_RATIO
    cos = np.abs(axis[0] * along[:, 0] + axis[1] * along[:, 1])
    return np.where(cos < 0.5, BLOB_RATIO, STREAK_RATIO)


def halves_many(pts, starts, stops, lab, min_size, valley_ratio, along=None):
    """Per cluster j (points pts[starts[j]:stops[j]], 2-means labels lab per point): whether
    `evstar.extract.Extractor._halves` keeps its two halves — each of >= min_size points,
    their centres >= 2 px apart and far apart against their spread along the axis between
    them (streak_ratios: across the motion `along`, (k, 2) or None, a blob's ratio), the
    1-px profile along it dipping to valley_ratio of the peaks between them.
    Centres are sums over counts as there (exact for integer coordinates); the spreads are
    sums in another order than numpy's std (equal to the last bits). The profile test runs
    per cluster, on the few that pass the others."""
    k = len(starts)
    ok = np.zeros(k, bool)
    if not k:
        return ok
    seg, sizes = _segments(starts, stops)
    one = np.asarray(lab).astype(bool)
    n1 = np.bincount(seg, one, k)
    n0 = sizes - n1
    n_min = np.minimum(n0, n1)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.stack([[np.bincount(seg, pts[:, d] * ~one, k) / n0 for d in (0, 1)],
                      [np.bincount(seg, pts[:, d] * one, k) / n1 for d in (0, 1)]])  # (2, 2, k)
        delta = c[1] - c[0]
        sep = np.hypot(delta[0], delta[1])
        axis = delta / sep
        proj = (pts[:, 0] - c[0, 0][seg]) * axis[0][seg] + (pts[:, 1] - c[0, 1][seg]) * axis[1][seg]
        centred = proj - np.where(one, sep[seg], 0.0)       # half 1 about its own centre
        mean = np.stack([np.bincount(seg, centred * ~one, k) / n0,
                         np.bincount(seg, centred * one, k) / n1])
        dev = (centred - mean[one.astype(int), seg]) ** 2
        std = np.sqrt(np.stack([np.bincount(seg, dev * ~one, k) / n0,
                                np.bincount(seg, dev * one, k) / n1]))
        axial = std.sum(0) / 2
        ratio = streak_ratios(axis, along)
        ok = (sizes >= 2 * min_size) & (n_min >= min_size) & (sep >= 2) \
            & ~(sep < (ratio + 8 / np.sqrt(n_min)) * np.maximum(axial, 0.25))
    for j in np.flatnonzero(ok):
        ok[j] = _dips(proj[starts[j]:stops[j]], sep[j], valley_ratio)
    return ok


def _dips(proj, sep, valley_ratio):
    """Whether the 1-px profile of the projections `proj` (c0 at 0, c1 at sep) dips between
    the two centres to valley_ratio of the lower of its peaks there (Extractor._halves)."""
    lo = np.floor(proj.min() - 0.5)
    hist = np.bincount(np.floor(proj - lo).astype(int))
    b0, b1 = int(np.floor(-lo)), int(np.floor(sep - lo))
    peaks = min(hist[max(b0 - 1, 0):b0 + 2].max(), hist[b1 - 1:b1 + 2].max())
    valley = hist[b0 + 1:b1].min() if b1 > b0 + 1 else peaks
    return valley <= valley_ratio * peaks
