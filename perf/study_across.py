"""A slow star's constant offset across its motion, and a per-track mean-shift that removes it.

The crossings estimator times each pixel's passage along the motion; across it the rows come
from centroids of the events the denoise filter kept, and a faint star's flank rows are kept
unevenly (a threshold on local counts), so its rows sit at a constant offset across the
motion (study_mismatch.py). This study measures that offset per scene (one star moving
along x: across = y) and what a per-track mean-shift of the across coordinate over *all*
events (unfiltered, noise included) in a band about the track's path would leave: the
window re-centred on its mean until it stops (a symmetric profile plus uniform background
has its fixed point at the star). The prototype of evstar.across, which the pipeline now
runs (estimate.across_kernel_px: Gaussian weights matched to the profile, events found per
track on curved paths); the last column is the pipeline's rows with it, the others its rows
without it.

    python perf/study_across.py

Writes perf/results/study_across.json and .md; prints the table.
"""
from __future__ import annotations

import pathlib

import numpy as np

from evstar import Config, Pipeline, profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
#: (°/s, magnitude, PSF σ px, seed): the grid's dev 2 °/s magnitude-5 star and others
SCENES = ((2.0, 5.0, 1.0, 1), (2.0, 5.0, 1.0, 2), (2.0, 5.0, 1.0, 3), (1.0, 4.0, 1.5, 7),
          (1.5, 4.5, 1.8, 21), (2.0, 3.0, 1.0, 1), (0.7, 3.5, 1.3, 21), (3.0, 5.0, 1.5, 21))
BANDS = (2.0, 3.0)          # half-widths (px) of the mean-shift window across the motion


def mean_shift(a, half_width, iterations=50):
    """The fixed point d of d = mean(a within half_width of d), from 0."""
    d = 0.0
    for _ in range(iterations):
        near = np.abs(a - d) <= half_width
        if not near.any():
            return float("nan")
        new = float(a[near].mean())
        if abs(new - d) < 1e-6:
            break
        d = new
    return d


def run(rate, mag, psf, seed):
    r = sim.simulate(sim.paper_preset(rate, magnitude=mag, psf_sigma_px=psf), seed=seed)
    ev = r.events
    off = Config().replace(**{"estimate.across_kernel_px": 0})
    c = Pipeline(off).run(ev, r.imu, r.camera).centroids
    c = c[c["track"] >= 0]
    on = Pipeline(Config()).run(ev, r.imu, r.camera).centroids
    on = on[on["track"] >= 0]
    c = c[np.argsort(c["t"], kind="stable")]
    true_y = r.truth.star_position(c["t"])[:, 0, 1]
    span = (ev.t >= c["t"][0]) & (ev.t <= c["t"][-1])
    x_path, y_path = np.interp(ev.t, c["t"], c["x"]), np.interp(ev.t, c["t"], c["y"])
    band = span & (np.abs(ev.x - x_path) <= 3)
    a = ev.y[band] - y_path[band]          # every event's offset across the motion
    out = {"rate": rate, "mag": mag, "psf": psf, "seed": seed,
           "rows_across": float((c["y"] - true_y).mean())}
    for w in BANDS:
        out[f"shifted_{w:g}"] = float((c["y"] + mean_shift(a, w) - true_y).mean())
    out["pipeline"] = float((on["y"] - r.truth.star_position(on["t"])[:, 0, 1]).mean())
    return out


def markdown(rows):
    head = "| °/s | mag | PSF σ | seed | rows' across offset px | " + " | ".join(
        f"after mean-shift, ±{w:g} px" for w in BANDS) + " | evstar.across |"
    lines = [head, "|" + "---|" * (6 + len(BANDS))]
    for r in rows:
        lines.append(f"| {r['rate']:g} | {r['mag']:g} | {r['psf']:g} | {r['seed']} | "
                     f"{r['rows_across']:+.3f} | " + " | ".join(
                         f"{r[f'shifted_{w:g}']:+.3f}" for w in BANDS)
                     + f" | {r['pipeline']:+.3f} |")
    mean_abs = lambda k: np.mean([abs(r[k]) for r in rows])
    lines.append(f"| mean \\|offset\\| | | | | {mean_abs('rows_across'):.3f} | " + " | ".join(
        f"{mean_abs(f'shifted_{w:g}'):.3f}" for w in BANDS) + f" | {mean_abs('pipeline'):.3f} |")
    return "\n".join(lines)


def main():
    rows = [run(*s) for s in SCENES]
    text = markdown(rows)
    profiling.write_report(RESULTS, "study_across", rows, "A slow star's offset across its "
                           "motion, and a per-track mean-shift", text)
    print(text)


if __name__ == "__main__":
    main()
