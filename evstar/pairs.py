"""Unresolved close pairs: a track whose crossings spread across its motion further than a
single star of its brightness does, split into the two stars that explain the excess.

Two stars 2–5 px apart share one DBSCAN cluster in every frame, so the tracker follows their
blend (up to 1.5 px from either star; perf/study_pairs.py). Pooled over the whole track,
their pixel crossings (evstar.crossings: where a star passed over a pixel, weighted here by
the crossing's level pairs) tell them apart: a pair's crossings spread across the motion
as two copies of a single star's profile, and their variance exceeds a single star's by
w(1 − w)·s² (s: the separation across, w: the fainter star's share).

A single star's spread is measured on the recording itself: it grows with brightness (a
brighter star's log response reaches further out), so the other tracks' across variances
against their brightness (level pairs per px of path) give a power law (scipy's Theil–Sen
in log–log; tracks far above it left out one at a time, _singles). A track standing far
above it (MIN_EXCESS_PX2, MIN_RATIO and EXCESS_MADS robust scales of the others' scatter)
is fitted as two stars: EM on its crossings' offsets (along, across its main direction),
each star's profile a Gaussian as wide across as a single star of its share's brightness,
started from the moments' closed-form solution (_moment_start). The fit is kept where the
two lie MIN_SEPARATION_PX apart, the fainter holds MIN_SHARE, and neither is wider than
MIN_RATIO single stars (three stars or more are left as they were). Each star's rows are
the track's rows moved by its offset; the brighter keeps the track, the fainter gets a
new one, both flagged `split`, σ widened by SIGMA_PER_SEPARATION per px apart.

Not split: recordings with fewer than MIN_REFERENCES other measured tracks (no single-star
width to compare with; a lone star is never split), tracks whose direction of motion turns
by more than MAX_TURN_DEG (the offsets would turn with it), and pairs along the motion
(each pixel passes both stars in one pulse: one crossing, at their blend).
"""
from __future__ import annotations

import numpy as np

from .frames import groups

#: crossings within this distance of a track's position count for its spread: a pair 5 px
#: apart has each star 2.5 px off its blend and a profile reaching ~4 px further
REACH_PX = 7.0
#: the fewest crossings that measure a track's spread (and a reference track's)
MIN_CROSSINGS = 60
#: the fewest other measured tracks that give the single-star width
MIN_REFERENCES = 3
#: a split's excess variance must reach this (px²; w(1 − w)s² of a 1:3 pair 2.3 px apart)
MIN_EXCESS_PX2 = 1.0
#: ... and this many times a single star's (the reference tracks' spread about their power
#: law is ~10 %), and this many robust scales (1.4826 MAD) of their log residuals
MIN_RATIO, EXCESS_MADS = 1.4, 4.0
#: the split stars at least this far apart (px) and the fainter with at least this share
MIN_SEPARATION_PX, MIN_SHARE = 2.0, 0.1
#: a track whose motion turns further than this from its main direction is not split
MAX_TURN_DEG = 20.0
#: the EM fit's steps, and the least along-motion variance of a star's crossings it assumes
#: (px²: crossings are timed so well that a single star's along spread is ~0.01)
EM_STEPS, MIN_ALONG_VAR_PX2 = 30, 0.25
#: added in quadrature to a split star's σ, per px of separation (the two-copy model's error)
SIGMA_PER_SEPARATION = 0.05


def split(rows, crossings):
    """`rows` (CENTROID_DTYPE, time-sorted) with each track that is an unresolved pair
    replaced by the pair's two stars (a new array, time-sorted; the new tracks' ids follow
    the largest)."""
    from .crossings import near_tracks

    tracked = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    if not len(tracked) or crossings is None or not len(crossings):
        return rows
    paths = _paths(rows[tracked])
    ci, track, dx, dy, _, _ = near_tracks(crossings, paths, REACH_PX)
    stats = _track_stats(paths, track, dx, dy, crossings["pairs"][ci])
    found = _pairs(stats)
    if not found:
        return rows
    return _with_pairs(rows, found)


def _paths(rows):
    """The tracks' rows with velocities (px/s: central differences), sorted by track then
    time, as near_tracks takes them."""
    rows = rows[np.lexsort((rows["t"], rows["track"]))]
    out = np.zeros(len(rows), [("t", "<f8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
                               ("vx", "<f8"), ("vy", "<f8")])
    for f in ("t", "track", "x", "y"):
        out[f] = rows[f]
    for idx in groups(out["track"])[1]:
        if len(idx) > 1:
            t = out["t"][idx]
            out["vx"][idx] = np.gradient(out["x"][idx], t) * 1e6
            out["vy"][idx] = np.gradient(out["y"][idx], t) * 1e6
    return out


def _track_stats(paths, track, dx, dy, levels):
    """Per track with MIN_CROSSINGS crossings: its id, main direction (unit), whether it
    holds that direction, brightness (_brightness), and its crossings' level pairs (weight)
    and offsets (along, across that direction)."""
    out = []
    cos_turn = np.cos(np.radians(MAX_TURN_DEG))
    mine = dict(zip(*groups(track)))
    for tid, rows in zip(*groups(paths["track"])):
        got = mine.get(tid)
        if got is None or len(got) < MIN_CROSSINGS:
            continue
        v = np.column_stack([paths["vx"][rows], paths["vy"][rows]])
        speed = np.linalg.norm(v, axis=1)
        u = v[speed > 0] / speed[speed > 0, None]
        if not len(u):
            continue
        _, vec = np.linalg.eigh(u.T @ u)      # the main axis of the directions (either sign)
        p = vec[:, -1]
        ox, oy = dx[got], dy[got]
        out.append({"track": int(tid), "axis": p,
                    "steady": bool(np.all(np.abs(u @ p) >= cos_turn)),
                    "bright": _brightness(paths[rows], levels[got]), "weight": levels[got],
                    "along": ox * p[0] + oy * p[1], "across": -ox * p[1] + oy * p[0]})
    return out


def _brightness(path, levels):
    """A star's brightness: its crossings' level pairs per px of its path (a pixel's
    count of level pairs grows with the star's log contrast there)."""
    length = np.hypot(np.diff(path["x"]), np.diff(path["y"])).sum()
    return float(levels.sum() / max(length, 1e-9))


def _pairs(stats):
    """{track: (axis, offset of the brighter, offset of the fainter (along, across px),
    the fainter's share, separation px)} of the tracks that are unresolved pairs."""
    var_al = np.array([_var(s["along"], s["weight"]) for s in stats])
    var_ac = np.array([_var(s["across"], s["weight"]) for s in stats])
    logb = np.log(np.maximum([s["bright"] for s in stats], 1.0))
    ref = _singles(var_ac, logb)
    if ref.sum() < MIN_REFERENCES:
        return {}
    width = _power_law(var_ac[ref], logb[ref])
    scale = _robust_scale(np.log(var_ac[ref] / width(logb[ref])))
    along = max(float(np.median(var_al[ref])), MIN_ALONG_VAR_PX2)
    found = {}
    for s, v, lb in zip(stats, var_ac, logb):
        if (not s["steady"] or not _stands_out(v, width(lb))
                or np.log(v / width(lb)) < EXCESS_MADS * scale):
            continue
        z = np.column_stack([s["along"], s["across"]])
        got = _two_stars(z, s["weight"], _moment_start(z, s["weight"], along, width(lb)),
                         lambda share: np.array([along, width(lb + np.log(share))]))
        if got is not None:
            found[s["track"]] = (s["axis"], *got)
    return found


def _var(x, w):
    m = np.average(x, weights=w)
    return float(np.average((x - m) ** 2, weights=w))


def _moment_start(z, wt, var_al, var_ac):
    """Two stars' offsets and the fainter's share from the moments of their crossings:
    the covariance's excess over one star's is w(1 − w)·s·sᵀ and the third moment along s
    w(1 − w)(1 − 2w)|s|³; the brighter first."""
    m = np.average(z, axis=0, weights=wt)
    lam, vec = np.linalg.eigh(np.cov(z.T, aweights=wt, bias=True) - np.diag([var_al, var_ac]))
    lam, e = max(lam[-1], 1e-6), vec[:, -1]
    skew = float(np.average(((z - m) @ e) ** 3, weights=wt))
    d = skew ** 2 / lam ** 3
    share = 0.5 * (1 - np.sqrt(d / (4 + d)))
    step = np.sqrt(lam / (share * (1 - share))) * (np.sign(skew) or 1.0) * e
    return np.array([m - share * step, m + (1 - share) * step]), share


def _two_stars(z, wt, start, variance):
    """(brighter's offset, fainter's offset, fainter's share, separation) of the two-star
    mixture of the crossings z (along, across) fitted by EM from start = (offsets, share),
    each star's profile Gaussian with variance(its share) per axis; None where the fit
    leaves the two closer than MIN_SEPARATION_PX, the fainter under MIN_SHARE, or either
    spread across wider than MIN_RATIO single stars of its share (three stars or more)."""
    mu, share = start
    w = np.array([1 - share, share])
    for _ in range(EM_STEPS):
        var = np.stack([variance(max(k, MIN_SHARE / 2)) for k in w])        # (2, 2 axes)
        logp = (np.log(w)[:, None] - 0.5 * (((z[None] - mu[:, None]) ** 2 / var[:, None])
                                            + np.log(var[:, None])).sum(axis=2))
        r = np.exp(logp - logp.max(axis=0))
        r *= wt / r.sum(axis=0)
        w = np.maximum(r.sum(axis=1) / wt.sum(), 1e-9)
        mu = (r @ z) / np.maximum(r.sum(axis=1), 1e-12)[:, None]
    # each star as narrow across as one of its brightness: not three stars or more
    spread = (r * (z[None, :, 1] - mu[:, None, 1]) ** 2).sum(axis=1) / np.maximum(r.sum(axis=1), 1e-12)
    order = np.argsort(-w)
    mu, w, spread = mu[order], w[order], spread[order]
    sep = float(np.linalg.norm(mu[1] - mu[0]))
    single = [variance(max(k, MIN_SHARE / 2))[1] for k in w]
    if sep < MIN_SEPARATION_PX or w[1] < MIN_SHARE or np.any(spread > MIN_RATIO * np.array(single)):
        return None
    return mu[0], mu[1], float(w[1]), sep


def _power_law(var, logb):
    """var against brightness as a power law (Theil–Sen in log–log; flat at the median
    where it would fall): the function of log brightness it gives."""
    from scipy.stats import theilslopes

    slope, icpt, _, _ = theilslopes(np.log(var), logb)
    if not slope > 0:
        slope, icpt = 0.0, float(np.median(np.log(var)))
    return lambda lb: np.exp(icpt + slope * lb)


def _singles(var, logb):
    """Which tracks measure a single star's width: all but those standing MIN_EXCESS_PX2
    above the power law of the rest, dropped one at a time from the highest (one pair among
    four tracks tilts their line)."""
    ref = np.ones(len(var), bool)
    while ref.sum() >= MIN_REFERENCES:
        width = _power_law(var[ref], logb[ref])(logb)
        ratio = np.where(ref & _stands_out(var, width), var / width, 0.0)
        worst = int(np.argmax(ratio))
        if not ratio[worst]:
            break
        ref[worst] = False
    return ref


def _stands_out(var, width):
    """A variance a single star of that width does not reach (MIN_EXCESS_PX2, MIN_RATIO)."""
    return (var - width >= MIN_EXCESS_PX2) & (var >= MIN_RATIO * width)


def _robust_scale(r):
    return 1.4826 * float(np.median(np.abs(r - np.median(r))))


def _with_pairs(rows, found):
    """rows with each found track's rows moved onto its brighter star and a copy of them,
    under a new track id, onto its fainter star."""
    out = rows.copy()
    extra = []
    next_id = int(rows["track"].max()) + 1
    for tid, (p, bright, faint, share, sep) in sorted(found.items()):
        mine = np.flatnonzero(rows["track"] == tid)
        out[mine] = _moved(rows[mine], bright, p, 1 - share, sep)
        twin = _moved(rows[mine], faint, p, share, sep)
        twin["track"] = next_id
        next_id += 1
        extra.append(twin)
    out = np.concatenate([out, *extra])
    return out[np.lexsort((out["x"], out["t"]))]


def _moved(rows, off, p, share, sep):
    """A copy of one star's `rows` moved by `off` (along, across the axis p, px), with its
    share of the events and σ widened by the split's model error."""
    rows = rows.copy()
    rows["x"] += off[0] * p[0] - off[1] * p[1]
    rows["y"] += off[0] * p[1] + off[1] * p[0]
    rows["n_events"] = np.rint(rows["n_events"] * share).astype(rows["n_events"].dtype)
    rows["sigma"] = np.hypot(rows["sigma"], SIGMA_PER_SEPARATION * sep)
    rows["split"] = True
    return rows
