"""Two stars along the motion in one pulse: the brighter star placed by its crossings' top
levels.

Two stars 2–4 px apart along their motion pass each pixel of their common path in one
pulse, so each such pixel gives one crossing (evstar.crossings) whose mean level-pair
midpoint lies between them, and the fainter star's own crossings beside the path pull the
track further: the track follows their blend, 0.4–1.5 px from the brighter star (an Orion
pan's close stars, docs/measurements.md). The crossing's top level pair is the brighter
star's peak alone, so its midpoint is when that star passed the pixel.

Per crossing near a track's centre line (within CENTRE_PX across, at least 2 level pairs)
the pixel's offset along the motion from the track's own path where it was at that top
midpoint's time, less the median over the other such tracks of theirs at as many pairs
(± LEVEL_WINDOW; what the sensor does to a single star's top level: its thresholds, its
timing), is where the brighter star lies off the track. Per track the median of these: a
single star's sits within ~0.04 px of 0, a blend's 0.2–1.5 px off. A track whose median
stands MIN_SHIFT_PX and SHIFT_SES standard errors off, but no further than MAX_SHIFT_PX,
is moved by it along its motion, its σ widened by SIGMA_SHARE of the move (the top pair
still feels the fainter star: 20–45 % of the offset is left). The offsets are the path's
own, not those of the estimator's earlier path that assigned the crossings to tracks: on a
slew that one strays from the final path by up to ~1.5 px and back, and single stars had
moved with it (why an earlier form of this step was kept off where the speed changes).

Only where it holds: tracks with MIN_CROSSINGS such crossings that keep their direction
(evstar.pairs.MAX_TURN_DEG), MIN_REFERENCES other such tracks, and runs whose crossings
are not moved for a pixel lag (estimation's PixelLag: on a low-pass sensor the top level
lags less than the mean by an amount that differs star by star, which moved single stars
0.2–0.4 px the wrong way on an EVK4 dark-sky pan at 20 °/s). The fainter star is not found.
"""
from __future__ import annotations

import numpy as np

from . import paths
from .pairs import MAX_TURN_DEG
from .robust import robust_sigma

#: crossings within this of a track's path across its motion (px): its centre line
CENTRE_PX = 1.0
#: the fewest level pairs of a crossing whose top pair is not its mean
MIN_LEVELS = 2
#: the fewest centre-line crossings that place a track's brighter star (20: a roll's or a
#: 2 °/s pan's 10–35 px paths; 60 left them all at their blends, 0.2–0.5 px, and with
#: offsets from the track's own path the standard-error test holds single stars there);
#: the fewest other tracks, each with PER_LEVEL crossings of a number of level pairs, that
#: give the reference at that number
MIN_CROSSINGS, MIN_REFERENCES, PER_LEVEL = 20, 3, 5
#: the reference at k level pairs pools k ± this (a field's stars differ in brightness)
LEVEL_WINDOW = 1
#: a track moves only by at least this (px) and this many standard errors of its median,
#: and at most MAX_SHIFT_PX: two stars 2–4 px apart put the brighter 0.4–1.5 px off their
#: blend; a track's crossings 4.3 px off it are no blend's (a track among three stars of a
#: Pleiades pan)
MIN_SHIFT_PX, SHIFT_SES, MAX_SHIFT_PX = 0.15, 4.0, 2.0
#: added in quadrature to a moved track's σ, per px it moved
SIGMA_SHARE = 0.5


def shifted(rows, crossings, near, lag=None):
    """`rows` (CENTROID_DTYPE) with each track that is an along-motion blend moved onto
    its brighter star (a new array, same order). near: evstar.crossings.near_tracks'
    assignment of `crossings` to the tracks; lag: the PixelLag the crossings were moved
    back by (not None: `rows` as they are, see the module doc)."""
    tracked = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    if lag is not None or not len(tracked) or not len(near[0]):
        return rows
    path = paths.of(rows[tracked])
    shift = track_shifts(path, crossings, near)
    moving = np.flatnonzero(shift != 0)
    if not len(moving):
        return rows
    out = rows.copy()
    g = paths.lookup(path["ids"], rows["track"][tracked])
    u = _mean_direction(path)[g]
    s = shift[g]
    out["x"][tracked] += s * u[:, 0]
    out["y"][tracked] += s * u[:, 1]
    out["sigma"][tracked] = np.hypot(out["sigma"][tracked], SIGMA_SHARE * s)
    return out


def track_shifts(path, crossings, near):
    """Per track of `path` (evstar.paths.of), how far its brighter star lies ahead of it
    along its motion (px; 0: not moved). near: evstar.crossings.near_tracks' assignment of
    the crossings to tracks (its first two fields)."""
    n_tr = len(path["ids"])
    ci, tid = near[:2]
    g = paths.lookup(path["ids"], tid)
    k = crossings["pairs"][ci]
    # the crossings of tracks that keep their direction, with a top pair not their mean
    use = np.flatnonzero(g >= 0)
    use = use[(k[use] >= MIN_LEVELS) & paths.directions(path, MAX_TURN_DEG)[1][g[use]]]
    ci, g, k = ci[use], g[use], k[use]
    # the pixel's offset from the track where it was at the top pair's time: the path
    # itself, not the estimator's earlier one that assigned the crossings (on a slew that
    # one strays from it by up to ~1.5 px along the motion and back)
    px, py, vx, vy = paths.at(path, g, crossings["t_top"][ci], ("x", "y", "vx", "vy"))
    speed = np.hypot(vx, vy)
    ux, uy = (np.divide(v, speed, out=np.zeros(len(v)), where=speed > 0) for v in (vx, vy))
    ox, oy = crossings["x"][ci] - px, crossings["y"][ci] - py
    centre = (speed > 0) & (np.abs(oy * ux - ox * uy) < CENTRE_PX)
    ci, g, k = ci[centre], g[centre], k[centre]
    off = ox[centre] * ux[centre] + oy[centre] * uy[centre]
    levels = _level_medians(g, k, off)
    off = off - _reference(g, k, levels, _references(g, k, off, levels, n_tr))
    ok = np.isfinite(off)
    g, off = g[ok], off[ok]
    ids, med, n = _group_medians(g, off)
    maybe = (n >= MIN_CROSSINGS) & (np.abs(med) >= MIN_SHIFT_PX) & (np.abs(med) <= MAX_SHIFT_PX)
    shift = np.zeros(n_tr)
    for j in np.flatnonzero(maybe):                 # a few tracks: their scatter one by one
        mine = off[g == ids[j]]
        se = robust_sigma(mine, med[j]) / np.sqrt(n[j])
        shift[ids[j]] = med[j] if abs(med[j]) >= SHIFT_SES * se else 0.0
    return shift


def _references(g, k, off, levels, n_tr):
    """Per track, whether it may be another's reference: not where its own median offset,
    against a reference of all the others, stands MIN_SHIFT_PX off (a blend, however few
    its crossings: on the independent simulator's 12 °/s pair scene of 5 tracks, the two
    short tracks of one blend put a single star's reference 1.1 px off, and moved it).
    levels: _level_medians(g, k, off)."""
    first = off - _reference(g, k, levels)
    ok = np.isfinite(first)
    ids, med, _ = _group_medians(g[ok], first[ok])
    usable = np.ones(n_tr, bool)
    usable[ids[np.abs(med) >= MIN_SHIFT_PX]] = False
    return usable


def _level_medians(g, k, off):
    """Per number of level pairs in k: (it, and of each track with crossings at it ±
    LEVEL_WINDOW: its index, its median offset there, their count)."""
    order = _by_group(g, off)          # any selection of it stays sorted: one sort for all
    k_sorted = k[order]
    out = []
    for level in np.unique(k):
        near = order[np.abs(k_sorted - level) <= LEVEL_WINDOW]
        out.append((level, *_group_medians(g[near], off[near], presorted=True)))
    return out


def _reference(g, k, levels, usable=None):
    """Per crossing (of track g, with k level pairs), the median over the other tracks of
    their median offset at k ± LEVEL_WINDOW (levels: _level_medians), among the tracks with
    PER_LEVEL crossings there (and `usable`, per track; None: all); NaN for a track with
    fewer itself, and where fewer than MIN_REFERENCES other such tracks have as many (one
    track's own crossings would be its reference)."""
    table = np.full((int(k.max(initial=0)) + 1, int(g.max(initial=0)) + 1), np.nan)
    for level, ids, med, n in levels:
        full = n >= PER_LEVEL
        use = full if usable is None else full & usable[ids]
        if np.count_nonzero(use) > MIN_REFERENCES:
            table[level, ids[use]] = _medians_without_each(med[use])
        if np.count_nonzero(use) >= MIN_REFERENCES:      # the others: all usable ones'
            table[level, ids[full & ~use]] = np.median(med[use])
    return table[k, g]


def _by_group(g, v):
    """The order that sorts by group g (non-negative integers), then by value v (finite)."""
    lo, hi = float(v.min(initial=0.0)), float(v.max(initial=0.0))
    return np.argsort(g * (hi - lo + 1.0) + (v - lo))


def _group_medians(g, v, presorted=False):
    """(groups, the median of v in each, its count): g, v in _by_group order if presorted."""
    if not len(g):
        return g, np.zeros(0), np.zeros(0, np.int64)
    if not presorted:
        order = _by_group(g, v)
        g, v = g[order], v[order]
    start = np.r_[0, np.flatnonzero(np.diff(g)) + 1]
    n = np.diff(np.r_[start, len(g)])
    return g[start], 0.5 * (v[start + (n - 1) // 2] + v[start + n // 2]), n


def _medians_without_each(v):
    """Per element of v, the median of the others."""
    order = np.argsort(v)
    rank = np.empty(len(v), np.int64)
    rank[order] = np.arange(len(v))
    s = v[order]
    m = len(v) - 1                                   # the others' count
    lo, hi = (m - 1) // 2, m // 2                    # their middle positions
    pick = lambda p: s[np.where(p < rank, p, p + 1)]
    return 0.5 * (pick(lo) + pick(hi))


def _mean_direction(path):
    """Per track, the unit vector of its mean velocity."""
    n_tr, g = len(path["ids"]), path["g"]
    v = np.column_stack([np.bincount(g, path["vx"], n_tr), np.bincount(g, path["vy"], n_tr)])
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)
