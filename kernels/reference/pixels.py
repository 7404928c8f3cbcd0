"""Events per pixel in plain numpy: the specification of evstar_kernels.taichi.pixel_counts
(and of the pixels evstar_kernels.taichi.event_warp rounds warped events to)."""
import numpy as np


def pixel_counts(x, y, width, height, keep=None):
    """(events per pixel, those of them `keep` selects or None) as (height, width) int64
    images of the events at integer pixels x, y."""
    pixel = np.asarray(y, np.int64) * width + np.asarray(x, np.int64)
    size = width * height
    every = np.bincount(pixel, minlength=size).reshape(height, width)
    if keep is None:
        return every, None
    return every, np.bincount(pixel[np.asarray(keep, bool)], minlength=size).reshape(height, width)


def pixel_flags(x, y, flags):
    """flags[y, x] (a (height, width) bool image) of every event."""
    return np.asarray(flags, bool)[np.asarray(y, np.intp), np.asarray(x, np.intp)]


def marked_pixels(x, y, keep, width, height):
    """(height, width) bool image: True at the pixel of every event `keep` selects."""
    out = np.zeros((height, width), bool)
    keep = np.asarray(keep, bool)
    out[np.asarray(y)[keep].astype(np.intp), np.asarray(x)[keep].astype(np.intp)] = True
    return out


def on_flagged_pixels(arrays, x, y, flags):
    """[a[sel] for a in arrays], sel: the events at pixels flags[y, x] sets (in order)."""
    sel = np.flatnonzero(pixel_flags(x, y, flags))
    return [np.asarray(a)[sel] for a in arrays]


def events_by_pixel(t, x, y, p, flags):
    """(t, pixel key y·width + x (uint32), p) of the events at pixels flags[y, x] sets (a
    (height, width) bool image), in the pixel-then-time order: time-sorted events stably
    sorted by pixel."""
    t, x, y, p = on_flagged_pixels([t, x, y, p], x, y, flags)
    key = y.astype(np.uint32) * np.uint32(np.shape(flags)[1]) + x
    order = np.argsort(key, kind="stable")
    return t[order], key[order], p[order]


def rounded_pixels(x, y, width, height):
    """(px, py uint16, inside bool) of float coordinates: the pixel i covering [i − ½, i + ½)
    and whether it lies on the width x height sensor (NaN never does); px = py = 0 where not."""
    rx, ry = (np.floor(np.asarray(a, np.float64) + 0.5) for a in (x, y))
    inside = (rx >= 0) & (rx < width) & (ry >= 0) & (ry < height)
    return (*(np.where(inside, r, 0).astype(np.uint16) for r in (rx, ry)), inside)
