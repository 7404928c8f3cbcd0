"""Tracks smoothed in pieces across readout stalls, and joined again where the gyro
bridges them.

A stall (evstar.frames.stalls: no event at all for over a frame) longer than coast_ms,
across which a track's centroids lie over twice coast_ms apart (so no frame of it is
reported there), cuts the track into pieces that the estimator fits apart: bridged, the
along fit honoured the gyro's turn across the stall, which a 250 ms stall took 0.012 ->
0.221 px off (P10 of perf/study_indep.py --fresh9). Where the prior's turn carries the
star from one piece's last measured position to the next one's first within BRIDGE_SIGMAS
of their σ, the pieces are joined and fitted across as before (P5's 150 ms stall: 0.015
px joined, 0.053 apart). A star's own silence, as at a slow turn, never cuts: the gyro
knows the turn (cut there, a ramp's turn went 0.037 -> 0.182 px). Pieces are tracks of
their own while fitted (ids above the run's) and carry their track's id in the rows.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: a stall is bridged (one fit across it) where the prior's turn carries a piece's last
#: measured position to the next one's first within this many of their σ (bridged)
BRIDGE_SIGMAS = 3.0


def cut(centroids, gap_us, stalls=None):
    """(`centroids` with each track cut where two of its centroids lie more than `gap_us`
    (twice coast_ms) apart across a readout stall of over half that (`stalls`: (n, 2) µs
    spans without events, frames.stalls), each later piece a track of its own; {piece's id:
    its track's})."""
    tracked = np.flatnonzero(centroids["track"] >= 0)
    if stalls is not None:
        stalls = stalls[stalls[:, 1] - stalls[:, 0] > gap_us / 2]   # over coast_ms
    if stalls is None or not len(stalls) or not len(tracked):
        return centroids, {}
    order = tracked[np.lexsort((centroids["t"][tracked], centroids["track"][tracked]))]
    tr, t = centroids["track"][order], centroids["t"][order]
    # a stall overlapping the time between two consecutive centroids: the first stall
    # ending after the earlier one begins before the later (centroids of compensated
    # frames carry the frame's mid-time, which may lie inside the stall)
    k = np.minimum(np.searchsorted(stalls[:, 1], t[:-1], side="right"), len(stalls) - 1)
    held = (stalls[k, 1] > t[:-1]) & (stalls[k, 0] < t[1:])
    split = (tr[1:] == tr[:-1]) & (np.diff(t) > gap_us) & held
    if not split.any():
        return centroids, {}
    start = np.r_[True, tr[1:] != tr[:-1]]               # a track's first row
    piece = np.cumsum(np.r_[False, split | start[1:]])      # each row's piece, ascending
    later = piece != np.maximum.accumulate(np.where(start, piece, 0))   # not its first
    ids = int(centroids["track"].max()) + 1 + piece
    new = centroids.copy()
    new["track"][order[later]] = ids[later]
    owner = {int(i): int(o) for i, o in zip(ids[later], tr[later])}
    return new, owner


class Gap(NamedTuple):
    """A stall between two pieces of a track (bridged)."""
    track: int
    t_before: int        # µs: the piece before's last measured row
    t_after: int         # µs: this piece's first
    miss_px: float       # how far the prior's turn across it leaves the one from the other
    bridged: bool


def bridged(est, owner, velocity_prior):
    """{later piece (cut): its Gap}: miss, how far the velocity prior's turn over the stall (and the piece
    before's own residual velocity, a gyro bias) leaves the piece before's last measured
    position from this one's first; bridged where that is within BRIDGE_SIGMAS of their σ
    and the prior's walk — a gyro that bridged a 150 ms stall well had kept a dark-sky
    sinusoid at 0.015 px (0.053 in pieces), one that did not put another 0.221 px off (P5,
    P10 of perf/study_indep.py --fresh9). Without a prior, {}."""
    from .smoothing import diffusion, prior_displacement, prior_velocity

    if velocity_prior is None:
        return {}
    measured = est[~est["coasted"]]
    ends = {int(tr): (measured[measured["track"] == tr][[0, -1]])
            for tr in np.unique(measured["track"])}
    out = {}
    for piece, track in owner.items():
        before = _before(piece, track, owner)
        if piece not in ends or before not in ends:
            continue
        a, b = ends[before][-1], ends[piece][0]
        za, zb = np.array([a["x"], a["y"]]), np.array([b["x"], b["y"]])
        t = np.array([a["t"], b["t"]])
        shift = prior_displacement(velocity_prior, t, t, np.vstack([za, zb]))[1]
        # the piece's own velocity less the prior's: a gyro bias, carried across
        bias = np.array([a["vx"], a["vy"]]) - prior_velocity(velocity_prior, t[:1], za[:1],
                                                              za[1:])[0]
        miss = float(np.hypot(*(zb - za - shift - bias * (t[1] - t[0]) * 1e-6)))
        var = (a["sigma_x"] ** 2 + a["sigma_y"] ** 2 + b["sigma_x"] ** 2 + b["sigma_y"] ** 2) / 2 \
            + diffusion(velocity_prior) * (t[1] - t[0]) * 1e-6
        out[piece] = Gap(track, int(t[0]), int(t[1]), miss, miss <= BRIDGE_SIGMAS * np.sqrt(var))
    return out


def coasted_honestly(rows, gaps, limit_px):
    """`rows` less the rows coasted into an unbridged stall (bridged's Gaps) whose σ, widened by the prior's miss across the stall
    pro rata to how far into it they lie (from the nearer side), exceeds limit_px
    (coast_sigma_px); the others with that σ. Coasted 60 ms into a 250 ms stall from either
    side on the gyro alone, rows had lain up to 1.6 px off with σ of a few hundredths."""
    gaps = [g for g in gaps if not g.bridged]
    if not gaps or not len(rows):
        return rows
    rows = rows.copy()
    keep = np.ones(len(rows), bool)
    coasted = rows["source"] == "coasted"
    for track, t_a, t_b, miss, _ in gaps:
        inside = coasted & (rows["track"] == track) & (rows["t"] > t_a) & (rows["t"] < t_b)
        depth = np.minimum(rows["t"][inside] - t_a, t_b - rows["t"][inside]) / (t_b - t_a)
        sigma = np.hypot(rows["sigma"][inside], miss * depth)
        rows["sigma"][inside] = sigma
        keep[np.flatnonzero(inside)[sigma > limit_px]] = False
    return rows[keep]


def _before(piece, track, owner):
    """The piece of `track` just before `piece` (its track's own id for the first)."""
    earlier = [p for p, t in owner.items() if t == track and p < piece]
    return max(earlier) if earlier else track


def rejoined(centroids, split, owner):
    """(`centroids` cut only where `owner` still holds a piece: each other piece joined to
    the one before it, the new owner map)."""
    labels = split["track"].copy()
    kept = {}
    for piece in sorted(set(labels[labels >= 0].tolist()) - set(centroids["track"].tolist())):
        if piece in owner:
            kept[piece] = owner[piece]
            continue
        # joined: to the latest kept piece of its track before it, else the track itself
        labels[labels == piece] = _before(piece, int(centroids["track"][labels == piece][0]),
                                          kept)
    out = split.copy()
    out["track"] = labels
    return out, kept


def owned(rows, owner, by_track=False):
    """`rows` with each piece's track id (cut) its track's again, in their order or, by_track,
    in track-then-time order (smoothed rows)."""
    if not owner or not len(rows):
        return rows
    rows = rows.copy()
    ids = rows["track"]
    for piece, track in owner.items():
        ids[ids == piece] = track
    return rows[np.lexsort((rows["t"], rows["track"]))] if by_track else rows
