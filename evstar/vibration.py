"""A platform's vibration across a star's motion, found in its track's residuals.

A constant-velocity smoother cannot follow an oscillation a few frames long: at 20 Hz in
10 ms frames the innovations' likelihood prefers a straight line (its prediction of the
next frame is better than a turn every 2.5 frames), so the track comes out straight while
its centroids swing across it (fresh-41 of perf/study_accuracy.py: 0.05° at 20 Hz on an
8 °/s pan, 0.54 px, without an IMU: 0.345 px against the per-frame mean's 0.157). Here each
long track's centroids' offsets across its smoothed motion are searched for one sinusoid
(scipy's Lomb-Scargle periodogram between MIN_HZ and the frames' Nyquist frequency); where
one explains them beyond chance (false-alarm probability FALSE_ALARM over the frequencies
searched) and by more than MIN_AMPLITUDE_PX, the centroids are moved back by it, the
estimator runs again on them, and the sinusoid — its amplitude and phase refitted to the new
fit's residuals — is added back to every row of the track across its motion. Along the
motion the crossings time the star; a vibration there is not modelled.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: the slowest vibration searched for (Hz): slower motion the smoother's own q follows
MIN_HZ = 4.0
#: ... and the fastest, as a share of the frames' Nyquist frequency (beyond, a sinusoid and
#: the frame-to-frame alternation of the centroids' noise are one: their fit is singular)
MAX_NYQUIST_SHARE = 0.8
#: the chance a track of white residuals shows a peak as strong somewhere in the band
FALSE_ALARM = 1e-7
#: a sinusoid smaller than this (px) is left in the track
MIN_AMPLITUDE_PX = 0.05
#: centroids a track needs to be searched
MIN_ROWS = 30


class Vibration(NamedTuple):
    """A track's sinusoid across its motion: a·cos(ω t) + b·sin(ω t), t in s from t0_us."""
    omega: float
    a: float
    b: float
    t0_us: int
    rms: float = 0.0

    def at(self, t_us):
        ts = (np.asarray(t_us, np.float64) - self.t0_us) * 1e-6
        return self.a * np.cos(self.omega * ts) + self.b * np.sin(self.omega * ts)


def across_offsets(est, centroids):
    """Per measured row of `est` (ESTIMATE_DTYPE, sorted by track and time) with a centroid:
    (track, t µs, its centroid's offset across the track's motion px, that unit normal)."""
    from .across import _directions

    m = np.flatnonzero(est["centroid"] >= 0)
    p = np.column_stack([est["x"], est["y"]])
    _, g = np.unique(est["track"], return_inverse=True)
    u = _directions(p, g)[m]
    normal = np.column_stack([-u[:, 1], u[:, 0]])
    c = est["centroid"][m]
    d = np.column_stack([centroids["x"][c], centroids["y"][c]]) - p[m]
    return est["track"][m], est["t"][m], (d * normal).sum(1), normal


def found(est, centroids, dt_us):
    """{track: Vibration} of the tracks whose across offsets hold one (module doc)."""
    out = {}
    track, t, r, _ = across_offsets(est, centroids)
    for tid in np.unique(track):
        sel = track == tid
        v = _sinusoid(t[sel], r[sel], dt_us)
        if v is not None:
            out[int(tid)] = v
    return out


def refit(est, centroids, vibrations):
    """Each track's sinusoid at its frequency, amplitude and phase fitted again to the
    across offsets of `centroids` from `est` (a fit of centroids moved back by it), and the
    RMS of what it leaves: the track's σ is at least that (the sinusoid follows the
    centroids, whose own lag across a fast swing the fit cannot see)."""
    track, t, r, _ = across_offsets(est, centroids)
    out = {}
    for tid, v in vibrations.items():
        sel = track == tid
        if sel.sum() >= 3:
            a, b = _fit(t[sel], r[sel], v.omega, v.t0_us)
            v = v._replace(a=a, b=b)
            rest = r[sel] - v.at(t[sel])
            out[tid] = v._replace(rms=float(np.sqrt(np.mean((rest - rest.mean()) ** 2))))
    return out


def removed(centroids, est, vibrations):
    """`centroids` of the vibrating tracks moved back across their motion (est's, at their
    times) by their sinusoid; a new array."""
    return _shifted(centroids, est, vibrations, -1.0)


def added(rows, est, vibrations):
    """`rows` of the vibrating tracks moved across their motion (est's, at their times) by
    their sinusoid; a new array."""
    return _shifted(rows, est, vibrations, 1.0)


def _shifted(rows, est, vibrations, sign):
    out = rows.copy()
    for tid, v in vibrations.items():
        sel = np.flatnonzero(rows["track"] == tid)
        mine = est[est["track"] == tid]
        if not len(sel) or len(mine) < 2:
            continue
        n = _normals(mine, rows["t"][sel])
        s = sign * v.at(rows["t"][sel])
        out["x"][sel] += s * n[:, 0]
        out["y"][sel] += s * n[:, 1]
        if "sigma" in rows.dtype.names:
            out["sigma"][sel] = np.maximum(out["sigma"][sel], v.rms)
    return out


def _normals(track, t_us):
    """The unit normals of one track's motion (its time-sorted rows) at times t_us."""
    from .across import _directions

    u = _directions(np.column_stack([track["x"], track["y"]]), np.zeros(len(track), np.int64))
    ts = track["t"].astype(np.float64)
    ux, uy = np.interp(t_us, ts, u[:, 0]), np.interp(t_us, ts, u[:, 1])
    norm = np.maximum(np.hypot(ux, uy), 1e-12)
    return np.column_stack([-uy / norm, ux / norm])


def _sinusoid(t_us, r, dt_us):
    """The Vibration of one track's across offsets, or None (module doc)."""
    from scipy.signal import lombscargle

    n = len(t_us)
    span_s = (t_us[-1] - t_us[0]) * 1e-6 if n else 0.0
    top = MAX_NYQUIST_SHARE * 0.5e6 / dt_us
    if n < MIN_ROWS or span_s <= 0 or top <= MIN_HZ:
        return None
    ts = (t_us - t_us[0]) * 1e-6
    # frequencies 4x oversampled against the span's resolution 1/span
    f = np.arange(MIN_HZ, top, 0.25 / span_s)
    power = lombscargle(ts, r - r.mean(), 2 * np.pi * f, normalize=True)
    k = int(np.argmax(power))
    # independent frequencies in the band: the span's resolution
    m = max((top - MIN_HZ) * span_s, 1.0)
    fap = 1.0 - (1.0 - (1.0 - power[k]) ** ((n - 3) / 2)) ** m
    if fap > FALSE_ALARM:
        return None
    a, b = _fit(t_us, r, 2 * np.pi * f[k], int(t_us[0]))
    if np.hypot(a, b) < MIN_AMPLITUDE_PX:
        return None
    return Vibration(float(2 * np.pi * f[k]), a, b, int(t_us[0]))


def _fit(t_us, r, omega, t0_us):
    """Least-squares (a, b) of r ≈ c + a·cos(ω t) + b·sin(ω t)."""
    ts = (np.asarray(t_us, np.float64) - t0_us) * 1e-6
    A = np.column_stack([np.cos(omega * ts), np.sin(omega * ts), np.ones(len(ts))])
    coef, *_ = np.linalg.lstsq(A, r, rcond=None)
    return float(coef[0]), float(coef[1])
