"""What the Taichi launchers share: launch sizes, device arrays, lane work units.

Module settings (tests shrink them to exercise many launches and batches):
MAX_LAUNCH_EVENTS, EVENT_GRID_BYTES, DEVICE_ARRAYS.
"""
import threading

import numpy as np

#: Taichi loop bounds are i32: one launch takes at most this many events
MAX_LAUNCH_EVENTS = 1 << 30
#: scratch planes of the event-parallel forms, per batch
EVENT_GRID_BYTES = 256 << 20
#: tests set True to run the CUDA data path (ti.ndarray) on the CPU
DEVICE_ARRAYS = False
#: Taichi's runtime is one per process and not thread-safe (a kernel called while another
#: thread's kernel compiles or runs fails), so the launchers' calls take turns
RUNTIME_LOCK = threading.Lock()


class Arrays:
    """Numpy arrays as the kernels take them: as they are on the CPU (no copy), copied into
    Taichi ndarrays on a GPU — once per launch, so the data stay resident across kernels."""

    def __init__(self, ti):
        self.ti = ti
        self.on_device = ti.lang.impl.current_cfg().arch != ti.cpu or DEVICE_ARRAYS

    def put(self, arr):
        arr = np.ascontiguousarray(arr)
        if not self.on_device:
            return arr
        dev = self.empty(arr.shape, arr.dtype)
        dev.from_numpy(arr)
        return dev

    def empty(self, shape, dtype):
        if not self.on_device:
            return np.empty(shape, dtype)
        return self.ti.ndarray(dtype=self.ti.lang.util.to_taichi_type(np.dtype(dtype)), shape=shape)

    def get(self, dev, out, skip=0):
        """Copy dev[skip:] into out."""
        out[...] = (dev if not self.on_device else dev.to_numpy())[skip:]


def pieces(n, size=None):
    """(start, stop) of consecutive launches over n events, each at most `size`
    (MAX_LAUNCH_EVENTS) long."""
    size = MAX_LAUNCH_EVENTS if size is None else size
    return [(a, min(a + size, n)) for a in range(0, n, size)]


def cpu_threads(ti):
    return max(1, int(ti.lang.impl.current_cfg().cpu_max_num_threads))


def units(bounds, n_threads, *per_piece):
    """Spread work pieces (bounds[j]..bounds[j+1]) over the iterations of a lane loop.

    Taichi's CPU loops give each thread a contiguous block of >= 512 iterations, so the
    loop has 512 iterations per thread and piece j sits at iteration j·U/n_pieces; the
    other iterations are empty (lo == hi). Extra per-piece arrays are spread the same way
    and returned first.
    """
    n_pieces = len(bounds) - 1
    n_iter = max(512 * n_threads, n_pieces)
    at = (np.arange(n_pieces, dtype=np.int64) * n_iter) // max(n_pieces, 1)
    out = []
    for values in (*per_piece, bounds[:-1], bounds[1:]):
        arr = np.zeros(n_iter, np.int32)
        arr[at] = values
        out.append(arr)
    return out


def balanced_cuts(cum, n_pieces):
    """Indices into `cum` (non-decreasing work prefix) cutting it into ~equal pieces."""
    targets = np.linspace(cum[0], cum[-1], n_pieces + 1)
    cuts = np.searchsorted(cum, targets, side="left")
    cuts[0], cuts[-1] = 0, len(cum) - 1
    return np.unique(cuts)


def frame_launches(offsets, max_events=None):
    """Runs of whole frames holding at most max_events events (a bigger frame goes alone)."""
    max_events = MAX_LAUNCH_EVENTS if max_events is None else max_events
    n_frames = len(offsets) - 1
    f0 = 0
    while f0 < n_frames:
        f1 = int(np.searchsorted(offsets, offsets[f0] + max_events, side="right")) - 1
        f1 = min(max(f1, f0 + 1), n_frames)
        yield f0, f1
        f0 = f1


def launched(on_launch):
    """Tell the caller's hook (if any) that a kernel launch has returned."""
    if on_launch is not None:
        on_launch()
