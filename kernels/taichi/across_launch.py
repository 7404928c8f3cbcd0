"""Launch of the across-offset histograms: one launch, its loop over frames."""
import numpy as np

from . import launch
from .across import across_counts_kernel

#: the CPU loop runs serially: two threads' atomic adds into one track's bins contend (the
#: 50-star EVK4 field: ~equal times, more spread)
SERIAL = True


def across_counts(ti, t, x, y, t0_us, dt_us, cell_shift, cells_w, start, pair_track, tracks,
                  table, rows, along_px, reach_px, bin_px, nb):
    """reference.across.across_counts: (n_tracks, nb) int64 counts; t time-ordered."""
    if not len(tracks) or not len(t):
        return np.zeros((len(tracks), nb), np.int64)
    arrays = launch.Arrays(ti)
    first, last = (int(t[0]) - t0_us) // dt_us, (int(t[-1]) - t0_us) // dt_us
    bounds = np.searchsorted(t, t0_us + np.arange(first, last + 2) * dt_us)
    counts = arrays.put(np.zeros(len(tracks) * nb, np.int64))
    args = [arrays.put(np.asarray(a, d)) for a, d in
            ((t, np.int64), (x, np.uint16), (y, np.uint16), (bounds, np.int64))]
    tables = [arrays.put(np.asarray(a, d)) for a, d in
              ((start, np.int64), (pair_track, np.int32), (tracks, np.int64), (table, np.int32),
               (rows, np.float64))]
    with launch.RUNTIME_LOCK:
        across_counts_kernel(SERIAL and not arrays.on_device)(
            *args, first, int(cell_shift), int(cells_w), *tables, float(along_px),
            float(reach_px), float(bin_px), int(nb), counts)
    return (counts.to_numpy() if arrays.on_device else counts).reshape(len(tracks), nb)
