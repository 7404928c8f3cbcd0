"""Sinusoids' turns on the independent simulator: variants of perf/study_indep.py's scenes.

A star on a sinusoid slows, stops and swings back at each turn; behind a low-pass pixel its
events lag, and a faint star's frames there are often one lobe. The twenty-eighth session
changed how the turns are estimated (evstar.smoothing._debiased) on the first set below
("dev": scenes 14–17 and 22 with other sensors, PSFs or motions, looked at while the change
was written) and ran the second ("held-out": twelve variants never looked at before) once
with the code before and after it. Each variant is a study_indep scene (same seed, star
placement and simulator) with some of its fields replaced, run by study_indep.run_scene (no
IMU unless the variant says "imu"); the table shows the default pipeline's scores.

    python perf/study_turns.py [--part dev|held-out] [--name NAME]

Writes perf/results/study_turns[_NAME].json and .md and prints the table.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import study_indep as SI  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
FIELDS = ("cam", "motion", "mags", "psf", "sensor", "noise", "hot", "dur")
#: (study_indep scene number, replaced fields, with the scene's gyro and compensate imu)
PARTS = {
    "dev": [
        (14, {"sensor": "lowpass"}, False),
        (14, {"sensor": "lowpass-asym"}, False),
        (16, {"sensor": "lowpass"}, False),
        (16, {"sensor": "lowpass-asym", "psf": ("gauss", 1.5)}, False),
        (15, {"sensor": "lowpass-asym", "psf": ("gauss", 1.2)}, False),
        (22, {"sensor": "lowpass", "cam": "davis"}, False),
        (15, {"motion": ("sine", 6, 1.0, 20), "sensor": "lowpass"}, False),
        (17, {"sensor": "lowpass"}, False),
        (14, {"sensor": "lowpass"}, True),
        (15, {}, True),
    ],
    "held-out": [
        (14, {"sensor": "lowpass", "psf": ("moffat", 2.0, 3.0), "motion": ("sine", 6, 1.5, 80)}, False),
        (16, {"sensor": "lowpass", "psf": ("gauss", 1.2), "mags": [4, 5, 5.5]}, False),
        (22, {"sensor": "lowpass-asym", "motion": ("sine", 5, 0.7, 10), "psf": ("gauss", 1.4)}, False),
        (15, {"sensor": "ideal", "motion": ("sine", 4, 1.5, 0)}, False),
        (14, {"sensor": "asym", "psf": ("gauss", 1.6)}, False),
        (16, {"sensor": "ideal"}, False),
        (7, {"motion": ("sine", 6, 1.0, 135)}, False),
        (9, {"motion": ("sine", 8, 1.0, 45)}, False),
        (21, {"motion": ("sine", 5, 1.0, 100)}, False),
        (12, {"motion": ("sine", 10, 1.0, 30)}, False),
        (12, {"motion": ("sine", 10, 1.0, 30)}, True),
        (7, {"motion": ("sine", 6, 1.0, 135)}, True),
    ],
}


def run_variant(number, changes, imu):
    """Scores (study_indep.scores) of the default pipeline on one variant
    (study_indep.run_scene, which runs the per-frame mean too)."""
    spec = dict(zip(FIELDS, SI.GRID[number - 1]), **changes)
    out = SI.run_scene(number - 1, tuple(spec[f] for f in FIELDS), imu=imu)
    label = ", ".join(f"{k} {v}" for k, v in changes.items()) or "as it is"
    return {"scene": number, "changes": label, "imu": imu, "motion": out["motion"],
            "sensor": spec["sensor"], "psf": out["psf"], **out["default"]}


def markdown(rows):
    lines = ["| part | scene | changes | motion | sensor | PSF | IMU | mean / max px | per star px | frames |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        stars = ", ".join(f"{v:.3f}" for v in r["per_star_mean"])
        lines.append(f"| {r['part']} | {r['scene']} | {r['changes']} | {r['motion']} | {r['sensor']} | "
                     f"{r['psf']} | {'yes' if r['imu'] else 'no'} | {r['mean']:.3f} / {r['max']:.2f} | "
                     f"{stars} | {100 * r['frames_min']:.0f} % |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=list(PARTS), help="one part alone (default: both)")
    ap.add_argument("--name", help="results: study_turns_NAME.* (e.g. an older evstar on PYTHONPATH)")
    a = ap.parse_args(argv)
    rows = []
    for part in [a.part] if a.part else list(PARTS):
        for number, changes, imu in PARTS[part]:
            rows.append({"part": part, **run_variant(number, changes, imu)})
            print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    name = "study_turns" + (f"_{a.name}" if a.name else "")
    (RESULTS / f"{name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"{name}.md").write_text("# Sinusoids' turns on the independent simulator "
                                        "(perf/study_turns.py)\n\n" + markdown(rows) + "\n")
    print(markdown(rows))


if __name__ == "__main__":
    main()
