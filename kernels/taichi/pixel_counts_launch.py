"""Launch of the pixel counts (launches of at most MAX_LAUNCH_EVENTS events; with a keep
mask the packed halves split, without it int32 counts) and of the per-event pixel flags."""
import numpy as np

from . import launch
from .pixel_counts import count_all_kernel, count_pixels_kernel, pixel_flags as _pixel_flags

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
        for e0 in range(0, len(x), launch.MAX_LAUNCH_EVENTS):
            e1 = min(e0 + launch.MAX_LAUNCH_EVENTS, len(x))
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
        for e0 in range(0, len(x), launch.MAX_LAUNCH_EVENTS):
            e1 = min(e0 + launch.MAX_LAUNCH_EVENTS, len(x))
            cells = arrays.put(np.zeros(width * height, np.int32))
            kernel(arrays.put(x[e0:e1]), arrays.put(y[e0:e1]), width, cells)
            every += cells.to_numpy() if arrays.on_device else cells
    return every.reshape(height, width)


def pixel_flags(ti, x, y, flags):
    """flags[y, x] (bool (height, width)) of every event (bool (n,))."""
    out = np.empty(len(x), np.uint8)
    arrays = launch.Arrays(ti)
    bits = arrays.put(np.packbits(np.asarray(flags, bool).reshape(-1), bitorder="little"))
    with launch.RUNTIME_LOCK:
        for e0 in range(0, len(x), launch.MAX_LAUNCH_EVENTS):
            e1 = min(e0 + launch.MAX_LAUNCH_EVENTS, len(x))
            # on the CPU the kernel writes into out's own (contiguous) slice
            part = arrays.empty(e1 - e0, np.uint8) if arrays.on_device else out[e0:e1]
            _pixel_flags(arrays.put(x[e0:e1]), arrays.put(y[e0:e1]), bits, flags.shape[1], part)
            if arrays.on_device:
                arrays.get(part, out[e0:e1])
    return out.view(bool)
