"""Launch of the Taichi event-warping kernel: host arrays in, warped float coordinates out."""
import numpy as np

from . import launch
from .event_warp import BLOCK, warp_events


def warp_to_reference(ti, t, x, y, ref_index, ref_q, node_t, node_q, node_phi, camera_params,
                      undistort_iterations, sensor=(0, 0)):
    """Warped coordinates xy float64 (n, 2) and their rounded pixels (px, py uint16, inside
    bool) on the sensor (width, height); camera_params = (fx, fy, cx, cy, k1, k2). Event
    arrays are read as they are (int64 t, uint16 or float x, y: no conversion copies)."""
    arrays = launch.Arrays(ti)
    n = len(t)
    out = [np.empty((n, 2)), np.empty(n, np.uint16), np.empty(n, np.uint16), np.empty(n, np.uint8)]
    track = [arrays.put(np.asarray(a, np.float64)) for a in (ref_q, node_t, node_q, node_phi)]
    for a, b in launch.pieces(n):
        ev = ([arrays.put(v[a:b]) for v in (t, x, y)]
              + [arrays.put(_starts(t[a:b], node_t)), arrays.put(np.asarray(ref_index[a:b], np.int32))])
        dev = [o[a:b] if not arrays.on_device else arrays.empty(o[a:b].shape, o.dtype)
               for o in out]
        with launch.RUNTIME_LOCK:
            warp_events(*ev, *track, *map(float, camera_params), int(undistort_iterations),
                        *map(int, sensor), *dev, int(undistort_iterations) > 0)
        if arrays.on_device:
            for d, o in zip(dev, out):
                arrays.get(d, o[a:b])
    return (*out[:3], out[3].view(bool))


def _starts(t, node_t):
    """Per block of BLOCK events the last node at or before its earliest time (−1 if none):
    where each event's search for its node begins (any order of times)."""
    if not len(t):
        return np.zeros(1, np.int32)
    # the minima of the times as they are (int64 µs: exact as floats), then floats
    first = np.minimum.reduceat(np.asarray(t), np.arange(0, len(t), BLOCK)).astype(np.float64)
    return (np.searchsorted(np.asarray(node_t, np.float64), first, side="right") - 1).astype(np.int32)
