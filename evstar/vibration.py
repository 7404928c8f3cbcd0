"""A platform's vibration, found in a star's track and followed.

A constant-velocity smoother cannot follow an oscillation a few frames long: at 20 Hz in
10 ms frames the innovations' likelihood prefers a straight line (its prediction of the
next frame is better than a turn every 2.5 frames), so the track comes out straight while
its centroids swing about it (fresh-41 of perf/study_accuracy.py: 0.05° at 20 Hz across an
8 °/s pan, 0.54 px, without an IMU: 0.345 px against the per-frame mean's 0.157; along it
0.354 against 0.162). Here each long track's centroids' offsets from its smoothed rows,
along and across its motion, are searched for one sinusoid each, from MIN_HZ to
MAX_NYQUIST_SHARE of the frames' Nyquist frequency (a periodogram on the frames' grid, then
scipy's Lomb-Scargle at the centroids' own times about its highest peaks); where one
explains them beyond chance (false-alarm probability FALSE_ALARM over the frequencies
searched) and by more than MIN_AMPLITUDE_PX, the centroids are moved back by it — and,
along the motion, the track's crossings to when the star without it passed their pixels —
the estimator runs again on them, and the sinusoid, its amplitude and phase refitted to the
new fit's residuals, is added back to every row of the track. A track longer than 1.5
WINDOW_S is searched in half-overlapping windows, each for its own sinusoid, blended between
their centres (Waves): a vibration's frequency and amplitude drift. A field is searched as one
first: the per-frame median of its tracks' offsets (in frames of >= MIN_SHARED_TRACKS
tracks) holds a rigid platform's vibration with the noise of many stars averaged down, and
one found there is given to every track; else a frequency one track holds is sought in the
others at it alone (KNOWN_FALSE_ALARM). Across the motion the sinusoid's amplitude and
phase are refitted to the track's crossings, each timed when the star passed its pixel's
column (_by_crossings): per-frame centroids see a fast swing across the motion early and
small. Where a velocity prior carries a track, the gyro carries the platform's motion and
nothing is sought (evstar.estimation.estimate).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .frames import groups
from .robust import robust_sigma

#: the slowest vibration searched for (Hz): slower motion the smoother's own q follows
MIN_HZ = 4.0
#: ... and the fastest, as a share of the frames' Nyquist frequency (beyond, a sinusoid and
#: the frame-to-frame alternation of the centroids' noise are one: their fit is singular;
#: 0.8 left fresh-44's 40 Hz vibration in 10 ms frames unfound, 0.149 px; 0.9: 0.104, and
#: 3000 white tracks still show none)
MAX_NYQUIST_SHARE = 0.9
#: the chance a track of white residuals shows a peak as strong somewhere in the band
FALSE_ALARM = 1e-7
#: ... or at a frequency another track of the recording holds (found)
KNOWN_FALSE_ALARM = 1e-3
#: a sinusoid smaller than this (px) is left in the track
MIN_AMPLITUDE_PX = 0.05
#: centroids a track needs to be searched
MIN_ROWS = 30
#: the periodogram is taken on the frames' grid first (an FFT, zero-padded OVERSAMPLE x:
#: scipy's Lomb-Scargle over the whole band cost 0.09 s of a 50-star run), then exactly, at
#: the centroids' own times, about its PEAKS highest peaks
OVERSAMPLE, PEAKS = 4, 3
#: ... where the grid's peak, this many times its power (the centroids' times off their
#: frames' lower it, by up to ~35 % at the band's top), could pass the false-alarm test
PRESCREEN = 2.0
#: a field's shared vibration is sought in the frames where this many tracks have a row
MIN_SHARED_TRACKS = 3
#: a track longer than 1.5 x this (s) is searched in windows this long, half overlapping,
#: each for its own sinusoid, blended between their centres: a vibration's frequency and
#: amplitude drift (one 15 -> 25 Hz over 3 s was not found as one sinusoid)
WINDOW_S = 1.0
#: crossings a window needs for its sinusoid across the motion to be fitted to them
#: (_by_crossings) rather than to the centroids
MIN_CROSSINGS = 30
#: ... each weighted by its level pairs to this power: a pixel's pairs count the star's
#: light at its passage (in log units, flat at the top), so a plain mean of the pixels'
#: offsets scatters; weighted by pairs they followed 0.38–0.91 of the independent
#: simulator's 15–30 Hz swings at their phase, by pairs² 0.53–0.93
PAIRS_POWER = 2
#: offsets further than this many robust standard deviations from their median are pulled
#: in to it before the search (_clipped)
CLIP_MADS = 2.5
#: the axes of a track's own frame a vibration is sought along
ALONG, ACROSS = 0, 1


class Vibration(NamedTuple):
    """A track's sinusoid along or across its motion: a·cos(ω t) + b·sin(ω t) px, t in s
    from t0_us."""
    omega: float
    a: float
    b: float
    t0_us: int
    rms: float = 0.0

    def at(self, t_us):
        ts = (np.asarray(t_us, np.float64) - self.t0_us) * 1e-6
        return self.a * np.cos(self.omega * ts) + self.b * np.sin(self.omega * ts)


class Waves(NamedTuple):
    """A vibration over a track's windows: each window's (lo, hi) µs and Vibration (zero
    where none was found there), blended linearly between the windows' centres; shared: a
    field's, found in all its tracks' per-frame median (_shared)."""
    bounds: tuple
    parts: tuple
    shared: bool = False

    def at(self, t_us):
        t = np.asarray(t_us, np.float64)
        if len(self.parts) == 1:
            return self.parts[0].at(t)
        c = np.array([(lo + hi) / 2 for lo, hi in self.bounds])
        j = np.clip(np.searchsorted(c, t), 1, len(c) - 1)
        w = np.clip((t - c[j - 1]) / (c[j] - c[j - 1]), 0.0, 1.0)
        values = np.array([p.at(t) for p in self.parts])          # (parts, n)
        n = np.arange(len(t))
        return (1 - w) * values[j - 1, n] + w * values[j, n]

    @property
    def rms(self):
        return max(p.rms for p in self.parts)

    @property
    def strongest(self):
        return max(self.parts, key=lambda p: np.hypot(p.a, p.b))


def offsets(est, centroids):
    """Per measured row of `est` (ESTIMATE_DTYPE) with a centroid, sorted by track and time:
    (track, t µs, frame, its centroid's offsets (n, 2) along and across the track's motion
    px, whether its track reverses (_reversing))."""
    est = _sorted(est)
    m = np.flatnonzero(est["centroid"] >= 0)
    p = np.column_stack([est["x"], est["y"]])
    frame = _frames(est)[m]
    c = est["centroid"][m]
    d = np.column_stack([centroids["x"][c], centroids["y"][c]]) - p[m]
    track = est["track"][m]
    return (track, est["t"][m], est["frame"][m], np.einsum("nij,nj->ni", frame, d),
            np.isin(track, sorted(_reversing(est))))


def found(est, centroids, dt_us):
    """{(track, axis): Waves} of the tracks whose offsets along or across their motion
    hold one (module doc): a field's shared one first (_shared, given to every track), else
    each long track's own; along the motion only where a track never reverses: a reversing
    star's centroids trail it along its motion by a lag that follows its speed, whose
    harmonics passed for a vibration (1.1-1.5 px at 4+ Hz on dark-sky 1 Hz sinusoids)."""
    track, t, frame, r, turning = offsets(est, centroids)
    shared = _shared(track, t, frame, r, turning, dt_us)
    if shared:
        return {(int(tid), axis): v for axis, v in shared.items() for tid in np.unique(est["track"])}
    out, rest = {}, []
    for tid, sel in zip(*groups(track)):
        if len(sel) < MIN_ROWS:
            continue
        for axis in (ACROSS,) if turning[sel[0]] else (ALONG, ACROSS):
            v = _search(t[sel], r[sel, axis], dt_us)
            if v is not None:
                out[(int(tid), axis)] = v
            else:
                rest.append((int(tid), axis, sel))
    # a rigid platform shakes every star: a frequency some track holds is sought in the
    # others at it alone (one frequency, not the band: KNOWN_FALSE_ALARM)
    omegas = sorted({v.strongest.omega for v in out.values()})
    for tid, axis, sel in rest if omegas else ():
        v = _at_known(t[sel], r[sel, axis], omegas)
        if v is not None:
            out[(tid, axis)] = v
    return out


def _at_known(t_us, r, omegas):
    """The Waves (one window) of one track's offsets r along one axis at the one of
    `omegas` (rad/s) _claimed with KNOWN_FALSE_ALARM over len(omegas) frequencies; else
    None."""
    t_us, r = _sorted_clipped(t_us, r)
    x = r - r.mean()
    if not np.ptp(x) > 0:
        return None
    v = _claimed(t_us, r, x, np.asarray(omegas), len(omegas), KNOWN_FALSE_ALARM)
    return None if v is None else Waves(((float(t_us[0]), float(t_us[-1])),), (v,))


def refit(est, centroids, vibrations, crossings=None):
    """Each sinusoid at its frequency, its amplitude and phase fitted again to the offsets of
    `centroids` from `est` (a fit of centroids moved back by it; a shared one to the
    per-frame median once for all tracks), and the RMS of what it leaves: the track's σ is
    at least that (the sinusoid follows the centroids, whose own lag behind a fast swing the
    fit cannot see). Across the motion, where `crossings` (CROSSING_DTYPE) give a window
    MIN_CROSSINGS, its amplitude and phase come from them instead (_by_crossings)."""
    track, t, frame, r, turning = offsets(est, centroids)
    wanted = crossings is not None and len(crossings) and any(a == ACROSS for _, a in vibrations)
    across = across_crossings(crossings, est) if wanted else None
    out, shared = {}, {}
    for (tid, axis), v in vibrations.items():
        if v.shared:
            if axis not in shared:   # one fit for all the tracks it was given to
                series = _median_series(track, t, frame, r[:, axis],
                                        ~turning if axis == ALONG else None)
                shared[axis] = None if series is None else _refitted(v, *series)
                if axis == ACROSS and shared[axis] is not None and across is not None:
                    shared[axis] = _by_crossings(shared[axis], *across)
            v = shared[axis]
        else:
            sel = track == tid
            v = _refitted(v, t[sel], r[sel, axis])
            if axis == ACROSS and v is not None and across is not None:
                mine = across[0] == tid
                v = _by_crossings(v, *(a[mine] for a in across))
        if v is not None:
            out[(tid, axis)] = v
    return out


def across_crossings(crossings, est):
    """Per crossing within assignment.REACH_PX of a moving track of `est`: (track, when the
    track passed the crossing's pixel along its motion µs, the pixel's offset across the
    motion px, its level pairs). A crossing's own time is when the star came nearest its
    pixel: a star swinging across its motion comes nearest a pixel beside its path earlier
    or later than it passes the pixel's column (by offset · ẏ / v²: ~20 ms a pixel for a
    0.27 px, 20 Hz swing across a 40 px/s pan)."""
    from .assignment import REACH_PX
    from .crossings import near_tracks
    from .smoothing import _speed_at

    est = _sorted(est)
    ci, tid, dx, dy, ux, uy = near_tracks(crossings, est, REACH_PX)   # (within REACH_PX)
    t = crossings["t"][ci].astype(np.float64)
    speed = np.zeros(len(ci))
    for track, sel in zip(*groups(tid)):
        speed[sel] = _speed_at(est[est["track"] == track], t[sel])
    column = t + (dx * ux + dy * uy) / np.maximum(speed, 1e-9) * 1e6
    return tid, column, dy * ux - dx * uy, crossings["pairs"][ci].astype(np.float64)


def _refitted(waves, t_us, r):
    """`waves` with each window's found sinusoid's amplitude and phase fitted to the offsets
    r at t_us in its window (_clipped), and the RMS they leave; None for fewer than 3 in a
    window."""
    parts = []
    for (lo, hi), v in zip(waves.bounds, waves.parts):
        if v.a == 0 and v.b == 0:       # none found there
            parts.append(v)
            continue
        m = (t_us >= lo) & (t_us <= hi)
        if m.sum() < 3:
            return None
        rm = _clipped(r[m])   # (as searched: a few wild frames neither pull nor widen it)
        v = v._replace(**dict(zip("ab", _fit(t_us[m], rm, v.omega, v.t0_us))))
        rest = rm - v.at(t_us[m])
        parts.append(v._replace(rms=float(np.sqrt(np.mean((rest - rest.mean()) ** 2)))))
    return waves._replace(parts=tuple(parts))


def _by_crossings(waves, track, t_us, d, pairs):
    """`waves` across the motion with each window's found sinusoid's amplitude and phase
    fitted to the offsets d of the crossings timed t_us (across_crossings), each weighted
    by its level pairs ** PAIRS_POWER (a pixel beside the path fires as many levels as the
    star's light at its passage reaches: their weighted mean across is the star's place
    when it passed that column), each track's weighted mean taken out, the amplitude at
    least the centroids' fit's in that phase; a window of fewer than MIN_CROSSINGS keeps
    the centroids' fit.

    Per-frame centroids see a fast swing across the motion early and small: a pixel fires
    its levels over its whole passage (±σ/v) and the ON lobe ahead tilts with the motion
    (the independent simulator's 15–25 Hz swings: 28–58° early, at 0.6–0.85 of the
    amplitude; the crossings' fit 0–17° off, mostly at 0.8–0.9 of it). Both read a swing
    small, the crossings most where the path swings within a pixel's passage (a defocused
    magnitude-4 star at 22 Hz on a wide lens: 0.47 of it, the centroids 0.72 in its
    phase): hence the floor."""
    parts = []
    for (lo, hi), v in zip(waves.bounds, waves.parts):
        m = (t_us >= lo) & (t_us <= hi)
        if (v.a == 0 and v.b == 0) or m.sum() < MIN_CROSSINGS:
            parts.append(v)
            continue
        w, dm, g = pairs[m] ** PAIRS_POWER, d[m], np.unique(track[m], return_inverse=True)[1]
        dm = dm - (np.bincount(g, w * dm) / np.bincount(g, w))[g]
        z = complex(*_fit(t_us[m], dm * np.sqrt(w), v.omega, v.t0_us, np.sqrt(w)))
        if abs(z) > 0:
            # both read a swing small: the centroids' in-phase amplitude is a floor
            z *= max(1.0, (complex(v.a, v.b) * z.conjugate()).real / abs(z) ** 2)
        parts.append(v._replace(a=z.real, b=z.imag))
    return waves._replace(parts=tuple(parts))


def _shared(track, t, frame, r, turning, dt_us):
    """{axis: Waves} of a field: the median over its tracks of each frame's offsets (each
    track's mean offset taken out: its lobes' bias), in frames of at least
    MIN_SHARED_TRACKS tracks, searched as one track's (a rigid platform moves every star;
    the median's noise falls as the tracks grow many, faint ones' too); along the motion
    without the reversing tracks."""
    out = {}
    for axis in (ALONG, ACROSS):
        series = _median_series(track, t, frame, r[:, axis], ~turning if axis == ALONG else None)
        v = None if series is None else _search(*series, dt_us)
        if v is not None:
            out[axis] = v._replace(shared=True)
    return out


def _median_series(track, t, frame, r, use=None):
    """(times µs, offsets) of the frames where >= MIN_SHARED_TRACKS tracks (of those `use`
    marks) have a row: their rows' median time and median offset less each track's mean;
    None for fewer than MIN_ROWS such frames."""
    if use is not None:
        track, t, frame, r = track[use], t[use], frame[use], r[use]
    if not len(track):
        return None
    _, where = np.unique(track, return_inverse=True)
    r = r - (np.bincount(where, r) / np.bincount(where))[where]
    # frames of enough distinct tracks (the distinct (frame, track) keys, as one integer)
    many = int(where.max()) + 1
    f, n = np.unique(np.unique(frame.astype(np.int64) * many + where) // many, return_counts=True)
    keep = np.isin(frame, f[n >= MIN_SHARED_TRACKS])
    if (n >= MIN_SHARED_TRACKS).sum() < MIN_ROWS:
        return None
    return _group_medians(frame[keep], t[keep]), _group_medians(frame[keep], r[keep])


def _group_medians(key, values):
    """The median of `values` per distinct `key`, keys ascending (one sort)."""
    order = np.lexsort((values, key))
    v, k = np.asarray(values, np.float64)[order], key[order]
    start = np.r_[0, np.flatnonzero(np.diff(k)) + 1]
    size = np.diff(np.r_[start, len(k)])
    return 0.5 * (v[start + (size - 1) // 2] + v[start + size // 2])


def summary(vibrations):
    """The vibrations found, for metrics.json: a field's shared one per axis once ("tracks":
    how many it was given to), each other one with its "track"; frequency (Hz) and
    amplitude (px) along or across the motion."""
    out, shared = [], {}
    for (tid, axis), waves in sorted(vibrations.items()):
        v = waves.strongest
        entry = {"axis": ("along", "across")[axis], "hz": round(v.omega / (2 * np.pi), 2),
                 "amplitude_px": round(float(np.hypot(v.a, v.b)), 3)}
        if len(waves.parts) > 1:   # the strongest of its windows'
            entry["windows"] = [sum(p.a != 0 or p.b != 0 for p in waves.parts), len(waves.parts)]
        if waves.shared:
            shared.setdefault(axis, {**entry, "tracks": 0})["tracks"] += 1
        else:
            out.append({**entry, "track": int(tid)})
    return [shared[a] for a in sorted(shared)] + out


def removed(centroids, est, vibrations):
    """`centroids` of the vibrating tracks moved back by their sinusoids (along and across
    est's motion at their times); a new array."""
    return _shifted(centroids, est, vibrations, -1.0)


def added(rows, est, vibrations):
    """`rows` of the vibrating tracks moved by their sinusoids; a new array."""
    return _shifted(rows, est, vibrations, 1.0)


def crossings_removed(crossings, est, vibrations):
    """`crossings` (CROSSING_DTYPE) of the tracks vibrating along their motion (each assigned
    to its nearest track of `est`, as the estimator assigns them) moved in time to when the
    track without its sinusoid passed their pixel: t − v(t) / speed; a new array."""
    from .assignment import REACH_PX
    from .crossings import along_track
    from .smoothing import _speed_at

    along = {tid: v for (tid, axis), v in vibrations.items() if axis == ALONG}
    out = crossings.copy()
    if not along or not len(crossings):
        return out
    est = _sorted(est)
    ci, owner, _, _ = along_track(crossings, est, REACH_PX)
    for tid, v in along.items():
        k = ci[owner == tid]
        mine = est[est["track"] == tid]
        t = crossings["t"][k]
        speed = _speed_at(mine, t)
        out["t"][k] = t - np.divide(v.at(t), speed, out=np.zeros(len(k)), where=speed > 0) * 1e6
    return out


def _reversing(est):
    """The tracks of `est` (sorted by track and time) whose smoothed velocity turns back (two
    consecutive rows' opposed)."""
    v = np.column_stack([est["vx"], est["vy"]])
    back = (np.sum(v[1:] * v[:-1], axis=1) < 0) & (est["track"][1:] == est["track"][:-1])
    return set(np.unique(est["track"][1:][back]).tolist())


def _sorted(est):
    return est[np.lexsort((est["t"], est["track"]))]


def _shifted(rows, est, vibrations, sign):
    est = _sorted(est)
    out = rows.copy()
    for (tid, axis), v in vibrations.items():
        sel = np.flatnonzero(rows["track"] == tid)
        mine = est[est["track"] == tid]
        if not len(sel) or len(mine) < 2:
            continue
        d = _axes_at(mine, rows["t"][sel])[:, axis]
        s = sign * v.at(rows["t"][sel])
        out["x"][sel] += s * d[:, 0]
        out["y"][sel] += s * d[:, 1]
        if "sigma" in rows.dtype.names:
            out["sigma"][sel] = np.maximum(out["sigma"][sel], v.rms)
    return out


def _frames(est):
    """Per row of `est` (sorted by track and time), its track's unit motion direction and
    normal as the rows of a 2×2 matrix."""
    from .across import _directions

    _, g = np.unique(est["track"], return_inverse=True)
    u = _directions(np.column_stack([est["x"], est["y"]]), g)
    return np.stack([u, np.column_stack([-u[:, 1], u[:, 0]])], axis=1)


def _axes_at(track, t_us):
    """One track's (its time-sorted rows) motion frames (_frames) at times t_us."""
    f = _frames(track)
    ts = track["t"].astype(np.float64)
    ux, uy = np.interp(t_us, ts, f[:, 0, 0]), np.interp(t_us, ts, f[:, 0, 1])
    norm = np.maximum(np.hypot(ux, uy), 1e-12)
    u = np.column_stack([ux / norm, uy / norm])
    return np.stack([u, np.column_stack([-u[:, 1], u[:, 0]])], axis=1)


def _search(t_us, r, dt_us):
    """The Waves of one track's (or a field's) offsets r along one axis: a sinusoid sought in
    each window (_windows), or None where no window holds one."""
    t_us, r = _sorted_clipped(t_us, r)
    bounds = _windows(t_us)
    masks = [(t_us >= lo) & (t_us <= hi) for lo, hi in bounds]
    parts = [_sinusoid(t_us[m], r[m], dt_us) if ok else None
             for m, ok in zip(masks, _worth(t_us, r, masks, dt_us))]
    if all(p is None for p in parts):
        return None
    zero = Vibration(0.0, 0.0, 0.0, int(t_us[0]))
    return Waves(tuple(bounds), tuple(zero if p is None else p for p in parts))


def _sorted_clipped(t_us, r):
    """(t_us, r) in time order (a field's median times may cross), r _clipped: a series as
    it is searched."""
    order = np.argsort(t_us, kind="stable")
    return np.asarray(t_us, np.float64)[order], _clipped(np.asarray(r, np.float64)[order])


def _clipped(r):
    """r with its outliers pulled in to CLIP_MADS robust standard deviations (1.4826 MAD) of
    its median: a few frames of few events (a star nearly stopped by a vibration along its
    motion: 1.4-2.2 px off among 0.5 px swings) hid fresh-51's 10 Hz sinusoid from the
    false-alarm test (its power 0.36 of the variance)."""
    med = np.median(r)
    spread = CLIP_MADS * robust_sigma(r, med)
    return np.clip(r, med - spread, med + spread) if spread > 0 else r


def _windows(t_us):
    """(lo, hi) µs of the windows a sorted series is searched in: the whole of it up to
    1.5 WINDOW_S long, else WINDOW_S-long ones every half window, the last one at its end."""
    w = WINDOW_S * 1e6
    t0, t1 = float(t_us[0]), float(t_us[-1])
    if t1 - t0 <= 1.5 * w:
        return [(t0, t1)]
    starts = list(np.arange(t0, t1 - w, w / 2)) + [t1 - w]
    return [(float(a), float(a + w)) for a in starts]


def _worth(t_us, r, masks, dt_us):
    """Per window (a mask of the sorted series t_us, r): could its frame-grid periodogram
    pass the false-alarm test at all? One FFT for all the windows (a cheap screen before
    _sinusoid's exact one; a track of 4 s has 7 windows)."""
    top = MAX_NYQUIST_SHARE * 0.5e6 / dt_us
    out = np.zeros(len(masks), bool)
    rows = [np.flatnonzero(m) for m in masks]
    ok = [len(k) >= MIN_ROWS and np.ptp(r[k]) > 0 and t_us[k[-1]] > t_us[k[0]] for k in rows]
    if top <= MIN_HZ or not any(ok):
        return out
    use = [k for k, good in zip(rows, ok) if good]
    frames = [np.round((t_us[k] - t_us[k[0]]) / dt_us).astype(np.int64) for k in use]
    grid = np.zeros((len(use), max(int(f.max()) for f in frames) + 1))
    x = [r[k] - r[k].mean() for k in use]
    for row, (f, xk) in enumerate(zip(frames, x)):
        np.add.at(grid[row], f, xk)
    size = OVERSAMPLE * grid.shape[1]
    spec = np.abs(np.fft.rfft(grid, size, axis=1)) ** 2
    freq = np.fft.rfftfreq(size, dt_us * 1e-6)
    band = (freq >= MIN_HZ) & (freq < top)
    peak = np.zeros_like(spec, bool)
    peak[:, 1:-1] = (spec[:, 1:-1] >= spec[:, :-2]) & (spec[:, 1:-1] >= spec[:, 2:])
    best = np.where(peak & band, spec, 0.0).max(axis=1)
    n = np.array([len(k) for k in use])
    rough = 2 * best / (n * np.array([float(np.dot(xk, xk)) for xk in x]))
    span = np.array([(t_us[k[-1]] - t_us[k[0]]) * 1e-6 for k in use])
    m = np.maximum((top - MIN_HZ) * span, 1.0)
    out[np.flatnonzero(ok)] = _false_alarm(np.minimum(PRESCREEN * rough, 1.0), n, m) <= FALSE_ALARM
    return out


def _sinusoid(t_us, r, dt_us):
    """The Vibration of one track's offsets r along one axis, or None (module doc)."""
    order = np.argsort(t_us, kind="stable")     # (a field's median times may cross)
    t_us, r, n = np.asarray(t_us, np.float64)[order], np.asarray(r, np.float64)[order], len(t_us)
    span_s = (t_us[-1] - t_us[0]) * 1e-6 if n else 0.0
    top = MAX_NYQUIST_SHARE * 0.5e6 / dt_us
    if n < MIN_ROWS or span_s <= 0 or top <= MIN_HZ or not np.ptp(r) > 0:
        return None   # (no spread: nothing to find, and the periodogram divides by it)
    x = r - r.mean()
    # independent frequencies in the band: the span's resolution
    m = max((top - MIN_HZ) * span_s, 1.0)
    f, rough = _peaks(t_us, x, dt_us, top)
    if not len(f) or _false_alarm(min(PRESCREEN * rough, 1.0), n, m) > FALSE_ALARM:
        return None
    return _claimed(t_us, r, x, 2 * np.pi * f, m, FALSE_ALARM)


def _claimed(t_us, r, x, omegas, m, alarm):
    """The Vibration of offsets r (x: r less its mean; t_us ascending) at the one of
    `omegas` (rad/s) where their normalised power is highest, where that passes the
    false-alarm probability `alarm` over m independent frequencies and MIN_AMPLITUDE_PX;
    else None."""
    from scipy.signal import lombscargle

    power = np.atleast_1d(lombscargle((t_us - t_us[0]) * 1e-6, x, omegas, normalize=True))
    k = int(np.argmax(power))
    if _false_alarm(power[k], len(x), m) > alarm:
        return None
    a, b = _fit(t_us, r, omegas[k], int(t_us[0]))
    if np.hypot(a, b) < MIN_AMPLITUDE_PX:
        return None
    return Vibration(float(omegas[k]), a, b, int(t_us[0]))


def _peaks(t_us, x, dt_us, top):
    """(frequencies (Hz) about the PEAKS highest local maxima in [MIN_HZ, top) of the
    offsets' periodogram on the frames' grid — an FFT, OVERSAMPLE x zero-padded: a centroid
    at its frame, whose own time the exact periodogram then takes — each ±1 bin in quarter
    bins; the highest one's normalised power there)."""
    frame = np.round((t_us - t_us[0]) / dt_us).astype(np.int64)
    grid = np.zeros(frame.max() + 1)
    np.add.at(grid, frame, x)
    size = OVERSAMPLE * len(grid)
    spec = np.abs(np.fft.rfft(grid, size)) ** 2
    f = np.fft.rfftfreq(size, dt_us * 1e-6)
    i = np.arange(1, len(spec) - 1)
    i = i[(spec[i] >= spec[i - 1]) & (spec[i] >= spec[i + 1]) & (f[i] >= MIN_HZ) & (f[i] < top)]
    i = i[np.argsort(spec[i])[::-1][:PEAKS]]
    fine = (f[i][:, None] + f[1] * np.linspace(-1.0, 1.0, 9)).ravel()
    # the highest peak's share of the variance (uniform sampling's normalised power)
    rough = 2 * spec[i[0]] / (len(x) * float(np.dot(x, x))) if len(i) else 0.0
    return fine[(fine >= MIN_HZ) & (fine < top)], rough


def _false_alarm(power, n, m):
    """The chance that white residuals (n of them) show a normalised power this high at one
    of m independent frequencies."""
    return 1.0 - (1.0 - (1.0 - power) ** ((n - 3) / 2)) ** m


def _fit(t_us, r, omega, t0_us, scale=1.0):
    """Least-squares (a, b) of r ≈ c + a·cos(ω t) + b·sin(ω t); with `scale` (per point), of
    r ≈ scale · (c + a·cos + b·sin): a weighted fit whose r and rows are scaled by √weight."""
    ts = (np.asarray(t_us, np.float64) - t0_us) * 1e-6
    A = np.column_stack([np.cos(omega * ts), np.sin(omega * ts), np.ones(len(ts))])
    A = A * np.reshape(scale, (-1, 1))
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    return float(coef[0]), float(coef[1])
