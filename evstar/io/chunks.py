"""Re-slice a stream of event packets into fixed time windows with bounded memory."""
from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..events import Events


def windows(packets, width, height, window_us, t_origin_us=None):
    """Yield (k, Events) for window k = [t0 + k·w, t0 + (k+1)·w); empty windows are skipped.

    `packets` yields (t, x, y, p) array tuples in time order; memory holds one window plus
    one packet.
    """
    if window_us <= 0:
        raise ParameterError(f"window_us must be positive, got {window_us}")
    pending = []
    k = None
    t0 = t_origin_us
    for t, x, y, p in packets:
        if len(t) == 0:
            continue
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


def _join(parts, width, height):
    cols = [np.concatenate(c) for c in zip(*parts)]
    return Events(*cols, width, height)
