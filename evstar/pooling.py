"""Faint stars' second look: the events no frame centroid used, pooled over longer frames.

A star that gives a few events per frame passes neither the density filter's per-frame
thresholds nor DBSCAN's min_samples in most frames, though its events are there. The events
no frame centroid used are filtered again among themselves (NDSEF at ``denoise.radius``,
whatever the frame filter) in frames ``extract.pool_frames`` (k) times as long (its
threshold for that length: the noise per frame grows k-fold, but so does the star's count,
and a slow star stays compact), and those it keeps are clustered in the long frames; a
cluster needs k - 1 times the frame clusters' smallest size (or _min_size's, where the
background makes that larger: at 10 Hz, 15-43-event noise clumps had pooled into false
tracks), or, where neither a frame centroid nor such a cluster lies near, more events than the measured background puts in a
DBSCAN disk of a long frame but about once a second over the sensor (_faint: stars of 2-3
events a frame). "Not used" are the events the
frame filter dropped and those it kept that no reported cluster holds: on a quiet sensor
(no background, so every event passes the filter) a wide faint star's events fail DBSCAN
alone, and a look at the filter's rejects found nothing (1.5 °/s, magnitude 4.5, σ 1.8 px,
no noise: 32 % of frames, 1.6 px). The used events are left out of the density too: counted,
they let the background along a bright star's path pass, which pooled into a false track
beside the star (10 Hz of background, a sinusoid: 12-14 false rows per 100 frames). A pooled
centroid's ``t`` is its members' mean time (where a linearly moving star was at its
position), its ``frame`` the frame of that time (a _faint one's: its long frame's middle)
and its ``source`` "pooled". One within
``track.gate_px`` of a frame centroid of its own frame is dropped (the tracker would see two
candidates for one star); the tracker links the rest with the frame centroids, and the
estimator drops pooled centroids no track took (noise that once pooled into a cluster).
"""
from __future__ import annotations

import numpy as np
from evstar_kernels.reference.denoise import disk_area, poisson_thresholds

from .denoise import NDSEF
from .extract import CENTROID_DTYPE
from .frames import FRAME_GAP, nearest_in_frame
from .lobes import PURITY, on_share
from .parameters import AUTO, MAX_DT_US

#: background-only DBSCAN disks over the whole sensor per second that hold the smallest
#: pooled cluster (the tracker's min_length then asks for more of them in a row)
_FALSE_CLUSTERS_PER_S = 1.0
#: long frames (each way) within which a joined pair's lobe geometry moves a lone ON lobe:
#: a slow star's direction holds that long (200 ms at the default 40 ms)
_PAIR_LONG_FRAMES = 5
#: the fewest events of a faint cluster, however quiet the sensor (two make no spread)
_MIN_FAINT_EVENTS = 3
#: a faint slow star's lone lobe lies √(π/2)·σ_PSF off the star and its events spread
#: √(1 + 2 − π/2)·σ (across: σ; along: the u·G(u) profile's): offset ≈ 1.05 × spread
_LOBE_OFFSET_PER_SPREAD = float(np.sqrt(np.pi / 2) / np.sqrt(3 - np.pi / 2))
#: ... and a pair's half-gap must reach this share of the offset its lobes' spreads predict
#: (pairs of one slow star: 0.78-1.8; the pieces of a 2 °/s star: 0.4-0.5)
_LOBE_GAP_SHARE = 0.6


def pooled_centroids(config, events, unused, t0_us, rate_hz, frame_centroids, scratch=None):
    """CENTROID_DTYPE rows (source "pooled") of the `unused` events (mask over `events`,
    the chunk's raw events: those no frame centroid used) in frames
    config.extract.pool_frames times config.dt_us long, aligned to t0_us, less those a
    frame centroid (frame_centroids) already covers. scratch: a Scratch its filter shares
    (the caller's, kept between calls), None for its own."""
    k = config.extract.pool_frames
    if k <= 1 or config.dt_us * k > MAX_DT_US or not unused.any():
        return np.zeros(0, CENTROID_DTYPE)
    d, e = config.denoise, config.extract
    # one density test, NDSEF at denoise.radius with its threshold for the long frame (a
    # third of MR-NDSEF's cost, as good here), among the unused events alone (above)
    flt = NDSEF(config.dt_us * k, d.radius, AUTO, alpha=d.alpha,
                rate_hz=d.rate_hz if d.rate_hz is not None else rate_hz, t0_us=t0_us,
                device=config.device)
    if scratch is not None:
        flt.sharing(scratch)
    rest = events[flt.kept_among(events, unused)]
    if not len(rest):
        return np.zeros(0, CENTROID_DTYPE)
    long_us = config.dt_us * k
    small = _min_size(e, flt.rate_hz_, long_us, events.width * events.height)
    strict = max(_strict_size(e), small)
    cents = _clusters(config, rest, t0_us, strict)
    cents["frame"] = (cents["t"] - t0_us) // config.dt_us
    if small < strict:   # ... unless it lies where nothing else was seen (_faint)
        faint = _faint(_clusters(config, rest, t0_us, small), strict, k, config.track.gate_px,
                       e.lobe_gap_px)
        cents = np.concatenate([cents, faint])
        cents = cents[np.lexsort((cents["x"], cents["t"]))]
    cents["source"] = "pooled"
    return cents[~_seen(cents, frame_centroids, config.track.gate_px)]


def _clusters(config, events, t0_us, min_size):
    """Centroids of `events` clustered in frames extract.pool_frames times as long, clusters
    of fewer than min_size events left out (and, where that is below extract.min_samples,
    DBSCAN's core points need min_size too: a cluster of 4 has no core point of 5)."""
    from .pipeline import Pipeline

    extra = {"extract.min_samples": min_size} if min_size < config.extract.min_samples else {}
    long = Pipeline(config.replace(dt_us=config.dt_us * config.extract.pool_frames,
                                   **{"extract.min_cluster_size": min_size, **extra}))
    return long.make_extractor(t0_us).centroids(events)


def _faint(cents, strict, k, radius, lobe_gap_px=None):
    """The clusters of fewer than `strict` events (`cents`: a long extraction down to the
    background's _min_size), those of one long frame within `radius` merged (_merged), a
    slow star's lone lobes joined (_lobes_joined, lobe_gap_px; None: never), OFF events
    alone then dropped: they are what a fast star leaves behind on slow (dark-sky) pixels
    (38 such clusters on a 20 °/s field, none a star; over a long frame a slow star shows
    both lobes). Each takes its long frame's middle frame (simultaneous: in consecutive
    frames the tracker chained two stars' clusters into one 20 px jump). Which of them a
    faint star alone explains is decided on the whole run (kept)."""
    cents = _merged(cents[cents["n_events"] < strict], radius)
    if lobe_gap_px is not None:
        cents = _lobes_joined(cents, lobe_gap_px)
    cents = cents[cents["n_on"] > (1 - PURITY) * cents["n_events"]]
    cents["frame"] = cents["frame"] * k + k // 2     # long frame -> its middle frame
    return cents


def _lobes_joined(cents, gap_px):
    """A faint slow star with a wide PSF: its leading ON lobe and trailing OFF lobe are
    clusters ~2.5 σ_PSF apart, each ~1.25 σ off the star (a σ 2.5 px star's ON lobes alone
    were its track, 3 px ahead), and so few events a long frame that one lobe is often
    seen a long frame before or after the other. Each ON-only cluster and its mutual
    nearest OFF-only one of the same or a neighbouring long frame, closer than gap_px
    (extract.lobe_gap_px, as the frame extractor joins a frame's lobes) but not closer than
    lobes of their width lie (_LOBE_GAP_SHARE), become one centroid at the midpoint of the
    two (the lobes lie symmetric about the star: their thresholds set how many events each
    has, not where) and their mean time; lone ON lobes near such a pair move by its
    half-gap (_lone_lobes_moved)."""
    from scipy.spatial import cKDTree

    share = on_share(cents)
    on, off = np.flatnonzero(share >= PURITY), np.flatnonzero(share <= 1 - PURITY)
    if not len(on) or not len(off):
        return cents

    scale = gap_px / 2    # Chebyshev distance < gap_px: long frames <= 1 apart
    d_on, j = cKDTree(_points(cents, off, scale)).query(_points(cents, on, scale), p=np.inf,
                                                        distance_upper_bound=gap_px)
    _, i = cKDTree(_points(cents, on, scale)).query(_points(cents, off, scale), p=np.inf,
                                                    distance_upper_bound=gap_px)
    found = np.flatnonzero(np.isfinite(d_on))
    a, b = on[found], off[j[found]]
    mutual = i[j[found]] == found
    a, b = a[mutual], b[mutual]
    # the half-gap, OFF lobe less ON lobe (the star lies there from its ON lobe)
    hx, hy = (cents["x"][b] - cents["x"][a]) / 2, (cents["y"][b] - cents["y"][a]) / 2
    half = np.hypot(hx, hy)
    # two lobes lie about their offset from the star apart on each side: a closer ON / OFF
    # pair is no slow star's lobes (a moving star's smeared pieces: joined, a 2 °/s σ 1.8 px
    # star's one such pair moved it 0.30 -> 0.64 px)
    lobe = _LOBE_OFFSET_PER_SPREAD * (cents["spread"][a] + cents["spread"][b]) / 2
    close = ((half < gap_px / 2) & (np.abs(cents["frame"][a] - cents["frame"][b]) <= 1)
             & (half >= _LOBE_GAP_SHARE * lobe))
    a, b, hx, hy, half = a[close], b[close], hx[close], hy[close], half[close]
    if not len(a):
        return cents
    out = cents.copy()
    for key in ("x", "y"):
        out[key][a] = (cents[key][a] + cents[key][b]) / 2
    out["t"][a] = (cents["t"][a] + cents["t"][b]) // 2
    out["spread"][a] = np.sqrt((cents["spread"][a] ** 2 + cents["spread"][b] ** 2) / 2 + half ** 2)
    # counted as its larger lobe: a pair is still a faint cluster (kept takes it only where no
    # star seen explains it), its σ the larger lobe's; its polarity share that of both
    n, n_on = cents["n_events"][a] + cents["n_events"][b], cents["n_on"][a] + cents["n_on"][b]
    out["n_events"][a] = np.maximum(cents["n_events"][a], cents["n_events"][b])
    out["n_on"][a] = np.rint(out["n_events"][a] * n_on / n)
    out["border"][a] |= cents["border"][b]
    _lone_lobes_moved(out, np.setdiff1d(on, a), a, hx, hy, gap_px)
    keep = np.ones(len(cents), bool)
    keep[b] = False
    return out[keep]


def _lone_lobes_moved(cents, lone, pairs, hx, hy, gap_px):
    """In place: each lone ON lobe (`lone`, indices into cents) moved by the half-gap
    (hx, hy: OFF lobe less ON lobe, halved) of the nearest joined pair (`pairs`) within
    gap_px and _PAIR_LONG_FRAMES long frames: the star's own lobe geometry, measured where
    both lobes showed (a σ 2.5 px star's lone ON lobes, 3 px ahead, were 37 false rows per
    100 frames)."""
    from scipy.spatial import cKDTree

    if not len(lone) or not len(pairs):
        return

    scale = gap_px / (_PAIR_LONG_FRAMES + 0.5)   # Chebyshev < gap_px: <= that many apart
    d, j = cKDTree(_points(cents, pairs, scale)).query(_points(cents, lone, scale), p=np.inf,
                                                       distance_upper_bound=gap_px)
    ok = np.isfinite(d)
    cents["x"][lone[ok]] += hx[j[ok]]
    cents["y"][lone[ok]] += hy[j[ok]]


def _points(cents, idx, frame_scale):
    """(x, y, long frame × frame_scale) of the rows idx: a Chebyshev query within gap_px of
    them spans |dx|, |dy| < gap_px and long frames fewer than gap_px / frame_scale apart."""
    return np.column_stack([cents["x"][idx], cents["y"][idx], cents["frame"][idx] * frame_scale])


def kept(centroids, config):
    """Per row of a whole run's centroids, whether the tracker gets it: every frame
    centroid; a pooled one unless it is lone, no other centroid (pooled, or of a frame)
    within 2·track.gate_px in x and in y and 2.5 long frames (a star's events pool again,
    a clump of noise does not: noise clusters of 9 events 20 px from a slow star started
    tracks that took its centroids, 18 false rows per 100 frames), or _faint and a star
    seen there explains it: a frame centroid or a pooled one of the usual size within
    2·gate_px and one long frame (so a star already seen keeps its track: its faint
    clusters had moved a 1 °/s faint star's rows by 0.1 px and undone the calibrated
    threshold ratio's gain). On the whole run: a streamed chunk's edge would cut a
    neighbour off."""
    from scipy.spatial import cKDTree

    out = np.ones(len(centroids), bool)
    pooled = centroids["source"] == "pooled"
    if not pooled.any():
        return out
    e, radius = config.extract, 2 * config.track.gate_px
    long_us = config.dt_us * e.pool_frames
    box = np.column_stack([centroids["x"], centroids["y"], centroids["t"] * (radius / long_us)])
    wide = box * [1, 1, 1 / 2.5]
    n = cKDTree(wide).query_ball_point(wide[pooled], radius, p=np.inf, return_length=True)
    out[pooled] = n >= 2
    faint = pooled & (centroids["n_events"] < _strict_size(e))
    if faint.any() and (~faint).any():
        near = cKDTree(box[~faint]).query(box[faint], p=np.inf, distance_upper_bound=radius)[0]
        out[faint] &= ~np.isfinite(near)
    return out


def _strict_size(extract):
    """A pooled cluster's usual size: (pool_frames - 1) frames' worth of the smallest frame
    cluster (a weaker one is as often a noise clump, or a bright star's stray flank, as a
    faint star; _faint takes those only where no star was seen)."""
    return (extract.pool_frames - 1) * (extract.min_cluster_size or extract.min_samples)


def _min_size(extract, rate_hz, long_us, sensor_px):
    """The smallest pooled cluster: more events than the background puts in a DBSCAN disk
    (radius extract.eps) of a long frame, the measured rate's Poisson count at the false-alarm
    probability that makes _FALSE_CLUSTERS_PER_S such disks over the sensor each second;
    never fewer than _MIN_FAINT_EVENTS. The fixed (k - 1) frame clusters (15 events) lose
    stars of 2-3 events a frame at 1 Hz of background; half of that lets noise clumps into
    the tracks at 5 Hz. On a quiet sensor the count falls below a frame cluster's
    min_samples (4 at 0.1 Hz on a DAVIS346), which had kept stars of 1-1.5 events a frame
    out (a 1.4 event/frame star at 0.1 Hz: no frame, now 23 % of them)."""
    area = disk_area(extract.eps)
    alpha = min(0.5, _FALSE_CLUSTERS_PER_S * area * long_us * 1e-6 / sensor_px)
    noise = int(poisson_thresholds(rate_hz, long_us, [extract.eps], alpha)[0])
    return max(_MIN_FAINT_EVENTS, noise)


def _merged(cents, radius):
    """Clusters of one long frame within `radius` of each other merged into one (their
    members' means, an event-weighted spread): a faint star's few events can fall into two
    DBSCAN clusters, whose halves would start a second track beside it (a 3 °/s star's two
    pooled halves, 4.6 px apart, pulled its track 3 px off). A close pair's split halves
    stay apart."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    xyf = np.column_stack([cents["x"], cents["y"], cents["frame"] * FRAME_GAP])
    pairs = cKDTree(xyf).query_pairs(radius, output_type="ndarray") if len(cents) > 1 else []
    if len(pairs):   # a split's halves are two stars (Extractor.split_valley): kept apart
        pairs = pairs[~(cents["split"][pairs[:, 0]] & cents["split"][pairs[:, 1]])]
    if not len(pairs):
        return cents
    n = len(cents)
    links = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, group = connected_components(links, directed=False)
    w = cents["n_events"].astype(float)
    total = np.bincount(group, w)

    def mean(v):
        return np.bincount(group, w * v) / total

    out = cents[np.unique(group, return_index=True)[1]]
    out["x"], out["y"] = mean(cents["x"]), mean(cents["y"])
    out["t"] = np.rint(mean(cents["t"].astype(float))).astype(np.int64)
    dx, dy = cents["x"] - out["x"][group], cents["y"] - out["y"][group]
    out["spread"] = np.sqrt(mean(cents["spread"] ** 2 + dx * dx + dy * dy))
    out["n_events"] = np.bincount(group, cents["n_events"])
    out["n_on"] = np.bincount(group, cents["n_on"])
    out["border"] = np.bincount(group, cents["border"]) > 0
    return out[np.lexsort((out["x"], out["t"]))]


def _seen(pooled, frame_centroids, radius):
    """Per pooled centroid: whether a frame centroid of its own frame lies within `radius`
    (the tracker would have two candidates for one star there)."""
    if not len(pooled) or not len(frame_centroids):
        return np.zeros(len(pooled), bool)
    d, _ = nearest_in_frame(np.column_stack([frame_centroids["x"], frame_centroids["y"]]),
                            frame_centroids["frame"],
                            np.column_stack([pooled["x"], pooled["y"]]), pooled["frame"], radius)
    return np.isfinite(d)
