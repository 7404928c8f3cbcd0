"""Grid DBSCAN on pseudo-frames and per-cluster moments (CPU and CUDA).

Specification: `evstar_kernels.reference.clusters` (dbscan_events: identical labels;
cluster_moments: identical integer sums, float sums to rounding).

Events form frames; each frame is binned into a plane of (rows x stride) cells whose zero
border (pad >= eps) makes every disk read unconditional.

GPU form (schedule "events"), for a batch of frames [b0, b1), each with its own plane:
1. `bin_cells` (event-parallel): every event adds 1 to its cell's count and atomically
   takes the cell's ownership when its index is the smallest (the cell's first event).
2. `core_cells` (event-parallel): every owner sums the counts of its disk (its weighted
   neighbourhood) and is core when that reaches min_samples.
3. `link_frames` (one thread per frame, sequential inside it, so no atomics and the same
   result on every run and device): union-find of the core owners within eps, each
   set's root being its first cell in (y, x) order; border owners take the first root
   among the cores of their disk; every event copies its owner's root; the planes are
   cleared again by the frame's own events.
CPU form (schedule "lanes", `cluster_lanes`): one launch; each busy iteration claims a
private plane (slots.claim) and does steps 1-3 for its run of frames alone, sequentially
(the first event to arrive owns a cell: no atomics). Both forms give the same roots.

The launcher numbers the roots (canonical labels), then `moments` (one thread per run of
frames: a frame's clusters are only its own, so no atomics) sums each cluster's events.

Indices are launch-local event indices; NONE marks an unowned cell.
"""
import functools

import numpy as np
import taichi as ti

from ..reference.clusters import SMOOTH, disk_offsets
from . import slots
from .event_counts import frame_of
from .arrays import any_1d, f64_1d, f64_2d, i32_1d, i32_2d, i64_1d, i64_2d, i8_1d, u8_1d, u8_2d

NONE = 2**31 - 1


def disk(eps, stride):
    """Flat plane offsets dy·stride + dx of the disk (int32), and of its half after (0, 0)
    in (dy, dx) order (a pair of cells is linked once). Read in a loop, not unrolled: one
    compiled kernel serves every eps (up to 64 px, thousands of offsets)."""
    dy, dx = disk_offsets(eps)
    flat = (dy * stride + dx).astype(np.int32)
    after = (dy > 0) | ((dy == 0) & (dx > 0))
    # eps < 1: no half; a cell linked to itself is a no-op (and arrays cannot be empty)
    return flat, flat[after] if after.any() else np.zeros(1, np.int32)


@ti.func
def find(parent: ti.template(), e: ti.i32) -> ti.i32:
    """Root of e's set, halving the path on the way (one thread per frame: no races)."""
    r = e
    while parent[r] != r:
        parent[r] = parent[parent[r]]
        r = parent[r]
    return r


@ti.func
def core_test(e: ti.i32, at: ti.i32, full: ti.template(), min_samples: ti.i32,
              count: ti.template(), owner: ti.template(), core: ti.template(),
              parent: ti.template(), first: ti.template()):
    """Event e at plane cell `at`: its cell's first event, its own set, and whether it owns
    a core cell (weighted count within eps >= min_samples; the cell's other events copy it)."""
    own = owner[at]
    first[e] = own
    parent[e] = e
    is_core = 0
    if own == e:
        s = 0
        for j in range(full.shape[0]):
            s += count[at + full[j]]
        is_core = ti.cast(s >= min_samples, ti.i32)
    core[e] = ti.cast(is_core, ti.u8)


@functools.lru_cache(maxsize=None)
def cluster_kernels():
    """(bin_cells, core_cells, link_frames, cluster_lanes); disks are passed as plane
    offsets (`disk`)."""

    @ti.func
    def cell_at(x: ti.template(), y: ti.template(), e: ti.i32, base: ti.i32, stride: ti.i32,
                pad: ti.i32) -> ti.i32:
        return base + (y[e] + pad) * stride + x[e] + pad

    @ti.kernel
    def bin_cells(x: i32_1d, y: i32_1d, offsets: i32_1d, b0: ti.i32, b1: ti.i32, plane: ti.i32,
                  stride: ti.i32, pad: ti.i32, count: i32_1d, owner: i32_1d):
        for e in range(offsets[b0], offsets[b1]):
            f = frame_of(offsets, b0, b1, e)
            at = cell_at(x, y, e, (f - b0) * plane, stride, pad)
            ti.atomic_add(count[at], 1)
            ti.atomic_min(owner[at], e)

    @ti.kernel
    def core_cells(x: i32_1d, y: i32_1d, offsets: i32_1d, b0: ti.i32, b1: ti.i32, plane: ti.i32,
                   stride: ti.i32, pad: ti.i32, full: i32_1d, min_samples: ti.i32, count: i32_1d,
                   owner: i32_1d, core: u8_1d, parent: i32_1d, first: i32_1d):
        for e in range(offsets[b0], offsets[b1]):
            f = frame_of(offsets, b0, b1, e)
            at = cell_at(x, y, e, (f - b0) * plane, stride, pad)
            core_test(e, at, full, min_samples, count, owner, core, parent, first)

    @ti.func
    def key(x: ti.template(), y: ti.template(), e: ti.i32, stride: ti.i32) -> ti.i32:
        return y[e] * stride + x[e]  # (y, x) order within a frame

    @ti.func
    def union(parent: ti.template(), x: ti.template(), y: ti.template(), stride: ti.i32,
              a: ti.i32, b: ti.i32):
        ra = find(parent, a)
        rb = find(parent, b)
        if ra != rb:
            if key(x, y, ra, stride) < key(x, y, rb, stride):
                parent[rb] = ra
            else:
                parent[ra] = rb

    @ti.func
    def border_root(x: ti.template(), y: ti.template(), owner: ti.template(), core: ti.template(),
                    parent: ti.template(), full: ti.template(), at: ti.i32,
                    stride: ti.i32) -> ti.i32:
        """The first root (in (y, x) order) among the cores of a non-core cell's disk."""
        r = -1
        best = NONE
        for j in range(full.shape[0]):
            n = owner[at + full[j]]
            if n != NONE:
                if core[n] != 0:
                    rn = find(parent, n)
                    k = key(x, y, rn, stride)
                    if k < best:
                        r = rn
                        best = k
        return r

    @ti.func
    def link_frame(f: ti.i32, base: ti.i32, x: ti.template(), y: ti.template(),
                   offsets: ti.template(), stride: ti.i32, pad: ti.i32, full: ti.template(),
                   half: ti.template(), count: ti.template(), owner: ti.template(),
                   core: ti.template(), parent: ti.template(), first: ti.template(),
                   root: ti.template()):
        """Frame f's roots from its binned plane at base (union-find, borders, copies);
        clears the plane."""
        for e in range(offsets[f], offsets[f + 1]):
            if first[e] == e and core[e] != 0:
                at = cell_at(x, y, e, base, stride, pad)
                for j in range(half.shape[0]):
                    n = owner[at + half[j]]
                    if n != NONE:
                        if core[n] != 0:
                            union(parent, x, y, stride, e, n)
        # an owner precedes its cell's other events, so its root is set when they copy it
        for e in range(offsets[f], offsets[f + 1]):
            own = first[e]
            if own == e:
                if core[e] != 0:
                    root[e] = find(parent, e)
                else:
                    root[e] = border_root(x, y, owner, core, parent, full,
                                          cell_at(x, y, e, base, stride, pad), stride)
            else:
                root[e] = root[own]
        for e in range(offsets[f], offsets[f + 1]):
            at = cell_at(x, y, e, base, stride, pad)
            count[at] = 0
            owner[at] = NONE

    @ti.kernel
    def link_frames(lo: i32_1d, hi: i32_1d, x: i32_1d, y: i32_1d, offsets: i32_1d, b0: ti.i32,
                    plane: ti.i32, stride: ti.i32, pad: ti.i32, full: i32_1d, half: i32_1d,
                    count: i32_1d, owner: i32_1d, core: u8_1d, parent: i32_1d, first: i32_1d,
                    root: i32_1d):
        for i in range(lo.shape[0]):
            for f in range(lo[i], hi[i]):
                link_frame(f, (f - b0) * plane, x, y, offsets, stride, pad, full, half, count,
                           owner, core, parent, first, root)

    @ti.kernel
    def cluster_lanes(lo: i32_1d, hi: i32_1d, x: i32_1d, y: i32_1d, offsets: i32_1d,
                      plane: ti.i32, stride: ti.i32, pad: ti.i32, full: i32_1d, half: i32_1d,
                      min_samples: ti.i32, count: i32_1d, owner: i32_1d, core: u8_1d,
                      parent: i32_1d, first: i32_1d, root: i32_1d, busy: i32_1d, n_slots: ti.i32):
        """The CPU form: a busy iteration claims a private plane and does a run of frames
        alone, each frame binned, tested and linked in turn (no atomics but the claim)."""
        for i in range(lo.shape[0]):
            if lo[i] < hi[i]:
                slot = slots.claim(busy, n_slots)
                base = slot * plane
                for f in range(lo[i], hi[i]):
                    # first come owns the cell; the plane is this thread's (`+=` would be atomic)
                    for e in range(offsets[f], offsets[f + 1]):
                        at = cell_at(x, y, e, base, stride, pad)
                        count[at] = count[at] + 1
                        if owner[at] == NONE:
                            owner[at] = e
                    for e in range(offsets[f], offsets[f + 1]):
                        at = cell_at(x, y, e, base, stride, pad)
                        core_test(e, at, full, min_samples, count, owner, core, parent, first)
                    link_frame(f, base, x, y, offsets, stride, pad, full, half, count, owner,
                               core, parent, first, root)
                slots.release(busy, slot)

    return bin_cells, core_cells, link_frames, cluster_lanes


@ti.kernel
def moments(lo: i32_1d, hi: i32_1d, offsets: i32_1d, labels: i32_1d, xf: any_1d, yf: any_1d,
            t: i64_1d, frame_t0: i64_1d, p: i8_1d, first: i32_1d, n: i64_2d, st: i64_2d,
            sums: f64_2d, box: f64_2d, cells: i64_1d, csum: f64_2d):
    """Per-cluster sums (reference: cluster_moments). sums[c, 5q + j], j = x, y, xx, yy, xy,
    for polarity q; box[c] = x min, x max, y min, y max (pre-filled with ±inf); cells and
    csum: distinct cells and their coordinate sums. Frames of one run are one thread's."""
    for i in range(lo.shape[0]):
        for f in range(lo[i], hi[i]):
            for e in range(offsets[f], offsets[f + 1]):
                c = labels[e]
                if c >= 0:  # plain read-modify-writes: `+=` on global memory is atomic
                    q = ti.cast(p[e] != 0, ti.i32)
                    x = ti.cast(xf[e], ti.f64)
                    y = ti.cast(yf[e], ti.f64)
                    n[c, q] = n[c, q] + 1
                    st[c, q] = st[c, q] + t[e] - frame_t0[f]
                    sums[c, 5 * q] = sums[c, 5 * q] + x
                    sums[c, 5 * q + 1] = sums[c, 5 * q + 1] + y
                    sums[c, 5 * q + 2] = sums[c, 5 * q + 2] + x * x
                    sums[c, 5 * q + 3] = sums[c, 5 * q + 3] + y * y
                    sums[c, 5 * q + 4] = sums[c, 5 * q + 4] + x * y
                    box[c, 0] = ti.min(box[c, 0], x)
                    box[c, 1] = ti.max(box[c, 1], x)
                    box[c, 2] = ti.min(box[c, 2], y)
                    box[c, 3] = ti.max(box[c, 3], y)
                    if first[e] == e:
                        cells[c] = cells[c] + 1
                        csum[c, 0] = csum[c, 0] + x
                        csum[c, 1] = csum[c, 1] + y


_SMOOTH = tuple(float(v) for v in SMOOTH)


@ti.kernel
def peak_images(lo: i32_1d, hi: i32_1d, offsets: i32_1d, labels: i32_1d, x: any_1d, y: any_1d,
                p: i8_1d, base: i32_1d, box: i32_2d, img: f64_2d):
    """Each screened cluster's event count images, img[0] OFF and img[1] ON events, at
    [base[c]:] (origin box[c, 0:2], width box[c, 2]); base -1: not screened. Frames of one
    run are one thread's."""
    for i in range(lo.shape[0]):
        for f in range(lo[i], hi[i]):
            for e in range(offsets[f], offsets[f + 1]):
                c = labels[e]
                if c >= 0:
                    if base[c] >= 0:
                        xe = ti.cast(x[e], ti.i32)
                        ye = ti.cast(y[e], ti.i32)
                        at = base[c] + (ye - box[c, 1]) * box[c, 2] + xe - box[c, 0]
                        q = ti.cast(p[e] != 0, ti.i32)
                        img[q, at] = img[q, at] + 1.0


@ti.func
def two_near_maxima(img: ti.template(), k: ti.i32, tmp: ti.template(), b: ti.i32, w: ti.i32,
                    h: ti.i32, rtol: ti.f64) -> ti.u8:
    """Whether image k at [b:] (w x h), smoothed by SMOOTH along y then x (in place), has
    two near-maxima of their 3 x 3 neighbourhood 2 px apart (bounding box of them all)."""
    # rows, then pixels (a 2-d ndrange divides its flat index per pixel)
    for r in range(h):  # along y into tmp
        for q in range(w):
            s = ti.f64(0.0)
            for d in ti.static(range(-2, 3)):
                if r + d >= 0 and r + d < h:
                    s += _SMOOTH[d + 2] * img[k, b + (r + d) * w + q]
            tmp[b + r * w + q] = s
    for r in range(h):  # along x back into the image
        for q in range(w):
            s = ti.f64(0.0)
            for d in ti.static(range(-2, 3)):
                if q + d >= 0 and q + d < w:
                    s += _SMOOTH[d + 2] * tmp[b + r * w + q + d]
            img[k, b + r * w + q] = s
    x0 = w  # the near-maxima's bounding box
    x1 = -1
    y0 = h
    y1 = -1
    for r in range(h):
        for q in range(w):
            v = img[k, b + r * w + q]
            if v > 0:
                m = v
                for dr in ti.static(range(-1, 2)):
                    for dq in ti.static(range(-1, 2)):
                        if r + dr >= 0 and r + dr < h and q + dq >= 0 and q + dq < w:
                            m = ti.max(m, img[k, b + (r + dr) * w + q + dq])
                if v >= m * (1 - rtol):
                    x0 = ti.min(x0, q)
                    x1 = ti.max(x1, q)
                    y0 = ti.min(y0, r)
                    y1 = ti.max(y1, r)
    return ti.cast((x1 - x0) ** 2 + (y1 - y0) ** 2 >= 4, ti.u8)


UNSURE = 2  # reference.clusters.PEAKS_UNSURE (NONE 0, FOUND 1)


@ti.func
def max_class(img: ti.template(), k: ti.i32, b: ti.i32, w: ti.i32, h: ti.i32, r: ti.i32,
              q: ti.i32, rtol: ti.f64) -> ti.i32:
    """Pixel (r, q) of smoothed image k at [b:]: 0 zero or certainly not a 3 x 3 maximum, 1
    maybe one (a neighbour within rtol), 2 certainly one."""
    v = img[k, b + r * w + q]
    cls = 0
    if v > 0:
        m = ti.f64(0.0)  # the neighbours' maximum (values are >= 0)
        for dr in ti.static(range(-1, 2)):
            for dq in ti.static(range(-1, 2)):
                if ti.static(dr != 0 or dq != 0):
                    if r + dr >= 0 and r + dr < h and q + dq >= 0 and q + dq < w:
                        m = ti.max(m, img[k, b + (r + dr) * w + q + dq])
        if m < v * (1 - rtol):
            cls = 2
        elif m <= v * (1 + rtol):
            cls = 1
    return cls


@ti.func
def far_apart(ri: ti.i32, qi: ti.i32, rj: ti.i32, qj: ti.i32) -> ti.i32:
    """Whether pixels (ri, qi) and (rj, qj) lie 2 px apart or more."""
    return ti.cast((ri - rj) ** 2 + (qi - qj) ** 2 >= 4, ti.i32)


@ti.func
def certain_peaks(img: ti.template(), k: ti.i32, tmp: ti.template(), b: ti.i32, w: ti.i32,
                  h: ti.i32, rtol: ti.f64, peaks: ti.template(), c: ti.i32, col: ti.i32):
    """two_peaks of smoothed image k at [b:] from certain comparisons only (reference:
    certain_peaks_of_image): peaks[c, col] = status, peaks[c, col + 1], peaks[c, col + 2] =
    the flat pixel indices of the two peaks where status is FOUND (1). tmp[b:] holds the
    pixels' max_class meanwhile. Pixels are walked row by row (r, q): no integer division
    per pixel pair."""
    top = -1
    vmax = ti.f64(0.0)
    r0, r1, q0, q1 = h, -1, w, -1  # C's bounding box
    for r in range(h):  # classes; C's highest (the first in row-major order)
        for q in range(w):
            j = r * w + q
            cls = max_class(img, k, b, w, h, r, q, rtol)
            tmp[b + j] = ti.cast(cls, ti.f64)
            if cls > 0:
                r0, r1, q0, q1 = ti.min(r0, r), ti.max(r1, r), ti.min(q0, q), ti.max(q1, q)
                if img[k, b + j] > vmax:
                    vmax = img[k, b + j]
                    top = j
    n_top = 0
    far = 0
    for rj in range(h):  # T: C within rtol of the highest; is any of C 2 px from one?
        for qj in range(w):
            j = rj * w + qj
            if tmp[b + j] > 0 and img[k, b + j] >= vmax * (1 - rtol):
                n_top += 1
                # on the pixel grid, 2 px apart (squared distance >= 4) is outside the
                # 3 x 3 block around j: some of C is iff C's box leaves that block
                if r0 < rj - 1 or r1 > rj + 1 or q0 < qj - 1 or q1 > qj + 1:
                    far = 1
    status = UNSURE
    second = -1
    if far == 0:
        status = 0
    elif n_top == 1 and tmp[b + top] == 2:
        rt, qt = top // w, top % w
        vs = ti.f64(0.0)
        for ri in range(h):  # the highest of C 2 px from the top
            for qi in range(w):
                i = ri * w + qi
                if tmp[b + i] > 0 and far_apart(ri, qi, rt, qt) != 0 and img[k, b + i] > vs:
                    vs = img[k, b + i]
                    second = i
        n_second = 0
        for ri in range(h):
            for qi in range(w):
                i = ri * w + qi
                if (tmp[b + i] > 0 and far_apart(ri, qi, rt, qt) != 0
                        and img[k, b + i] >= vs * (1 - rtol)):
                    n_second += 1
        if n_second == 1 and tmp[b + second] == 2:
            status = 1
    peaks[c, col] = status
    peaks[c, col + 1] = top
    peaks[c, col + 2] = second


@ti.kernel
def peak_screen(base: i32_1d, box: i32_2d, polarities: u8_1d, img: f64_2d, tmp: f64_1d,
                rtol: ti.f64, maybe: u8_2d, peaks: i32_2d):
    """maybe[c, 0] = 0 only where two_peaks of all the cluster's events is None, maybe[c, 1]
    (looked at only where maybe[c, 0] and polarities[c]) = 0 only where it is None for the
    OFF or for the ON events (reference: maybe_two_peaks). img[2] holds the sum of img[0]
    and img[1]. peaks[c, 3s:3s + 3]: certain_peaks of all events (s = 0), the OFF (1) and
    the ON ones (2); status 0 where the screen rules the image out, UNSURE where not looked
    at. One thread per cluster."""
    for c in range(base.shape[0]):
        for s in range(3):
            peaks[c, 3 * s] = UNSURE
        if base[c] >= 0:
            b = base[c]
            w = box[c, 2]
            h = box[c, 3]
            for j in range(w * h):
                img[2, b + j] = img[0, b + j] + img[1, b + j]
            both = ti.u8(0)
            peaks[c, 0] = 0
            # the images in turn (one call site each: Taichi inlines a function per call, and
            # three sites tripled this kernel's first-call build): all events, OFF, ON; each
            # looked at only where the one before has two near-maxima
            go = 1
            for s in range(3):
                if go != 0:
                    go = 0
                    k = (s + 2) % 3  # image 2 (both polarities), 0 (OFF), 1 (ON)
                    near = two_near_maxima(img, k, tmp, b, w, h, rtol)
                    if s == 2:
                        both = near
                    if near != 0:
                        if s == 0:
                            maybe[c, 0] = ti.u8(1)
                        certain_peaks(img, k, tmp, b, w, h, rtol, peaks, c, 3 * s)
                        if s == 1 or (s == 0 and polarities[c] != 0):
                            peaks[c, 3 * s + 3] = 0
                            go = 1
            maybe[c, 1] = both


@ti.kernel
def two_means(x: any_1d, y: any_1d, at: i32_1d, starts: i32_1d, stops: i32_1d, seeds: f64_2d,
              iterations: ti.i32, lab: i32_1d, p: i8_1d, halves: i64_2d):
    """Lloyd's 2-means of each cluster's points (x[at[i]], y[at[i]]) for i in
    starts[j]:stops[j] from the centres seeds[j] = (ax, ay, bx, by): labels 0/1 per i, one
    thread per cluster; halves[j] = (points labelled 0, labelled 1, those with p[i] != 0
    labelled 0, labelled 1). x, y: any numbers (pixels or float coordinates), read through
    `at` (no gathered copy of the points).

    Specification: `evstar.extract._two_means` per cluster (stop when the labels repeat or
    one half is empty; centres: sums in point order / counts, as `evstar.splitting`'s
    batched form)."""
    for j in range(starts.shape[0]):
        s, e = starts[j], stops[j]
        c0x, c0y, c1x, c1y = seeds[j, 0], seeds[j, 1], seeds[j, 2], seeds[j, 3]
        for it in range(iterations):
            ones, changed = 0, 0
            for i in range(s, e):
                xi, yi = ti.cast(x[at[i]], ti.f64), ti.cast(y[at[i]], ti.f64)
                d0 = (xi - c0x) ** 2 + (yi - c0y) ** 2
                d1 = (xi - c1x) ** 2 + (yi - c1y) ** 2
                new = ti.cast(d1 < d0, ti.i32)
                if it > 0:
                    changed += ti.abs(new - lab[i])
                lab[i] = new
                ones += new
            if (it > 0 and changed == 0) or ones == 0 or ones == e - s:
                break
            sx0, sy0, sx1, sy1 = ti.f64(0.0), ti.f64(0.0), ti.f64(0.0), ti.f64(0.0)
            # branch-free (~15 % quicker): finite x·1 and x·0 add the bits the branches would
            for i in range(s, e):
                xi, yi = ti.cast(x[at[i]], ti.f64), ti.cast(y[at[i]], ti.f64)
                one = ti.cast(lab[i], ti.f64)
                sx1 += xi * one
                sy1 += yi * one
                sx0 += xi * (1.0 - one)
                sy0 += yi * (1.0 - one)
            n1 = ti.cast(ones, ti.f64)
            n0 = ti.cast(e - s - ones, ti.f64)
            c0x, c0y, c1x, c1y = sx0 / n0, sy0 / n0, sx1 / n1, sy1 / n1
        for h in ti.static(range(4)):
            halves[j, h] = 0
        for i in range(s, e):
            halves[j, lab[i]] = halves[j, lab[i]] + 1
            if p[i] != 0:
                halves[j, 2 + lab[i]] = halves[j, 2 + lab[i]] + 1
