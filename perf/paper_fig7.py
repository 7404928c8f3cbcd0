"""Reproduction of Liu et al. (2025), Figure 7: SNR after each filter and time per event, 4–20 °/s.

The paper's experiment on evstar's simulator: a magnitude-3-equivalent star on the paper's
turntable (DVXplorer Lite 320x240, 12 mm lens, 1.5 Hz/pixel background, 5 hot pixels),
constant rates 4, 8, 12, 16, 20 °/s, 500 ms streams, several seeds. Filters as shipped:
classical (dv's, k=1, dt 10 ms), NDSEF (radius 5, auto threshold), MR-NDSEF (radii 3..11,
auto thresholds, alpha 1e-3), all on 10 ms frames. SNR = 10·lg(signal / noise events)
(paper §4.2) before and after filtering, from the simulator's per-event labels.

"Equal signal retention": MR-NDSEF (auto) is compared with (1) the classical filter as
shipped (dv's: k=1, dt 10 ms), which keeps all the star as MR-NDSEF does, and (2) the
classical filter tuned with the labels: swept over dt in 0.5..50 ms and k in 1..8, its best
SNR among the settings that keep at least as much of the star as MR-NDSEF (minus 1
percentage point). (2) is an oracle no real run has; it is reported to be honest about
how much of the gain a well-tuned classical filter also gets.

Quality goal checked (per rate and seed): MR-NDSEF auto keeps >= 90 % of the star's events
with >= 25 dB SNR gain, and beats the classical filter by >= 10 dB at equal retention —
against (1) in `goal_met`, against (2) in `goal_met_vs_tuned`.

Time per event: median wall time of apply() over --repeats runs (after a warm-up) on each
500 ms stream (~65 k events), Taichi on the CPU and the numpy reference; the paper reports
~10 µs per event for MR-NDSEF.

    python perf/paper_fig7.py [--seeds 3] [--repeats 5]

Writes perf/results/paper_fig7.json, paper_fig7.md and paper_fig7.png.
"""
from __future__ import annotations

import argparse
import itertools
import pathlib
import time

import numpy as np

from evstar import denoise, metrics, profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
CLASSICAL_DT_MS = (0.5, 1, 2, 5, 10, 20, 50)
GOAL_RETAINED, GOAL_GAIN_DB, GOAL_MARGIN_DB = 0.90, 25.0, 10.0


def filters(backend):
    return {"classical": denoise.ClassicalFilter(10_000, 1, backend=backend),
            "ndsef": denoise.NDSEF(10_000, 5, "auto", backend=backend),
            "mr-ndsef": denoise.MRNDSEF(10_000, (3, 5, 7, 9, 11), "auto", backend=backend)}


def time_per_event_us(flt, events, repeats):
    flt.apply(events)  # warm-up (and compilation)
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        flt.apply(events)
        runs.append(time.perf_counter() - t0)
    return float(np.median(runs)) / len(events) * 1e6


def classical_at_retention(events, is_signal, retained):
    """Best classical SNR over the (dt, k) sweep among settings keeping >= retained − 1 pp."""
    best = None
    for dt_ms, k in itertools.product(CLASSICAL_DT_MS, range(1, 9)):
        keep = denoise.ClassicalFilter(int(dt_ms * 1000), k).apply(events)
        s = metrics.denoise_scores(is_signal, keep)
        if s["signal_retained"] >= retained - 0.01 and (best is None or s["snr_after_db"] > best["snr_after_db"]):
            best = dict(s, dt_ms=dt_ms, k=k)
    return best


def run_one(rate, seed, repeats):
    run = sim.simulate(sim.paper_preset(rate), seed=seed)
    ev, is_signal = run.events, run.truth.labels >= 0
    row = dict(rate_dps=rate, seed=seed, events=len(ev), signal_events=int(is_signal.sum()),
               snr_before_db=metrics.snr_db(is_signal.sum(), (~is_signal).sum()))
    for name, flt in filters("taichi").items():
        s = metrics.denoise_scores(is_signal, flt.apply(ev))
        row[f"{name}_snr_db"] = s["snr_after_db"]
        row[f"{name}_gain_db"] = s["snr_gain_db"]
        row[f"{name}_retained"] = s["signal_retained"]
        row[f"{name}_noise_removed"] = s["noise_removed"]
        row[f"{name}_us_per_event"] = time_per_event_us(flt, ev, repeats)
        if hasattr(flt, "thresholds_"):
            row[f"{name}_thresholds"] = list(flt.thresholds_)
    for name, flt in filters("reference").items():
        row[f"{name}_reference_us_per_event"] = time_per_event_us(flt, ev, 1)
    best = classical_at_retention(ev, is_signal, row["mr-ndsef_retained"])
    row["classical_eq_snr_db"] = best["snr_after_db"] if best else None
    row["classical_eq_setting"] = f"dt {best['dt_ms']} ms, k {best['k']}" if best else None
    row["mr_margin_tuned_db"] = row["mr-ndsef_snr_db"] - best["snr_after_db"] if best else None
    equal = row["classical_retained"] >= row["mr-ndsef_retained"] - 0.01
    row["mr_margin_db"] = row["mr-ndsef_snr_db"] - row["classical_snr_db"] if equal else None
    quality = row["mr-ndsef_retained"] >= GOAL_RETAINED and row["mr-ndsef_gain_db"] >= GOAL_GAIN_DB
    row["goal_met"] = bool(quality and row["mr_margin_db"] is not None and row["mr_margin_db"] >= GOAL_MARGIN_DB)
    row["goal_met_vs_tuned"] = bool(quality and row["mr_margin_tuned_db"] is not None
                                    and row["mr_margin_tuned_db"] >= GOAL_MARGIN_DB)
    return row


def summarise(rows):
    out = []
    for rate in sorted({r["rate_dps"] for r in rows}):
        rs = [r for r in rows if r["rate_dps"] == rate]
        s = {"rate_dps": rate, "seeds": len(rs), "goal_met_all_seeds": all(r["goal_met"] for r in rs),
             "goal_met_vs_tuned_all_seeds": all(r["goal_met_vs_tuned"] for r in rs)}
        for key in rs[0]:
            if isinstance(rs[0][key], (int, float)) and not isinstance(rs[0][key], bool) \
                    and key not in ("rate_dps", "seed"):
                s[key] = float(np.mean([r[key] for r in rs]))
        s["mr-ndsef_retained_min"] = min(r["mr-ndsef_retained"] for r in rs)
        s["mr-ndsef_gain_db_min"] = min(r["mr-ndsef_gain_db"] for r in rs)
        s["mr_margin_db_min"] = min(r["mr_margin_db"] for r in rs)
        s["mr_margin_tuned_db_min"] = min(r["mr_margin_tuned_db"] for r in rs)
        out.append(s)
    return out


def plot(summary, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rate = [s["rate_dps"] for s in summary]
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 5.6))
    a.plot(rate, [s["snr_before_db"] for s in summary], "k:", marker="o", label="raw")
    for name, style in (("classical", "C0"), ("ndsef", "C1"), ("mr-ndsef", "C2")):
        a.plot(rate, [s[f"{name}_snr_db"] for s in summary], color=style, marker="o", label=name)
    a.plot(rate, [s["classical_eq_snr_db"] for s in summary], "C0--", marker="x",
           label="classical tuned with labels (best dt, k at MR-NDSEF's retention)")
    a.set(xlabel="angular rate (°/s)", ylabel="SNR after filtering (dB)", title="(a) signal-to-noise ratio")
    a.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0, -0.14), ncol=2)
    a.grid(alpha=0.3)
    for name, style in (("classical", "C0"), ("ndsef", "C1"), ("mr-ndsef", "C2")):
        b.plot(rate, [s[f"{name}_us_per_event"] for s in summary], color=style, marker="o", label=f"{name} (Taichi CPU)")
        b.plot(rate, [s[f"{name}_reference_us_per_event"] for s in summary], color=style, ls="--",
               marker=".", label=f"{name} (numpy reference)")
    b.axhline(10.0, color="grey", ls=":", label="paper: MR-NDSEF ~10 µs")
    b.set(xlabel="angular rate (°/s)", ylabel="processing time per event (µs)", yscale="log",
          title="(b) event-processing time")
    b.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0, -0.14), ncol=2)
    b.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    rows = []
    for rate, seed in itertools.product(sim.PAPER_RATES_DPS, range(args.seeds)):
        rows.append(run_one(rate, seed, args.repeats))
        r = rows[-1]
        print(f"{rate:4.0f} °/s seed {seed}: SNR raw {r['snr_before_db']:.1f}, classical {r['classical_snr_db']:.1f}, "
              f"NDSEF {r['ndsef_snr_db']:.1f}, MR-NDSEF {r['mr-ndsef_snr_db']:.1f} dB "
              f"(keeps {100 * r['mr-ndsef_retained']:.1f} %), tuned classical at equal retention "
              f"{r['classical_eq_snr_db']:.1f} dB ({r['classical_eq_setting']})", flush=True)
    summary = summarise(rows)
    RESULTS.mkdir(exist_ok=True)
    meta = dict(scenario="sim.paper_preset(rate): DVXplorer Lite 320x240, 12 mm, magnitude 3, 0.5 s, "
                         "1.5 Hz/pixel background, 5 hot pixels", dt_us=10_000,
                goal=f"MR-NDSEF auto keeps >= {GOAL_RETAINED:.0%} of the star with >= {GOAL_GAIN_DB} dB gain "
                     f"and beats classical by >= {GOAL_MARGIN_DB} dB at equal retention",
                goal_met_everywhere=all(r["goal_met"] for r in rows),
                goal_met_vs_tuned_everywhere=all(r["goal_met_vs_tuned"] for r in rows), summary=summary)
    profiling.write_results(RESULTS / "paper_fig7.json", rows, meta)
    cols = [("rate_dps", "°/s", ".0f"), ("snr_before_db", "SNR raw dB", ".1f"),
            ("classical_snr_db", "classical dB", ".1f"), ("ndsef_snr_db", "NDSEF dB", ".1f"),
            ("mr-ndsef_snr_db", "MR-NDSEF dB", ".1f"), ("mr-ndsef_gain_db_min", "MR gain dB (min)", ".1f"),
            ("mr-ndsef_retained_min", "MR star kept (min)", ".3f"),
            ("mr_margin_db_min", "MR − classical dB (min)", ".1f"),
            ("classical_eq_snr_db", "tuned classical @ equal retention dB", ".1f"),
            ("mr_margin_tuned_db_min", "MR − tuned classical dB (min)", ".1f"),
            ("classical_us_per_event", "classical µs/ev", ".3f"), ("ndsef_us_per_event", "NDSEF µs/ev", ".3f"),
            ("mr-ndsef_us_per_event", "MR-NDSEF µs/ev", ".3f"),
            ("mr-ndsef_reference_us_per_event", "MR-NDSEF numpy µs/ev", ".2f"),
            ("goal_met_all_seeds", "goal met", ""), ("goal_met_vs_tuned_all_seeds", "goal met vs tuned", "")]
    text = profiling.table(summary, cols)
    (RESULTS / "paper_fig7.md").write_text(
        f"Figure 7 reproduction, means over {args.seeds} seeds (min where marked). Goal met at every "
        f"rate and seed against the shipped classical filter: {meta['goal_met_everywhere']}; against the "
        f"label-tuned classical filter: {meta['goal_met_vs_tuned_everywhere']}\n\n{text}\n")
    plot(summary, RESULTS / "paper_fig7.png")
    print(text)
    return rows


if __name__ == "__main__":
    main()
