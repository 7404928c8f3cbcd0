"""Launch of the NDSEF / MR-NDSEF disk counts: runs of frames, scratch, kernel calls.

`count_density` runs the lane kernel of frame_counts (the CPU form) or the event-parallel
kernels of event_counts (the GPU form) over a stream cut into pseudo-frames, and returns
the keep mask and per-radius counts of `evstar_kernels.reference.denoise.mr_ndsef`.
"""
import numpy as np

from ..reference.denoise import disk_rows
from . import event_counts, frame_costs, frame_counts, frame_grids
from .disk_reads import disk_padding
from . import launch

_CELL_DTYPES = {"u16x4": (np.uint64, 4), "i32": (np.int32, 1)}  # dtype, cells per element
_NEVER = np.iinfo(np.int32).max  # a dense_min no frame reaches: direct reads only


def disks(radii):
    """Nested lattice disks as compile-time tuples of (dy, half-width) rows."""
    return tuple(tuple(zip(*(v.tolist() for v in disk_rows(r)))) for r in radii)


def count_density(ti, x, y, width, height, offsets, radii, thresholds, *, strategy, schedule,
                  scratch, on_launch=None, select=None, full=True):
    """(keep bool (n,), counts int32 (n, K) or None) of the events x, y in frames offsets.

    strategy: "auto" (cost model), "sparse" (direct reads) or "dense" (row prefix sums);
    schedule: "lanes" or "events"; scratch: the caller's Scratch; on_launch() is called
    after every kernel launch; select: bool (n,), the events to test (the reference's
    `select`: the others are not kept, their counts -1), None for all; full=False: the
    mask alone (the reference's `full`; counts None: the lane kernel stores radius 1's only,
    which it needs, ~100 MB less memory traffic for 5 M events and 5 radii).
    """
    n = len(x)
    counts = np.empty((n, len(radii) if full else 1), np.int32)
    keep = np.empty(n, np.uint8)
    if n:
        run = _counts_lanes if schedule == "lanes" else _counts_events
        with launch.RUNTIME_LOCK, scratch:
            th = np.asarray(thresholds, np.int32)
            run(ti, (x, y, width, height, select), offsets, disks(radii), (th, _enough(th, full)),
                strategy, scratch, on_launch, counts, keep)
    return keep.view(bool), counts if full else None


def _enough(th, full):
    """Per radius k, the count from which an event is kept uncounted at the larger radii:
    their largest threshold (nested disks: their counts are no lower); never when full."""
    out = np.full(len(th), _NEVER, np.int32)
    if not full:
        out[:-1] = np.maximum.accumulate(th[::-1])[::-1][1:]
    return out


def _counts_lanes(ti, stream, offsets, disks, th, strategy, scratch, on_launch, counts, keep):
    x, y, width, height, select = stream
    th, enough = th
    # the lane kernel skips the events not asked (no count: most of its work)
    ask = np.zeros(1, np.uint8) if select is None else np.asarray(select).view(np.uint8)
    dense_min = {"auto": -1, "sparse": _NEVER, "dense": 0}[strategy]
    threads = launch.cpu_threads(ti)
    key = (disks, width, height, threads)
    cells, prefix_cells, tile_cells = frame_counts.scratch_sizes(disks, width, height)

    def slots_of(name, n, dtype):  # one zeroed part per thread
        return scratch.array(name, key, lambda: np.zeros(threads * n, dtype))

    prefix = slots_of("prefix", prefix_cells, np.int32)
    tiles, repeated = slots_of("tiles", tile_cells, np.uint64), slots_of("repeated", tile_cells, np.uint64)
    owners = slots_of("owners", cells, np.int32)
    masks = scratch.array("masks", key, lambda: frame_counts.tile_masks(disks, width, height))
    busy = np.zeros(threads, np.int32)
    for f0, f1 in launch.frame_launches(offsets):
        e0, e1 = int(offsets[f0]), int(offsets[f1])
        local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
        biggest = int(np.diff(local).max())
        # packed 16-bit cells are exact while no frame holds more than MAX_EVENTS events
        cell = "u16x4" if biggest <= frame_grids.MAX_EVENTS else "i32"
        dtype, per_element = _CELL_DTYPES[cell]
        grid = slots_of(f"grid-{cell}", cells // per_element, dtype)
        room = min(biggest, width * height)  # a frame's pixels, each listed at most once
        repeats, owned = (np.empty(threads * room, np.int32) for _ in range(2))
        lo, hi = launch.units(launch.balanced_cuts(local, 8 * threads), threads)
        kernel = frame_counts.count_frames_kernel(disks, width, height, cell, select is not None,
                                                  counts.shape[1])
        asked = ask if select is None else ask[e0:e1]
        kernel(x[e0:e1], y[e0:e1], asked, local, lo, hi, th, enough, dense_min, grid, prefix, tiles,
               repeated, masks, repeats, owners, owned, busy, counts[e0:e1], keep[e0:e1])
        launch.launched(on_launch)


def _counts_events(ti, stream, offsets, disks, th, strategy, scratch, on_launch, counts, keep):
    x, y, width, height, select = stream
    th, enough = th
    geo = frame_grids.Geometry(width, height, disk_padding(disks))
    direct = frame_costs.direct_costs(disks, geo, "i32")
    dense_min = {"auto": frame_costs.prefix_break_even(direct, disks, geo),
                 "sparse": _NEVER, "dense": 0}[strategy]
    bin_frames, prefix_rows, count, unbin_frames = event_counts.count_events_kernels(disks, width, height)
    arrays = launch.Arrays(ti)
    planes = max(1, launch.EVENT_GRID_BYTES // (4 * (geo.plane + geo.prefix_plane)))
    planes = min(planes, len(offsets) - 1)
    key = (geo, planes, arrays.on_device)
    grid = scratch.array("ev-grid", key, lambda: arrays.put(np.zeros(planes * geo.plane, np.int32)))
    prefix = scratch.array("ev-prefix", key, lambda: arrays.put(np.zeros(planes * geo.prefix_plane, np.int32)))
    th_d, enough_d = arrays.put(th), arrays.put(enough)
    for f0, f1 in launch.frame_launches(offsets):
        e0, e1 = int(offsets[f0]), int(offsets[f1])
        local = (offsets[f0:f1 + 1] - e0).astype(np.int32)
        x_d, y_d, off = arrays.put(x[e0:e1]), arrays.put(y[e0:e1]), arrays.put(local)
        c_d, k_d = arrays.empty((e1 - e0, len(disks)), np.int32), arrays.empty(e1 - e0, np.uint8)
        sizes = np.diff(local)
        for b0 in range(0, f1 - f0, planes):
            b1 = min(b0 + planes, f1 - f0)
            bin_frames(x_d, y_d, off, b0, b1, grid)
            launch.launched(on_launch)
            if np.any(sizes[b0:b1] >= dense_min):
                prefix_rows(off, b0, b1, dense_min, grid, prefix)
            count(x_d, y_d, off, b0, b1, th_d, enough_d, dense_min, grid, prefix, c_d, k_d)
            unbin_frames(x_d, y_d, off, b0, b1, grid)
            launch.launched(on_launch)
        if counts.shape[1] == len(disks):  # else the mask alone: no counts
            arrays.get(c_d, counts[e0:e1])
        arrays.get(k_d, keep[e0:e1])
    if select is not None:  # every event was tested: forget those not asked
        counts[~select] = -1
        keep[~select] = 0
