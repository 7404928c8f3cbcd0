"""The measured pixel lag (evstar.level_lag) on star fields, where stars of many magnitudes
share one sensor — study_accuracy's scenes hold one star each.

DAVIS346 fields of 25 Hipparcos stars (`evstar simulate --preset davis346 --stars 25`,
1 s, seed 3: never used while writing the estimator) at 6 and 14 °/s under the dark-sky
sensor, and the default sensor at 14 °/s as the control, and an EVK4 field of 50 stars at
10 °/s under the dark sky (stars 2.5× faster in pixels); the default pipeline with
estimate.measure_lag off and on. Errors against the truth per star-brightness bin (events
per 10 ms frame), false rows (matching no star within 3 px; stars leaving over the border
count here) per 100 frames.

    python perf/study_lag_field.py

Writes perf/results/study_lag_field.json and .md.
"""
from __future__ import annotations

import pathlib

import numpy as np

from evstar import Config, Pipeline, accuracy, profiling
from evstar.bench import field_scene

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
SCENES = ("--preset davis346 --stars 25 --rate 6 --sensor dark-sky --duration 1 --seed 3",
          "--preset davis346 --stars 25 --rate 14 --sensor dark-sky --duration 1 --seed 3",
          "--preset davis346 --stars 25 --rate 14 --duration 1 --seed 3",
          "--preset evk4 --stars 50 --rate 10 --sensor dark-sky --duration 1 --seed 3")
BINS = ((20, np.inf), (4, 20))


def scores(run, measure_lag):
    ev, lab = run.events, run.truth.labels
    n_frames = (ev.t[-1] - ev.t[0]) / 10_000
    n_stars = run.truth.star_position(ev.t[:1]).shape[1]
    per_star = np.bincount(lab[lab >= 0], minlength=n_stars) / n_frames
    rows = Pipeline(Config().replace(**{"estimate.measure_lag": measure_lag})).run(
        ev, None, run.camera).centroids
    star, err = accuracy.match(rows, run.truth.star_position)
    ok = star >= 0
    out = {"false_per_100": 100 * float((~ok).sum()) / n_frames}
    for lo, hi in BINS:
        rate = per_star[np.maximum(star, 0)]
        m = ok & (rate >= lo) & (rate < hi)
        out[f">={lo}"] = ({"mean": float(err[m].mean()), "max": float(err[m].max()),
                           "stars": int(len(np.unique(star[m])))} if m.any() else None)
    return out


COLUMNS = [("scene", "scene", ""), ("measure_lag", "measure_lag", ""),
           (">=20", "stars >= 20 ev/frame: mean / max px", ""), (">=4", "4–20: mean / max px", ""),
           ("false_per_100", "false rows / 100 frames", ".1f")]


def _cells(row):
    """A row with its bins as 'mean / max (n stars)' text, for profiling.table."""
    out = {**row, "measure_lag": "on" if row["measure_lag"] else "off"}
    for lo, _ in BINS:
        b = row[f">={lo}"]
        out[f">={lo}"] = None if b is None else f"{b['mean']:.3f} / {b['max']:.2f} ({b['stars']} stars)"
    return out


def main():
    rows = []
    for argv in SCENES:
        run = field_scene(argv.split())
        for measure in (False, True):
            rows.append({"scene": argv, "measure_lag": measure, **scores(run, measure)})
            print(rows[-1], flush=True)
    text = profiling.table([_cells(r) for r in rows], COLUMNS)
    profiling.write_results(RESULTS / "study_lag_field.json", rows)
    (RESULTS / "study_lag_field.md").write_text("# Measured pixel lag on star fields\n\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
