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
against their brightness (level pairs per px of path) give a power law (Theil–Sen in
log–log, over all tracks and over the LOCAL_REFERENCES nearest in brightness, the larger;
tracks far above it left out one at a time, _singles). A track standing far
above it (MIN_EXCESS_PX2, MIN_RATIO and EXCESS_MADS robust scales of the others' scatter)
is fitted as two stars: EM on its crossings' offsets (along, across its main direction),
each star's profile a Gaussian as wide across as a single star of its share's brightness,
started from the moments' closed-form solution (_moment_start). The fit is kept where the
two lie MIN_SEPARATION_PX to MAX_SEPARATION_PX apart, the fainter holds MIN_SHARE, their
mean lies within MAX_ALONG_PX of the track along the motion, and neither is wider than
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

from . import paths
from .robust import robust_sigma

#: crossings within this distance of a track's position count for its spread: a pair 5 px
#: apart has each star 2.5 px off its blend and a profile reaching ~4 px further
REACH_PX = 7.0
#: the fewest crossings that measure a track's spread (and a reference track's)
MIN_CROSSINGS = 60
#: the fewest other measured tracks that give the single-star width, and the nearest in
#: brightness that give it locally (_expected)
MIN_REFERENCES, LOCAL_REFERENCES = 3, 8
#: a split's excess variance must reach this (px²; w(1 − w)s² of a 1:3 pair 2.3 px apart)
MIN_EXCESS_PX2 = 1.0
#: ... and this many times a single star's (the reference tracks' spread about their power
#: law is ~10 %), and this many robust scales (1.4826 MAD) of their log residuals
MIN_RATIO, EXCESS_MADS = 1.4, 4.0
#: the split stars at least this far apart (px) and the fainter with at least this share;
#: at most MAX_SEPARATION_PX: pairs further apart have tracks of their own in most frames,
#: and a star that far off the track has its profile cut by the REACH_PX window (an EVK4
#: sinusoid's short track took a neighbour 9.7 px away, 0.43 px off, as its pair)
MIN_SEPARATION_PX, MIN_SHARE, MAX_SEPARATION_PX = 2.0, 0.1, 6.0
#: a track whose motion turns further than this from its main direction is not split
MAX_TURN_DEG = 20.0
#: the two stars' mean along the motion at most this far from the track (px; a 5 px pair at 45°
#: to the motion whose track follows the brighter: 1.4 px): a short track
#: at a sinusoid's turn had its crossings 3.5 px behind it, and a third star beside it
MAX_ALONG_PX = 2.0
#: the EM fit's steps, and the least along-motion variance of a star's crossings it assumes
#: (px²: crossings are timed so well that a single star's along spread is ~0.01)
EM_STEPS, MIN_ALONG_VAR_PX2 = 30, 0.25
#: added in quadrature to a split star's σ, per px of separation (the two-copy model's error)
SIGMA_PER_SEPARATION = 0.05


def split(rows, crossings, near, tracks):
    """`rows` (CENTROID_DTYPE, time-sorted) with each track that is an unresolved pair
    replaced by the pair's two stars (a new array, time-sorted; the new tracks' ids follow
    the largest). near: evstar.crossings.near_tracks of the crossings to `tracks` (rows
    with t, track, x, y sorted by track then time: the estimator's, before its last
    steps moved them into `rows`) with reach REACH_PX."""
    tracked = np.flatnonzero((rows["track"] >= 0) & np.isfinite(rows["x"]) & np.isfinite(rows["y"]))
    if not len(tracked) or not len(near[0]):
        return rows
    path = paths.of(rows[tracked])
    found = _pairs(_track_stats(path, crossings["pairs"], near, paths.moved_by(path, tracks)))
    return _with_pairs(rows, found) if found else rows


def _track_stats(path, levels, near, moved):
    """Per track (path: evstar.paths.of): its id, main direction of motion (axis, unit, either
    sign), whether it holds it (steady), brightness (level pairs per px of path),
    crossings and the level-pair-weighted variances of their offsets from it along and
    across the axis (var_al, var_ac); and per crossing near one of these tracks (near:
    evstar.crossings.near_tracks, its offsets less the track's `moved`) its track's index
    (g) and level pairs (w) and its offset (along, across)."""
    n_tr, g = len(path["ids"]), path["g"]
    axis, steady = paths.directions(path, MAX_TURN_DEG)
    same = g[1:] == g[:-1]
    step = np.hypot(np.diff(path["x"]), np.diff(path["y"]))
    length = np.bincount(g[1:][same], step[same], n_tr)
    ci, track, dx, dy = near[:4]
    gc = paths.lookup(path["ids"], track)
    keep = np.flatnonzero(gc >= 0)
    gc, w = gc[keep], np.asarray(levels, np.float64)[ci[keep]]
    ox, oy = dx[keep] - moved[gc, 0], dy[keep] - moved[gc, 1]
    along = ox * axis[gc, 0] + oy * axis[gc, 1]
    across = oy * axis[gc, 0] - ox * axis[gc, 1]
    total = np.bincount(gc, w, n_tr)
    return {"ids": path["ids"], "axis": axis, "steady": steady,
            "crossings": np.bincount(gc, None, n_tr),
            "bright": total / np.maximum(length, 1e-9),
            "var_al": _weighted_var(along, w, gc, total), "var_ac": _weighted_var(across, w, gc, total),
            "g": gc, "w": w, "along": along, "across": across}


def _weighted_var(v, w, g, total):
    """Per track the w-weighted variance of v (g: each value's track, total: its weights'
    sum)."""
    n = len(total)
    mean = np.bincount(g, w * v, n) / np.maximum(total, 1e-12)
    return np.bincount(g, w * (v - mean[g]) ** 2, n) / np.maximum(total, 1e-12)


def _pairs(st):
    """{track: (axis, offset of the brighter, offset of the fainter (along, across px),
    the fainter's share, separation px)} of the tracks that are unresolved pairs (st:
    _track_stats)."""
    measured = np.flatnonzero(st["crossings"] >= MIN_CROSSINGS)
    var_al, var_ac = st["var_al"][measured], st["var_ac"][measured]
    logb = np.log(np.maximum(st["bright"][measured], 1e-3))
    ref = _singles(var_ac, logb)
    if ref.sum() < MIN_REFERENCES:
        return {}
    width = _power_law(var_ac[ref], logb[ref])
    single = _expected(var_ac, logb, ref)
    scale = float(robust_sigma(np.log(var_ac[ref] / single[ref])))
    along = max(float(np.median(var_al[ref])), MIN_ALONG_VAR_PX2)
    wide = (st["steady"][measured] & _stands_out(var_ac, single)
            & (np.log(var_ac / single) >= EXCESS_MADS * scale))
    found = {}
    for k, lb in zip(measured[wide], logb[wide]):
        mine = st["g"] == k
        z = np.column_stack([st["along"][mine], st["across"][mine]])
        w = st["w"][mine]
        got = _two_stars(z, w, _moment_start(z, w, along, width(lb)),
                         lambda share: np.array([along, width(lb + np.log(share))]))
        if got is not None:
            found[int(st["ids"][k])] = (st["axis"][k], *got)
    return found


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
    leaves the two closer than MIN_SEPARATION_PX or further than MAX_SEPARATION_PX, the
    fainter under MIN_SHARE, their mean
    more than MAX_ALONG_PX off the track along the motion, or either spread across wider
    than MIN_RATIO single stars of its share (three stars or more)."""
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
    # the track's own timing: their crossings centred on it along the motion
    off_track = abs(float(w @ mu[:, 0])) > MAX_ALONG_PX
    if (not MIN_SEPARATION_PX <= sep <= MAX_SEPARATION_PX or w[1] < MIN_SHARE or off_track
            or np.any(spread > MIN_RATIO * np.array(single))):
        return None
    return mu[0], mu[1], float(w[1]), sep


def _power_law(var, logb):
    """var against brightness as a power law (Theil–Sen in log–log: the median of the
    pairwise slopes, scipy.stats.theilslopes' estimate without its input checks, which
    cost ~15 ms a call; flat at the median where it would fall): the function of log
    brightness it gives."""
    logv = np.log(var)
    i, j = np.triu_indices(len(logb), 1)
    run = logb[j] - logb[i]
    ok = run != 0
    slope = float(np.median((logv[j] - logv[i])[ok] / run[ok])) if ok.any() else 0.0
    if not slope > 0:
        slope = 0.0
    icpt = float(np.median(logv) - slope * np.median(logb))
    return lambda lb: np.exp(icpt + slope * lb)


def _expected(var, logb, ref):
    """Each track's variance as a single star of its brightness: the larger of the power
    law of all references and that of the LOCAL_REFERENCES nearest it in brightness (not
    itself): the law steepens towards bright stars (a faint star's width is its PSF's, a
    bright one's grows with its log contrast), and one line through the faint bulk would
    call the brightest single stars wide."""
    out = _power_law(var[ref], logb[ref])(logb)
    idx = np.flatnonzero(ref)
    k = min(LOCAL_REFERENCES, len(idx) - 1)
    if k < 2:
        return out
    lv = np.log(var)
    dist = np.abs(logb[:, None] - logb[idx][None]) + np.where(idx[None] == np.arange(len(var))[:, None], np.inf, 0.0)
    near = idx[np.argsort(dist, axis=1)[:, :k]]                       # (n, k)
    i, j = np.triu_indices(k, 1)
    run = logb[near[:, j]] - logb[near[:, i]]
    rise = lv[near[:, j]] - lv[near[:, i]]
    slope = np.nanmedian(np.where(run != 0, rise / np.where(run != 0, run, 1.0), np.nan), axis=1)
    slope = np.where(slope > 0, slope, 0.0)
    icpt = np.median(lv[near], axis=1) - slope * np.median(logb[near], axis=1)
    return np.maximum(out, np.exp(icpt + slope * logb))


def _singles(var, logb):
    """Which tracks measure a single star's width: all but those standing MIN_EXCESS_PX2
    above the power law of the rest, dropped one at a time from the highest (one pair among
    four tracks tilts their line)."""
    ref = np.ones(len(var), bool)
    while ref.sum() >= MIN_REFERENCES:
        width = _expected(var, logb, ref)
        ratio = np.where(ref & _stands_out(var, width), var / width, 0.0)
        worst = int(np.argmax(ratio))
        if not ratio[worst]:
            break
        ref[worst] = False
    return ref


def _stands_out(var, width):
    """A variance a single star of that width does not reach (MIN_EXCESS_PX2, MIN_RATIO)."""
    return (var - width >= MIN_EXCESS_PX2) & (var >= MIN_RATIO * width)



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
