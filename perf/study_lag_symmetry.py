"""Exploration (not in the pipeline): the pixels' low-pass lag from the time symmetry of the
input, on dark-sky scenes where the level-profile fit (evstar.level_lag) falls short.

A symmetric PSF moving steadily gives each pixel a time-symmetric input u(t) (log intensity
over the sky). A first-order photoreceptor whose cutoff grows with the photocurrent,
y' = (u − y)·e^u / τ_bg, delays and skews it. Undoing the filter at each event — y its level
(reference + n·C), y' the level step over the time between its neighbours — gives
u = y + y'·τ_bg·e^(−u) (Newton). With the right τ_bg the reconstructed points of both flanks
lie on one symmetric pulse: ln(e^u − 1) a parabola in t (a Gaussian PSF), whose vertex is
the passage time. Per scene, on the star's own events (the truth's labels) and told the
sensor's threshold C (the reference offset taken as −C/2): the parabolas' residual (mean
square, pooled over pixels passed within 2.5 px) and the median vertex − true passage time,
for τ as fractions of the sensor's τ_bg = 1/(2π·cutoff_hz_background).

Found by the tenth session: the lag goes through zero at 0.55–0.78 τ_bg on all four scenes,
and the residual's minimum lies near it on three (vertex −0.5 to +0.35 ms off, against the
level-profile fit's 2 ms short on the first two), but it is noisy (a few events per flank);
C and the reference offset would have to be fitted too before a product could use it, and
a first try at C failed: on a grid of 0.6–1.5 × the true C the residual (raw, or over the
variance of ln(e^u − 1)) is least at the grid's smallest C on three of the four scenes, and
the lag there is −1.34, −0.25, −0.41 and +2.39 ms.

    python perf/study_lag_symmetry.py

Writes perf/results/study_lag_symmetry.json and .md.
"""
from __future__ import annotations

import pathlib

import numpy as np

import study_accuracy as sa
from evstar import profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
SCENES = {"dark-sky-15, 10 °/s, mag 5": dict(motion=10, mag=5, psf=1.1, sensor="dark-sky-15", seed=17),
          "dark-sky-20, 14 °/s, mag 4.5": dict(motion=14, mag=4.5, psf=1.3, sensor="dark-sky-20", seed=13),
          "dark-sky-40, 25 °/s, mag 4": dict(motion=25, mag=4, psf=1.1, sensor="dark-sky-40", seed=17),
          "dark-sky-20, 5 °/s, mag 3.5": dict(motion=5, mag=3.5, psf=1.3, sensor="dark-sky-20", seed=13)}
FRACTIONS = (0.0, 0.25, 0.4, 0.55, 0.7, 0.85, 1.0, 1.2)
NEAR_PX = 2.5
COLUMNS = [("scene", "scene", ""), ("tau_fraction", "τ / τ_bg", ".2f"), ("tau_ms", "τ ms", ".1f"),
           ("residual", "parabola residual", ".4f"), ("lag_ms", "vertex − passage ms", "+.2f"),
           ("pixels", "pixels", "")]


def passages(s):
    """(ON times, OFF times, true passage µs) of each pixel the star passed within NEAR_PX:
    its first ON run and the OFF run after it (star events only)."""
    run = sim.simulate(sa.scenario(dict(s, comp="none")), seed=s["seed"])
    ev, star = run.events, run.truth.labels >= 0
    t, x, y, p = ev.t[star], ev.x[star].astype(int), ev.y[star].astype(int), ev.p[star]
    key = y * ev.width + x
    o = np.lexsort((t, key))
    t, key, p, x, y = t[o], key[o], p[o], x[o], y[o]
    out = []
    for start, stop in zip(*_groups(key)):
        tt, pp = t[start:stop].astype(float), p[start:stop]
        change = np.flatnonzero(np.diff(pp.astype(int)) != 0)
        if pp[0] != 1 or not len(change):
            continue
        a = change[0] + 1
        b = a + (np.argmax(pp[a:] != 0) if np.any(pp[a:] != 0) else len(pp) - a)
        if a < 2 or b - a < 2:
            continue
        probe = np.linspace(tt[0] - 50_000, tt[b - 1], 400).astype(np.int64)
        d = np.hypot(*(run.truth.star_position(probe)[:, 0] - (x[start], y[start])).T)
        if d.min() <= NEAR_PX:
            out.append((tt[:a], tt[a:b], float(probe[np.argmin(d)])))
    return out


def _groups(key):
    edges = np.flatnonzero(np.r_[True, key[1:] != key[:-1], True])
    return edges[:-1], edges[1:]


def reconstructed(on, off, c, tau_s):
    """(event times, reconstructed input log intensity) of one passage."""
    ref = -c / 2
    lv_on = ref + c * np.arange(1, len(on) + 1)
    lv_off = ref + c * (len(on) - np.arange(1, len(off) + 1))
    slope = np.r_[np.gradient(lv_on, on), np.gradient(lv_off, off)] * 1e6   # per second
    lv, u = np.r_[lv_on, lv_off], np.r_[lv_on, lv_off]
    for _ in range(30):   # Newton on u − y − y'·τ·e^(−u) = 0
        d = 1 + slope * tau_s * np.exp(-u)
        d = np.where(np.abs(d) < 0.2, np.copysign(0.2, d), d)
        u = u - (u - lv - slope * tau_s * np.exp(-u)) / d
    return np.r_[on, off], u


def score(passes, c, tau_s):
    """(mean square parabola residual, median vertex − passage µs, pixels used)."""
    sq, n, lags = 0.0, 0, []
    for on, off, t_pass in passes:
        t, u = reconstructed(on, off, c, tau_s)
        ok = np.expm1(u) > 1e-3
        if ok.sum() < 4:
            continue
        z, ts = np.log(np.expm1(u[ok])), (t[ok] - t[ok].mean()) * 1e-3
        coef, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(ts)), ts, ts ** 2]), z, rcond=None)
        r = z - coef[0] - coef[1] * ts - coef[2] * ts ** 2
        sq, n = sq + float(r @ r), n + len(r)
        if coef[2] < 0:
            lags.append(-coef[1] / (2 * coef[2]) * 1e3 + t[ok].mean() - t_pass)
    return sq / max(n, 1), float(np.median(lags)) if lags else float("nan"), len(lags)


def main():
    rows = []
    for name, s in SCENES.items():
        spec = sa.SENSORS[s["sensor"]]()
        tau_bg = 1 / (2 * np.pi * spec.cutoff_hz_background)
        passes = passages(s)
        for f in FRACTIONS:
            res, lag, used = score(passes, spec.threshold_on, f * tau_bg)
            rows.append({"scene": name, "tau_fraction": f, "tau_ms": f * tau_bg * 1e3,
                         "residual": res, "lag_ms": lag / 1e3, "pixels": used})
            print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    text = profiling.table(rows, COLUMNS)
    profiling.write_results(RESULTS / "study_lag_symmetry.json", rows, {"fractions": FRACTIONS})
    (RESULTS / "study_lag_symmetry.md").write_text("# Lag from the input's time symmetry\n\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
