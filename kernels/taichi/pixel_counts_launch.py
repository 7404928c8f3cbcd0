"""Launch of the pixel counts (launches of at most MAX_LAUNCH_EVENTS events; with a keep
mask the packed halves split, without it int32 counts), of the per-event pixel flags, the
kept events' pixels and the events on flagged pixels (in order, or by pixel)."""
import numpy as np

from . import launch, sorting_launch
from .pixel_counts import count_all_kernel, count_pixels_kernel
from .pixel_counts import flagged_ids, mark_pixels
from .pixel_counts import pixel_flags as _pixel_flags

_LOW = (1 << 32) - 1


def pixel_counts(ti, x, y, width, height, keep=None):
    """reference.pixels.pixel_counts: (all, kept or None) int64 (height, width) images."""
    if keep is None:
        return _all_counts(ti, x, y, width, height), None
    size = width * height
    every, kept = np.zeros(size, np.int64), np.zeros(size, np.int64)   # no events: zeros
    arrays = launch.Arrays(ti)
    kernel = count_pixels_kernel(not arrays.on_device)
    with launch.RUNTIME_LOCK:
        for e0, e1 in launch.pieces(len(x)):
            cells = arrays.put(np.zeros(size, np.int64))
            kernel(arrays.put(x[e0:e1]), arrays.put(y[e0:e1]),
                   arrays.put(np.asarray(keep[e0:e1], bool).view(np.uint8)), width, cells)
            packed = cells.to_numpy() if arrays.on_device else cells
            # the first launch's halves are the sums (no adds into zeros)
            every = packed & _LOW if e0 == 0 else every + (packed & _LOW)
            kept = packed >> 32 if e0 == 0 else kept + (packed >> 32)
    return every.reshape(height, width), kept.reshape(height, width)


def _all_counts(ti, x, y, width, height):
    """The events per pixel alone: int32 cells per launch, summed into int64."""
    every = np.zeros(width * height, np.int64)
    arrays = launch.Arrays(ti)
    kernel = count_all_kernel(not arrays.on_device)
    with launch.RUNTIME_LOCK:
        for e0, e1 in launch.pieces(len(x)):
            cells = arrays.put(np.zeros(width * height, np.int32))
            kernel(arrays.put(x[e0:e1]), arrays.put(y[e0:e1]), width, cells)
            every += cells.to_numpy() if arrays.on_device else cells
    return every.reshape(height, width)


def _packed(flags):
    """The (height, width) bool flags packed 8 a byte, little-endian, as the kernels read
    them, zero bytes added up to whole 32-bit words."""
    packed = np.packbits(np.asarray(flags, bool).reshape(-1), bitorder="little")
    return np.concatenate([packed, np.zeros(-len(packed) % 4, np.uint8)])


#: set bits of each byte value
_POPCOUNT8 = np.array([bin(b).count("1") for b in range(256)], np.int64)


def _words(packed):
    """The flags _packed gives as 32-bit words, little-endian (uint32), and the count of
    flags in the words before each (int32): a popcount table over the bytes, not a sum over
    a padded copy of the bool image (~10x quicker on a megapixel sensor)."""
    per_word = _POPCOUNT8[packed].reshape(-1, 4).sum(1)
    return packed.view("<u4"), np.r_[0, np.cumsum(per_word)[:-1]].astype(np.int32)


def marked_pixels(ti, x, y, keep, width, height):
    """reference.pixels.marked_pixels: a (height, width) bool image, True at the pixel of
    every event `keep` (bool) selects (mark_pixels at those events); `keep` may also be
    their ascending indices (np.flatnonzero of the mask, where the caller has them)."""
    keep = np.asarray(keep)
    arrays = launch.Arrays(ti)
    flags = arrays.put(np.zeros(width * height, np.uint8))
    with launch.RUNTIME_LOCK:
        for e0, e1, at in _launches_at(np.flatnonzero(keep) if keep.dtype == bool else keep,
                                       len(x)):
            mark_pixels(*(arrays.put(np.asarray(a[e0:e1], np.uint16)) for a in (x, y)),
                        arrays.put(at), width, flags)
    return (flags.to_numpy() if arrays.on_device else flags).view(bool).reshape(height, width)


def _launches_at(at, n):
    """(e0, e1, the indices `at` (ascending) within events e0 .. e1 − 1, less e0) of each
    launch over n events (launch.pieces) that holds some."""
    pieces = launch.pieces(n)
    cuts = np.searchsorted(at, [e0 for e0, _ in pieces] + [n])
    return [(e0, e1, at[a0:a1] - e0 if e0 else at[a0:a1])
            for (e0, e1), a0, a1 in zip(pieces, cuts[:-1], cuts[1:]) if a0 < a1]


def on_flagged_pixels(ti, t, x, y, p, flags):
    """reference.pixels.on_flagged_pixels of (t, x, y, p): (t int64, x, y uint16, p int8)
    of the events at pixels flags[y, x] sets, in order: the flags per event (pixel_flags),
    np.flatnonzero and numpy's gathers (take: a bool mask's compress scans it once per
    array). On the CPU a copy in lanes of runs of events took ~2x as long (EVK4 field spans
    of 2-3 M events, half of them flagged, numpy 2.4)."""
    sel = np.flatnonzero(pixel_flags(ti, x, y, flags))
    return [np.asarray(a, d).take(sel) for a, d in
            ((t, np.int64), (x, np.uint16), (y, np.uint16), (p, np.int8))]


def events_by_pixel(ti, t, x, y, p, flags):
    """reference.pixels.events_by_pixel of time-sorted events (p 0 or 1): (t int64, pixel key
    uint32, p int8) of those at pixels flags[y, x] sets, in the pixel-then-time order. The
    counting sort is by the flagged pixels' ranks (a table that fits the cache) and moves
    the times and polarities as one value, 2t + p."""
    pixels = np.flatnonzero(flags).astype(np.uint32)       # the flagged pixels' keys by rank
    ids, tp = _flagged_ids(ti, t, x, y, p, flags)
    tp, count = sorting_launch.counting_sort(ti, ids, tp, len(pixels))
    p_out = tp.astype(np.int8)                               # the low bit kept: p
    p_out &= 1
    tp >>= 1                                                 # in place: the times
    return tp, np.repeat(pixels, count), p_out


def _flagged_ids(ti, t, x, y, p, flags):
    """(ranks of their pixels among the flagged, 2t + p) of the events at flagged pixels,
    in order: the flags per event, np.flatnonzero, then the flagged_ids kernel at those."""
    packed = _packed(flags)                 # packed once: the flags per event and the ranks
    at = np.flatnonzero(_packed_flags(ti, x, y, packed, flags.shape[1]))
    ids, tp = np.empty(len(at), np.uint32), np.empty(len(at), np.int64)
    arrays = launch.Arrays(ti)
    words, before = (arrays.put(a) for a in _words(packed))
    a0 = 0
    with launch.RUNTIME_LOCK:
        for e0, e1, at_e in _launches_at(at, len(x)):
            a1 = a0 + len(at_e)
            # on the CPU the kernel writes into the outputs' own (contiguous) slices
            out = ((arrays.empty(a1 - a0, np.uint32), arrays.empty(a1 - a0, np.int64))
                   if arrays.on_device else (ids[a0:a1], tp[a0:a1]))
            flagged_ids(*(arrays.put(np.asarray(a[e0:e1], d)) for a, d in
                          ((t, np.int64), (x, np.uint16), (y, np.uint16), (p, np.int8))),
                        arrays.put(at_e), words, before, flags.shape[1], *out)
            if arrays.on_device:
                arrays.get(out[0], ids[a0:a1])
                arrays.get(out[1], tp[a0:a1])
            a0 = a1
    return ids, tp


def pixel_flags(ti, x, y, flags):
    """flags[y, x] (bool (height, width)) of every event (bool (n,))."""
    return _packed_flags(ti, x, y, _packed(flags), flags.shape[1])


def _packed_flags(ti, x, y, packed, width):
    """pixel_flags of flags already _packed (a sensor `width` pixels wide)."""
    out = np.empty(len(x), np.uint8)
    arrays = launch.Arrays(ti)
    bits = arrays.put(packed)
    with launch.RUNTIME_LOCK:
        for e0, e1 in launch.pieces(len(x)):
            # on the CPU the kernel writes into out's own (contiguous) slice
            part = arrays.empty(e1 - e0, np.uint8) if arrays.on_device else out[e0:e1]
            _pixel_flags(arrays.put(x[e0:e1]), arrays.put(y[e0:e1]), bits, width, part)
            if arrays.on_device:
                arrays.get(part, out[e0:e1])
    return out.view(bool)
