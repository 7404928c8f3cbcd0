"""A slow star's two lobes: one target that DBSCAN sees as two clusters.

A star moving a fraction of a pixel per frame fires ON events where its leading flank
brightens the pixels and OFF events where its trailing flank darkens them; its centre,
where the intensity barely changes, fires almost nothing. With a wide PSF (σ ≳ 1.2 px) the
gap between the two flanks exceeds eps and the star becomes an ON-only and an OFF-only
cluster about 3.5 σ apart, each reported as a star ~1.7 σ off the truth (one of them false).
Here such pairs — mutual nearest, of opposite dominant polarity, in the same frame, closer
than ``extract.lobe_gap_px`` — are joined into one cluster. A moving star's own cluster
holds both polarities, so it never pairs with a neighbour's lobe.
"""
from __future__ import annotations

import numpy as np

from .frames import nearest_in_frame

#: a cluster is one polarity's lobe when at least this share of its events has it
PURITY = 2 / 3


def pairs(frame, n_by_p, sx, sy, max_px):
    """(ON lobes, OFF lobes): index arrays of the cluster pairs to join. frame: frame per
    cluster; n_by_p, sx, sy: per-cluster (OFF, ON) event counts and coordinate sums."""
    n = n_by_p.sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        on_share = n_by_p[:, 1] / n
        xy = np.column_stack([sx.sum(1) / n, sy.sum(1) / n])
    on, off = np.flatnonzero(on_share >= PURITY), np.flatnonzero(on_share <= 1 - PURITY)
    if not len(on) or not len(off):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    _, j = nearest_in_frame(xy[off], frame[off], xy[on], frame[on], max_px)
    _, i = nearest_in_frame(xy[on], frame[on], xy[off], frame[off], max_px)
    found = j < len(off)                     # query's "none within the bound" is len(off)
    mutual = np.zeros(len(on), bool)
    mutual[found] = i[j[found]] == np.arange(len(on))[found]
    return on[mutual], off[j[mutual]]


def join(m, frame, labels, a, b):
    """Cluster moments, frame per cluster and event labels with each cluster b[i] joined
    into a[i] (the b rows removed, labels renumbered in order)."""
    k = len(frame)
    kept = np.ones(k, bool)
    kept[b] = False
    new_id = np.cumsum(kept) - 1
    lookup = new_id.copy()
    lookup[b] = new_id[a]
    out = {}
    for key, v in m.items():
        v = v.copy()
        if key == "box":
            v[a, 0::2] = np.minimum(v[a, 0::2], v[b, 0::2])
            v[a, 1::2] = np.maximum(v[a, 1::2], v[b, 1::2])
        else:
            v[a] += v[b]
        out[key] = v[kept]
    labels = np.where(labels >= 0, lookup[np.maximum(labels, 0)], -1)
    return out, frame[kept], labels
