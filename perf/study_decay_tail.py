"""The pixels' background time constant read off a star's OFF decay tails, and the crossings'
true lag in units of it (an exploration, not in the pipeline: the forty-third session's lead
on the fast dark-sky lag the level profiles read short).

Behind a photoreceptor whose cutoff follows its intensity (f_c = f_bg · I), a star that
crosses a pixel faster than the background time constant τ_bg = 1 / (2π f_bg) leaves the
pixel's output high when it has gone: the output then relaxes at τ_bg alone, and the OFF
events mark levels δ, δ + C, δ + 2C, ... on that exponential, t_j = T − τ_bg · ln(δ/C + j).
Fitting each pixel pass's OFF events to that form (δ/C on a grid, T and τ_bg linear) reads
τ_bg without knowing C. The true lag of the crossings (each crossing's time less the
star's passage of its pixel along the motion, truth) is reported over τ_bg, beside the
level profiles' lag (evstar.level_lag) over τ_bg.

Scenes: perf/study_accuracy.py's dark-rates star (EVK4, σ 1.4 px, no IMU, seed 42) on
dark skies of 10–60 Hz, at `--rates`, magnitude `--mag`; the star's own events (truth
labels) feed the tail fit. The `--model` part instead runs one pixel's first-order
low-pass (the simulator's law, 2 kHz ceiling) on a Gaussian pulse of peak A × the
background and σ_t ms, and gives the mean of its level-pair midpoints' lag (what a
crossing's time lags) over τ_bg.

    python perf/study_decay_tail.py [--rates 4,12,25] [--mag 4] [--sensors dark-sky,...]
    python perf/study_decay_tail.py --model
    [--name NAME]: results under that name

Writes perf/results/study_decay_tail.json and .md (study_decay_tail_model.* with --model)
and prints the table.
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

from evstar import Config, Pipeline, estimation, profiling, sim
from evstar.level_lag import LevelProfiles, speed_changes

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
COLUMNS = [("sensor", "sensor", ""), ("rate", "°/s", ""), ("mag", "mag", ""),
           ("tau_bg_ms", "τ_bg ms", ".2f"), ("tail_ms", "tail fit ms (median)", ".2f"),
           ("tail_iqr", "tail fit IQR ms", ""), ("passes", "pixel passes", ""),
           ("true_lag_tau", "true lag / τ_bg", ".2f"), ("profile_lag_tau", "profiles' lag / τ_bg", ".2f")]
MODEL_COLUMNS = [("tau_bg_ms", "τ_bg ms", ".2f"), ("A", "peak A", ""), ("sigma_t_ms", "σ_t ms", ""),
                 ("levels", "levels", ""), ("lag_tau", "crossing lag / τ_bg", ".2f")]
#: the model pixel's reference levels below the background (× the threshold)
_REFERENCES = (0.1, 0.3, 0.5, 0.7, 0.9)
#: δ/C grid of the decay fit
_OFFSETS = np.linspace(0.02, 1.0, 50)


def decay_tau(t_off):
    """τ (µs) of OFF times t_off (ascending, ≥ 3) on t_j = T − τ·ln(δ/C + (n − 1 − j))."""
    n = len(t_off)
    best = (np.inf, np.nan)
    for d in _OFFSETS:
        a = np.column_stack([np.ones(n), -np.log(d + np.arange(n - 1, -1, -1.0))])
        sol = np.linalg.lstsq(a, t_off, rcond=None)[0]
        r = float(((a @ sol - t_off) ** 2).sum())
        if r < best[0]:
            best = (r, float(sol[1]))
    return best[1]


def tail_taus(events, labels, min_off=4):
    """The decay fit's τ (µs) of every pixel pass of the star's own events (labels >= 0)
    with at least min_off OFF events after its first ON event."""
    m = labels >= 0
    key = events.y[m].astype(np.int64) * events.width + events.x[m]
    t, p = events.t[m], events.p[m]
    o = np.lexsort((t, key))
    key, t, p = key[o], t[o], p[o]
    cuts = np.flatnonzero(np.diff(key)) + 1
    out = []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(key)]):
        on = t[a:b][p[a:b] == 1]
        if not len(on):
            continue
        off = t[a:b][(p[a:b] == 0) & (t[a:b] > on[0])].astype(np.float64)
        if len(off) >= min_off:
            out.append(decay_tau(off))
    return np.array(out)


def true_lags(run, crossings):
    """Each crossing's time less the star's passage of its pixel along the motion (µs), and
    its distance across the motion (px); one star at a constant rate. (study_lag_truth's
    _true_lags keeps only crossings within 3 px of the star at their time, which drops the
    fast stars' most-lagged ones: 0.24 τ_bg where all read 0.46 on dark-sky-15 at 25 °/s.)"""
    t = np.arange(int(run.events.t[0]), int(run.events.t[-1]), 20, dtype=np.int64)
    pos = run.truth.star_position(t, 0)
    ok = np.isfinite(pos).all(1)
    t, pos = t[ok], pos[ok]
    u = (pos[-1] - pos[0]) / np.linalg.norm(pos[-1] - pos[0])
    n = np.array([-u[1], u[0]])
    q = np.column_stack([crossings["x"], crossings["y"]]).astype(np.float64)
    s = pos @ u
    passed = np.interp(q @ u, s, t.astype(np.float64))
    return crossings["t"] - passed, q @ n - np.interp(q @ u, s, pos @ n)


def scene_row(sensor, rate, mag):
    import study_accuracy as sa

    s = dict(set="decay", motion=rate, mag=mag, psf=1.4, sensor=sensor, comp="none", seed=42,
             direction=135, camera="evk4")
    run = sim.simulate(sa.scenario(s), seed=42)
    spec = sa.SENSORS[sensor]()
    cfg = Config().replace(**{"estimate.estimator": "mean"})
    res = Pipeline(cfg).run(run.events, run.imu, run.camera)
    profiles = LevelProfiles()
    cr = estimation.chunk_crossings(run.events, res.keep, cfg.estimate.crossing_radius_px,
                                    profiles=profiles)
    lag = profiles.lag(speed_changes(res.centroids))
    lag_us, across = true_lags(run, cr)
    near = np.abs(across) < 3
    tau_bg = 1e6 / (2 * np.pi * spec.cutoff_hz_background)
    taus = tail_taus(run.events, run.truth.labels)
    profile = (float(np.median(lag.lag_at(cr["pairs"][near], 1.0))) / tau_bg
               if lag is not None else float("nan"))
    return {"sensor": sensor, "rate": rate, "mag": mag, "tau_bg_ms": tau_bg / 1e3,
            "tail_ms": float(np.median(taus)) / 1e3 if len(taus) else float("nan"),
            "tail_iqr": (f"{np.percentile(taus, 25) / 1e3:.2f}–{np.percentile(taus, 75) / 1e3:.2f}"
                         if len(taus) else "—"),
            "passes": len(taus), "true_lag_tau": float(np.median(lag_us[near])) / tau_bg,
            "profile_lag_tau": profile}


def pulse_lag(tau_ms, peak, sigma_t_ms, threshold=0.2, ceiling_hz=2000.0, dt_s=2e-6,
              offset=0.5):
    """(level pairs, mean level-pair midpoint less the pulse's centre in ms) of one pixel
    (cutoff 1/(2π τ) · I up to ceiling_hz) seeing a Gaussian pulse of peak `peak` × the
    background, its events at ±threshold in log intensity from a reference `offset` ×
    threshold below the background, the j-th ON from the top paired with the j-th OFF from
    the top."""
    s = sigma_t_ms * 1e-3
    t = np.arange(-8 * s - 0.01, 8 * s + 0.1, dt_s)
    intensity = 1 + peak * np.exp(-0.5 * (t / s) ** 2)
    f = np.clip(intensity / (2 * np.pi * tau_ms * 1e-3), None, ceiling_hz)
    decay = np.exp(-2 * np.pi * f * dt_s)
    log_i = np.log(intensity)
    ref, y, on, off = -offset * threshold, 0.0, [], []
    for ti, u, a in zip(t, log_i, decay):
        y = u + (y - u) * a
        while y - ref >= threshold:
            ref += threshold
            on.append(ti)
        while ref - y >= threshold:
            ref -= threshold
            off.append(ti)
    k = min(len(on), len(off))
    if not k:
        return 0, float("nan")
    mids = (np.array(on[len(on) - k:]) + np.array(off[:k])[::-1]) / 2
    return k, float(mids.mean()) * 1e3


def model_rows():
    rows = []
    for tau in (2.65, 5.31, 15.9):
        for peak in (3, 10, 30, 200):
            for sigma_t in (0.5, 1.5, 4.0):
                # the pixel's reference level at random: five offsets averaged
                runs = [pulse_lag(tau, peak, sigma_t, offset=o) for o in _REFERENCES]
                rows.append({"tau_bg_ms": tau, "A": peak, "sigma_t_ms": sigma_t,
                             "levels": f"{min(k for k, _ in runs)}–{max(k for k, _ in runs)}",
                             "lag_tau": float(np.mean([lag for _, lag in runs])) / tau})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rates", default="4,12,25")
    ap.add_argument("--mag", type=float, default=4.0)
    ap.add_argument("--sensors", default="dark-sky,dark-sky-15,dark-sky-60")
    ap.add_argument("--model", action="store_true", help="the one-pixel model's table instead")
    ap.add_argument("--name", help="results name (default study_decay_tail[_model])")
    a = ap.parse_args()
    if a.model:
        rows, columns, name = model_rows(), MODEL_COLUMNS, "study_decay_tail_model"
    else:
        sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
        rows = [scene_row(s, float(r), a.mag) for s in a.sensors.split(",")
                for r in a.rates.split(",")]
        columns, name = COLUMNS, "study_decay_tail"
    text = profiling.table(rows, columns)
    profiling.write_report(RESULTS, a.name or name, rows, "Background time constant from OFF decay tails",
                           text, vars(a))
    print(text)


if __name__ == "__main__":
    main()
