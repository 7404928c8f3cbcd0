"""Grid DBSCAN on the distinct weighted cells of pseudo-frames, and per-cluster moments, in
plain numpy: the executable specification of the Taichi kernels (docs/kernels.md).

A **cell** is a distinct (frame, x, y) of integer pixel coordinates; its weight is the
number of events there. Clustering is DBSCAN (Ester et al. 1996) with sample weights, in
scikit-learn's sense, on each frame's cells:

- **disk**: offsets (dx, dy) with dx² + dy² <= eps² (float64; inclusive, as scikit-learn's
  ``radius_neighbors``) — unlike the denoising filters' strict disk.
- **core** cell: the weights of the cells of its frame within the disk (itself included)
  sum to >= min_samples.
- **clusters**: connected components of core cells, two cores linked when within eps.
- **border** cells: a non-core cell within eps of at least one core joins the cluster
  whose first core cell comes first (tie rule below); other cells are noise (-1).
- **canonical labels**: clusters numbered 0, 1, ... in the (frame, y, x) order of their
  first core cell. A border cell near several clusters joins the lowest-numbered one.

With cells in (frame, y, x) order this is exactly scikit-learn's DBSCAN on the cells with
``sample_weight`` = weights (its expansion visits cores in input order, numbers clusters in
the order of their first core, and a border cell keeps the first cluster that reaches it).
Frames never mix.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def disk_offsets(eps):
    """(dy, dx) int64 arrays of the lattice offsets with dx² + dy² <= eps², in (dy, dx) order."""
    r = math.floor(eps)
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    inside = (dx * dx + dy * dy).astype(np.float64) <= float(eps) ** 2
    return dy[inside].astype(np.int64), dx[inside].astype(np.int64)


def cells(frame, x, y):
    """Distinct cells in (frame, y, x) order: (frame, x, y, weight, inverse) — inverse maps
    each event to its cell. x, y may be negative (any integers)."""
    frame, x, y = (np.asarray(a, np.int64) for a in (frame, x, y))
    if len(frame) == 0:
        z = np.zeros(0, np.int64)
        return z, z, z, z, z
    order = np.lexsort((x, y, frame))
    f, xs, ys = frame[order], x[order], y[order]
    new = np.r_[True, (f[1:] != f[:-1]) | (ys[1:] != ys[:-1]) | (xs[1:] != xs[:-1])]
    cell_of_sorted = np.cumsum(new) - 1
    inverse = np.empty(len(frame), np.int64)
    inverse[order] = cell_of_sorted
    weight = np.bincount(cell_of_sorted)
    return f[new], xs[new], ys[new], weight, inverse


def _neighbour_pairs(cf, cx, cy, eps):
    """(i, j) index pairs of cells within eps of each other in one frame (i == j included)."""
    def key(dy, dx):  # monotone in (frame, y, x) for |x|, |y| < 2**20
        return (cf << 42) + ((cy + dy + (1 << 20)) << 21) + (cx + dx + (1 << 20))

    # cells are in (frame, y, x) order: a neighbour is found by binary search on its key
    flat = key(0, 0)
    ii, jj = [], []
    for dy, dx in zip(*disk_offsets(eps)):
        want = key(dy, dx)
        j = np.searchsorted(flat, want)
        hit = j < len(flat)
        hit[hit] = flat[j[hit]] == want[hit]
        ii.append(np.flatnonzero(hit))
        jj.append(j[hit])
    return np.concatenate(ii), np.concatenate(jj)


def dbscan_cells(cf, cx, cy, weight, eps, min_samples):
    """(labels, core) of cells in (frame, y, x) order (see the module docstring)."""
    n = len(cf)
    labels = np.full(n, -1, np.int64)
    if n == 0:
        return labels, np.zeros(0, bool)
    i, j = _neighbour_pairs(cf, cx, cy, eps)
    core = np.bincount(i, weights=weight[j], minlength=n) >= min_samples
    # components of the core-core graph; each is named by its first core cell
    both = core[i] & core[j]
    graph = coo_matrix((np.ones(both.sum()), (i[both], j[both])), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    first = np.full(n, n, np.int64)
    np.minimum.at(first, comp[core], np.flatnonzero(core))
    root = np.where(core, first[comp], n)
    # border cells: the smallest root among the cores within eps
    to_core = core[j] & ~core[i]
    np.minimum.at(root, i[to_core], first[comp[j[to_core]]])
    roots = np.unique(root[root < n])          # sorted: canonical cluster order
    has = root < n
    labels[has] = np.searchsorted(roots, root[has])
    return labels, core


def dbscan_events(frame, x, y, eps, min_samples):
    """Per-event cluster labels (-1 noise) of grid DBSCAN on each frame's weighted cells."""
    cf, cx, cy, weight, inverse = cells(frame, x, y)
    labels, _ = dbscan_cells(cf, cx, cy, weight, eps, min_samples)
    return labels[inverse]


def cluster_moments(labels, frame, x, y, t, p, frame_t0, cell_first=None):
    """Per-cluster sums of the events of labels >= 0 (clusters 0 .. labels.max()).

    x, y: the coordinates summed (float64; integers are summed exactly); t int64 µs, summed
    relative to frame_t0[frame] (int64 per frame) to stay exact; p: polarity 0/1.
    Returns a dict: n, st (int64, shape (k, 2): per polarity OFF, ON), sx, sy, sxx, syy, sxy
    (float64, (k, 2)), box (float64, (k, 4): x min, x max, y min, y max of all events) and,
    when cell_first (bool per event: the event is its cell's first) is given, cells (int64,
    (k,)) and cx, cy (float64, (k,)): count and coordinate sums of the distinct cells.
    """
    labels = np.asarray(labels, np.int64)
    k = int(labels.max()) + 1 if len(labels) and labels.max() >= 0 else 0
    m = labels >= 0
    lab, q = labels[m], np.asarray(p)[m].astype(np.int64)
    xs, ys = np.asarray(x, np.float64)[m], np.asarray(y, np.float64)[m]
    tr = np.asarray(t, np.int64)[m] - np.asarray(frame_t0, np.int64)[np.asarray(frame)[m]]
    slot = lab * 2 + q

    def per(values):
        return np.bincount(slot, weights=values, minlength=2 * k).reshape(k, 2)

    out = {"n": np.bincount(slot, minlength=2 * k).reshape(k, 2).astype(np.int64),
           "sx": per(xs), "sy": per(ys), "sxx": per(xs * xs), "syy": per(ys * ys),
           "sxy": per(xs * ys)}
    st = np.zeros(2 * k, np.int64)
    np.add.at(st, slot, tr)
    out["st"] = st.reshape(k, 2)
    box = np.empty((k, 4))
    box[:, 0], box[:, 2] = np.inf, np.inf
    box[:, 1], box[:, 3] = -np.inf, -np.inf
    np.minimum.at(box[:, 0], lab, xs)
    np.maximum.at(box[:, 1], lab, xs)
    np.minimum.at(box[:, 2], lab, ys)
    np.maximum.at(box[:, 3], lab, ys)
    out["box"] = box
    if cell_first is not None:
        first = np.asarray(cell_first, bool)[m]
        out["cells"] = np.bincount(lab[first], minlength=k).astype(np.int64)
        out["cx"] = np.bincount(lab[first], weights=xs[first], minlength=k)
        out["cy"] = np.bincount(lab[first], weights=ys[first], minlength=k)
    return out


#: the split test's smoothing: a Gaussian of sigma 0.7 px, taps -2..2
SMOOTH = np.exp(-0.5 * (np.arange(-2, 3) / 0.7) ** 2)


def smoothed_image(pts):
    """(image, origin): the count image of `pts` at their rounded pixels, with a 2-px
    border, smoothed by SMOOTH along y then x; origin = the (x, y) of pixel [0, 0]."""
    ij = np.floor(pts + 0.5).astype(np.int64)
    origin = ij.min(0) - 2
    w, h = ij.max(0) - origin + 3
    flat = (ij[:, 1] - origin[1]) * w + (ij[:, 0] - origin[0])
    img = np.bincount(flat, minlength=w * h).reshape(h, w).astype(np.float64)
    img = ndimage.correlate1d(ndimage.correlate1d(img, SMOOTH, 0, mode="constant"), SMOOTH, 1,
                              mode="constant")
    return img, origin


def two_peaks(pts):
    """(x, y) of the two highest local maxima, at least 2 px apart, of the events' count
    image smoothed by a Gaussian of 0.7 px; None when there is one. (`pts`: float (n, 2),
    counted at their rounded pixels.)"""
    img, origin = smoothed_image(pts)
    is_max = (img == ndimage.maximum_filter(img, size=3)) & (img > 0)
    yx = np.argwhere(is_max)[np.argsort(-img[is_max], kind="stable")]
    far = np.flatnonzero(((yx[1:] - yx[0]) ** 2).sum(1) >= 4)  # >= 2 px from the highest
    if not len(far):
        return None
    return (yx[0][::-1] + origin).astype(float), (yx[far[0] + 1][::-1] + origin).astype(float)


def maybe_two_peaks(pts, rtol=1e-9):
    """False only where two_peaks(pts) is None: no two near-maxima (within rtol of their
    3 x 3 neighbourhood's maximum) lie 2 px apart. A superset test, safe against rounding
    differences in the smoothed image, which the Taichi screen computes in its own order."""
    img, origin = smoothed_image(pts)
    near = (img >= ndimage.maximum_filter(img, size=3) * (1 - rtol)) & (img > 0)
    ys, xs = np.nonzero(near)
    return bool(np.hypot(xs.max() - xs.min(), ys.max() - ys.min()) >= 2)


#: certain_two_peaks' status: two_peaks is None, two_peaks is (a, b), or not decided
PEAKS_NONE, PEAKS_FOUND, PEAKS_UNSURE = 0, 1, 2


def certain_peaks_of_image(img, rtol=1e-9):
    """(status, a, b) of a smoothed image whose values may differ from two_peaks' own by a
    relative error far below rtol (another rounding order, fused multiply-adds): every value
    is a sum of non-negative terms, so each carries a small relative error, and only
    comparisons decided by more than rtol are trusted. a, b: the (row, col) of the two
    peaks where status is PEAKS_FOUND.

    Each pixel > 0 is certainly a maximum (every 3 x 3 neighbour < v·(1 - rtol)), certainly
    not (one > v·(1 + rtol)) or maybe one; C = the certain and maybe ones (every true
    maximum is in C), T = those of C within rtol of C's highest value (the true highest is
    in T). PEAKS_NONE: no pixel of C lies 2 px or more from a pixel of T. PEAKS_FOUND: T is
    one certain maximum and the highest of C 2 px or more from it is a certain maximum
    higher by more than rtol than the rest. Else PEAKS_UNSURE (near ties: exact ties of
    symmetric count patterns among them)."""
    h, w = img.shape
    pad = np.pad(img, 1)  # outside the image counts as nothing (values are >= 0)
    nb = np.max([pad[1 + dr:1 + dr + h, 1 + dq:1 + dq + w] for dr in (-1, 0, 1) for dq in (-1, 0, 1)
                 if (dr, dq) != (0, 0)], axis=0)
    pos = img > 0
    sure = pos & (nb < img * (1 - rtol))
    cand = pos & (nb <= img * (1 + rtol))
    r, q = np.nonzero(cand)
    v = img[r, q]
    top = np.argmax(v)  # the first highest in row-major order
    in_t = v >= v[top] * (1 - rtol)
    d2 = (r[:, None] - r[None, in_t]) ** 2 + (q[:, None] - q[None, in_t]) ** 2
    if not (d2 >= 4).any():
        return PEAKS_NONE, None, None
    if in_t.sum() > 1 or not sure[r[top], q[top]]:
        return PEAKS_UNSURE, None, None
    far = (r - r[top]) ** 2 + (q - q[top]) ** 2 >= 4
    s = np.flatnonzero(far)[np.argmax(v[far])]
    if (far & (v >= v[s] * (1 - rtol))).sum() > 1 or not sure[r[s], q[s]]:
        return PEAKS_UNSURE, None, None
    return PEAKS_FOUND, (r[top], q[top]), (r[s], q[s])


def certain_two_peaks(pts, rtol=1e-9):
    """(status, a, b): two_peaks(pts) decided from certain comparisons only (the
    specification of the Taichi screen's peaks, which smooths in its own rounding order):
    PEAKS_NONE where two_peaks is None, PEAKS_FOUND where it is (a, b), PEAKS_UNSURE where
    near ties leave it open (the caller then runs two_peaks itself)."""
    img, origin = smoothed_image(pts)
    status, a, b = certain_peaks_of_image(img, rtol)
    if status != PEAKS_FOUND:
        return status, None, None
    return status, (np.array(a[::-1]) + origin).astype(float), (np.array(b[::-1]) + origin).astype(float)
