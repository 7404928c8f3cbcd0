"""A slow star's two lobes: one target that DBSCAN sees as two clusters.

A star moving a fraction of a pixel per frame fires ON events where its leading flank
brightens the pixels and OFF events where its trailing flank darkens them; its centre,
where the intensity barely changes, fires almost nothing. With a wide PSF (σ ≳ 1.2 px) the
gap between the two flanks exceeds eps and the star becomes an ON-only and an OFF-only
cluster about 3.5 σ apart, each reported as a star ~1.7 σ off the truth (one of them false).
Here such pairs — mutual nearest, of opposite dominant polarity, in the same frame, closer
than ``extract.lobe_gap_px`` — are joined into one cluster. A moving star's own cluster
holds both polarities, so it never pairs with a neighbour's lobe. An OFF-only cluster on
the path behind a moving star is no star (trails): with a slow (dark-sky) photoreceptor the
pixels a fast star passed relax for tens of ms and fire OFF events well behind it, clusters
that became false tracks trailing the star (17 false rows per 100 frames on a 20 Hz
dark-sky sinusoid). A lone OFF lobe elsewhere stays: a slow star's ON lobe may be missed.
"""
from __future__ import annotations

import numpy as np

from .frames import nearest_in_frame

#: a cluster is one polarity's lobe when at least this share of its events has it
PURITY = 2 / 3


def on_share(centroids):
    """Per centroid (CENTROID_DTYPE) the share of its events that are ON."""
    return centroids["n_on"] / np.maximum(centroids["n_events"], 1)


def balanced(centroids):
    """Per centroid (CENTROID_DTYPE): does it hold both lobes — an ON share strictly between
    1 − PURITY and PURITY?"""
    share = on_share(centroids)
    return (share > 1 - PURITY) & (share < PURITY)


def lone(centroids):
    """Per centroid (CENTROID_DTYPE): is it one lobe alone — it holds events, not both
    polarities (balanced: no)?"""
    return ~balanced(centroids) & (centroids["n_events"] > 0)


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


#: a trail lies on its star's path: within this of the line through the star along its motion
TRAIL_ACROSS_PX = 3.0


def trails(frame, n_by_p, sx, sy):
    """Per cluster: is it a trail — OFF events alone (an ON share <= 1 − PURITY) behind a
    larger cluster of both polarities of its frame, on the line through that one along its
    motion (its ON centre less its OFF centre, >= 0.5 px)? Pixels a fast star passed relax
    and fire OFF events behind it; with a slow (dark-sky) photoreceptor for tens of ms, far
    enough to become clusters of their own. frame, n_by_p, sx, sy: as pairs()."""
    n = n_by_p.sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = np.column_stack([sx.sum(1) / n, sy.sum(1) / n])
        d = np.column_stack([sx[:, 1] / n_by_p[:, 1] - sx[:, 0] / n_by_p[:, 0],
                             sy[:, 1] / n_by_p[:, 1] - sy[:, 0] / n_by_p[:, 0]])
    length = np.hypot(d[:, 0], d[:, 1])
    moving = np.flatnonzero((n_by_p.min(1) > 0) & (length >= 0.5))
    out = np.zeros(len(n), bool)
    for g in np.flatnonzero(n_by_p[:, 1] <= (1 - PURITY) * n):
        s = moving[(frame[moving] == frame[g]) & (n[moving] > n[g])]
        out[g] = _behind_on_line(xy[g] - xy[s], d[s] / length[s, None])
    return out


def _behind_on_line(w, u, reach=np.inf):
    """Does a point at offsets `w` (n, 2) from n centres, each moving along its unit `u`
    (n, 2), lie behind one of them (less than `reach` px), within TRAIL_ACROSS_PX of its line?"""
    along = np.sum(w * u, axis=1)
    across = np.abs(w[:, 0] * u[:, 1] - w[:, 1] * u[:, 0])
    return bool(np.any((along < 0) & (along > -reach) & (across < TRAIL_ACROSS_PX)))


#: a slow star's lone ON lobe lies ~1.25 σ_PSF ahead of it (_LOBE_OFFSET_PER_SPREAD in
#: evstar.pooling): within this of a track's row, ahead on its line, it is that star's
#: (fresh-11's 2 °/s, σ 1.5 px star: lone ON lobes 2 px ahead, OFF ones 3 px behind)
LOBE_AHEAD_PX = 4.0


#: a track whose events are at most this share ON is a trail of OFF lobes, not a star: a
#: star's passages fire ON for ~r/(1 + r) of its events (r = C_off/C_on: 0.29–0.71 for
#: ratios 0.4–2.5), while the pixels a fast star left behind on a slow (dark-sky)
#: photoreceptor relax with OFF events alone. Moved with the gyro (IMU compensation), those
#: separate from the star's own ON-led cluster, which trails() then cannot pair them with
#: (Scorpius EVK4 16 mm dark-sky 20 °/s sinusoid: 99 tracks of ON share < 1/3, none a star's)
TRAIL_ON_SHARE = 0.2
#: ... judged on at least this many of its centroids off the sensor's edge (a star entering
#: at the edge at its turn gave one OFF-heavy centroid there, 1 ON of 10)
TRAIL_MIN_CENTROIDS = 5


def trail_tracks(centroids):
    """Ids of the tracks of `centroids` whose events, all their centroids' off the sensor's
    edge together, are TRAIL_ON_SHARE or less ON (a star leaving the sensor shows its OFF
    events alone there: an Orion star at 2 °/s, 10 ON of 76), of TRAIL_MIN_CENTROIDS or
    more; none where no centroid holds an ON event (their polarities not counted)."""
    on = (centroids["track"] >= 0) & ~centroids["border"] & (centroids["n_events"] > 0)
    if not centroids["n_on"].any():
        return np.zeros(0, np.int64)
    ids, k = np.unique(centroids["track"][on], return_inverse=True)
    n = np.bincount(k, centroids["n_events"][on], len(ids))
    n_on = np.bincount(k, centroids["n_on"][on], len(ids))
    enough = np.bincount(k, minlength=len(ids)) >= TRAIL_MIN_CENTROIDS
    return ids[enough & (n_on <= TRAIL_ON_SHARE * n)]


def of_tracks(rows, tracks):
    """Per row of `rows` (untracked centroids): is it a tracked star's lobe — a trail,
    TRAIL_ON_SHARE or less ON, behind a track's row of its frame (`tracks`: ESTIMATE_DTYPE
    rows with velocities) on the line through it along its motion (within TRAIL_ACROSS_PX),
    or a slow star's lone ON lobe, 1 − TRAIL_ON_SHARE or more ON, ahead of one within
    LOBE_AHEAD_PX? trails() for the clusters no track took, with the track's own motion
    where the frame holds no two-polarity cluster ahead (IMU compensation sets the star's
    ON-led cluster apart from its OFF trail)."""
    out = np.zeros(len(rows), bool)
    speed = np.hypot(tracks["vx"], tracks["vy"])
    moving = speed > 0
    off = rows["n_on"] <= TRAIL_ON_SHARE * rows["n_events"]
    on = rows["n_on"] >= (1 - TRAIL_ON_SHARE) * rows["n_events"]
    for i in np.flatnonzero(off | on):
        s = moving & (tracks["frame"] == rows["frame"][i])
        if not s.any():
            continue
        u = np.column_stack([tracks["vx"][s], tracks["vy"][s]]) / speed[s, None]
        w = np.column_stack([rows["x"][i] - tracks["x"][s], rows["y"][i] - tracks["y"][s]])
        out[i] = _behind_on_line(w, u) if off[i] else _behind_on_line(-w, u, LOBE_AHEAD_PX)
    return out


#: centroids a track needs before its lobe bias is measured
MIN_LOBE_CENTROIDS = 10
#: least std of a track's ON shares: enough one-lobe centroids to measure the bias against
MIN_SHARE_STD = 0.2
#: least share of the residuals' variance the lobe bias must explain: a stiff fit of a track
#: that accelerates leaves residuals the shares do not explain
MIN_LOBE_R2 = 0.5
#: a centroid whose residual from the stiff fit exceeds this many times its track's median
#: |residual| is no lobe's (a lobe moves a centroid by ~β/2 at most) and sets no β
WILD = 5.0


def _shares(centroids):
    """ON share less ½ per centroid (n_on / n_events − ½)."""
    return on_share(centroids) - 0.5


def candidates(centroids):
    """Ids of the confirmed tracks with MIN_LOBE_CENTROIDS centroids whose ON shares spread
    by MIN_SHARE_STD: those whose lobe bias debiased() may measure."""
    on = centroids["track"] >= 0
    ids, k = np.unique(centroids["track"][on], return_inverse=True)
    s = _shares(centroids[on])
    n = np.maximum(np.bincount(k, minlength=len(ids)), 1)
    mean = np.bincount(k, s, len(ids)) / n
    var = np.bincount(k, s * s, len(ids)) / n - mean ** 2
    return ids[(n >= MIN_LOBE_CENTROIDS) & (var >= MIN_SHARE_STD ** 2)]


def debiased(centroids, est):
    """(centroids less each track's lobe bias, ids of the tracks changed). A centroid with ON
    share s (n_on / n_events) sits ~β·(s − ½) ahead of its star along the motion: its ON events
    lead the centre, its OFF events trail it, and a faint slow star's frames often catch one
    lobe alone (±1.5 σ_PSF). β is measured per track — the slope of its centroids' residuals
    along the motion from a stiff fit `est` (ESTIMATE_DTYPE rows, "centroid" indexing
    `centroids`; a fit free to turn follows the lobes) against s − ½ — and removed from the
    candidates() tracks where β > 0 explains MIN_LOBE_R2 of the residuals' variance; a
    centroid of both lobes in balance (s = ½) stays."""
    e = est[(est["centroid"] >= 0) & (np.hypot(est["vx"], est["vy"]) > 0)
            & np.isin(est["track"], candidates(centroids))]
    c = e["centroid"]
    speed = np.hypot(e["vx"], e["vy"])
    ux, uy = e["vx"] / speed, e["vy"] / speed
    s = _shares(centroids[c])
    r = (centroids["x"][c] - e["x"]) * ux + (centroids["y"][c] - e["y"]) * uy
    ids, k = np.unique(e["track"], return_inverse=True)
    # a wild centroid (another star's, taken by the tracker) would set β: left out
    typical = np.array([np.median(np.abs(r[k == j])) for j in range(len(ids))])
    tame = np.abs(r) <= WILD * typical[k]
    e, c, s, r, ux, uy, k = e[tame], c[tame], s[tame], r[tame], ux[tame], uy[tame], k[tame]
    n = np.bincount(k, minlength=len(ids)).astype(float)
    mean = lambda v: np.bincount(k, v, len(ids)) / n
    ds, dr = s - mean(s)[k], r - mean(r)[k]
    sxx, sxy = np.bincount(k, ds * ds, len(ids)), np.bincount(k, ds * dr, len(ids))
    syy = np.bincount(k, dr * dr, len(ids))
    with np.errstate(invalid="ignore", divide="ignore"):
        beta = sxy / sxx
        use = (beta > 0) & (sxy * beta >= MIN_LOBE_R2 * syy)   # R² = β·Sxy / Syy
    out = centroids.copy()
    on = use[k]
    shift = beta[k][on] * s[on]
    out["x"][c[on]] -= shift * ux[on]
    out["y"][c[on]] -= shift * uy[on]
    return out, ids[use]
