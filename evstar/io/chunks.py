"""Re-slice a stream of event packets into fixed time windows with bounded memory."""
from __future__ import annotations

import numpy as np

from ..errors import DataError, ParameterError
from ..events import SORT_HINT, Events


def windows(packets, width, height, window_us, t_origin_us=None):
    """Yield (k, Events) for window k = [t0 + k·w, t0 + (k+1)·w); empty windows are skipped.

    `packets` yields (t, x, y, p) array tuples in time order; memory holds one window plus
    one packet. Time going back (within or between packets) is a DataError naming the
    event's index in the whole stream.
    """
    if window_us <= 0:
        raise ParameterError(f"window_us must be positive, got {window_us}")
    pending = []
    k = None
    t0 = t_origin_us
    seen, last = 0, None          # events read so far, the last one's time
    for t, x, y, p in packets:
        if len(t) == 0:
            continue
        _check_order(t, seen, last)
        seen, last = seen + len(t), int(t[-1])
        if t0 is None:
            t0 = int(t[0])
        ks = (t - t0) // window_us
        if k is None:
            k = int(ks[0])
        while len(t):
            cut = int(np.searchsorted(ks, k, side="right"))
            if cut:
                pending.append((t[:cut], x[:cut], y[:cut], p[:cut]))
            if cut == len(t):
                break
            if pending:
                yield k, _join(pending, width, height)
            pending = []
            t, x, y, p, ks = t[cut:], x[cut:], y[cut:], p[cut:], ks[cut:]
            k = int(ks[0])
    if pending:
        yield k, _join(pending, width, height)


def _check_order(t, seen, last):
    """DataError where timestamps decrease in this packet (its first event at stream index
    `seen`) or from the previous packet's last time `last` to its first."""
    t = np.asarray(t)
    down = np.flatnonzero(np.diff(t) < 0) + 1
    if last is not None and int(t[0]) < last:
        i, before = 0, last
    elif len(down):
        i, before = int(down[0]), int(t[down[0] - 1])
    else:
        return
    raise DataError(f"event timestamps decrease at index {seen + i} ({before} -> {int(t[i])} µs); "
                    + SORT_HINT)


def _join(parts, width, height):
    cols = [np.concatenate(c) for c in zip(*parts)]
    return Events(*cols, width, height)
