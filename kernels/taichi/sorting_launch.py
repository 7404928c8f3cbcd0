"""Launch of the Taichi counting sort: keys in, stable sorting permutation (or the values
in that order) out."""
import numpy as np

from . import launch
from .sorting import sorted_values as _sorted_values, stable_order as _stable_order

#: the kernel's loop bounds and run starts are i32: larger sorts go to numpy
_I32 = 1 << 31


def stable_order(ti, key, n_keys):
    """np.argsort(key, kind="stable") of uint32 keys below n_keys (int64 permutation)."""
    key = np.ascontiguousarray(key, np.uint32)
    if not len(key):   # no kernel: a device array cannot be empty (a GPU run failed here)
        return np.zeros(0, np.int64)
    arrays = launch.Arrays(ti)
    if max(len(key), n_keys) >= _I32:
        return np.argsort(key, kind="stable")
    start = arrays.put(np.zeros(n_keys + 1, np.int32))
    order = arrays.empty(len(key), np.int64)
    with launch.RUNTIME_LOCK:
        _stable_order(arrays.put(key), start, order)
    return order.to_numpy() if arrays.on_device else order   # no copy on the CPU


def counting_sort(ti, key, value, n_keys):
    """(value in the stable order of uint32 keys below n_keys (int64 values), the count of
    each key)."""
    key, value = np.ascontiguousarray(key, np.uint32), np.ascontiguousarray(value, np.int64)
    if not len(key):
        return value, np.zeros(n_keys, np.int64)
    if max(len(key), n_keys) >= _I32:
        return value[np.argsort(key, kind="stable")], np.bincount(key, minlength=n_keys)
    arrays = launch.Arrays(ti)
    end = arrays.put(np.zeros(n_keys + 1, np.int32))
    out = arrays.empty(len(key), np.int64)
    with launch.RUNTIME_LOCK:
        _sorted_values(arrays.put(key), arrays.put(value), end, out)
    if arrays.on_device:
        end, out = end.to_numpy(), out.to_numpy()
    return out, np.diff(end[:n_keys], prepend=0)
