"""Multi-target tracking: link centroids across pseudo-frames into tracks.

Each track predicts its next position with a constant-velocity model (from its last two
centroids); centroids of a frame are assigned to tracks by minimum total distance
(Hungarian, scipy) within a gate. A track survives up to ``max_gap`` frames without a
centroid (a star fading or crossing a dead region keeps its id); unassigned centroids
start new tracks, so stars entering the field get fresh ids.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from .errors import ParameterTypeError
from .frames import frame_bounds
from .parameters import TRACK as T

_NEEDED = ("x", "y", "frame", "track")  # the centroid fields linking reads and writes


class Tracker:
    def __init__(self, gate_px=T["gate_px"].default, init_gate_px=T["init_gate_px"].default,
                 max_gap=T["max_gap"].default, min_length=T["min_length"].default):
        self.gate_px = float(T.check("gate_px", gate_px))
        self.init_gate_px = float(T.check("init_gate_px", init_gate_px))
        self.max_gap, self.min_length = T.check("max_gap", max_gap), T.check("min_length", min_length)

    def link(self, centroids):
        """Return a copy of `centroids` with the ``track`` field filled (time-sorted input).

        Tracks shorter than ``min_length`` centroids get track = -1 (unconfirmed).
        """
        fields = getattr(getattr(centroids, "dtype", None), "names", None) or ()
        if not isinstance(centroids, np.ndarray) or not set(_NEEDED) <= set(fields):
            raise ParameterTypeError("centroids must be a structured array with fields "
                                     f"{', '.join(_NEEDED)} (evstar.extract.CENTROID_DTYPE), "
                                     f"got {type(centroids).__name__}")
        out = centroids.copy()
        order = np.argsort(out["frame"], kind="stable")
        frames, starts, stops = frame_bounds(out["frame"][order])
        tracks = []  # dicts: id, frames [..], xy [..]
        live = []    # the tracks that can still take a centroid, in order of creation
        next_id = 0
        for f, a, b in zip(frames, starts, stops):
            rows = order[a:b]
            # frames only grow: a track past its gap never comes back
            live = [tr for tr in live if f - tr["frames"][-1] <= self.max_gap + 1]
            pts = np.column_stack([out["x"][rows], out["y"][rows]])
            pairs = self._assign(live, pts, f)
            taken = set()
            for ti, ri in pairs:
                live[ti]["frames"].append(f)
                live[ti]["xy"].append(pts[ri])
                out["track"][rows[ri]] = live[ti]["id"]
                taken.add(ri)
            for ri in range(len(rows)):
                if ri not in taken:
                    tracks.append({"id": next_id, "frames": [f], "xy": [pts[ri]]})
                    live.append(tracks[-1])
                    out["track"][rows[ri]] = next_id
                    next_id += 1
        _join(out, tracks, self.gate_px, self.max_gap)
        return _drop_short(out, self.min_length)

    def _assign(self, live, pts, f):
        if not live or not len(pts):
            return []
        pred = _predict(live, f)
        gates = np.array([self.gate_px if len(tr["xy"]) > 1 else self.init_gate_px for tr in live])
        cost = np.linalg.norm(pred[:, None, :] - pts[None, :, :], axis=2)
        big = 1e9
        masked = np.where(cost <= gates[:, None], cost, big)
        ti, ri = linear_sum_assignment(masked)
        return [(t, r) for t, r in zip(ti, ri) if masked[t, r] < big]


def _predict(tracks, f):
    """(n, 2) positions at frame f: constant velocity from each track's last two centroids
    (per frame), else where it is; all tracks at once."""
    last = np.array([tr["xy"][-1] for tr in tracks])
    two = np.array([len(tr["xy"]) > 1 for tr in tracks])
    prev = np.array([tr["xy"][-2] if len(tr["xy"]) > 1 else tr["xy"][-1] for tr in tracks])
    f_last = np.array([tr["frames"][-1] for tr in tracks])
    f_prev = np.array([tr["frames"][-2] if len(tr["frames"]) > 1 else tr["frames"][-1] - 1
                       for tr in tracks])
    v = (last - prev) / (f_last - f_prev)[:, None]
    return np.where(two[:, None], last + v * (f - f_last)[:, None], last)


def _join(out, tracks, gate_px, max_gap):
    """Relabel a track that starts where another just ended as that one (in place): a star
    that stops and turns back (a slew's turnaround) can give two centroids in one frame,
    one of which goes on alone and ends its track while the other starts a new one. B joins
    A when B's first frame is at most one frame before, or max_gap + 1 after, A's last one
    and B's first centroid lies within gate_px of A's last; the nearest A wins."""
    ends = {}
    for tr in sorted(tracks, key=lambda tr: tr["frames"][0]):
        first = tr["frames"][0]
        # an end too far behind this track is so for every later one (first frames only grow)
        ends = {k: a for k, a in ends.items() if first - a["frames"][-1] <= max_gap + 1}
        best, best_d = None, gate_px
        for a in ends.values():
            if first - a["frames"][-1] < -1 or a["frames"][0] >= first:
                continue
            d = float(np.linalg.norm(tr["xy"][0] - a["xy"][-1]))
            if d <= best_d:
                best, best_d = a, d
        if best is None:
            ends[tr["id"]] = tr
            continue
        out["track"][out["track"] == tr["id"]] = best["id"]
        best["frames"] += tr["frames"]
        best["xy"] += tr["xy"]


def _drop_short(out, min_length):
    ids, counts = np.unique(out["track"], return_counts=True)
    short = ids[counts < min_length]
    out["track"][np.isin(out["track"], short)] = -1
    # renumber confirmed tracks 0, 1, 2 ... in order of appearance
    confirmed = out["track"] >= 0
    _, first = np.unique(out["track"][confirmed], return_index=True)
    old = out["track"][confirmed][np.sort(first)]
    remap = {o: n for n, o in enumerate(old)}
    out["track"][confirmed] = [remap[v] for v in out["track"][confirmed]]
    return out
