"""Multi-target tracking: link centroids across pseudo-frames into tracks.

Each track predicts its next position with a constant-velocity model from its last two
centroids; centroids of a frame are assigned to tracks by minimum total distance
(Hungarian, scipy) within a gate. A slow star's centroids jump between its lobes (an
ON-only cluster ~1.25 σ_PSF ahead of it, an OFF-only one as far behind) in frames too
short to hold both: the last two then give the velocity of a lobe's jump. So where the
centroid, or one of the track's last two, is a lone lobe (lobes.lone), the track
may also take it within the gate of a chord from the oldest of its last _CHORD_CENTROIDS
(three steps averaged). Elsewhere the chord is not used: in a crowded dark-sky field it
let tracks take neighbours' centroids. A track survives up to ``max_gap`` frames without a
centroid (a star fading or crossing a dead region keeps its id); unassigned centroids
start new tracks, so stars entering the field get fresh ids. A track that begins where
another ended continues it (_join): at a turn a star can give two centroids in a frame,
or, slow, none for longer than max_gap frames; a readout stall silences every star at
once, and a fast one on a curved path leaves the straight prediction's gate in it.

A new track (one centroid) has no velocity of its own. Stars are fixed on the sky, so
they all move with the camera's rotation: once confirmed tracks exist, a new track moves
like its nearest confirmed ones (the field's flow), within gate_px plus their velocities'
spread per frame (a roll spreads them), or stands still within gate_px (a turn stops every
star before their flow shows it). Only where no track is confirmed yet does it stand
still within init_gate_px. Without the flow, a crowded field's faint stars, seen
now and then, chained into false tracks: one star's centroid, then another's 30 px
away, then a third that happened to lie on the jump's extrapolation. A target moving on
its own (a satellite) faster than gate_px per frame against the stars starts no track
once stars are confirmed.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import linear_sum_assignment

from . import lobes
from .errors import DataError, ParameterTypeError
from .frames import frame_bounds
from .parameters import TRACK as T

_NEEDED = ("x", "y", "frame", "track")  # the centroid fields linking reads and writes


class Tracker:
    def __init__(self, gate_px=T["gate_px"].default, init_gate_px=T["init_gate_px"].default,
                 max_gap=T["max_gap"].default, min_length=T["min_length"].default):
        self.gate_px = float(T.check("gate_px", gate_px))
        self.init_gate_px = float(T.check("init_gate_px", init_gate_px))
        self.max_gap, self.min_length = T.check("max_gap", max_gap), T.check("min_length", min_length)

    def link(self, centroids, velocity_prior=None):
        """Return a copy of `centroids` with the ``track`` field filled (time-sorted input).

        Tracks shorter than ``min_length`` centroids get track = -1 (unconfirmed).
        velocity_prior: the gyro's image velocity, (t_us, x, y) -> (n, 2) px/s
        (evstar.smoothing.imu_velocity_prior), where the run has one: a track then continues
        another across a longer gap where it begins where the gyro says the star went.
        """
        fields = getattr(getattr(centroids, "dtype", None), "names", None) or ()
        if not isinstance(centroids, np.ndarray) or not set(_NEEDED) <= set(fields):
            raise ParameterTypeError("centroids must be a structured array with fields "
                                     f"{', '.join(_NEEDED)} (evstar.extract.CENTROID_DTYPE), "
                                     f"got {type(centroids).__name__}")
        bad = np.flatnonzero(~(np.isfinite(centroids["x"]) & np.isfinite(centroids["y"])))
        if len(bad):   # a NaN's distances gate nothing: its track broke silently
            i = int(bad[0])
            raise DataError(f"centroid {i} has a non-finite position ({centroids['x'][i]}, "
                            f"{centroids['y'][i]}); tracks need finite x, y")
        out = centroids.copy()
        order = np.argsort(out["frame"], kind="stable")
        frames, starts, stops = frame_bounds(out["frame"][order])
        xy, track = np.column_stack([out["x"], out["y"]])[order], out["track"]
        spread2 = (out["spread"][order] ** 2 if "spread" in fields
                   else np.full(len(out), np.nan))
        # lone lobes (one polarity's cluster), where the polarities are counted
        lone = (lobes.lone(out[order]) if {"n_on", "n_events"} <= set(fields)
                else np.zeros(len(out), bool))
        st = _Tracks(len(out))
        live = np.zeros(0, np.int64)  # the tracks that can still take a centroid, in creation order
        for f, a, b in zip(frames, starts, stops):
            rows = order[a:b]
            # frames only grow: a track past its gap never comes back
            live = live[f - st.last_f[live] <= self.max_gap + 1]
            pts, s2 = xy[a:b], spread2[a:b]
            t, r = self._assign(st, live, pts, f, lone[a:b])
            t, r, blends = self._without_blends(st, live, (pts, s2), f, t, r)
            st.extend(live[t], f, pts[r], s2[r], lone[a:b][r])
            track[rows[r]] = live[t]             # a track's id is its index
            track[rows[blends]] = BLENDED
            if len(r) + len(blends) < len(rows):  # the others start tracks
                new = np.ones(len(rows), bool)
                new[r] = False
                new[blends] = False
                born = st.start(f, pts[new], s2[new], lone[a:b][new])
                track[rows[new]] = born
                live = np.concatenate([live, born])
        _join(out, st.as_dicts(), self.gate_px, self.max_gap, velocity_prior, self.min_length)
        return _drop_short(out, self.min_length)

    def _assign(self, st, live, pts, f, lone):
        """(indices into live, rows of pts) of the frame's assignment within the gates
        (lone: the pts that are lone lobes)."""
        if not len(live) or not len(pts):
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        big = 1e9
        n, last_f = st.n[live], st.last_f[live]
        pred = st.predict(live, f)
        gates = np.where(n > 1, self.gate_px, self.init_gate_px)
        new = np.flatnonzero(n == 1)
        flow = live[(n >= self.min_length) & (last_f >= f - 1)]
        guided = len(new) and (len(flow) or len(new) >= FLOW_NEIGHBOURS)
        if len(new) and len(flow):
            pred[new], gates[new] = _with_flow(st, live[new], flow, f, self.gate_px,
                                               self.init_gate_px)
        elif guided:   # no confirmed track yet (a recording's first frames), but a field
            pred[new], gates[new] = _provisional_flow(st, live[new], pts, f, self.gate_px,
                                                      self.init_gate_px)
        cost = _gated(pred, gates, pts, big)
        chord = np.flatnonzero(n >= 3)
        jumped = st.last_lone[live[chord]] | st.prev_lone[live[chord]]
        if len(chord) and (lone.any() or jumped.any()):
            either = lone[None, :] | jumped[:, None]
            by_chord = _gated(st.predict_chord(live[chord], f), gates[chord], pts, big)
            cost[chord] = np.where(either, np.minimum(cost[chord], by_chord), cost[chord])
        if guided:
            # or still, within gate_px: a turn stops every star, while the flow measured
            # on the frames before still has them moving
            cost[new] = np.minimum(cost[new], _gated(st.last_xy[live[new]], self.gate_px, pts, big))
        ti, ri = linear_sum_assignment(cost)
        ok = cost[ti, ri] < big
        return ti[ok], ri[ok]

    def _without_blends(self, st, live, frame_rows, f, t, r):
        """(t, r, blended rows of pts): the assignment less the centroids that are two
        confirmed tracks' blend — a centroid between the predictions of two confirmed
        tracks (BLEND_SHARE of the way from each at least) and within gate_px of both, one
        of which took it while the other took none: two stars close enough to share a
        DBSCAN cluster in some frames (a close pair, stars whose paths cross). Both tracks
        coast through it; given to either, it pulled that track halfway to the other star
        and the two swapped (perf/study_indep.py --fresh3 H8: 5 px apart, 0.72 px). A blend
        is also wider than the taker's own clusters: its spread² exceeds their mean by
        BLEND_SPREAD_SHARE of what two stars a share w and L apart add, w(1 − w)L² (on a
        crowded field a track's noisy prediction put its own star's centroid "between" it
        and a faint neighbour's track); and the two tracks were last seen in one frame (a slow
        wide star's two tracks, never seen together, are one star: study_indep scene 23)."""
        pts, s2 = frame_rows
        none = np.zeros(0, np.int64)
        if len(t) == len(live) or not len(t):
            return t, r, none
        confirmed = st.n[live] >= self.min_length
        idle = confirmed.copy()
        idle[t] = False
        lonely = live[idle]
        mine = np.flatnonzero(confirmed[t])
        if not len(lonely) or not len(mine):
            return t, r, none
        takers = live[t[mine]]
        pb = st.predict(lonely, f)                                 # idle tracks'
        c = pts[r[mine]]
        d_b = _distances(c, pb)                                    # (takers, idle)
        # ... and last seen in one frame with the taker: two stars, not one star's two tracks
        seen = st.last_f[takers][:, None] == st.last_f[lonely][None]
        near = (d_b <= self.gate_px) & seen
        if not near.any():   # most frames: no idle track near a taken centroid
            return t, r, none
        i, j = np.nonzero(near)
        pa = st.predict(takers[i], f)                              # takers' predictions
        ab = pb[j] - pa
        length2 = np.maximum((ab * ab).sum(1), 1e-12)
        share = ((c[i] - pa) * ab).sum(1) / length2
        wider = s2[r[mine[i]]] - st.mean_spread2(takers[i])
        blend = ((share >= BLEND_SHARE) & (share <= 1 - BLEND_SHARE)
                 & (wider >= BLEND_SPREAD_SHARE * share * (1 - share) * length2))
        if not blend.any():
            return t, r, none
        keep = np.ones(len(t), bool)
        keep[mine[i[blend]]] = False
        return t[keep], r[keep], r[~keep]


#: the track field of a centroid that is two confirmed tracks' blend (Tracker._without_blends)
BLENDED = -2
#: a blend lies at least this share of the way from each of the two tracks' predictions
#: (two stars' flux-weighted mean: 0.38 for a magnitude 3.5 and 4 pair)
BLEND_SHARE = 0.2
#: ... and its spread² exceeds the taker's mean by this share of w(1 − w)L² (H8: ~0.9)
BLEND_SPREAD_SHARE = 0.5


def _gated(pred, gates, pts, big):
    """Distances from each prediction to each point, `big` beyond the prediction's gate."""
    d = _distances(pred, pts)
    d[~(d <= np.reshape(gates, (-1, 1)))] = big
    return d


def _distances(a, b):
    """(len(a), len(b)) distances between the points a and b ((n, 2) each): the bits of
    np.linalg.norm over their differences (sqrt of dx² + dy², one add), without its cost."""
    dx = a[:, 0, None] - b[None, :, 0]
    dy = a[:, 1, None] - b[None, :, 1]
    return np.sqrt(dx * dx + dy * dy)


#: confirmed tracks whose velocities make a new track's flow
FLOW_NEIGHBOURS = 5


def _with_flow(st, new, flow, f, gate_px, init_gate_px):
    """(predictions at frame f, gates) of the `new` tracks moving with the field's flow:
    the median velocity of their nearest `flow` tracks, gated by gate_px plus those
    velocities' largest deviation from it per frame since the new track's centroid."""
    v = st.velocity(flow)
    d = np.linalg.norm(st.last_xy[new][:, None] - st.last_xy[flow][None], axis=2)
    k = min(FLOW_NEIGHBOURS, len(flow))
    near = np.argpartition(d, k - 1, axis=1)[:, :k]
    vn = v[near]                                              # (new, k, 2)
    vc = np.median(vn, axis=1)
    spread = np.linalg.norm(vn - vc[:, None], axis=2).max(axis=1)
    steps = f - st.last_f[new]
    return (st.last_xy[new] + vc * steps[:, None],
            np.minimum(gate_px + spread * steps, init_gate_px))


def _provisional_flow(st, new, pts, f, gate_px, init_gate_px):
    """_with_flow's (predictions at frame f, gates) before any track is confirmed: each new
    track's step (per frame) to its nearest centroid of frame f, within init_gate_px; its
    flow the median step of its FLOW_NEIGHBOURS nearest new tracks — stars lying farther
    apart than they move, most nearest steps are the true ones — and its gate gate_px
    plus three times their median deviation from it (one wrong step must not open it)."""
    steps = (f - st.last_f[new]).astype(float)
    d = pts[None, :, :] - st.last_xy[new][:, None, :]
    j = np.argmin(np.linalg.norm(d, axis=2), axis=1)
    step = d[np.arange(len(new)), j] / steps[:, None]
    step[np.linalg.norm(step, axis=1) > init_gate_px] = np.nan
    gap = np.linalg.norm(st.last_xy[new][:, None] - st.last_xy[new][None], axis=2)
    near = np.argpartition(gap, FLOW_NEIGHBOURS - 1, axis=1)[:, :FLOW_NEIGHBOURS]
    vn = step[near]                                           # (new, k, 2)
    known = np.isfinite(vn[..., 0]).any(axis=1)
    vc = np.zeros((len(new), 2))
    dev = np.full(len(new), np.inf)
    if known.any():
        vc[known] = np.nanmedian(vn[known], axis=1)
        dev[known] = np.nanmedian(np.linalg.norm(vn[known] - vc[known][:, None], axis=2), axis=1)
    gates = np.minimum(gate_px + 3 * dev * steps, init_gate_px)
    return st.last_xy[new] + vc * steps[:, None], gates


#: centroids whose oldest and last give a track's chord prediction (_Tracks.predict_chord):
#: its velocity over three steps. Alone it split tracks where the last two predicted
#: better (a 1 °/s star whose OFF lobe fell 6.1 px from the chord, 4.9 from the last two),
#: hence the nearer of the two (_assign), and only about lone lobes
_CHORD_CENTROIDS = 4


class _Tracks:
    """Every track's first, last and second-to-last centroid (frame, x y), its last
    _CHORD_CENTROIDS (a ring), and length, as arrays indexed by track id (at most one track
    per centroid)."""

    def __init__(self, capacity):
        self.m = 0
        self.first_f, self.last_f, self.prev_f, self.n = (np.zeros(capacity, np.int64)
                                                          for _ in range(4))
        self.first_xy, self.last_xy, self.prev_xy = (np.zeros((capacity, 2)) for _ in range(3))
        self.spread2 = np.zeros(capacity)     # the sum of its clusters' spread²
        # its last and second-to-last centroids lone lobes
        self.last_lone, self.prev_lone = np.zeros(capacity, bool), np.zeros(capacity, bool)
        self.ring_xy = np.zeros((capacity, _CHORD_CENTROIDS, 2))
        self.ring_f = np.zeros((capacity, _CHORD_CENTROIDS), np.int64)

    def start(self, f, pts, spread2, lone=False):
        """New tracks at pts in frame f (their clusters' spread², NaN: unknown); their ids."""
        ids = np.arange(self.m, self.m + len(pts))
        self.m += len(pts)
        self.first_f[ids] = self.last_f[ids] = f
        self.prev_f[ids] = f - 1      # a one-centroid track stands still (see predict)
        self.first_xy[ids] = self.last_xy[ids] = self.prev_xy[ids] = pts
        self.n[ids] = 1
        self.spread2[ids] = spread2
        self.ring_xy[ids, 0], self.ring_f[ids, 0] = pts, f
        self.last_lone[ids] = self.prev_lone[ids] = lone
        return ids

    def extend(self, ids, f, pts, spread2, lone=False):
        self.prev_f[ids], self.prev_xy[ids] = self.last_f[ids], self.last_xy.take(ids, 0)
        self.last_f[ids], self.last_xy[ids] = f, pts
        slot = self.n[ids] % _CHORD_CENTROIDS    # the centroid n (0-based) goes to slot n mod K
        self.ring_xy[ids, slot], self.ring_f[ids, slot] = pts, f
        self.prev_lone[ids], self.last_lone[ids] = self.last_lone[ids], lone
        self.n[ids] += 1
        self.spread2[ids] += spread2

    def mean_spread2(self, ids):
        """Each track's mean cluster spread² (NaN where any was unknown)."""
        return self.spread2[ids] / self.n[ids]

    def velocity(self, ids):
        """(n, 2) px per frame from each track's last two centroids (0 for one centroid)."""
        return ((self.last_xy.take(ids, 0) - self.prev_xy.take(ids, 0))
                / (self.last_f[ids] - self.prev_f[ids])[:, None])

    def predict(self, ids, f):
        """(n, 2) positions at frame f: constant velocity from each track's last two
        centroids (per frame), else where it is."""
        last, f_last = self.last_xy.take(ids, 0), self.last_f[ids]
        v = self.velocity(ids)
        return np.where((self.n[ids] > 1)[:, None], last + v * (f - f_last)[:, None], last)

    def predict_chord(self, ids, f):
        """(n, 2) positions at frame f: constant velocity from each track's oldest of its
        last _CHORD_CENTROIDS centroids to its last (tracks of 3 centroids or more)."""
        n = self.n[ids]
        oldest = np.where(n >= _CHORD_CENTROIDS, n % _CHORD_CENTROIDS, 0)
        last, f_last = self.last_xy.take(ids, 0), self.last_f[ids]
        v = (last - self.ring_xy[ids, oldest]) / (f_last - self.ring_f[ids, oldest])[:, None]
        return last + v * (f - f_last)[:, None]

    def as_dicts(self):
        """_join's tracks: id, frames and xy (first and last) in creation order."""
        return [{"id": i, "frames": [self.first_f[i], self.last_f[i]],
                 "xy": [self.first_xy[i], self.last_xy[i]]} for i in range(self.m)]


def _join(out, tracks, gate_px, max_gap, velocity_prior=None, min_length=1):
    """Relabel a track that starts where another just ended as that one (in place): a star
    that stops and turns back (a slew's turnaround) can give two centroids in one frame,
    one of which goes on alone and ends its track while the other starts a new one; or
    none for several frames, too slow (or, faint, too fast) to fire its pixels. B joins A
    when B's first centroid lies within gate_px of A's last and B's first frame is at most
    one frame before A's last one or after it by at most max_gap + 1 frames; or by up to
    _SLOW_GAPS times that where A ended or B began so slowly that it could not have left
    the gate in the gap, or where they move opposite ways and an even turn's reach stays
    in the gate, B beginning within that of A's end (a star turning: _Ends.reach); failing
    those, with a velocity prior, where the
    means of A's last and B's first _END_CENTROIDS centroids, carried by the prior to B's
    first time, lie within gate_px × _CARRY_GATE, or, without one, where A's end line and
    B's start line, each carried to the middle of the gap on a constant-rate turn, meet
    within that (a readout stall on a fast curved path: _Ends.met; both over more than a
    frame's gap, A and B of min_length centroids at least: confirmed pieces of a star's
    track, not noise); the nearest A wins."""
    ends, at_ends = {}, _Ends(out)
    normal, slow = max_gap + 1, _SLOW_GAPS * (max_gap + 1)
    for tr in sorted(tracks, key=lambda tr: tr["frames"][0]):
        first = tr["frames"][0]
        # an end too far behind this track is so for every later one (first frames only grow)
        ends = {k: a for k, a in ends.items() if first - a["frames"][-1] <= slow}
        best, best_d, far = None, gate_px, []
        for a in ends.values():
            gap = first - a["frames"][-1]
            if gap < -1 or a["frames"][0] >= first:
                continue
            dx, dy = tr["xy"][0] - a["xy"][-1]
            d = math.sqrt(dx * dx + dy * dy)       # np.linalg.norm's bits (_distances)
            if d <= best_d and (gap <= normal or
                                at_ends.reach(a["ids"][-1], tr["id"], gap, d) <= gate_px):
                best, best_d = a, d
            elif gap > (normal if velocity_prior is not None else 1):
                far.append(a)      # carried below: by the prior, or by their own speeds
        # short tracks (most are noise; a crowded field has thousands) are carried nowhere
        if far and best is None and at_ends.count(tr["id"]) >= min_length:
            far = [a for a in far if at_ends.count(a["ids"][-1]) >= min_length]
            if velocity_prior is not None:
                d = at_ends.carried(velocity_prior, [a["ids"][-1] for a in far], tr["id"]) if far else []
            else:
                d = [at_ends.met(a["ids"][-1], tr["id"]) for a in far]
            for a, d_a in zip(far, d):
                if d_a <= min(best_d, gate_px * _CARRY_GATE):
                    best, best_d = a, d_a
        if best is None:
            tr["ids"] = [tr["id"]]
            ends[tr["id"]] = tr
            continue
        out["track"][out["track"] == tr["id"]] = best["id"]
        best["frames"] += tr["frames"]
        best["xy"] += tr["xy"]
        best["ids"].append(tr["id"])


#: a slow track's gap (_join) in units of max_gap + 1 frames at most: a star slowing to a
#: turn on a 0.5°, 1 Hz sinusoid (DVXplorer Lite, 8 mm) gave no centroid for 8 frames
_SLOW_GAPS = 4
#: how far past a turn's reach (_Ends.reach) a track may begin: its ends' centroid scatter
_TURN_SLACK_PX = 1.0
#: centroids at a track's end whose least-squares line gives its speed there: one faint
#: centroid at a turn was 1.3 px off
_END_CENTROIDS = 4


#: steps of the velocity prior between a track's end and another's start (_Ends.carried)
_CARRY_STEPS = 8
#: the share of gate_px within which a carried end must meet a track's start (the means of
#: their _END_CENTROIDS outermost centroids): on a 350-star field (Cygnus, DVXplorer 8 mm,
#: 15 °/s sinusoid, 1.5 Hz of background) 334 of 347 within 6 px were within 2, one within
#: 2–3, the rest 3–6 (a close neighbour's, likely); a faint star behind slow pixels, its
#: centroids trailing it one way before a turn and the other way after, met its own at 1.5
_CARRY_GATE = 1 / 3


class _Ends:
    """Tracks' end rows in `out` (track = id as linked, before any join): the speed (px per
    frame) at an end, and where a velocity prior carries a track's last centroid; the rows
    sorted when first asked (most runs join nothing across a long gap)."""

    def __init__(self, out):
        # the ids as linked: _join relabels `out` as it goes
        self.out, self.track, self.order = out, out["track"].copy(), None

    def reach(self, a, b, gap, d):
        """How far (px) the star could have gone from track a's end or b's start in `gap`
        frames, were they one star (d px apart): the slower of the two speeds × gap (it
        could not have left that gate); where they are opposed (a turn: it slowed to rest
        and came back), an even turn's: slowing evenly from va to rest and speeding up
        evenly to vb in the gap, it goes gap·va²/2(va + vb) past a's end and comes back to
        gap·vb²/2(va + vb) before b's start — the larger of the two — if b begins within
        that of a's end (and _TURN_SLACK_PX); inf where neither speed is known (tracks of
        one centroid). (The faster × gap / 2, twice that at equal speeds, left faint stars
        silent for 17–21 frames at a sinusoid's turn split: DAVIS346 8 mm, 10 °/s.)"""
        va = self._velocity(self._rows(a)[-_END_CENTROIDS:])
        vb = self._velocity(self._rows(b)[:_END_CENTROIDS])
        known = [np.hypot(*v) for v in (va, vb) if v is not None]
        if not known:
            return np.inf
        straight = min(known) * gap
        if len(known) == 2 and float(np.dot(va, vb)) < 0:
            turn = gap * max(known) ** 2 / (2 * (known[0] + known[1]))
            if d <= turn + _TURN_SLACK_PX:
                return min(straight, turn)
        return straight

    def carried(self, prior, ends, b):
        """Distances (px) at track b's first time between the mean of its first
        _END_CENTROIDS centroids and that of each of tracks `ends`' last ones, every
        centroid carried there by the velocity prior (its velocity taken along the straight
        way between, _CARRY_STEPS points), in one call of the prior (its answer checked as
        everywhere)."""
        from .smoothing import prior_velocity

        o = self.out
        rows_b = self._rows(b)[:_END_CENTROIDS]
        t_ref = float(o["t"][rows_b[0]])
        rows = [self._rows(a)[-_END_CENTROIDS:] for a in ends] + [rows_b]
        i = np.concatenate(rows)
        t0, x0, y0 = o["t"][i].astype(float)[:, None], o["x"][i][:, None], o["y"][i][:, None]
        s = ((np.arange(_CARRY_STEPS) + 0.5) / _CARRY_STEPS)[None, :]
        # the straight way: toward b's first centroid (b's own rows: where they are)
        xj, yj = o["x"][rows_b[0]], o["y"][rows_b[0]]
        v = prior_velocity(prior, (t0 + s * (t_ref - t0)).ravel(), (x0 + s * (xj - x0)).ravel(),
                           (y0 + s * (yj - y0)).ravel())
        shift = v.reshape(len(i), _CARRY_STEPS, 2).mean(axis=1) * ((t_ref - t0) * 1e-6)
        at = np.column_stack([x0[:, 0], y0[:, 0]]) + shift
        sizes = np.array([len(r) for r in rows])
        means = np.add.reduceat(at, np.r_[0, np.cumsum(sizes)[:-1]], axis=0) / sizes[:, None]
        return np.hypot(*(means[:-1] - means[-1]).T)

    def met(self, a, b):
        """Without a velocity prior: how far (px) track a's end and track b's start miss
        each other at the middle of the gap between them, each carried there by the
        least-squares line of its _END_CENTROIDS outermost centroids, turning at the
        constant rate that takes a's velocity to b's between the lines' mean times (a
        readout stall on a fast curved path: a 3° cone at 1.2 Hz through a telephoto,
        1000 px/s, turned 26° in a 60 ms stall, where straight ways missed by 4.6 px);
        straight where they move the same way. inf where either has no line (one time) or
        they turn by over a right angle (a star turning back: the slow join's, reach)."""
        ra, rb = self._rows(a)[-_END_CENTROIDS:], self._rows(b)[:_END_CENTROIDS]
        mid = 0.5 * (float(self.out["t"][ra[-1]]) + float(self.out["t"][rb[0]]))
        la, lb = self._line(ra), self._line(rb)
        if la is None or lb is None:
            return np.inf
        (ta, pa, va), (tb, pb, vb) = la, lb
        turn = math.atan2(va[0] * vb[1] - va[1] * vb[0], float(np.dot(va, vb)))
        if abs(turn) > math.pi / 2:
            return np.inf
        rate = turn / (tb - ta)
        return float(np.hypot(*(_turned(pa, va, rate, mid - ta) - _turned(pb, vb, rate, mid - tb))))

    def _line(self, rows):
        """(mean time µs, position there, velocity px/µs) of these rows' least-squares line
        in time; None from rows of one time."""
        t = self.out["t"][rows].astype(float)
        if len(rows) < 2 or np.ptp(t) == 0:
            return None
        tm = t.mean()
        v, p = np.polyfit(t - tm, np.column_stack([self.out["x"][rows], self.out["y"][rows]]), 1)
        return tm, p, v

    def count(self, track):
        """Centroids of a track as linked."""
        self._sort()
        return int(self.bounds[track, 1] - self.bounds[track, 0])

    def _rows(self, track):
        self._sort()
        return self.order[self.bounds[track, 0]:self.bounds[track, 1]]

    def _sort(self):
        """The rows by track, then time, and each id's (first, stop) in that order (ids
        are the linker's: 0 .. max, some absent where _drop_short's input has none)."""
        if self.order is None:
            self.order = np.lexsort((self.out["t"], self.track))
            ids, starts, counts = np.unique(self.track[self.order], return_index=True,
                                            return_counts=True)
            self.bounds = np.zeros((ids.max(initial=-1) + 1, 2), np.int64)
            self.bounds[ids] = np.column_stack([starts, starts + counts])

    def _velocity(self, rows):
        """The least-squares velocity (px per frame) of these rows; None from one frame."""
        f = self.out["frame"][rows].astype(float)
        if len(rows) < 2 or np.ptp(f) == 0:
            return None
        return np.polyfit(f, np.column_stack([self.out["x"][rows], self.out["y"][rows]]), 1)[0]


def _turned(p, v, rate, dt):
    """Where a point at p moving at v (per µs) is dt µs later turning at `rate` rad/µs
    (counter-clockwise in x, y): p + sin(ωt)/ω·v + (1 − cos ωt)/ω·v⊥, straight at ω = 0."""
    x = rate * dt
    along = dt * np.sinc(x / np.pi)                   # sin(ωt)/ω
    side = 0.5 * x * dt * np.sinc(x / (2 * np.pi)) ** 2   # (1 − cos ωt)/ω
    return p + along * v + side * np.array([-v[1], v[0]])


def _drop_short(out, min_length):
    ids, counts = np.unique(out["track"], return_counts=True)
    short = ids[(counts < min_length) & (ids >= 0)]   # BLENDED stays
    out["track"][np.isin(out["track"], short)] = -1
    # renumber confirmed tracks 0, 1, 2 ... in order of appearance
    confirmed = out["track"] >= 0
    _, first, which = np.unique(out["track"][confirmed], return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first)] = np.arange(len(first))   # each id's place by first appearance
    out["track"][confirmed] = rank[which]
    return out
