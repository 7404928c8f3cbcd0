"""Launch of the across-offset histograms: launches of whole frames, each loop over frames."""
import numpy as np

from . import launch
from .across import across_counts_kernel

#: the CPU loop runs serially: two threads' atomic adds into one track's bins contend (the
#: 50-star EVK4 field: ~equal times, more spread)
SERIAL = True


def across_counts(ti, t, x, y, t0_us, dt_us, cell_shift, cells_w, start, pair_track, tracks,
                  table, rows, along_px, reach_px, bin_px, nb):
    """reference.across.across_counts: (n_tracks, nb) int64 counts; t time-ordered. Runs of
    whole frames of at most MAX_LAUNCH_EVENTS events a launch (i32 loop bounds)."""
    if not len(tracks) or not len(t):
        return np.zeros((len(tracks), nb), np.int64)
    arrays = launch.Arrays(ti)
    first, last = (int(t[0]) - t0_us) // dt_us, (int(t[-1]) - t0_us) // dt_us
    offsets = np.searchsorted(t, t0_us + np.arange(first, last + 2) * dt_us)
    total = np.zeros(len(tracks) * nb, np.int64)
    tables = [arrays.put(np.asarray(a, d)) for a, d in
              ((start, np.int32), (pair_track, np.int32), (tracks, np.int64), (table, np.int32),
               (rows, np.float64))]
    kernel = across_counts_kernel(SERIAL and not arrays.on_device)
    with launch.RUNTIME_LOCK:
        for f0, f1 in launch.frame_launches(offsets):
            e0, e1 = offsets[f0], offsets[f1]
            counts = arrays.put(np.zeros(len(tracks) * nb, np.int64))
            kernel(arrays.put(np.asarray(t[e0:e1], np.int64)),
                   arrays.put(np.asarray(x[e0:e1], np.uint16)),
                   arrays.put(np.asarray(y[e0:e1], np.uint16)),
                   arrays.put((offsets[f0:f1 + 1] - e0).astype(np.int32)), first + f0,
                   int(cell_shift), int(cells_w), *tables, float(along_px), float(reach_px),
                   float(bin_px), int(nb), counts)
            total += counts.to_numpy() if arrays.on_device else counts
    return total.reshape(len(tracks), nb)
