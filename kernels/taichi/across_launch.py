"""Launch of the across-offset histograms: launches of whole frames, each in lanes of frames
(the CPU: one per thread, each with its own histogram, summed here; a GPU: one per frame)."""
import numpy as np

from . import launch
from .across import across_counts_kernel


def across_counts(ti, t, x, y, t0_us, dt_us, cell_shift, cells_w, start, pair_track, tracks,
                  table, rows, along_px, reach_px, bin_px, nb):
    """reference.across.across_counts: (n_tracks, nb) int64 counts; t time-ordered. Runs of
    whole frames of at most MAX_LAUNCH_EVENTS events a launch (i32 loop bounds)."""
    if not len(tracks) or not len(t):
        return np.zeros((len(tracks), nb), np.int64)
    arrays = launch.Arrays(ti)
    first, last = (int(t[0]) - t0_us) // dt_us, (int(t[-1]) - t0_us) // dt_us
    offsets = np.searchsorted(t, t0_us + np.arange(first, last + 2) * dt_us)
    size = len(tracks) * nb
    total = np.zeros(size, np.int64)
    tables = [arrays.put(np.asarray(a, d)) for a, d in
              ((start, np.int32), (pair_track, np.int32), (tracks, np.int64),
               (_slots(table, rows), np.float64))]
    kernel = across_counts_kernel(not arrays.on_device)
    with launch.RUNTIME_LOCK:
        for f0, f1 in launch.frame_launches(offsets):
            e0, e1 = offsets[f0], offsets[f1]
            local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
            lane, lo, hi = _lanes(ti, local, arrays.on_device)
            counts = arrays.put(np.zeros(int(lane.max()) * size + size, np.int64))
            kernel(arrays.put(np.asarray(t[e0:e1], np.int64)),
                   arrays.put(np.asarray(x[e0:e1], np.uint16)),
                   arrays.put(np.asarray(y[e0:e1], np.uint16)), arrays.put(local),
                   arrays.put(lane), arrays.put(lo), arrays.put(hi), first + f0,
                   int(cell_shift), int(cells_w), *tables, float(along_px), float(reach_px),
                   float(bin_px), int(nb), size, counts)
            total += (counts.to_numpy() if arrays.on_device else counts).reshape(-1, size).sum(0)
    return total.reshape(len(tracks), nb)


def _slots(table, rows):
    """rows at the table's slots (a track's row of each of its frames), zeros (away 0: no
    count) where it has none."""
    rows = np.asarray(rows, np.float64)
    table = np.asarray(table)
    out = np.zeros((len(table), rows.shape[1]))
    have = table >= 0
    out[have] = rows[table[have]]
    return out


def _lanes(ti, offsets, on_device):
    """(lane, lo, hi) of the kernel's loop: on a GPU a frame an iteration, all into
    histogram 0; on the CPU the frames cut into a run of ~equal events per thread, each
    run its own histogram, spread so that each thread's iterations hold one
    (launch.units)."""
    n_frames = len(offsets) - 1
    if on_device:
        frames = np.arange(n_frames, dtype=np.int32)
        return np.zeros(n_frames, np.int32), frames, frames + 1
    threads = launch.cpu_threads(ti)
    cuts = launch.balanced_cuts(offsets, threads)
    return launch.units(cuts.astype(np.int32), threads, np.arange(len(cuts) - 1, dtype=np.int32))
