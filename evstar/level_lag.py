"""The pixels' low-pass lag measured from the recording itself: crossings' level profiles.

A pixel crossing (evstar.crossings) pairs the rising and the falling time of each reference
level its intensity passed; level j (counted down from the top, j = 1..k) has the midpoint
m_j. A photoreceptor whose cutoff grows with its photocurrent (f_c ∝ I^γ, v2e's model; what
Reed et al.'s EBS-EKF measure on the night sky) delays level j by τ(I_j), and the levels are
C apart in log intensity, so

    m_j = t0 + a·ρ^j        (ρ = e^{γC}, one per sensor; a per crossing, by its peak)

while a pixel without a low-pass has flat profiles. The lag of the crossing's mean time is
m̄ − t0: the geometric trend's extrapolation to a level bright enough to have none. Per
number of pairs k the median demeaned profile D_k(j) = a_k·ρ^j + c_k is fitted (a_k, c_k
linear, ρ shared, on a grid), and the crossing lag is −c_k. The deepest level is left out
of the shape where a profile has >= 4: near the background τ approaches the pulse's own
length and the quasi-static model misses its lag (from 5 levels at first; unequal
thresholds, OFF levels 1.5 ON apart, give a bright star only 2–4 pairs, whose 4th level
took ρ 1.58 where the first three give ~1.3, and every lag 0.6–0.8 ms short of the
crossings' true lag on perf/study_indep.py's scene 22).

Trusted only where the model explains the profiles (R² >= MIN_R2): a sensor without a
low-pass has profiles of timestamp jitter, refractory and threshold-ratio effects (R²
0.77–0.98 on the simulator's default and mismatched-threshold sensors, >= 0.997 with a
20, 30 or 60 Hz dark-sky low-pass, single stars and fields), whose extrapolation would be noise.
"""
from __future__ import annotations

import numpy as np

from .frames import stable_order
from .robust import robust_sigma

#: fewest crossings with k pairs for a profile of k
MIN_PROFILES = 10
#: crossings per k a run keeps for the fit (the median profile of more tells no more)
MAX_PROFILES = 500
#: least fraction of the profiles' variance the geometric lag must explain to be used
MIN_R2 = 0.99
#: profiles with less than this share of the fullest one's crossings neither veto a lag
#: (falling with depth) nor shape it: on a fast dark-sky field a k of a few dozen crossings
#: (28 of 11 pairs beside 500s) fell where a background event was paired in it, and its
#: shape took R² below MIN_R2 (their lag is still read off the shared fit). The veto counts
#: all the run's crossings of each k, not the MAX_PROFILES kept: a faint star on a dark sky
#: with OFF below ON had 843 crossings of 3 pairs and 73 of 2 (a leak or slow first ON in
#: their ON run) whose profile fell with depth; against the 500 kept, 15 % of them vetoed
#: the lag (magnitude 5 on the paper's sinusoid with the IMU: 0.99 px; 0.06 without the veto)
FILLED_SHARE = 0.1
#: standard errors a profile's depth delay is taken below its median (depth_delay_us)
DELAY_SE = 3.0
#: profiles with at least this many levels drop their deepest from the shape fit
_DROP_BOTTOM_FROM = 4
#: ρ's grid: C·γ from 0.1 to 0.9 (contrast thresholds of DVS pixels are ~0.1–0.5)
_RHOS = np.exp(np.linspace(0.1, 0.9, 161))


#: a pixel's passage is its events between gaps of more than this (µs); one with two ON
#: and two OFF events or more gives its OFF events' span over its ON events' (slow_decay)
PASSAGE_GAP_US = 50_000
#: passages a run keeps for that ratio, read from at most this many of a span's events
#: each time (the median of more tells no more)
MAX_PASSAGES, PASSAGE_EVENTS = 2000, 200_000
#: least passages the ratio needs
MIN_PASSAGES = 50
#: a median OFF/ON span ratio from this tells a low-pass the stars cross faster than its
#: time constant: the pixels relax at the dim background's rate, slower than they rose
#: (the stars' own passages on 12 accuracy-grid scenes without a low-pass, ideal to 3 ms
#: refractory periods, 1–35 °/s: 0.81–0.99; behind fast dark skies 2.1–4.8). It needs no
#: depth: a faint star's one- and two-level crossings show none
SLOW_DECAY_RATIO = 1.5


class LevelProfiles:
    """Demeaned level-midpoint profiles of crossings, by number of pairs k (at most
    MAX_PROFILES each), gathered chunk by chunk, and the stars' pixel passages' OFF/ON span
    ratios (at most MAX_PASSAGES: slow_decay)."""

    def __init__(self):
        self._by_k = {}
        self.seen = {}          # k: all the crossings of k pairs offered (wanted or not)
        self._spans = []        # OFF/ON span ratios of passages (add_passages)

    def add_passages(self, t, key, p):
        """Keep the OFF/ON span ratios of the passages of events (t µs, pixel key, p 1 ON)
        in the pixel-then-time order (their first PASSAGE_EVENTS; a passage the cut may
        have shortened left out), up to MAX_PASSAGES in all."""
        room = MAX_PASSAGES - sum(map(len, self._spans))
        n = min(len(t), PASSAGE_EVENTS)
        if room <= 0 or n < 4:
            return
        t, key, on = np.asarray(t[:n], np.int64), np.asarray(key[:n]), np.asarray(p[:n]) == 1
        starts = np.flatnonzero(np.r_[True, (key[1:] != key[:-1]) | (np.diff(t) > PASSAGE_GAP_US)])
        big = np.iinfo(np.int64).max

        def span(sel):   # per passage: (last − first) time of the selected events, and count
            first = np.minimum.reduceat(np.where(sel, t, big), starts)
            last = np.maximum.reduceat(np.where(sel, t, -big), starts)
            return last - first, np.add.reduceat(sel.astype(np.int64), starts)

        (on_span, n_on), (off_span, n_off) = span(on), span(~on)
        ok = (n_on >= 2) & (n_off >= 2) & (on_span > 0)
        if n < len(key):
            ok[-1] = False
        self._spans.append((off_span[ok] / on_span[ok])[:room])

    def slow_decay(self):
        """Whether the passages' median OFF/ON span ratio reaches SLOW_DECAY_RATIO (False
        with fewer than MIN_PASSAGES)."""
        spans = np.concatenate(self._spans) if self._spans else np.zeros(0)
        return len(spans) >= MIN_PASSAGES and float(np.median(spans)) >= SLOW_DECAY_RATIO

    def wanted(self, k):
        """Indices into `k` (pairs per crossing) of the crossings still wanted: per k >= 2,
        the first up to MAX_PROFILES less those held. Every crossing offered is counted in
        `seen`, wanted or not (fit_lag's veto)."""
        k = np.asarray(k)
        per_k = np.bincount(k) if len(k) else np.zeros(0, np.int64)      # k >= 0
        for kk in range(2, len(per_k)):
            self.seen[kk] = self.seen.get(kk, 0) + int(per_k[kk])
        take = {kk: min(int(per_k[kk]), MAX_PROFILES - self._count(kk))
                for kk in range(2, len(per_k))}
        take = {kk: n for kk, n in take.items() if n > 0}
        if not take:
            return np.zeros(0, np.int64)
        # each k's crossings in their order, by one stable sort (not a scan of all per k)
        order, first = stable_order(k), np.cumsum(per_k) - per_k
        return np.sort(np.concatenate([order[first[kk]:first[kk] + n] for kk, n in take.items()]))

    def add(self, k, mids, halves=None, t=None, xy=None):
        """k (n,) pairs and mids (n, max k) level midpoints (µs; beyond k ignored) of
        crossings the caller found wanted; halves: their pairs' half-widths (µs, as mids),
        t: their times (µs) and xy: their pixels (n, 2), for speed_changes (or None)."""
        for kk in np.unique(k[k >= 2]):
            m = k == kk
            rows = mids[m, :kk]
            part = {"D": rows - rows.mean(axis=1, keepdims=True)}
            if halves is not None:
                part.update(h=halves[m, :kk], t=np.asarray(t, np.float64)[m],
                            xy=np.asarray(xy, np.float64)[m])
            self._by_k.setdefault(int(kk), []).append(part)

    def _count(self, kk):
        return sum(len(a["D"]) for a in self._by_k.get(int(kk), []))

    def medians(self, speed_change=None):
        """{k: (median demeaned profile (k,), crossings)} for each k with MIN_PROFILES.
        speed_change: κ(t, xy), the relative speed change a/v (1/s) of the star passing
        each crossing (NaN: none known; speed_changes): each level's midpoint moved by
        κ·h²/2 first, h its pair's half-width — speeding up, the star reaches a pair's far
        flank early, by more the wider the pair, which took a low-pass sensor's accelerating
        star's profiles (perf/study_indep.py --fresh F10) to R² 0.9896 and a lag of 1.0–2.0
        ms against a true 2.5–3.3 (corrected with the true κ: 0.9968, 2.2–2.9 ms)."""
        out = {}
        for kk, parts in sorted(self._by_k.items()):
            rows = np.concatenate([_moved(p, speed_change) for p in parts])
            if len(rows) >= MIN_PROFILES:
                out[kk] = (np.median(rows, axis=0), len(rows))
        return out

    def depth_delay_us(self):
        """How much later, at least, the deepest level of a crossing passes than its top: per
        k with MIN_PROFILES, the median over its profiles of that delay less DELAY_SE of its
        standard error (1.2533 × 1.4826 MAD / √n); the largest, or 0. A low-pass delays a
        dimmer level more (0.7–3.8 ms on the accuracy grid's dark skies); without one the
        levels pass together (within 0.02 ms where a k has 100 profiles or more)."""
        out = 0.0
        for kk, parts in self._by_k.items():
            rows = np.concatenate([p["D"] for p in parts])
            if len(rows) >= MIN_PROFILES:
                d = rows[:, _levels(kk) - 1] - rows[:, 0]
                mid = np.median(d)
                se = 1.2533 * robust_sigma(d, mid) / np.sqrt(len(d))
                out = max(out, float(mid - DELAY_SE * se))
        return out

    def lag(self, speed_change=None):
        """The measured PixelLag (one speed column: the lag of a level is a time), or None
        when the profiles are too few or not a low-pass's (fit_lag); speed_change: as
        medians takes it, used only where the profiles as they are fit no low-pass (on a
        sinusoid, speeding up and slowing down cancel in the median profiles, and the
        centroids' κ near its turns took a fitted lag of 1.4–1.8 ms to 2.1–2.8 and
        perf/study_turns.py's dev 16 from 0.222 to 0.261 px)."""
        fit = fit_lag(self.medians(), self.seen)
        if fit is None and speed_change is not None:
            fit = fit_lag(self.medians(speed_change), self.seen)
        if fit is None:
            return None
        from .calibration import PixelLag

        ks, lag_us, r2, rho = fit
        return PixelLag(ks, [1.0], lag_us[:, None], np.zeros((len(ks), 1)),
                        {"source": "level profiles", "r2": round(r2, 4), "rho": round(rho, 4)})


#: a crossing is a track's where it lies within this (px) of the track's position at its time
MATCH_PX = 2.0
#: a track's speed change at a row: quadratic fits to its centroids within this (µs) of it
FIT_HALF_US = 100_000
#: ... of at least this many of them
MIN_FIT_ROWS = 5


def speed_changes(centroids):
    """κ(t, xy) for LevelProfiles.medians: the relative speed change a/v (1/s) of the track
    of the linked `centroids` that passes each pixel xy (n, 2) at time t (µs), from local
    quadratic fits to its centroids; NaN where no track passes within MATCH_PX that changes
    speed by evstar.smoothing.SPEED_CHANGE_RATIO and never reverses (as the crossings'
    refit without an IMU: at a constant rate κ is noise, and a turn's fits the least sure)."""
    import functools

    from .frames import groups

    @functools.cache
    def tracks():   # fitted on the first call only: most runs' profiles need no κ
        tracked = centroids[centroids["track"] >= 0]
        each = [_speed_profile(tracked[i[np.argsort(tracked["t"][i], kind="stable")]])
                for i in (groups(tracked["track"])[1] if len(tracked) else [])]
        return [f for f in each if f is not None]

    def kappa(t, xy):
        out = np.full(len(t), np.nan)
        for tt, x, y, k in tracks():
            near = (t >= tt[0]) & (t <= tt[-1]) & np.isnan(out)
            near &= np.hypot(np.interp(t, tt, x) - xy[:, 0], np.interp(t, tt, y) - xy[:, 1]) <= MATCH_PX
            out[near] = np.interp(t[near], tt, k)
        return out

    return kappa


def _speed_profile(rows):
    """(t, x, y, κ) at a track's time-sorted rows, or None where its speed (local fits)
    spans less than SPEED_CHANGE_RATIO or it reverses."""
    from .smoothing import SPEED_CHANGE_RATIO

    t = rows["t"].astype(np.float64)
    if len(t) < 2 * MIN_FIT_ROWS or t[-1] - t[0] < 2 * FIT_HALF_US:
        return None
    p = np.column_stack([rows["x"], rows["y"]]).astype(np.float64)
    lo = np.searchsorted(t, t - FIT_HALF_US)
    hi = np.searchsorted(t, t + FIT_HALF_US, side="right")
    if np.any(hi - lo < MIN_FIT_ROWS):
        return None
    # first the windows' mean velocities (cheap): most tracks keep their speed
    v = (p[hi - 1] - p[lo]) / np.maximum(t[hi - 1] - t[lo], 1.0)[:, None]
    speed = np.linalg.norm(v, axis=1)
    if speed.max() < SPEED_CHANGE_RATIO * max(speed.min(), 1e-12) or np.any(v @ v.mean(axis=0) <= 0):
        return None
    # then quadratic fits at ~every 20 ms (interpolated between)
    at = np.unique(np.searchsorted(t, np.arange(t[0], t[-1], FIT_HALF_US / 5)))
    kappa = np.empty(len(at))
    for n, i in enumerate(at):
        c = np.polyfit((t[lo[i]:hi[i]] - t[i]) * 1e-6, p[lo[i]:hi[i]], 2)   # (3, 2): a/2, v, p
        kappa[n] = 2 * (c[0] @ c[1]) / max(c[1] @ c[1], 1e-18)
    return t, p[:, 0], p[:, 1], np.interp(t, t[at], kappa)


#: a level pair's midpoint is moved for its star's speed change only where that speed
#: changes by at most this fraction over the pair's half-width (the shift's expansion holds)
MAX_SPEED_CHANGE = 0.5


def _moved(part, speed_change):
    """A part's demeaned rows, each level moved by κ·h²/2 where speed_change knows κ."""
    D = part["D"]
    if speed_change is None or "h" not in part or not len(D):
        return D
    kappa = speed_change(part["t"], part["xy"])
    h = part["h"] * 1e-6                                      # s
    ok = np.isfinite(kappa) & (np.abs(np.nan_to_num(kappa)) * h.max(axis=1) <= MAX_SPEED_CHANGE)
    if not ok.any():
        return D
    out = D.copy()
    out[ok] += 0.5 * kappa[ok, None] * h[ok] ** 2 * 1e6       # µs
    out[ok] -= out[ok].mean(axis=1, keepdims=True)
    return out


def fit_lag(profiles, seen=None):
    """(k values, lag µs per k, R², ρ) of the geometric model fitted to `profiles` ({k:
    (median demeaned profile, count)}), or None when fewer than two profiles have >= 3
    levels to shape it or R² < MIN_R2. Lags below 0 are 0 (a low-pass only delays).
    seen: {k: the run's crossings of k pairs}, for the veto's FILLED_SHARE (None: the counts)."""
    # a low-pass delays a dimmer level more: every well-filled profile rises with depth over
    # the levels that shape the fit (a sensor without one has profiles of jitter and refractory
    # effects, some falling, whose fit can still pass the R² gate; the deepest level of a
    # long profile, left out of the shape, may fall: a background event of a fast field
    # paired there)
    if any(D[_levels(k) - 1] <= D[0] for k, (D, n) in _filled(profiles, seen).items() if k >= 2):
        return None
    filled = _filled(profiles)
    shaped = {k: v for k, v in filled.items() if _levels(k) >= 3}
    deep = {k: v for k, v in shaped.items() if k >= _DROP_BOTTOM_FROM}
    shape = deep if len(deep) >= 2 else shaped
    if len(shape) < 2:
        return None
    total = sum(n * np.sum((D[:_levels(k)] - D[:_levels(k)].mean()) ** 2) for k, (D, n) in shape.items())
    costs = sum(n * _fit_grid(D, k)[1] for k, (D, n) in shape.items())
    best = int(np.argmin(costs))
    rho = float(_RHOS[best])
    r2 = 1.0 - costs[best] / total if total > 0 else 0.0
    if r2 < MIN_R2:
        return None
    ks = np.array(sorted(profiles))
    lag = np.array([max(-_fit_grid(profiles[k][0], k)[0][best], 0.0) for k in ks])
    return ks, lag, r2, rho


def _filled(profiles, seen=None):
    """The profiles with FILLED_SHARE of the fullest one's crossings: counted in all where
    `seen` ({k: crossings}) is given, else as kept."""
    count = {k: n if seen is None else seen.get(k, n) for k, (D, n) in profiles.items()}
    fullest = max(count.values(), default=0)
    return {k: v for k, v in profiles.items() if count[k] >= FILLED_SHARE * fullest}


def _levels(k):
    """Levels of a k-pair profile that shape the fit (the deepest left out from 4)."""
    return k - 1 if k >= _DROP_BOTTOM_FROM else k


def _fit_grid(D, k):
    """(c, residual sum of squares) per ρ of _RHOS for D[:levels] = a·ρ^j + c, least
    squares (closed form: a = cov(ρ^j, D) / var(ρ^j))."""
    n = _levels(k)
    d = D[:n] - D[:n].mean()
    b = _RHOS[:, None] ** np.arange(1, n + 1)
    bc = b - b.mean(axis=1, keepdims=True)
    a = bc @ d / np.sum(bc * bc, axis=1)
    c = D[:n].mean() - a * b.mean(axis=1)
    return c, np.sum(d * d) - a * a * np.sum(bc * bc, axis=1)


#: crossings of at least this many pairs anchor each track's lags: their profiles have the
#: levels that shape the fit (the deepest one dropped, see _levels) — at least four
ANCHOR_PAIRS = 5
#: a track anchors only with this many anchoring crossings
MIN_ANCHORS = 10
#: fewest anchored crossings of one k to correct its lag (50 let a lone faint star correct
#: its own from a few dozen: a magnitude-5 star at 20 °/s on a dark sky 0.104 -> 0.158 px)
MIN_CORRECTED = 100
#: slowest crossings measured (px/s): a lag is seen as an along offset of speed × lag, so
#: slower ones tell the time little (0.3 px of pixel noise is 6 ms at 50 px/s)
MIN_SPEED_PX_S = 50.0


def track_consistent(lag, crossings, assigned, rows):
    """`lag` (a PixelLag of one speed column, from the level profiles) moved to agree with
    the tracks, and the ids of the tracks that told it (none: unchanged).

    The geometric extrapolation of a 2–4-level profile overestimates the lag where a star
    crosses a pixel in a time near the pixel's time constant (EVK4 dark sky at 1–3 px a
    frame: k = 2 measured 5.3 against a true 3.2 ms), and those crossings are the many, so
    the fit leads the star. Along one track all crossings time one motion: a crossing's
    lag seen from the refitted `rows` (evstar.smoothing estimates with vx, vy, sorted by
    track, then time) is −(along offset) / speed; less the lag used, its median over a
    track's anchoring crossings is the track's own offset, and the median, over tracks that
    have anchors, of the faint crossings' remainder per k is their lag's error. The
    remainders also tell how the lag grows with a crossing's outer half-width (t_outer) at
    one k (the PixelLag's width terms), which carries the lag over to stars with too few
    anchors: a faint star's crossings are wider than a bright star's flank crossings of the
    same k, and lag more. (Per speed bin as well, the corrections scattered: Scorpius 20 °/s
    sinusoid 0.21 -> 0.31 px.)
    assigned: (indices into `crossings`, their track ids), as the refit assigned them (a
    fast star's raw crossings lie px behind its refitted rows)."""
    owner, k, speed, width, d = _seen(lag, crossings, assigned, rows)
    rel, told = _from_anchors(d, owner, k >= ANCHOR_PAIRS)
    if told.sum() < MIN_CORRECTED:
        return lag, np.zeros(0, np.int64)
    from .calibration import PixelLag

    pairs = np.union1d(lag.pairs, np.arange(1, ANCHOR_PAIRS))
    faint = told & (k < ANCHOR_PAIRS)
    error = _k_medians(rel[faint], k[faint], pairs, MIN_CORRECTED)
    lag_us = np.maximum(lag.lag_at(pairs, 1.0) + np.nan_to_num(error), 0.0)
    known = np.isfinite(width)
    use = told & known
    ref_us, ref_px = _width_refs(width[use], speed[use], k[use], pairs,
                                 _k_medians(width[known], k[known], pairs, 1))
    out = PixelLag(pairs, [1.0], lag_us[:, None], np.zeros((len(pairs), 1)),
                   {**lag.meta, "track_consistent": int(told.sum())},
                   width_ref_us=ref_us, width_ref_px=ref_px)
    out.width_slope = _width_slopes(rel[use], width[use] - out.width_at(k[use], speed[use]),
                                    k[use], pairs)
    return out, np.unique(owner[told])


#: fewest told crossings of one k that fit its reference width
MIN_REF_CROSSINGS = 30
#: least spread of 1 / speed (10–90 % quantiles, a fraction of its median) to fit a k's
#: widths against it
MIN_SPEED_SPREAD = 0.2
#: the width slope is fitted on residuals within this many robust σ of their k's median
_SLOPE_CLIP = 3.0


def _seen(lag, crossings, assigned, rows):
    """(track, k, speed px/s, outer half-width µs, lag seen less the lag used µs) of the
    assigned crossings faster than MIN_SPEED_PX_S along their refitted tracks."""
    got, owner = assigned
    t = crossings["t"][got]
    q = np.column_stack([crossings["x"][got], crossings["y"][got]]).astype(np.float64)
    p, v = _on_tracks(t, owner, rows)
    speed = np.hypot(v[:, 0], v[:, 1])
    fast = speed >= MIN_SPEED_PX_S
    along = ((q - p) * v)[fast].sum(axis=1) / speed[fast]
    k, speed = crossings["pairs"][got][fast], speed[fast]
    d = -along / speed * 1e6 - lag.lag_at(k, speed)
    return owner[fast], k, speed, crossings["t_outer"][got][fast], d


def _k_medians(values, k, pairs, least):
    """Per k of `pairs`, the median of its `values` where it has `least` (else NaN)."""
    out = np.full(len(pairs), np.nan)
    for i, kk in enumerate(pairs):
        m = k == kk
        if m.sum() >= least:
            out[i] = np.median(values[m])
    return out


def _width_refs(width, speed, k, pairs, fallback):
    """Per k of `pairs`, (µs, px): its told crossings' widths as a + b / speed (least
    squares within _SLOPE_CLIP robust σ), the passage's own part scaling as 1 / speed and
    the pixel's not (on sinusoids either alone left the faint lag up to 0.5 or 1.2 ms off,
    against 0.15 ms: DVXplorer 15 °/s, EVK4 20 °/s); `fallback` µs and 0 where a k has
    fewer than MIN_REF_CROSSINGS; the widths' median where their speeds span less than
    MIN_SPEED_SPREAD (a pan: the line would be extrapolated from noise)."""
    us, px = np.nan_to_num(fallback), np.zeros(len(pairs))
    for i, kk in enumerate(pairs):
        m = k == kk
        m[m] = _within(width[m])
        if m.sum() < MIN_REF_CROSSINGS:
            continue
        inv = 1e6 / speed[m]
        lo, mid, hi = np.quantile(inv, [0.1, 0.5, 0.9])   # a track's ends may crawl
        b = np.polyfit(inv, width[m], 1)[0] if hi - lo > MIN_SPEED_SPREAD * mid else 0.0
        # through the median, not the mean: stray-widened pairs skew the widths, and a mean
        # reference took lag from the faint stars (Cygnus EVK4 20 °/s pan 0.39 -> 0.45 px)
        us[i], px[i] = np.median(width[m] - b * inv), b
    return us, px


def _within(v):
    """Whether each of `v` lies within _SLOPE_CLIP robust σ (1.4826 × MAD) of its median."""
    if not len(v):
        return np.zeros(0, bool)
    dev = np.abs(v - np.median(v))
    return dev <= _SLOPE_CLIP * max(robust_sigma(dev, 0.0), 1e-9)


def _width_slopes(rel, x, k, pairs):
    """Per k of `pairs`: how much more (µs per µs) a crossing lags than its k's median for
    each µs its outer half-width exceeds the k's reference (x), least squares through the
    remainders `rel`, each k's median removed, both within _SLOPE_CLIP robust σ, in [0, 1]
    (a wider flank delays, and no more than it is wide). The slope falls with k (EVK4 dark
    sky at 20 °/s, true lags: 0.79 at k = 1, 0.45 at 5, 0.26 at 8), so each k with
    MIN_CORRECTED crossings has its own; the others the pooled one (0 when too few tell)."""
    from .frames import groups

    y = rel.copy()
    for rows in groups(k)[1]:
        y[rows] -= np.median(y[rows])
    keep = _within(x) & _within(y)        # a stray event's pair is wide and tells no lag
    x, y, k = x[keep], y[keep], k[keep]
    pooled = _slope(x, y)
    return np.array([_slope(x[k == kk], y[k == kk], pooled) for kk in pairs])


def _slope(x, y, fallback=0.0):
    """The least-squares slope of y on x in [0, 1], or `fallback` below MIN_CORRECTED points."""
    if len(x) < MIN_CORRECTED:
        return fallback
    x = x - x.mean()
    sxx = np.sum(x * x)
    return float(np.clip(np.sum(x * (y - y.mean())) / sxx, 0.0, 1.0)) if sxx > 0 else fallback


def _from_anchors(d, owner, anchor):
    """(d less its track's median over its anchors, whether the track has MIN_ANCHORS)."""
    from .frames import groups

    rel, told = np.zeros(len(d)), np.zeros(len(d), bool)
    for rows in groups(owner)[1]:
        a = rows[anchor[rows]]
        if len(a) >= MIN_ANCHORS:
            rel[rows] = d[rows] - np.median(d[a])
            told[rows] = True
    return rel, told


def _on_tracks(t, owner, rows):
    """Each time's (position (n, 2), velocity (n, 2)) on its track, linear between the
    track's `rows`."""
    from .frames import groups

    p, v = np.zeros((len(t), 2)), np.zeros((len(t), 2))
    tid, each = groups(owner)
    lo, hi = np.searchsorted(rows["track"], tid), np.searchsorted(rows["track"], tid, "right")
    for at, a, b in zip(each, lo, hi):
        r = rows[a:b]
        for j, f in enumerate("xy"):
            p[at, j] = np.interp(t[at], r["t"], r[f])
            v[at, j] = np.interp(t[at], r["t"], r["v" + f])
    return p, v
