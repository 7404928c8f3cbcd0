"""Launch of the Taichi counting sort: keys in, stable sorting permutation out."""
import numpy as np

from . import launch
from .sorting import stable_order as _stable_order

#: the kernel's loop bounds and run starts are i32: larger sorts go to numpy
_I32 = 1 << 31


def stable_order(ti, key, n_keys):
    """np.argsort(key, kind="stable") of uint32 keys below n_keys (int64 permutation)."""
    key = np.ascontiguousarray(key, np.uint32)
    arrays = launch.Arrays(ti)
    if max(len(key), n_keys) >= _I32:
        return np.argsort(key, kind="stable")
    start = arrays.put(np.zeros(n_keys + 1, np.int32))
    order = arrays.empty(len(key), np.int64)
    if len(key):
        with launch.RUNTIME_LOCK:
            _stable_order(arrays.put(key), start, order)
    return order.to_numpy() if arrays.on_device else order   # no copy on the CPU
