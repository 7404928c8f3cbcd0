"""evstar's star-position accuracy on events of an independent simulator (perf/indep_sim.py).

indep_sim shares no code or modelling choices with evstar.sim: its own PSFs (Gaussian,
Moffat, a defocused disk, an elliptical Gaussian, pixel-integrated), its own photoreceptor
law (cutoff f_min + (f_max − f_min)·I/(I + I_half)), its own refractory rule, log-normal
background rates and hot pixels. 1–5 fixed stars per scene; the camera turns (constant rate,
sinusoid, constant acceleration from rest) and the pinhole projects them (indep_sim's
projection "rotate": the rate holds at the principal point, up to (1 + (r/f)²) faster at
the edges; a plain image translation would misfit evstar's rigid-field step, which
moved faint stars of 4–5-star scenes by up to 0.6 px when tried).

The grid (24 scenes, fixed seeds, run once; none was looked at while evstar was written):
rates 1, 3, 8, 20 °/s, sinusoids (3–8° at 0.5–2 Hz) and one acceleration from rest;
magnitudes 3–6; the four PSF shapes at widths ~1–2.5 px; ideal and low-pass pixels;
equal (0.2/0.2) and unequal (0.2/0.3) ON/OFF thresholds; 0.1–5 Hz of background, with and
without hot pixels; the DAVIS346 (346x260, f 280 px), a VGA (640x480, f 540) and an HD
(1280x720, f 1100) sensor; 1 s recordings (0.5 s at 20 °/s).

Each scene runs evstar's default pipeline (default Config: the "crossings" estimator; no
IMU, or with `--imu` the scene's gyro and motion.compensate "imu") and the same with
estimate.estimator = "mean". Per scene and estimator: mean /
median / max error (px) of the rows matched to a star (within 3 px, at the row's own
time), the fraction of 10 ms frames with a position (the lowest over the stars), false rows
(matching no star) per 100 frames, the signed mean error along the motion (+ = ahead of the
star: lag shows as −, ON-lobe pull as +) and across it; for the default the median of
error/σ (1.18 for honest Gaussian σ). Per star: signal events per frame N and the
single-frame bound σ_eff/√N (σ_eff: the PSF's per-axis RMS width with the pixel's 1/12 px²).

    python perf/study_indep.py [--scenes 1,5,12 | --only davis|vga|hd|sine|lowpass|asym]
        [--quick (recordings shortened to 0.3 s)] [--imu [--clock-offset-us N]] [--fresh | --fresh2 | ... | --fresh22 | --vibe | --vibe2]
        [--calibrated (each scene with its sensor's lag file from a calibration recording)]
        [--set KEY=VALUE --name NAME]

--fresh, --fresh2 and --fresh3 run the held-out grids instead (F1–F12, written in the
thirtieth session; G1–G14, in the thirty-first; H1–H12, in the thirty-second: coning, leak
events, readout gaps, a close pair, 50 hot pixels), each run once before any change made
after seeing it (that first run: study_indep_fresh3_first.md, _imu_first.md); --fresh4
(K1–K10, the forty-second session's), --fresh5 (L1–L10, the forty-third's), --fresh6
(M1–M10, the forty-fourth's), --fresh7 (N1–N10, the forty-fifth's), --fresh8 (O1–O10,
the forty-sixth's: rolls about the boresight, a wide lens and a telephoto, stray light),
--fresh9 (P1–P10, the forty-seventh's), --fresh10 (Q1–Q10, the forty-eighth's) and
--fresh11 (R1–R10, the fiftieth's), --fresh12 (S1–S10, the fifty-first's), --fresh13
(T1–T10, the fifty-third's), --fresh14 (U1–U10, the fifty-fourth's), --fresh15
(W1–W10, the fifty-fifth's), --fresh16 (X1–X10, the fifty-sixth's), --fresh17 (Y1–Y10,
the fifty-seventh's), --fresh18 (Z1–Z10, the fifty-eighth's), --fresh19 (A1–A10,
the fifty-ninth's), --fresh20 (B1–B10, the sixtieth's), --fresh21 (D1–D10, the
sixty-second's) and --fresh22 (E1–E10, the sixty-third's) likewise; --vibe2 (C1–C10,
vibrating platforms, the sixty-first's) was run once on the code before and after its
change.

Writes perf/results/study_indep.json and .md (a subset: study_indep_SUBSET.*) and prints
the table.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import indep_sim as S  # noqa: E402
from study_field import settings_of  # noqa: E402

from evstar import Config, Imu, Pipeline, accuracy  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
CAMERAS = {"davis": (346, 260, 280.0), "vga": (640, 480, 540.0), "hd": (1280, 720, 1100.0),
           # the eighth fresh grid's (--fresh8): a wide lens (80° across) and a telephoto
           "wide": (640, 480, 380.0), "tele": (1280, 720, 2600.0)}
SENSORS = {   # pixel model and thresholds; noise, hot pixels per scene
    "ideal": dict(pixel="ideal", c_on=0.2, c_off=0.2),
    "lowpass": dict(pixel="lowpass", f_min_hz=10.0, f_max_hz=800.0, i_half=20.0, c_on=0.2, c_off=0.2),
    "asym": dict(pixel="ideal", c_on=0.2, c_off=0.3),
    "lowpass-asym": dict(pixel="lowpass", f_min_hz=10.0, f_max_hz=800.0, i_half=20.0,
                         c_on=0.2, c_off=0.3, mismatch=0.05, jitter_us=30.0),
    # the fresh grid's sensors (--fresh; written in the thirtieth session, never tuned on):
    # a dark sky whose pixels cut off at ~30 Hz (the accuracy issue's), OFF below ON with
    # a long refractory period and jitter, coarse and fine thresholds
    "dark": dict(pixel="lowpass", f_min_hz=30.0, f_max_hz=400.0, i_half=50.0, c_on=0.25,
                 c_off=0.25, mismatch=0.05),
    "dark-asym": dict(pixel="lowpass", f_min_hz=20.0, f_max_hz=1500.0, i_half=10.0, c_on=0.3,
                      c_off=0.2, refractory_us=300.0, jitter_us=50.0),
    "coarse": dict(pixel="ideal", c_on=0.35, c_off=0.35, refractory_us=500.0),
    "fine": dict(pixel="ideal", c_on=0.12, c_off=0.15, mismatch=0.08),
    # the second fresh grid's (--fresh2; written in the thirty-first session, never tuned on):
    # timestamps jittered by 200 µs, a 15 % threshold mismatch, a low-pass that reaches its
    # ceiling early (I_half 2), background mostly OFF events
    "jittery": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=50.0, jitter_us=200.0),
    "mismatch15": dict(pixel="ideal", c_on=0.22, c_off=0.22, mismatch=0.15),
    "early-ceiling": dict(pixel="lowpass", f_min_hz=60.0, f_max_hz=600.0, i_half=2.0, c_on=0.2,
                          c_off=0.25),
    "off-noise": dict(pixel="ideal", c_on=0.18, c_off=0.18, noise_on_fraction=0.2),
    # the third fresh grid's (--fresh3; written in the thirty-second session, never tuned
    # on): leak events, readout gaps, coarse thresholds on a dark sky, a 2 ms refractory period
    "leaky": dict(pixel="ideal", c_on=0.2, c_off=0.2, leak_hz=0.5),
    "gappy": dict(pixel="ideal", c_on=0.2, c_off=0.2, gaps_s=((0.30, 0.33), (0.62, 0.64))),
    "dark-coarse": dict(pixel="lowpass", f_min_hz=15.0, f_max_hz=1000.0, i_half=30.0, c_on=0.4,
                        c_off=0.4),
    "slow-refractory": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=2000.0),
    # the fourth fresh grid's (--fresh4; written in the forty-second session, never tuned
    # on): a very dark sky (5 Hz in the dark, half-way at 100 × the sky), a 1 ms refractory
    # period with 80 µs of jitter, a dark sky whose background is mostly OFF events, a
    # low-pass with OFF below ON and a 10 % mismatch
    "deep-dark": dict(pixel="lowpass", f_min_hz=5.0, f_max_hz=1500.0, i_half=100.0, c_on=0.2,
                      c_off=0.2),
    "refractory-1ms": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=1000.0,
                           jitter_us=80.0),
    "dark-off-noise": dict(pixel="lowpass", f_min_hz=25.0, f_max_hz=600.0, i_half=30.0,
                           c_on=0.22, c_off=0.22, noise_on_fraction=0.25),
    "lowpass-off-low": dict(pixel="lowpass", f_min_hz=15.0, f_max_hz=1200.0, i_half=15.0,
                            c_on=0.3, c_off=0.18, mismatch=0.10),
    # the fifth fresh grid's (--fresh5; written in the forty-third session, never tuned on):
    # a quick dark sky (80 Hz in the dark, half-way at 5 × the sky), 0.08 thresholds, OFF
    # above ON by 2.3 ×, a dark sky with a 12 % threshold mismatch, a 200 µs refractory
    # period with 100 µs of jitter
    "fast-dark": dict(pixel="lowpass", f_min_hz=80.0, f_max_hz=3000.0, i_half=5.0, c_on=0.2,
                      c_off=0.2),
    "tiny-thresh": dict(pixel="ideal", c_on=0.08, c_off=0.08),
    "off-high": dict(pixel="ideal", c_on=0.15, c_off=0.35),
    "mismatch-dark": dict(pixel="lowpass", f_min_hz=25.0, f_max_hz=1000.0, i_half=25.0,
                          c_on=0.22, c_off=0.22, mismatch=0.12),
    "refractory-200": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=200.0,
                           jitter_us=100.0),
    # the sixth fresh grid's (--fresh6; written in the forty-fourth session, never tuned on):
    # a middling dark sky (40 Hz, half-way at 40 × the sky) with OFF below ON, coarse 0.3
    # thresholds behind a 300 µs refractory period, a background of 80 % ON events with a
    # 10 % mismatch, a dark sky with 150 µs of jitter
    "med-dark": dict(pixel="lowpass", f_min_hz=40.0, f_max_hz=2000.0, i_half=40.0, c_on=0.25,
                     c_off=0.2, jitter_us=20.0),
    "coarse-ref": dict(pixel="ideal", c_on=0.3, c_off=0.3, refractory_us=300.0),
    "on-heavy": dict(pixel="ideal", c_on=0.25, c_off=0.2, mismatch=0.10, noise_on_fraction=0.8),
    "dark-jitter": dict(pixel="lowpass", f_min_hz=20.0, f_max_hz=1500.0, i_half=20.0,
                        c_on=0.2, c_off=0.2, jitter_us=150.0),
    # the seventh fresh grid's (--fresh7; written in the forty-fifth session, never tuned
    # on): a dark sky with readout gaps, OFF above ON behind a 800 µs refractory period, a
    # leaky sensor with 3 Hz of background, a slow dark sky (12 Hz) that reaches its
    # ceiling late
    "gappy-dark": dict(pixel="lowpass", f_min_hz=50.0, f_max_hz=2000.0, i_half=30.0, c_on=0.2,
                       c_off=0.2, gaps_s=((0.21, 0.24), (0.55, 0.58))),
    "thresh-mix": dict(pixel="ideal", c_on=0.18, c_off=0.26, refractory_us=800.0,
                       jitter_us=60.0),
    "leak-2": dict(pixel="ideal", c_on=0.2, c_off=0.2, leak_hz=2.0),
    "slow-dark": dict(pixel="lowpass", f_min_hz=12.0, f_max_hz=2500.0, i_half=60.0, c_on=0.22,
                      c_off=0.22),
    # the eighth fresh grid's (--fresh8; written in the forty-sixth session, never tuned
    # on): stray light raising the background 6-fold over the recording, the same 4-fold on
    # a dark sky, a leaky dark sky with OFF above ON behind a 150 µs refractory period
    "stray": dict(pixel="ideal", c_on=0.2, c_off=0.2, noise_growth=6.0),
    "stray-dark": dict(pixel="lowpass", f_min_hz=30.0, f_max_hz=1500.0, i_half=30.0,
                       c_on=0.22, c_off=0.22, noise_growth=4.0),
    "leaky-dark": dict(pixel="lowpass", f_min_hz=35.0, f_max_hz=1800.0, i_half=15.0,
                       c_on=0.25, c_off=0.3, leak_hz=0.3, refractory_us=150.0, jitter_us=40.0),
    # the ninth fresh grid's (--fresh9; written in the forty-seventh session, never tuned
    # on): readouts that stall for 250 ms, and for 150 ms on a dark sky
    "stall": dict(pixel="ideal", c_on=0.2, c_off=0.2, gaps_s=((0.40, 0.65),)),
    "stall-dark": dict(pixel="lowpass", f_min_hz=35.0, f_max_hz=1500.0, i_half=25.0,
                       c_on=0.22, c_off=0.22, gaps_s=((0.55, 0.70),)),
    # the tenth fresh grid's (--fresh10; written in the forty-eighth session, never tuned
    # on): a dark sky at 25 Hz with a 6 % mismatch behind 50 µs, fine thresholds on a
    # background of 35 % ON events, a quick leaky dark sky with OFF below ON, a 120 ms
    # stall with 120 µs of jitter
    "dark-25": dict(pixel="lowpass", f_min_hz=25.0, f_max_hz=1000.0, i_half=40.0, c_on=0.22,
                    c_off=0.22, mismatch=0.06, refractory_us=50.0),
    "busy-fine": dict(pixel="ideal", c_on=0.12, c_off=0.16, mismatch=0.10,
                      noise_on_fraction=0.35, refractory_us=100.0),
    "dark-leak-off": dict(pixel="lowpass", f_min_hz=45.0, f_max_hz=2500.0, i_half=12.0,
                          c_on=0.28, c_off=0.2, leak_hz=1.0, jitter_us=30.0),
    "stall-jitter": dict(pixel="ideal", c_on=0.2, c_off=0.2, jitter_us=120.0,
                         gaps_s=((0.30, 0.42),)),
    # the eleventh fresh grid's (--fresh11; written in the fiftieth session, never tuned
    # on): a dark sky whose bright pixels stay slow (a 300 Hz ceiling), fine dark-sky
    # thresholds, OFF below ON behind a 400 µs refractory period, fine thresholds that leak
    # on a background of 60 % ON events, a very slow dark sky (8 Hz) with a 10 % mismatch
    "dark-ceiling": dict(pixel="lowpass", f_min_hz=30.0, f_max_hz=300.0, i_half=20.0,
                         c_on=0.2, c_off=0.2),
    "fine-dark": dict(pixel="lowpass", f_min_hz=20.0, f_max_hz=2000.0, i_half=20.0,
                      c_on=0.15, c_off=0.15, mismatch=0.04),
    "off-low-ref": dict(pixel="ideal", c_on=0.25, c_off=0.17, refractory_us=400.0,
                        jitter_us=40.0),
    "leaky-fine": dict(pixel="ideal", c_on=0.14, c_off=0.14, leak_hz=1.0),
    "very-dark": dict(pixel="lowpass", f_min_hz=8.0, f_max_hz=2000.0, i_half=50.0,
                      c_on=0.22, c_off=0.22, mismatch=0.10),
    # the twelfth fresh grid's (--fresh12; written in the fifty-first session, never tuned
    # on): a dark sky among hot pixels, a slow dark sky that reaches its ceiling early with
    # OFF above ON, coarse thresholds with 100 µs of jitter and an 8 % mismatch, a dark sky
    # on a busy background, a dark sky behind a 700 µs refractory period, a dark sky whose
    # OFF threshold is 1.7 × its ON one
    "dark-hot": dict(pixel="lowpass", f_min_hz=25.0, f_max_hz=1200.0, i_half=30.0,
                     c_on=0.22, c_off=0.22),
    "dark-steep": dict(pixel="lowpass", f_min_hz=15.0, f_max_hz=3000.0, i_half=5.0,
                       c_on=0.2, c_off=0.25),
    "coarse-jitter": dict(pixel="ideal", c_on=0.3, c_off=0.3, jitter_us=100.0, mismatch=0.08),
    "dark-busy": dict(pixel="lowpass", f_min_hz=35.0, f_max_hz=1500.0, i_half=20.0,
                      c_on=0.2, c_off=0.2),
    "ref-dark": dict(pixel="lowpass", f_min_hz=30.0, f_max_hz=1000.0, i_half=30.0,
                     c_on=0.22, c_off=0.22, refractory_us=700.0),
    "off-high-dark": dict(pixel="lowpass", f_min_hz=25.0, f_max_hz=2000.0, i_half=25.0,
                          c_on=0.18, c_off=0.3),
    # the thirteenth fresh grid's (--fresh13; written in the fifty-third session, never
    # tuned on): a 40 Hz dark sky with a 6 % mismatch and 80 µs of jitter, fine thresholds
    # with OFF below ON behind 150 µs, a dark sky whose background triples and is mostly OFF
    # events, coarse 0.32 thresholds that leak, with 60 µs of jitter, a dark sky with OFF
    # above ON and a 60 ms readout stall
    "dark-40-jitter": dict(pixel="lowpass", f_min_hz=40.0, f_max_hz=1200.0, i_half=15.0,
                           c_on=0.2, c_off=0.2, mismatch=0.06, jitter_us=80.0),
    "fine-off-low": dict(pixel="ideal", c_on=0.14, c_off=0.1, refractory_us=150.0),
    "dark-stray-off": dict(pixel="lowpass", f_min_hz=20.0, f_max_hz=2500.0, i_half=40.0,
                           c_on=0.25, c_off=0.25, noise_growth=3.0, noise_on_fraction=0.4),
    "coarse-leak": dict(pixel="ideal", c_on=0.32, c_off=0.32, leak_hz=1.5, jitter_us=60.0),
    "dark-gap-asym": dict(pixel="lowpass", f_min_hz=30.0, f_max_hz=1500.0, i_half=25.0,
                          c_on=0.22, c_off=0.3, gaps_s=((0.30, 0.36),)),
    # the fourteenth fresh grid's (--fresh14; written in the fifty-fourth session, never
    # tuned on): a 60 Hz dark sky with a low ceiling and a 12 % mismatch, coarse ON above a
    # finer OFF threshold behind 250 µs with 40 µs of jitter, a slow dark sky that leaks with
    # 60 µs of jitter, fine thresholds on a background that doubles and is mostly ON, a dark
    # sky with OFF above ON behind 400 µs
    "dark-60-mismatch": dict(pixel="lowpass", f_min_hz=60.0, f_max_hz=900.0, i_half=10.0,
                             c_on=0.18, c_off=0.22, mismatch=0.12),
    "coarse-off-low-ref": dict(pixel="ideal", c_on=0.34, c_off=0.22, refractory_us=250.0,
                               jitter_us=40.0),
    "dark-leak-jitter": dict(pixel="lowpass", f_min_hz=18.0, f_max_hz=2500.0, i_half=35.0,
                             c_on=0.24, c_off=0.24, leak_hz=0.8, jitter_us=60.0),
    "fine-busy-on": dict(pixel="ideal", c_on=0.1, c_off=0.11, noise_on_fraction=0.8,
                         noise_growth=2.0),
    "dark-ref-off-high": dict(pixel="lowpass", f_min_hz=28.0, f_max_hz=1800.0, i_half=22.0,
                              c_on=0.2, c_off=0.32, refractory_us=400.0),
    # the fifteenth fresh grid's (--fresh15; written in the fifty-fifth session, never
    # tuned on): a fast 80 Hz dark sky with fine thresholds and 30 µs of jitter, a 600 µs
    # refractory period with a 7 % mismatch, a slow dark sky with OFF below ON that leaks, a
    # coarse sensor on a fading background of mostly OFF events, a dark sky behind 200 µs
    # with an 80 ms readout stall
    "dark-80-fine-jitter": dict(pixel="lowpass", f_min_hz=80.0, f_max_hz=1600.0, i_half=12.0,
                                c_on=0.15, c_off=0.15, jitter_us=30.0),
    "slow-ref-mismatch": dict(pixel="ideal", c_on=0.22, c_off=0.22, refractory_us=600.0,
                              mismatch=0.07),
    "dark-off-low-leak": dict(pixel="lowpass", f_min_hz=22.0, f_max_hz=2200.0, i_half=30.0,
                              c_on=0.26, c_off=0.18, leak_hz=0.6),
    "busy-off-coarse": dict(pixel="ideal", c_on=0.28, c_off=0.3, noise_on_fraction=0.3,
                            noise_growth=0.5),
    "dark-stall-ref": dict(pixel="lowpass", f_min_hz=45.0, f_max_hz=1400.0, i_half=18.0,
                           c_on=0.2, c_off=0.2, refractory_us=200.0, gaps_s=((0.50, 0.58),)),
    # the sixteenth fresh grid's (--fresh16; written in the fifty-sixth session, never tuned
    # on): a slow 15 Hz dark sky with coarse thresholds behind 150 µs, fine jittered
    # thresholds that leak, a dark sky reaching its ceiling early with ON below OFF and a 10 %
    # mismatch, a fading background of mostly ON events, a dark sky with an early readout gap
    "dark-15-coarse-ref": dict(pixel="lowpass", f_min_hz=15.0, f_max_hz=900.0, i_half=40.0,
                               c_on=0.3, c_off=0.3, refractory_us=150.0),
    "fine-jitter-leak": dict(pixel="ideal", c_on=0.13, c_off=0.13, jitter_us=70.0, leak_hz=0.4),
    "dark-on-low-mismatch": dict(pixel="lowpass", f_min_hz=35.0, f_max_hz=3000.0, i_half=8.0,
                                 c_on=0.17, c_off=0.27, mismatch=0.1),
    "busy-fading-on": dict(pixel="ideal", c_on=0.22, c_off=0.2, noise_on_fraction=0.75,
                           noise_growth=0.3),
    "gap-early-dark": dict(pixel="lowpass", f_min_hz=50.0, f_max_hz=1200.0, i_half=25.0,
                           c_on=0.22, c_off=0.22, gaps_s=((0.10, 0.16), (0.70, 0.72))),
    # the seventeenth fresh grid's (--fresh17; written in the fifty-seventh session, never
    # tuned on): a 28 Hz dark sky whose ceiling is low with 40 µs of jitter, coarse OFF
    # thresholds behind 350 µs with a 6 % mismatch, fine thresholds on a rising background
    # of mostly OFF events, a 60 Hz dark sky that leaks with ON above OFF, a late readout
    # stall on an ideal pixel with jitter
    "dark-28-low-ceiling-jitter": dict(pixel="lowpass", f_min_hz=28.0, f_max_hz=500.0,
                                       i_half=20.0, c_on=0.21, c_off=0.21, jitter_us=40.0),
    "coarse-off-ref-350": dict(pixel="ideal", c_on=0.2, c_off=0.3, refractory_us=350.0,
                               mismatch=0.06),
    "fine-rising-off": dict(pixel="ideal", c_on=0.14, c_off=0.14, noise_on_fraction=0.25,
                            noise_growth=2.5),
    "dark-60-leak-on-high": dict(pixel="lowpass", f_min_hz=60.0, f_max_hz=2500.0, i_half=15.0,
                                 c_on=0.26, c_off=0.2, leak_hz=0.7),
    "late-stall-jitter": dict(pixel="ideal", c_on=0.2, c_off=0.2, jitter_us=90.0,
                              gaps_s=((0.82, 0.90),)),
    # the eighteenth fresh grid's (--fresh18; written in the fifty-eighth session, never
    # tuned on): a 40 Hz dark sky with a 700 Hz ceiling behind 250 µs, an ideal pixel with a
    # 9 % mismatch and OFF below ON, a dark sky whose references start at zero with 60 µs of
    # jitter, a leaking sensor with coarse thresholds on a fading background, a dark sky
    # with two short readout gaps and fine thresholds
    "dark-40-ceiling-700-ref": dict(pixel="lowpass", f_min_hz=40.0, f_max_hz=700.0, i_half=25.0,
                                    c_on=0.22, c_off=0.22, refractory_us=250.0),
    "mismatch-09-off-low": dict(pixel="ideal", c_on=0.25, c_off=0.17, mismatch=0.09),
    "dark-zero-ref-jitter": dict(pixel="lowpass", f_min_hz=32.0, f_max_hz=2000.0, i_half=16.0,
                                 c_on=0.2, c_off=0.2, jitter_us=60.0, random_reference=False),
    "leak-coarse-fading": dict(pixel="ideal", c_on=0.31, c_off=0.29, leak_hz=1.2,
                               noise_growth=0.4),
    "dark-gaps-fine": dict(pixel="lowpass", f_min_hz=55.0, f_max_hz=1800.0, i_half=10.0,
                           c_on=0.15, c_off=0.15, gaps_s=((0.30, 0.34), (0.61, 0.65))),
    # the nineteenth fresh grid's (--fresh19; written in the fifty-ninth session, never
    # tuned on): a 22 Hz dark sky whose cutoff climbs late (I_half 60) with OFF above ON, an
    # ideal pixel with fine thresholds on a busy background of mostly ON events, a 70 Hz
    # dark sky with a 7 % mismatch and 120 µs of jitter, coarse thresholds that leak behind
    # 80 µs, an ideal pixel whose readout stalls early with a rising background
    "dark-22-late-off-high": dict(pixel="lowpass", f_min_hz=22.0, f_max_hz=1200.0, i_half=60.0,
                                  c_on=0.2, c_off=0.26),
    "fine-13-busy-on": dict(pixel="ideal", c_on=0.13, c_off=0.13, noise_on_fraction=0.8),
    "dark-70-mismatch-jitter": dict(pixel="lowpass", f_min_hz=70.0, f_max_hz=1600.0, i_half=12.0,
                                    c_on=0.23, c_off=0.23, mismatch=0.07, jitter_us=120.0),
    "coarse-leak-ref-80": dict(pixel="ideal", c_on=0.33, c_off=0.33, leak_hz=0.8,
                               refractory_us=80.0),
    "early-stall-rising": dict(pixel="ideal", c_on=0.2, c_off=0.2, noise_growth=3.0,
                               gaps_s=((0.12, 0.19),)),
    # the twentieth fresh grid's (--fresh20; written in the sixtieth session, never tuned
    # on): a 28 Hz dark sky climbing early (I_half 6) to 900 Hz behind 150 µs, an ideal pixel
    # with OFF well below ON and 40 µs of jitter, a 50 Hz dark sky with fine thresholds and a
    # 0.5 Hz leak, an ideal pixel with a 6 % mismatch on a background fading to a third, an
    # ideal pixel whose readout loses 40 ms late with 300 µs of refractory period
    "dark-28-early-ref-150": dict(pixel="lowpass", f_min_hz=28.0, f_max_hz=900.0, i_half=6.0,
                                  c_on=0.22, c_off=0.22, refractory_us=150.0),
    "off-low-jitter-40": dict(pixel="ideal", c_on=0.27, c_off=0.16, jitter_us=40.0),
    "dark-50-fine-leak": dict(pixel="lowpass", f_min_hz=50.0, f_max_hz=2500.0, i_half=25.0,
                              c_on=0.14, c_off=0.14, leak_hz=0.5),
    "mismatch-06-fading": dict(pixel="ideal", c_on=0.21, c_off=0.21, mismatch=0.06,
                               noise_growth=0.33),
    "late-gap-ref-300": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=300.0,
                             gaps_s=((0.70, 0.74),)),
    # the twenty-first fresh grid's (--fresh21; written in the sixty-second session, never
    # tuned on): a 40 Hz dark sky climbing late (I_half 40) to 1.8 kHz with OFF above ON
    # behind 100 µs, an ideal pixel with fine thresholds on a busy mostly-OFF background, an
    # ideal pixel with a 4 % mismatch, a 1 Hz leak and 90 µs of jitter, a slow 20 Hz dark sky
    # with coarse thresholds and a low 700 Hz ceiling, an ideal pixel whose readout loses
    # 60 ms midway on a background doubling
    "dark-40-late-ref-100": dict(pixel="lowpass", f_min_hz=40.0, f_max_hz=1800.0, i_half=40.0,
                                 c_on=0.2, c_off=0.24, refractory_us=100.0),
    "fine-busy-off": dict(pixel="ideal", c_on=0.15, c_off=0.12, noise_on_fraction=0.35),
    "mismatch-04-leak-1-jitter-90": dict(pixel="ideal", c_on=0.22, c_off=0.22, mismatch=0.04,
                                         leak_hz=1.0, jitter_us=90.0),
    "dark-20-coarse": dict(pixel="lowpass", f_min_hz=20.0, f_max_hz=700.0, i_half=10.0,
                           c_on=0.3, c_off=0.3),
    "mid-gap-rising": dict(pixel="ideal", c_on=0.2, c_off=0.2, noise_growth=2.0,
                           gaps_s=((0.40, 0.46),)),
    # the twenty-second fresh grid's (--fresh22; written in the sixty-third session, never
    # tuned on): a 33 Hz dark sky to 1.4 kHz with OFF above ON behind 200 µs, an ideal pixel
    # with fine thresholds and 60 µs of jitter, an ideal pixel with an 8 % mismatch, a 60 Hz
    # dark sky climbing early (I_half 5) to 2.2 kHz with a 0.7 Hz leak, an ideal pixel whose
    # readout loses two spans behind 200 µs of refractory period
    "dark-33-ref-200-off-high": dict(pixel="lowpass", f_min_hz=33.0, f_max_hz=1400.0, i_half=15.0,
                                     c_on=0.19, c_off=0.25, refractory_us=200.0),
    "fine-jitter-60": dict(pixel="ideal", c_on=0.14, c_off=0.14, jitter_us=60.0),
    "mismatch-08": dict(pixel="ideal", c_on=0.21, c_off=0.21, mismatch=0.08),
    "dark-60-early-leak": dict(pixel="lowpass", f_min_hz=60.0, f_max_hz=2200.0, i_half=5.0,
                               c_on=0.2, c_off=0.2, leak_hz=0.7),
    "two-gaps-ref-200": dict(pixel="ideal", c_on=0.2, c_off=0.2, refractory_us=200.0,
                             gaps_s=((0.25, 0.29), (0.62, 0.70))),
}
#: (camera, motion, magnitudes, PSF, sensor, noise Hz, hot pixels, seconds)
GRID = [
    ("davis", ("lin", 1, 0), [3, 4.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("davis", ("lin", 1, 60), [5, 6], ("moffat", 2.5, 3.0), "ideal", 0.1, 0, 1.0),
    ("davis", ("lin", 3, 30), [3, 4, 5], ("defocus", 1.5, 0.5), "ideal", 1.0, 5, 1.0),
    ("davis", ("lin", 3, 0), [4, 5.5], ("ellip", 1.2, 0.8, 30), "asym", 1.0, 0, 1.0),
    ("davis", ("lin", 3, 90), [3.5], ("gauss", 1.5), "lowpass", 0.5, 0, 1.0),
    ("davis", ("lin", 8, 20), [3, 4, 5, 6], ("gauss", 1.0), "ideal", 5.0, 5, 1.0),
    ("davis", ("lin", 8, 135), [3.5, 5], ("moffat", 3.5, 2.5), "lowpass-asym", 1.0, 0, 1.0),
    ("davis", ("lin", 8, 0), [4, 4.5], ("defocus", 2.5, 0.7), "asym", 0.3, 0, 1.0),
    ("davis", ("lin", 8, 45), [3, 5], ("ellip", 1.6, 1.0, 60), "lowpass", 1.0, 3, 1.0),
    ("davis", ("lin", 20, 0), [3, 4.5], ("gauss", 1.2), "ideal", 1.0, 0, 0.5),
    ("davis", ("lin", 20, 200), [4, 5, 6], ("moffat", 2.0, 4.0), "asym", 2.0, 5, 0.5),
    ("davis", ("lin", 20, 30), [3, 5], ("defocus", 2.0, 0.6), "lowpass", 1.0, 0, 0.5),
    ("davis", ("lin", 20, -60), [3.5], ("ellip", 0.9, 1.6, 45), "lowpass-asym", 0.1, 0, 0.5),
    ("davis", ("sine", 5, 1.0, 0), [3, 4.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("davis", ("sine", 3, 2.0, 70), [4, 5.5], ("moffat", 2.5, 3.0), "lowpass", 1.0, 3, 1.0),
    ("davis", ("sine", 8, 0.5, 30), [3.5, 4.5, 5], ("ellip", 1.4, 1.0, -20), "asym", 0.5, 0, 1.0),
    ("davis", ("acc", 40, 0), [3.5, 5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("davis", ("lin", 1, 10), [3, 4], ("gauss", 2.5), "asym", 1.0, 0, 1.0),
    ("davis", ("lin", 3, 160), [6, 5.5], ("gauss", 1.0), "lowpass", 5.0, 5, 1.0),
    ("vga", ("lin", 3, 10), [3, 4, 5, 6, 4.5], ("gauss", 1.3), "ideal", 0.5, 5, 1.0),
    ("vga", ("lin", 8, 100), [4, 5], ("defocus", 1.2, 0.4), "lowpass", 1.0, 0, 1.0),
    ("vga", ("sine", 4, 1.0, 45), [3.5, 5], ("gauss", 2.0), "lowpass-asym", 0.3, 0, 1.0),
    ("hd", ("lin", 1, 0), [4, 5], ("moffat", 3.0, 3.0), "ideal", 0.1, 0, 1.0),
    ("hd", ("lin", 20, 0), [3, 4.5], ("gauss", 1.0), "asym", 0.2, 3, 0.5),
]
#: held out (--fresh): new sensors, cases from the accuracy issue's outside test (a mag-3
#: star at 2 and 4 °/s, a 5-star field at 12 °/s with a hot pixel, the 10°/1 Hz sinusoid on
#: a dark sky), 30 °/s and an acceleration on a dark sky; seeds 5000 + i
FRESH = [
    ("vga", ("lin", 2, 25), [3, 4], ("gauss", 1.1), "dark", 0.5, 2, 1.0),
    ("vga", ("lin", 12, 80), [3, 4, 5], ("moffat", 2.2, 3.5), "dark", 1.0, 0, 1.0),
    ("hd", ("lin", 8, 200), [3.5, 4.5], ("gauss", 1.4), "dark-asym", 0.3, 3, 1.0),
    ("davis", ("sine", 10, 1.0, 15), [3, 5], ("gauss", 1.0), "dark", 1.0, 0, 1.0),
    ("davis", ("lin", 4, 0), [3], ("gauss", 1.0), "coarse", 1.0, 0, 1.0),
    ("davis", ("lin", 2, 45), [3], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("vga", ("lin", 12, -30), [3, 3.5, 4, 4.5, 5], ("gauss", 1.2), "fine", 1.0, 1, 1.0),
    ("hd", ("sine", 6, 0.7, 120), [4, 5], ("defocus", 1.8, 0.5), "dark-asym", 0.5, 0, 1.0),
    ("davis", ("lin", 20, 300), [3, 4], ("ellip", 1.0, 1.4, 10), "coarse", 0.5, 2, 0.5),
    ("vga", ("acc", 25, 60), [3.5, 4.5], ("gauss", 1.2), "dark", 1.0, 0, 1.0),
    ("hd", ("lin", 30, 10), [3, 4], ("gauss", 1.0), "dark", 0.3, 0, 0.4),
    ("davis", ("lin", 8, 170), [4, 5], ("moffat", 3.0, 2.8), "fine", 2.0, 5, 1.0),
]
FRESH_SEED = 5000
#: held out (--fresh2, written in the thirty-first session and run once before any change):
#: a crowded noisy field, a very slow star, diagonal and fast motion, an undersampled PSF, a
#: very bright star beside a faint one, a slow acceleration, new sensors; seeds 6000 + i
FRESH2 = [
    ("vga", ("lin", 5, 15), [3, 3.5, 4, 4.5, 5, 5.5, 6, 4], ("gauss", 1.0), "ideal", 5.0, 10, 1.0),
    ("davis", ("lin", 0.5, 70), [3], ("gauss", 1.3), "ideal", 0.5, 0, 1.0),
    ("hd", ("lin", 15, 45), [4, 5], ("moffat", 2.5, 2.5), "lowpass", 1.0, 0, 0.6),
    ("vga", ("sine", 3, 2.0, 100), [3.5, 5], ("gauss", 1.2), "jittery", 1.0, 0, 1.0),
    ("davis", ("acc", 60, -45), [3, 4.5], ("ellip", 1.3, 0.9, 20), "coarse", 1.0, 0, 0.8),
    ("hd", ("lin", 4, 160), [5, 5.5, 6], ("defocus", 2.0, 0.5), "ideal", 0.2, 0, 1.0),
    ("vga", ("lin", 25, 200), [2.5, 4], ("gauss", 0.7), "ideal", 1.0, 2, 0.5),
    ("davis", ("sine", 15, 0.5, 30), [3, 4], ("gauss", 1.0), "lowpass-asym", 1.0, 0, 1.0),
    ("hd", ("lin", 8, -100), [3, 4], ("gauss", 1.5), "mismatch15", 1.0, 0, 1.0),
    ("vga", ("lin", 1.5, 10), [4, 5], ("gauss", 2.0), "dark-asym", 2.0, 0, 1.0),
    ("davis", ("lin", 12, 135), [2, 5], ("gauss", 1.0), "early-ceiling", 1.0, 0, 1.0),
    ("vga", ("acc", 10, 250), [3.5, 4.5], ("moffat", 3.0, 3.0), "ideal", 1.0, 0, 1.0),
    ("hd", ("sine", 8, 1.5, 60), [3.5, 4.5], ("gauss", 1.1), "fine", 1.0, 0, 1.0),
    ("vga", ("lin", 6, 300), [4, 4.5], ("gauss", 1.2), "off-noise", 3.0, 3, 1.0),
]
FRESH2_SEED = 6000
#: held out (--fresh3, written in the thirty-second session and run once before any change):
#: coning (a constant speed whose direction turns), leak events, readout gaps, coarse
#: thresholds on a dark sky, a long refractory period, a close pair, 50 hot pixels, a
#: defocus ring, 10 Hz of background; seeds 7000 + i. An optional 9th entry: {"pair_px": d}
#: places the stars in a row d px apart
FRESH3 = [
    ("vga", ("circle", 2.0, 1.0), [3.5, 5], ("gauss", 1.1), "ideal", 1.0, 0, 1.0),
    ("davis", ("circle", 4.0, 0.5), [3, 4.5], ("gauss", 1.0), "lowpass", 1.0, 0, 1.0),
    ("hd", ("lin", 10, 30), [3.5, 4.5], ("gauss", 1.2), "leaky", 0.5, 0, 0.6),
    ("vga", ("lin", 6, 0), [3, 4], ("gauss", 1.0), "gappy", 1.0, 0, 1.0),
    ("davis", ("sine", 8, 1.0, 90), [3.5], ("gauss", 1.0), "gappy", 1.0, 0, 1.0),
    ("vga", ("lin", 12, 210), [3.5, 4.5], ("gauss", 1.2), "dark-coarse", 1.0, 0, 1.0),
    ("davis", ("lin", 15, 60), [3, 4.5], ("gauss", 1.0), "slow-refractory", 1.0, 0, 0.8),
    ("vga", ("lin", 4, 120), [3.5, 4], ("gauss", 1.2), "ideal", 1.0, 0, 1.0, {"pair_px": 5.0}),
    ("hd", ("lin", 2, 300), [4.5, 5], ("moffat", 2.8, 2.5), "ideal", 2.0, 50, 1.0),
    ("davis", ("lin", 25, 15), [2.5, 4], ("defocus", 2.5, 0.3), "ideal", 1.0, 0, 0.5),
    ("vga", ("circle", 1.5, 2.0), [4, 5], ("gauss", 1.3), "dark", 1.0, 0, 1.0),
    ("davis", ("lin", 1, 45), [4], ("gauss", 0.9), "ideal", 10.0, 0, 1.0),
]
FRESH3_SEED = 7000
#: held out (--vibe, written in the forty-first session after evstar.vibration, run once):
#: platforms vibrating across or along a constant turn, on this simulator's own sensors and
#: PSFs; seeds 8000 + i
VIBE = [
    ("davis", ("vibe", 8, 0, 0.05, 20.0, 90), [3, 4], ("gauss", 1.1), "ideal", 1.0, 0, 1.0),
    ("vga", ("vibe", 6, 30, 0.03, 15.0, 120), [3.5, 4.5, 5], ("moffat", 2.5, 3.0), "ideal", 0.5, 2, 1.0),
    ("hd", ("vibe", 5, 200, 0.01, 25.0, 290), [3.5, 4.5], ("gauss", 1.2), "asym", 1.0, 0, 1.0),
    ("davis", ("vibe", 10, 60, 0.04, 12.0, 60), [3, 4.5], ("defocus", 1.5, 0.5), "ideal", 1.0, 0, 1.0),
    ("vga", ("vibe", 8, 100, 0.03, 18.0, 10), [3.5, 4], ("gauss", 1.3), "lowpass", 1.0, 0, 1.0),
    ("davis", ("vibe", 12, 0, 0.03, 30.0, 90), [3, 3.5, 4, 4.5, 5], ("gauss", 1.0), "ideal", 1.0, 3, 1.0),
]
VIBE_SEED = 8000
#: held out (--fresh4, written in the forty-second session and run once before any change):
#: a very dark sky, a 1 ms refractory period, OFF-heavy and asymmetric dark skies, coning
#: on the HD sensor, acceleration from rest on a dark sky, five stars on a fast pan with hot
#: pixels, a 1.5 s crawl; seeds 9000 + i
FRESH4 = [
    ("hd", ("lin", 12, 20), [3, 4, 5], ("gauss", 1.1), "deep-dark", 0.5, 0, 0.5),
    ("vga", ("sine", 6, 1.0, 40), [3.5, 4.5], ("moffat", 2.2, 3.0), "refractory-1ms", 1.0, 2, 1.0),
    ("davis", ("acc", 30, 120), [3, 4], ("gauss", 1.2), "dark", 0.5, 0, 1.0),
    ("hd", ("circle", 3.0, 0.5), [4, 5], ("gauss", 1.3), "lowpass", 1.0, 0, 1.0),
    ("vga", ("lin", 20, 250), [3, 3.5, 4, 5, 5.5], ("defocus", 1.6, 0.5), "asym", 2.0, 10, 0.5),
    ("davis", ("lin", 5, 300), [4.5, 5.5], ("ellip", 1.5, 1.0, 0), "fine", 0.5, 0, 1.0),
    ("hd", ("sine", 4, 1.5, 10), [3.5, 4.5], ("gauss", 1.0), "dark-asym", 1.0, 0, 1.0),
    ("vga", ("lin", 10, 170), [3, 4], ("gauss", 0.8), "dark-off-noise", 1.0, 0, 1.0),
    ("davis", ("lin", 2, 80), [3.5], ("moffat", 2.0, 4.0), "lowpass-asym", 0.3, 0, 1.5),
    ("vga", ("lin", 8, 330), [3.5, 4.5], ("gauss", 1.1), "lowpass-off-low", 1.0, 0, 1.0),
]
FRESH4_SEED = 9000
#: held out (--fresh5, written in the forty-third session and run once before any change):
#: 35 °/s, a quick dark sky on a sinusoid, a six-star field with 20 hot pixels on 3 Hz, fine
#: thresholds, OFF far above ON with a wide Moffat, an acceleration on the HD sensor, a
#: mismatched dark sky with an elliptical PSF, a 0.7 °/s crawl, an undersampled PSF behind a
#: 200 µs refractory period, coning with a defocus ring on 5 Hz; seeds 10000 + i
FRESH5 = [
    ("davis", ("lin", 35, 70), [3, 4], ("gauss", 1.0), "ideal", 1.0, 0, 0.4),
    ("vga", ("sine", 15, 0.7, 20), [3.5, 4.5], ("gauss", 1.2), "fast-dark", 0.5, 0, 1.0),
    ("hd", ("lin", 9, 140), [3, 3.5, 4, 4.5, 5, 5.5], ("gauss", 1.1), "ideal", 3.0, 20, 0.6),
    ("vga", ("lin", 7, 45), [3.5, 4.5], ("gauss", 1.0), "tiny-thresh", 1.0, 0, 1.0),
    ("davis", ("lin", 4, 200), [4, 5], ("moffat", 3.0, 2.5), "off-high", 1.0, 0, 1.0),
    ("hd", ("acc", 50, 300), [3.5, 4.5], ("gauss", 1.2), "ideal", 1.0, 0, 0.8),
    ("vga", ("lin", 11, 95), [3, 4], ("ellip", 1.6, 0.9, 45), "mismatch-dark", 1.0, 0, 0.8),
    ("davis", ("lin", 0.7, 10), [3.5], ("gauss", 0.9), "ideal", 0.2, 0, 2.5),
    ("vga", ("lin", 15, 260), [3.5, 4.5], ("gauss", 0.6), "refractory-200", 1.0, 0, 0.8),
    ("hd", ("circle", 5.0, 0.4), [3.5, 4.5], ("defocus", 2.0, 0.6), "ideal", 5.0, 0, 0.8),
]
FRESH5_SEED = 10000
#: held out (--fresh6, written in the forty-fourth session and run once before any change):
#: 25 °/s with an elongated PSF, a diagonal low-pass sinusoid with hot pixels, a middling
#: dark sky, a hard acceleration behind a 300 µs refractory period, a slow defocus ring,
#: coning on 8 Hz of background, seven stars among 50 hot pixels, a 3 Hz sinusoid, an
#: ON-heavy background, a jittery dark sky under a narrow Moffat; seeds 11000 + i
FRESH6 = [
    ("hd", ("lin", 25, 160), [3, 4], ("ellip", 1.4, 1.0, 80), "ideal", 1.0, 0, 0.5),
    ("vga", ("sine", 10, 1.0, 135), [3.5, 4.5], ("moffat", 2.0, 2.2), "lowpass", 1.0, 3, 1.0),
    ("davis", ("lin", 6, 225), [3, 3.5, 4], ("gauss", 1.4), "med-dark", 2.0, 0, 1.0),
    ("hd", ("acc", 80, 20), [4, 5], ("gauss", 1.0), "coarse-ref", 1.0, 0, 0.6),
    ("vga", ("lin", 2, 315), [4, 5], ("defocus", 2.5, 0.7), "ideal", 0.5, 0, 1.5),
    ("davis", ("circle", 4.0, 1.0), [3, 4], ("gauss", 1.1), "ideal", 8.0, 0, 1.0),
    ("hd", ("lin", 15, 5), [3, 3.5, 4, 4.5, 5, 5.5, 6], ("gauss", 1.2), "ideal", 1.0, 50, 0.6),
    ("vga", ("sine", 4, 3.0, 60), [3.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("davis", ("lin", 10, 120), [3.5, 4.5], ("gauss", 1.0), "on-heavy", 1.0, 0, 1.0),
    ("hd", ("lin", 5, 250), [3, 4.5], ("moffat", 1.6, 4.5), "dark-jitter", 1.0, 0, 1.0),
]
FRESH6_SEED = 11000
#: held out (--fresh7, written in the forty-fifth session and run once before any change):
#: 40 °/s under a narrow PSF, a dark-sky sinusoid, a pair 3.5 px apart, six faint stars at
#: 3 °/s, a gappy dark sky, coning at 0.5 Hz, a fast 25 Hz vibration on the HD sensor, an
#: acceleration behind OFF-above-ON thresholds and an 800 µs refractory period, a leaky
#: sensor among 100 hot pixels, a slow dark sky under a wide Moffat; seeds 12000 + i
FRESH7 = [
    ("hd", ("lin", 40, 30), [3, 4], ("gauss", 0.9), "ideal", 1.0, 0, 0.4),
    ("vga", ("sine", 8, 0.5, 20), [3.5, 4.5], ("gauss", 1.1), "dark", 1.0, 0, 1.5),
    ("davis", ("lin", 6, 100), [3.5, 4], ("gauss", 1.0), "ideal", 1.0, 0, 1.0, {"pair_px": 3.5}),
    ("hd", ("lin", 3, 290), [4, 4.5, 5, 5.5, 6, 6.5], ("gauss", 1.0), "ideal", 0.3, 0, 1.5),
    ("vga", ("lin", 12, 200), [3.5, 4.5], ("gauss", 1.2), "gappy-dark", 1.0, 0, 0.8),
    ("davis", ("circle", 6.0, 0.5), [3, 4], ("gauss", 1.2), "ideal", 1.0, 0, 1.0),
    ("hd", ("vibe", 10, 45, 0.03, 25, 135), [3.5, 4.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("vga", ("acc", 30, 170), [3.5, 4.5], ("gauss", 1.1), "thresh-mix", 1.0, 0, 1.0),
    ("davis", ("lin", 8, 0), [3.5, 4.5], ("gauss", 1.0), "leak-2", 3.0, 100, 1.0),
    ("hd", ("lin", 18, 260), [3, 4], ("moffat", 1.8, 3.0), "slow-dark", 1.0, 0, 0.8),
]
FRESH7_SEED = 12000
#: held out (--fresh8, written in the forty-sixth session and run once before any change):
#: a slow roll about the boresight, a fast roll with a pan, a wide lens (stars at the edges
#: up to 1.8 × faster than at the centre), a telephoto low-pass field, stray light rising
#: 6-fold, stray light on a dark-sky sinusoid, ten stars among hot pixels, a roll on a
#: low-pass sensor, a leaky dark sky under a wide Moffat, a telephoto sinusoid; seeds
#: 13000 + i. Rolls: ("roll", roll °/s, pan °/s, pan direction °)
FRESH8 = [
    ("hd", ("roll", 3, 0, 0), [3, 4.5, 5], ("gauss", 1.2), "ideal", 0.5, 0, 1.5),
    ("vga", ("roll", 20, 8, 30), [3.5, 4, 5], ("gauss", 1.1), "ideal", 1.0, 2, 1.0),
    ("wide", ("lin", 12, 150), [3, 4, 4.5, 5], ("gauss", 1.0), "asym", 1.0, 0, 1.0),
    ("tele", ("lin", 4, 75), [4.5, 5.5], ("gauss", 1.6), "lowpass", 1.0, 0, 1.0),
    ("vga", ("lin", 6, 220), [3.5, 4.5, 5.5], ("gauss", 1.2), "stray", 1.0, 0, 1.0),
    ("davis", ("sine", 6, 1.0, 100), [3, 4], ("gauss", 1.0), "stray-dark", 0.5, 0, 1.0),
    ("vga", ("lin", 10, 60), [3, 3.5, 4, 4.5, 5, 5, 5.5, 6, 4, 3.5], ("gauss", 1.1), "ideal",
     2.0, 10, 1.0),
    ("hd", ("roll", 10, 0, 0), [3.5, 4.5], ("gauss", 1.2), "lowpass", 1.0, 0, 1.0),
    ("davis", ("lin", 15, 320), [3.5, 4.5], ("moffat", 2.4, 2.8), "leaky-dark", 1.0, 0, 0.8),
    ("tele", ("sine", 1.5, 1.5, 170), [3.5, 4.5], ("gauss", 1.3), "ideal", 1.0, 0, 1.0),
]
FRESH8_SEED = 13000
#: held out (--fresh9, written in the forty-seventh session and run once before any change
#: of it): damaged gyro records (with --imu; "imu_gaps": spans in s without samples,
#: "imu_spikes": (s, samples, factor) runs of corrupt samples), stalled readouts, a crowded
#: field, a slow telephoto pan; seeds 14000 + i
FRESH9 = [
    ("vga", ("sine", 10, 1.0, 40), [3.5, 4.5], ("gauss", 1.1), "ideal", 1.0, 0, 1.0,
     {"imu_gaps": ((0.35, 0.45),)}),
    ("hd", ("lin", 12, 120), [3, 4, 5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0,
     {"imu_spikes": ((0.3, 10, 40.0), (0.7, 1, 80.0))}),
    ("davis", ("sine", 4, 2.0, 0), [3, 4], ("gauss", 1.0), "dark", 1.0, 0, 1.0,
     {"imu_gaps": ((0.6, 0.66),), "imu_spikes": ((0.2, 3, 10.0),)}),
    ("vga", ("lin", 8, 45), [3.5, 4.5], ("gauss", 1.2), "stall", 1.0, 0, 1.2),
    ("hd", ("sine", 5, 0.7, 100), [3, 4], ("gauss", 1.0), "stall-dark", 1.0, 0, 1.5),
    ("vga", ("lin", 10, 30), [3, 3.5, 4, 4, 4.5, 4.5, 5, 5, 5, 5.5, 5.5, 5.5, 6, 6, 6, 3.5, 4,
                              4.5, 5, 5.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("hd", ("roll", 6, 4, 60), [3.5, 4.5, 5], ("gauss", 1.2), "leaky", 1.0, 5, 1.0,
     {"imu_gaps": ((0.5, 0.58),)}),
    ("tele", ("lin", 2, 200), [4, 5], ("gauss", 1.4), "ideal", 0.5, 0, 1.5),
    ("wide", ("sine", 12, 1.0, 300), [3, 4.5], ("gauss", 1.0), "asym", 2.0, 3, 1.0,
     {"imu_spikes": ((0.5, 5, 30.0),)}),
    ("vga", ("sine", 8, 1.5, 150), [3.5, 4.5], ("gauss", 1.1), "stall", 1.0, 0, 1.0,
     {"imu_gaps": ((0.15, 0.25),)}),
]
FRESH9_SEED = 14000
#: held out (--fresh10, written in the forty-eighth session and run once before any change
#: of it): the accuracy issue's constant-rate dark sky on new settings, a bright star at
#: 25 °/s on fine thresholds, a 0.5 °/s crawl, coning and a vibration on dark skies, a
#: 12-star wide field among 20 hot pixels, a slow telephoto sinusoid, an acceleration
#: through a stall, a gyro gap across a sinusoid's turn, a roll on a dark sky; seeds 15000 + i
FRESH10 = [
    ("vga", ("lin", 8, 250), [3, 4, 5], ("gauss", 1.3), "dark-25", 0.5, 2, 1.2),
    ("hd", ("lin", 25, 15), [2, 3.5], ("moffat", 2.0, 3.5), "busy-fine", 3.0, 5, 0.6),
    ("davis", ("lin", 0.5, 135), [3.5], ("gauss", 1.0), "ideal", 0.3, 0, 2.0),
    ("vga", ("circle", 4, 0.8), [3, 4.5], ("gauss", 1.1), "dark-leak-off", 1.0, 3, 1.0),
    ("hd", ("vibe", 10, 60, 0.04, 12, 150), [3.5, 4.5], ("gauss", 1.2), "dark-25", 1.0, 0, 1.0),
    ("wide", ("lin", 15, 200), [3, 3.5, 4, 4, 4.5, 4.5, 5, 5, 5.5, 5.5, 6, 6], ("gauss", 1.1),
     "busy-fine", 2.0, 20, 1.0),
    ("tele", ("sine", 3, 0.6, 30), [4, 5], ("gauss", 1.5), "dark-leak-off", 0.5, 0, 1.5),
    ("vga", ("acc", 60, 100), [3.5, 5], ("ellip", 1.3, 0.9, 30), "stall-jitter", 1.0, 0, 1.0),
    ("davis", ("sine", 15, 0.5, 200), [3, 4], ("gauss", 1.0), "ideal", 1.0, 0, 1.5,
     {"imu_gaps": ((0.40, 0.62),)}),
    ("hd", ("roll", 15, 3, 300), [3, 4, 4.5, 5], ("gauss", 1.0), "dark-25", 1.0, 0, 1.0),
]
FRESH10_SEED = 15000
#: held out (--fresh11, written in the fiftieth session and run once before any change of
#: it): a dark-sky vibration with the gyro, five new sensors (above), a 1.5 °/s faint pair
#: on the VGA, a fast telephoto pan, a ±12° sinusoid on the wide lens at 0.4 Hz, a roll on
#: a leaky sensor, a 6-star dark field at 6 °/s; seeds 16000 + i
FRESH11 = [
    ("vga", ("vibe", 5, 20, 0.03, 15, 110), [3.5, 4.5], ("gauss", 1.1), "dark", 1.0, 0, 1.0),
    ("hd", ("sine", 6, 1.0, 60), [3, 4.5], ("gauss", 1.2), "dark-ceiling", 0.5, 0, 1.0),
    ("vga", ("lin", 10, 170), [3.5, 4.5, 5.5], ("gauss", 1.0), "fine-dark", 1.0, 2, 1.0),
    ("davis", ("lin", 5, 250), [3.5, 5], ("moffat", 2.0, 3.0), "off-low-ref", 1.0, 0, 1.0),
    ("vga", ("lin", 1.5, 40), [4.5, 5], ("gauss", 1.2), "ideal", 0.3, 0, 1.5),
    ("tele", ("lin", 6, 300), [3.5, 4.5], ("gauss", 1.3), "leaky-fine", 1.0, 3, 0.8),
    ("wide", ("sine", 12, 0.4, 15), [3, 4], ("gauss", 1.0), "ideal", 1.0, 0, 1.5),
    ("hd", ("roll", 8, 2, 120), [3.5, 4.5, 5], ("gauss", 1.1), "leaky-fine", 1.0, 0, 1.0),
    ("vga", ("lin", 6, 80), [3, 3.5, 4, 4.5, 5, 5.5], ("gauss", 1.2), "very-dark", 0.5, 0, 1.0),
    ("davis", ("sine", 10, 1.0, 90), [4, 5], ("gauss", 1.0), "fine-dark", 1.0, 0, 1.0),
]
FRESH11_SEED = 16000
#: held out (--fresh12, written in the fifty-first session and run once before any change of
#: it): six new sensors (above), a slow dark-sky sinusoid on the HD sensor, a fast pan under
#: a Moffat PSF, a 3 °/s crawl on a busy dark sky, an acceleration behind a long refractory
#: period, a telephoto roll, a vibration on the wide lens, a circle under an elliptical
#: PSF, a wide dark sinusoid with a gyro gap, an 8-star dark field among hot pixels; seeds
#: 17000 + i
FRESH12 = [
    ("vga", ("lin", 9, 200), [3.5, 4.5], ("gauss", 1.1), "dark-hot", 1.0, 30, 1.0),
    ("hd", ("sine", 8, 0.8, 45), [3, 4], ("gauss", 1.2), "dark-steep", 0.5, 0, 1.2),
    ("davis", ("lin", 18, 330), [3, 4], ("moffat", 1.8, 3.5), "coarse-jitter", 1.0, 0, 0.8),
    ("vga", ("lin", 3, 100), [4, 5], ("gauss", 1.3), "dark-busy", 4.0, 0, 1.5),
    ("hd", ("acc", 40, 250), [3.5, 4.5], ("gauss", 1.0), "ref-dark", 1.0, 0, 0.8),
    ("tele", ("roll", 5, 3, 200), [3.5, 4.5], ("gauss", 1.4), "ideal", 1.0, 0, 1.0),
    ("wide", ("vibe", 6, 140, 0.05, 8, 50), [3, 4], ("gauss", 1.0), "off-high-dark", 1.0, 0, 1.0),
    ("vga", ("circle", 3, 1.2), [3.5, 5], ("ellip", 1.5, 1.0, 120), "ideal", 1.0, 5, 1.0),
    ("davis", ("sine", 20, 0.5, 10), [3, 4], ("gauss", 1.0), "dark-steep", 1.0, 0, 1.5,
     {"imu_gaps": ((0.9, 0.95),)}),
    ("hd", ("lin", 12, 20), [3, 3.5, 4, 4.5, 5, 5.5, 6, 4], ("gauss", 1.1), "dark-hot", 1.5, 30,
     0.8),
]
FRESH12_SEED = 17000
#: held out (--fresh13, written in the fifty-third session and run once before any change of
#: it): five new sensors (above), a 7 °/s pan of three stars on the HD sensor, a sinusoid
#: under a Moffat PSF among hot pixels, a 2 °/s crawl on a brightening dark sky, a pan
#: through the telephoto under an elliptical PSF, an acceleration from rest across a stall,
#: a fast pan on the wide lens under a defocused PSF, a roll of four stars, a vibration on
#: the DAVIS346, coning on the HD sensor, a 25 °/s pan across a stall; seeds 18000 + i
FRESH13 = [
    ("hd", ("lin", 7, 300), [3.5, 4.5, 5.5], ("gauss", 1.2), "dark-40-jitter", 1.0, 0, 1.0),
    ("vga", ("sine", 5, 1.2, 20), [3.5, 5], ("moffat", 1.6, 2.8), "fine-off-low", 1.0, 10, 1.0),
    ("davis", ("lin", 2, 135), [4, 5], ("gauss", 1.4), "dark-stray-off", 0.5, 0, 1.5),
    ("tele", ("lin", 4, 60), [3, 4], ("ellip", 1.3, 0.9, 45), "coarse-leak", 1.0, 0, 1.0),
    ("hd", ("acc", 25, 10), [3, 4], ("gauss", 1.1), "dark-gap-asym", 1.0, 0, 1.0),
    ("wide", ("lin", 15, 200), [3.5, 4.5], ("defocus", 1.8, 0.6), "ideal", 2.0, 20, 0.8),
    ("vga", ("roll", 6, 1.5, 30), [3.5, 4, 4.5, 5], ("gauss", 1.0), "dark-40-jitter", 1.0, 0, 1.0),
    ("davis", ("vibe", 4, 300, 0.04, 12, 30), [3.5, 4.5], ("gauss", 1.2), "fine-off-low", 1.0,
     0, 1.0),
    ("hd", ("circle", 5, 0.8), [3, 4.5], ("gauss", 1.3), "dark-stray-off", 1.0, 0, 1.0),
    ("vga", ("lin", 25, 240), [3, 4], ("gauss", 1.0), "dark-gap-asym", 1.0, 0, 0.6),
]
FRESH13_SEED = 18000
#: held out (--fresh14, written in the fifty-fourth session and run once before any change of
#: it): five new sensors (above), a 9 °/s pan of three stars, a sinusoid on the HD sensor
#: among hot pixels, a 3 °/s crawl under a Moffat PSF, a 2 °/s pan through the telephoto, an
#: acceleration from rest on the wide lens, a roll of three stars, a vibration across a VGA
#: pan, coning under an elliptical PSF, an 18 °/s pan of three defocused stars among hot
#: pixels, a slow sinusoid of 12°; seeds 19000 + i
FRESH14 = [
    ("vga", ("lin", 9, 250), [3.5, 4.5, 5], ("gauss", 1.1), "dark-60-mismatch", 1.0, 0, 1.0),
    ("hd", ("sine", 7, 0.9, 40), [3, 4], ("gauss", 1.2), "coarse-off-low-ref", 1.0, 5, 1.0),
    ("davis", ("lin", 3, 200), [3.5, 4.5], ("moffat", 2.2, 3.5), "dark-leak-jitter", 1.0, 0,
     1.2),
    ("tele", ("lin", 2, 310), [3.5, 4], ("gauss", 1.5), "fine-busy-on", 2.0, 0, 1.0),
    ("wide", ("acc", 35, 60), [3, 4], ("gauss", 1.0), "dark-ref-off-high", 1.0, 0, 1.0),
    ("hd", ("roll", 8, 2, 150), [3.5, 4, 4.5], ("gauss", 1.1), "dark-60-mismatch", 1.0, 0, 1.0),
    ("vga", ("vibe", 5, 70, 0.03, 18, 160), [3.5, 4.5], ("gauss", 1.2), "coarse-off-low-ref",
     1.0, 0, 1.0),
    ("davis", ("circle", 4, 1.0), [3, 4], ("ellip", 1.4, 1.0, 70), "dark-leak-jitter", 1.0, 0,
     1.0),
    ("hd", ("lin", 18, 120), [3, 4, 5], ("defocus", 1.6, 0.5), "fine-busy-on", 1.5, 10, 0.6),
    ("vga", ("sine", 12, 0.6, 300), [3.5, 4.5], ("gauss", 1.0), "dark-ref-off-high", 1.0, 0,
     1.5),
]
FRESH14_SEED = 19000
#: the fifteenth held-out grid (written in the fifty-fifth session, run once on its start):
#: five new sensors (above) under a three-star HD pan, a DAVIS346 sinusoid, a Moffat VGA
#: pan, an acceleration on the wide lens, a circle through a readout stall, a 22 Hz
#: vibration, a roll under an elliptical PSF, a slow DAVIS346 crawl, a defocused sinusoid
#: among hot pixels, a fast VGA pan; seeds 20000 + i
FRESH15 = [
    ("hd", ("lin", 14, 35), [3, 4, 5], ("gauss", 1.2), "dark-80-fine-jitter", 1.0, 0, 1.0),
    ("davis", ("sine", 9, 0.8, 60), [3.5, 4.5], ("gauss", 1.0), "slow-ref-mismatch", 1.0, 3, 1.0),
    ("vga", ("lin", 6, 140), [3.5, 4.5], ("moffat", 2.0, 3.0), "dark-off-low-leak", 1.0, 0, 1.0),
    ("wide", ("acc", 45, 200), [3, 4], ("gauss", 1.1), "busy-off-coarse", 2.5, 0, 0.8),
    ("tele", ("circle", 3, 0.7), [3.5, 4], ("gauss", 1.3), "dark-stall-ref", 1.0, 0, 1.2),
    ("hd", ("vibe", 7, 20, 0.02, 22, 110), [3.5, 4.5, 5], ("gauss", 1.0), "dark-80-fine-jitter",
     1.0, 0, 1.0),
    ("vga", ("roll", 10, 3, 45), [3, 4, 4.5], ("ellip", 1.3, 1.0, 30), "slow-ref-mismatch", 1.0,
     0, 1.0),
    ("davis", ("lin", 1.5, 80), [3, 4], ("gauss", 1.4), "dark-off-low-leak", 0.5, 0, 1.5),
    ("hd", ("sine", 14, 1.2, 200), [3, 4], ("defocus", 1.5, 0.5), "busy-off-coarse", 1.5, 20,
     1.0),
    ("vga", ("lin", 20, 330), [3.5, 4.5], ("gauss", 0.9), "dark-stall-ref", 1.0, 0, 1.0),
]
FRESH15_SEED = 20000
#: the sixteenth held-out grid (written in the fifty-sixth session, run once on its start):
#: five new sensors (above) under a three-star VGA pan, an HD sinusoid, a Moffat DAVIS346
#: pan among warm pixels, an acceleration on the wide lens, a tele pan through an early
#: readout gap, a 14 Hz vibration, a circle under an elliptical PSF, a roll on the DAVIS346,
#: a fast defocused VGA pan, a slow HD sinusoid among hot pixels; seeds 21000 + i
FRESH16 = [
    ("vga", ("lin", 11, 75), [3, 4, 5], ("gauss", 1.1), "dark-15-coarse-ref", 1.0, 0, 1.0),
    ("hd", ("sine", 6, 1.4, 250), [3.5, 4.5], ("gauss", 1.2), "fine-jitter-leak", 1.0, 0, 1.0),
    ("davis", ("lin", 5, 170), [3, 4], ("moffat", 2.5, 4.0), "dark-on-low-mismatch", 1.0, 2, 1.0),
    ("wide", ("acc", 25, 300), [3.5, 4.5], ("gauss", 1.0), "busy-fading-on", 3.0, 0, 1.0),
    ("tele", ("lin", 8, 15), [3, 4], ("gauss", 1.6), "gap-early-dark", 1.0, 0, 1.0),
    ("vga", ("vibe", 4, 100, 0.025, 14, 10), [3.5, 4.5], ("gauss", 1.1), "fine-jitter-leak", 1.0,
     0, 1.2),
    ("hd", ("circle", 5, 0.5), [3, 4, 5], ("ellip", 1.5, 1.1, 120), "dark-on-low-mismatch", 1.0,
     0, 1.0),
    ("davis", ("roll", 6, 1, 260), [3, 3.5], ("gauss", 1.2), "busy-fading-on", 2.0, 5, 1.0),
    ("vga", ("lin", 25, 190), [3, 4], ("defocus", 1.4, 0.6), "dark-15-coarse-ref", 1.0, 0, 0.8),
    ("hd", ("sine", 16, 0.5, 130), [3.5, 4.5], ("gauss", 1.0), "gap-early-dark", 1.0, 8, 1.5),
]
FRESH16_SEED = 21000
#: the seventeenth held-out grid (written in the fifty-seventh session, run once on its
#: start): five new sensors (above) under a three-star HD pan, a VGA sinusoid, a slow Moffat
#: tele pan, an acceleration on the DAVIS346, a wide pan through a late stall, a 9 Hz
#: vibration, a circle among hot pixels, a roll on the HD sensor, a fast elliptical DAVIS346
#: pan, a slow wide sinusoid; seeds 22000 + i
FRESH17 = [
    ("hd", ("lin", 9, 55), [3, 4, 5], ("gauss", 1.1), "dark-28-low-ceiling-jitter", 1.0, 0, 1.0),
    ("vga", ("sine", 7, 1.1, 320), [3.5, 4.5], ("gauss", 1.0), "coarse-off-ref-350", 1.0, 0, 1.0),
    ("tele", ("lin", 2, 200), [3, 4], ("moffat", 2.2, 3.5), "fine-rising-off", 1.0, 0, 1.2),
    ("davis", ("acc", 30, 100), [3.5, 4.5], ("gauss", 1.2), "dark-60-leak-on-high", 1.0, 0, 1.0),
    ("wide", ("lin", 12, 280), [3, 4], ("gauss", 1.0), "late-stall-jitter", 1.0, 0, 1.0),
    ("hd", ("vibe", 6, 40, 0.03, 9, 130), [3.5, 4.5], ("gauss", 1.2), "coarse-off-ref-350", 1.0,
     0, 1.2),
    ("vga", ("circle", 4, 0.8), [3, 4], ("gauss", 1.3), "fine-rising-off", 1.0, 15, 1.0),
    ("hd", ("roll", 8, 2, 80), [3, 4, 4.5], ("ellip", 1.2, 1.0, 10), "dark-60-leak-on-high",
     1.0, 0, 1.0),
    ("davis", ("lin", 22, 240), [3, 4], ("ellip", 1.0, 1.4, 75), "dark-28-low-ceiling-jitter",
     1.0, 0, 0.8),
    ("wide", ("sine", 5, 0.6, 20), [3.5, 4.5], ("defocus", 1.3, 0.5), "late-stall-jitter", 1.0,
     3, 1.5),
]
FRESH17_SEED = 22000
#: the eighteenth held-out grid (written in the fifty-eighth session, run once on its
#: start): five new sensors (above) under a three-star DAVIS346 pan, an HD sinusoid, a slow
#: elliptical VGA pan, an acceleration on the tele lens, a wide pan through two gaps, an
#: 11 Hz vibration, a circle on the DAVIS346, a roll on the VGA sensor, a fast HD pan, a
#: slow tele sinusoid among hot pixels; seeds 23000 + i
FRESH18 = [
    ("davis", ("lin", 7, 110), [3, 4, 5], ("gauss", 1.2), "dark-40-ceiling-700-ref", 1.0, 0, 1.0),
    ("hd", ("sine", 9, 0.9, 40), [3.5, 4.5], ("gauss", 1.0), "mismatch-09-off-low", 1.0, 0, 1.0),
    ("vga", ("lin", 3, 310), [3, 4], ("ellip", 1.3, 0.9, 50), "dark-zero-ref-jitter", 1.0, 0,
     1.2),
    ("tele", ("acc", 20, 170), [3.5, 4.5], ("gauss", 1.4), "leak-coarse-fading", 1.0, 0, 1.0),
    ("wide", ("lin", 10, 20), [3, 4], ("gauss", 1.1), "dark-gaps-fine", 1.0, 0, 1.0),
    ("vga", ("vibe", 5, 200, 0.03, 11, 290), [3.5, 4.5], ("gauss", 1.0), "mismatch-09-off-low",
     1.0, 0, 1.2),
    ("davis", ("circle", 6, 0.7), [3, 4], ("gauss", 1.2), "dark-zero-ref-jitter", 1.0, 4, 1.0),
    ("vga", ("roll", 10, 3, 140), [3, 4, 4.5], ("gauss", 1.1), "leak-coarse-fading", 1.0, 0,
     1.0),
    ("hd", ("lin", 26, 95), [3, 4], ("moffat", 2.0, 3.0), "dark-40-ceiling-700-ref", 1.0, 0, 0.8),
    ("tele", ("sine", 3, 0.7, 230), [3.5, 4.5], ("defocus", 1.4, 0.5), "dark-gaps-fine", 1.0,
     10, 1.5),
]
FRESH18_SEED = 23000
#: the nineteenth held-out grid (written in the fifty-ninth session, run once on its start):
#: five new sensors (above) under a three-star HD pan, a DAVIS346 sinusoid, a slow wide pan,
#: an acceleration on the VGA sensor, a tele pan through an early stall, a 16 Hz vibration,
#: a circle on the HD sensor, a roll on the DAVIS346, a fast wide pan, a slow VGA sinusoid
#: among hot pixels; seeds 24000 + i
FRESH19 = [
    ("hd", ("lin", 8, 250), [3, 4, 5], ("gauss", 1.1), "dark-22-late-off-high", 1.0, 0, 1.0),
    ("davis", ("sine", 8, 1.2, 60), [3.5, 4.5], ("gauss", 1.2), "fine-13-busy-on", 2.0, 0, 1.0),
    ("wide", ("lin", 2.5, 15), [3, 4], ("moffat", 2.4, 3.0), "dark-70-mismatch-jitter", 1.0, 0,
     1.2),
    ("vga", ("acc", 25, 300), [3.5, 4.5], ("gauss", 1.0), "coarse-leak-ref-80", 1.0, 0, 1.0),
    ("tele", ("lin", 5, 140), [3, 4], ("gauss", 1.3), "early-stall-rising", 1.0, 0, 1.0),
    ("hd", ("vibe", 7, 330, 0.02, 16, 60), [3.5, 4.5], ("gauss", 1.1), "fine-13-busy-on", 1.0, 0,
     1.2),
    ("hd", ("circle", 5, 0.6), [3, 4], ("ellip", 1.3, 1.0, 20), "dark-22-late-off-high", 1.0, 0,
     1.0),
    ("davis", ("roll", 12, 2, 45), [3, 4, 4.5], ("gauss", 1.0), "coarse-leak-ref-80", 1.0, 0,
     1.0),
    ("wide", ("lin", 24, 170), [3, 4], ("defocus", 1.6, 0.5), "dark-70-mismatch-jitter", 1.0, 0,
     0.8),
    ("vga", ("sine", 4, 0.8, 100), [3.5, 4.5], ("gauss", 1.2), "early-stall-rising", 1.0, 8,
     1.5),
]
FRESH19_SEED = 24000
#: the twentieth (B1–B10; the sixtieth session, run once before any change for it)
FRESH20 = [
    ("vga", ("lin", 11, 35), [3, 4, 5], ("gauss", 1.2), "dark-28-early-ref-150", 1.0, 0, 1.0),
    ("hd", ("sine", 6, 0.9, 20), [3.5, 4.5], ("gauss", 1.0), "off-low-jitter-40", 1.0, 0, 1.2),
    ("davis", ("lin", 3, 290), [3, 4], ("moffat", 2.0, 3.5), "dark-50-fine-leak", 1.0, 0, 1.2),
    ("tele", ("acc", 15, 200), [3.5, 4.5], ("gauss", 1.1), "mismatch-06-fading", 2.0, 0, 1.0),
    ("wide", ("lin", 18, 75), [3, 4], ("gauss", 1.3), "late-gap-ref-300", 1.0, 3, 1.0),
    ("hd", ("circle", 4, 0.8), [3.5, 4.5], ("gauss", 1.1), "off-low-jitter-40", 1.0, 0, 1.0),
    ("vga", ("vibe", 6, 10, 0.025, 22, 100), [3, 4], ("gauss", 1.0), "dark-50-fine-leak", 1.0, 0,
     1.0),
    ("davis", ("roll", 8, 3, 200), [3, 4], ("ellip", 1.2, 0.9, 60), "mismatch-06-fading", 1.0, 0,
     1.0),
    ("hd", ("sine", 10, 1.1, 150), [3.5, 4.5], ("defocus", 1.4, 0.4), "dark-28-early-ref-150",
     1.0, 0, 1.0),
    ("tele", ("lin", 1.5, 320), [4, 5], ("gauss", 1.2), "late-gap-ref-300", 0.5, 0, 1.5),
]
FRESH20_SEED = 25000
#: the twenty-first (D1–D10; the sixty-second session, run once before any change for it)
FRESH21 = [
    ("hd", ("lin", 9, 140), [3, 4.5], ("gauss", 1.1), "dark-40-late-ref-100", 1.0, 0, 1.0),
    ("davis", ("sine", 7, 0.7, 60), [3.5, 4.5], ("moffat", 2.4, 3.0), "fine-busy-off", 2.0, 0, 1.5),
    ("vga", ("lin", 2, 250), [3, 4], ("gauss", 1.4), "mismatch-04-leak-1-jitter-90", 0.5, 3, 1.5),
    ("wide", ("lin", 15, 20), [3, 4], ("gauss", 1.1), "dark-20-coarse", 1.0, 0, 0.8),
    ("tele", ("circle", 3, 1.2), [3.5, 4.5], ("gauss", 1.2), "mid-gap-rising", 1.0, 2, 1.0),
    ("hd", ("acc", 30, 300), [3.5, 4.5], ("ellip", 1.3, 1.0, 10), "fine-busy-off", 1.0, 0, 1.0),
    ("davis", ("roll", 10, 4, 100), [3, 4], ("gauss", 1.0), "dark-40-late-ref-100", 1.0, 0, 1.0),
    ("vga", ("vibe", 8, 60, 0.02, 20.0, 150), [3.5, 4.5], ("gauss", 1.1),
     "mismatch-04-leak-1-jitter-90", 1.0, 0, 1.0),
    ("davis", ("lin", 5, 210), [3, 4, 5, 5.5], ("defocus", 1.8, 0.5), "mid-gap-rising", 1.0, 5,
     1.0),
    ("hd", ("sine", 4, 1.6, 330), [3, 4], ("gauss", 1.0), "dark-20-coarse", 0.5, 0, 1.0),
]
FRESH21_SEED = 27000
#: the twenty-second (E1–E10; the sixty-third session, run once before any change for it)
FRESH22 = [
    ("vga", ("lin", 13, 60), [3, 4, 5], ("gauss", 1.1), "dark-33-ref-200-off-high", 1.0, 0, 1.0),
    ("hd", ("sine", 5, 1.3, 240), [3.5, 4.5], ("gauss", 1.2), "fine-jitter-60", 1.5, 0, 1.2),
    ("davis", ("lin", 4, 330), [3, 4], ("moffat", 2.2, 3.0), "mismatch-08", 0.5, 2, 1.2),
    ("tele", ("lin", 2.5, 110), [3.5, 4.5], ("gauss", 1.3), "dark-60-early-leak", 1.0, 0, 1.2),
    ("wide", ("circle", 6, 0.9), [3, 4], ("gauss", 1.0), "two-gaps-ref-200", 1.0, 0, 1.0),
    ("hd", ("acc", 20, 45), [3.5, 4.5], ("defocus", 1.5, 0.5), "dark-33-ref-200-off-high", 1.0, 0,
     1.0),
    ("vga", ("roll", 9, 5, 270), [3, 4], ("gauss", 1.1), "fine-jitter-60", 1.0, 3, 1.0),
    ("davis", ("vibe", 6, 100, 0.03, 14.0, 190), [3.5, 4.5], ("gauss", 1.2), "dark-60-early-leak",
     1.0, 0, 1.2),
    ("hd", ("lin", 22, 250), [3, 4, 4.5], ("ellip", 1.3, 0.9, 70), "two-gaps-ref-200", 1.0, 0, 1.0),
    ("vga", ("sine", 9, 0.6, 15), [3.5, 4.5], ("gauss", 1.0), "mismatch-08", 1.0, 0, 1.5),
]
FRESH22_SEED = 28000
#: held out (--vibe2, C1–C10; written in the sixty-first session after its change to
#: evstar.vibration, which it was developed on --vibe for, and run once on the code before
#: and after it): platforms vibrating at 8–35 Hz across, along and oblique to pans of
#: 3–14 °/s, on cameras, PSFs and sensors --vibe did not use, one to five stars, 1–2.5 s
VIBE2 = [
    ("davis", ("vibe", 5, 45, 0.04, 10.0, 135), [3, 4], ("gauss", 1.2), "ideal", 1.0, 0, 1.0),
    ("hd", ("vibe", 12, 200, 0.008, 35.0, 290), [3.5, 4.5], ("gauss", 1.0), "ideal", 1.0, 0, 1.0),
    ("vga", ("vibe", 4, 300, 0.03, 16.0, 30), [3.5, 4.5, 5], ("moffat", 2.2, 3.0), "asym", 1.0, 2,
     1.0),
    ("tele", ("vibe", 3, 120, 0.005, 14.0, 210), [4, 5], ("gauss", 1.3), "lowpass", 0.5, 0, 1.0),
    ("wide", ("vibe", 10, 80, 0.06, 22.0, 170), [3, 4], ("defocus", 1.5, 0.4), "ideal", 1.0, 0,
     1.0),
    ("davis", ("vibe", 7, 160, 0.04, 18.0, 160), [3, 4], ("gauss", 1.1), "ideal", 1.0, 0, 1.0),
    ("vga", ("vibe", 9, 250, 0.03, 25.0, 295), [3, 4], ("ellip", 1.4, 1.0, 30), "dark", 1.0, 0,
     1.0),
    ("hd", ("vibe", 6, 20, 0.012, 12.0, 110), [3, 3.5, 4, 4.5, 5], ("gauss", 1.1), "ideal", 1.0,
     0, 1.5),
    ("davis", ("vibe", 14, 330, 0.03, 30.0, 60), [3.5], ("gauss", 1.0), "asym", 1.0, 0, 1.0),
    ("vga", ("vibe", 5, 90, 0.02, 8.0, 180), [3.5, 4.5], ("gauss", 1.3), "ideal", 2.0, 0, 2.5),
]
VIBE2_SEED = 26000
#: the held-out grids by command-line flag (the later grid first where flags are combined):
#: (scenes, seed index of the first, label prefix)
HELD_OUT = {"fresh22": (FRESH22, FRESH22_SEED, "E"), "fresh21": (FRESH21, FRESH21_SEED, "D"), "vibe2": (VIBE2, VIBE2_SEED, "C"), "fresh20": (FRESH20, FRESH20_SEED, "B"), "fresh19": (FRESH19, FRESH19_SEED, "A"), "fresh18": (FRESH18, FRESH18_SEED, "Z"), "fresh17": (FRESH17, FRESH17_SEED, "Y"), "fresh16": (FRESH16, FRESH16_SEED, "X"), "fresh15": (FRESH15, FRESH15_SEED, "W"), "fresh14": (FRESH14, FRESH14_SEED, "U"), "fresh13": (FRESH13, FRESH13_SEED, "T"), "fresh12": (FRESH12, FRESH12_SEED, "S"), "fresh11": (FRESH11, FRESH11_SEED, "R"), "fresh10": (FRESH10, FRESH10_SEED, "Q"), "fresh9": (FRESH9, FRESH9_SEED, "P"), "fresh8": (FRESH8, FRESH8_SEED, "O"), "fresh7": (FRESH7, FRESH7_SEED, "N"), "fresh6": (FRESH6, FRESH6_SEED, "M"), "fresh5": (FRESH5, FRESH5_SEED, "L"), "fresh4": (FRESH4, FRESH4_SEED, "K"),
            "vibe": (VIBE, VIBE_SEED, "V"), "fresh3": (FRESH3, FRESH3_SEED, "H"),
            "fresh2": (FRESH2, FRESH2_SEED, "G"), "fresh": (FRESH, FRESH_SEED, "F")}
ESTIMATORS = ("default", "mean")
#: the stars are fixed and the camera turns (indep_sim's "rotate"): a translation of the whole
#: image is no motion a camera can make, and evstar's rigid-field step fits rotations
PROJECTION = "rotate"


def make_psf(spec):
    kind, *a = spec
    return {"gauss": S.Gaussian, "moffat": S.Moffat, "defocus": S.Defocus,
            "ellip": S.Elliptical}[kind](*a)


def make_motion(spec):
    kind, *a = spec
    if kind == "lin":
        return S.Linear(a[0], a[1])
    if kind == "sine":
        return S.Sinusoid(a[0], a[1], a[2])
    if kind == "circle":
        return S.Circle(a[0], a[1])
    if kind == "roll":   # (roll °/s, pan °/s, pan direction °)
        return S.Rolled(a[0], S.Linear(a[1], a[2]))
    if kind == "vibe":   # (rate °/s, direction °, amplitude °, Hz, the wave's direction °)
        return S.Shaken(S.Linear(a[0], a[1]), S.Sinusoid(a[2], a[3], a[4]))
    return S.Accelerating(a[0], a[1])


def start_positions(width, height, f, motion, duration, n, rng, margin=12.0, sep=18.0):
    """Start centres such that every star stays `margin` px inside the sensor for the whole
    recording (the turning camera's projection) and no two are closer than `sep` px."""
    t = np.linspace(0, duration, 201)
    out = []
    for _ in range(20_000):
        p = rng.random(2) * [width - 1, height - 1]
        path = S.Scene(width, height, f, [tuple(p)], [0.0], motion, S.Gaussian(1.0), duration,
                       PROJECTION).positions(t)[:, 0]
        inside = (np.all(path >= margin) and np.all(path[:, 0] <= width - 1 - margin)
                  and np.all(path[:, 1] <= height - 1 - margin))
        if inside and all(np.hypot(*(p - q)) >= sep for q in out):
            out.append(p)
            if len(out) == n:
                return [tuple(map(float, q)) for q in out]
    raise ValueError("no room for the stars")


def pair_positions(width, height, f, motion, duration, n, rng, d):
    """n start centres in a row d px apart at a random angle, all staying inside."""
    p0 = start_positions(width, height, f, motion, duration, 1, rng, margin=12.0 + n * d)[0]
    a = rng.uniform(0, math.pi)
    return [tuple(map(float, np.asarray(p0) + k * d * np.array([math.cos(a), math.sin(a)])))
            for k in range(n)]


def scene_label(i):
    """The label of the scene of seed index i: its held-out grid's prefix and place (F1, G1,
    H1 ...), else its 1-based place in GRID."""
    for _, seed0, prefix in HELD_OUT.values():
        if i >= seed0:
            return f"{prefix}{i - seed0 + 1}"
    return i + 1


def held_out_scene(label):
    """(seed index, spec) of a held-out scene's label (F1..F12, G1..G14, H1..H12)."""
    grid, seed0 = next(v[:2] for v in HELD_OUT.values() if v[2] == label[0])
    i = int(label[1:]) - 1
    return seed0 + i, grid[i]


def scene_of(i, spec, duration_scale=1.0):
    """Scene of seed index i (of GRID or a held-out grid, HELD_OUT's seeds) and spec."""
    cam, motion, mags, psf, sensor, noise, hot, dur, *extra = spec
    extra = extra[0] if extra else {}
    w, h, f = CAMERAS[cam]
    dur = dur * duration_scale
    rng = np.random.default_rng(1000 + i)
    mot = make_motion(motion)
    starts = (pair_positions(w, h, f, mot, dur, len(mags), rng, extra["pair_px"])
              if "pair_px" in extra else start_positions(w, h, f, mot, dur, len(mags), rng))
    scene = S.Scene(w, h, f, starts, list(mags), mot, make_psf(psf), dur, PROJECTION)
    sens = S.Sensor(**{**SENSORS[sensor], "noise_hz": noise, "hot_pixels": hot})
    return scene, sens


def motion_dirs(scene, t_us, star):
    """(len(t), 2) unit image velocity of each row's star (NaN where it is nearly still)."""
    t = np.asarray(t_us, float) * 1e-6
    dt = 1e-4
    p = scene.positions(np.concatenate([t - dt, t + dt]))
    n = np.arange(len(t))
    v = (p[len(t):][n, star] - p[:len(t)][n, star]) / (2 * dt)
    s = np.hypot(v[:, 0], v[:, 1])
    return np.where((s > 2.0)[:, None], v / np.maximum(s, 1e-12)[:, None], np.nan)


def scores(rows, scene, truth, frames_t, n_frames):
    star, err = accuracy.match(rows, truth)
    ok = star >= 0
    _, per_star = accuracy.detection(rows[ok], truth, np.arange(n_frames), frames_t,
                                     scene.width, scene.height)
    out = {"rows": int(len(rows)), "frames_min": float(np.nanmin(per_star)),
           "frames_per_star": [float(v) for v in per_star],
           "false_per_100": 100 * float((~ok).sum()) / n_frames}
    nan = float("nan")
    if not ok.any():
        return {**out, "mean": nan, "median": nan, "max": nan, "along": nan, "across": nan,
                "z_median": nan, "per_star_mean": [nan] * len(scene.mags)}
    r = rows[ok]
    xy = truth(r["t"])[np.arange(len(r)), star[ok]]
    d = np.column_stack([r["x"] - xy[:, 0], r["y"] - xy[:, 1]])
    u = motion_dirs(scene, r["t"], star[ok])
    along = np.nansum(d * u, 1)
    across = d[:, 1] * u[:, 0] - d[:, 0] * u[:, 1]
    moving = np.isfinite(u[:, 0])
    e = err[ok]
    return {**out, "mean": float(e.mean()), "median": float(np.median(e)), "max": float(e.max()),
            "along": float(along[moving].mean()) if moving.any() else nan,
            "across": float(np.abs(across[moving]).mean()) if moving.any() else nan,
            "z_median": float(np.median(e / np.maximum(r["sigma"], 1e-12))),
            "per_star_mean": [float(e[star[ok] == s].mean()) if (star[ok] == s).any() else nan
                              for s in range(len(scene.mags))]}


#: `--calibrated`'s calibration recording: five stars of a VGA field on a 10°/0.5 Hz sinusoid
#: with the gyro, 2 s (no scene of any grid)
CALIBRATION = ("vga", ("sine", 10, 0.5, 30), [3, 3.5, 4, 4.5, 5], ("gauss", 1.2), None, 1.0, 0, 2.0)
CALIBRATION_SEED = 12345


def calibration_file(sensor):
    """`evstar calibrate`'s file (evstar.calibration.calibrate) of CALIBRATION recorded with
    `sensor` (a SENSORS name), made once per sensor in the temporary folder."""
    from study_calibration import cached_lag_file

    spec = CALIBRATION[:4] + (sensor,) + CALIBRATION[5:]
    return cached_lag_file(f"indep_{sensor}", lambda: S.simulate(
        *scene_of(CALIBRATION_SEED, spec, 1.0), seed=CALIBRATION_SEED, imu=True))


def run_scene(i, spec, duration_scale=1.0, imu=False, clock_offset_us=0, settings=None):
    scene, sensor = scene_of(i, spec, duration_scale)
    t = time.perf_counter()
    run = S.simulate(scene, sensor, seed=i, imu=imu)
    if imu and clock_offset_us:   # the gyro's clock behind the camera's, not told
        run.imu = Imu(run.imu.t - clock_offset_us, run.imu.gyro)
    if imu and len(spec) > 8:     # a damaged gyro record (FRESH9)
        run.imu = damaged(run.imu, spec[8])
    sim_s = time.perf_counter() - t
    ev = run.events
    cfg = Config().replace(**{**(settings or {}), "motion.compensate": "imu" if imu else "none"})
    t0 = int(ev.t[0])
    n_frames = int((ev.t[-1] - t0) // cfg.dt_us) + 1
    frames_t = t0 + (np.arange(n_frames) + 0.5) * cfg.dt_us
    frames_s = scene.duration_s / (cfg.dt_us * 1e-6)
    per_frame = [n / frames_s for n in run.info["per_star_events"]]
    sig = math.sqrt(scene.psf.sigma_eff() ** 2 + 1 / 12)
    cam, motion, mags, psf, sens, noise, hot, dur, *_ = spec
    out = {"scene": scene_label(i), "camera": cam, "motion": scene.motion.label(),
           "direction": motion[-1] if motion[0] != "circle" else 0, "mags": list(mags), "psf": scene.psf.label(),
           "sigma_eff_px": sig, "sensor": sens, "noise_hz": noise, "hot_pixels": hot,
           "duration_s": scene.duration_s, "events": int(len(ev)), "sim_s": sim_s,
           "events_per_frame": per_frame,
           "bound_px": [sig / math.sqrt(max(n, 1.0)) for n in per_frame]}
    for name in ESTIMATORS:
        c = cfg if name == "default" else cfg.replace(**{"estimate.estimator": name})
        t = time.perf_counter()
        res = Pipeline(c).run(ev, run.imu, run.camera)
        out[name] = {**scores(res.centroids, scene, run.truth, frames_t, n_frames),
                     "run_s": time.perf_counter() - t}
    return out


def damaged(imu, extra):
    """`imu` without its samples in extra["imu_gaps"] ((t0, t1) s) and with each run of
    extra["imu_spikes"] ((t s, samples, factor)) multiplied by its factor."""
    t, g = imu.t, imu.gyro.copy()
    keep = np.ones(len(t), bool)
    for t0, t1 in extra.get("imu_gaps", ()):
        keep &= (t < t0 * 1e6) | (t > t1 * 1e6)
    for at, n, factor in extra.get("imu_spikes", ()):
        i = int(np.searchsorted(t, at * 1e6))
        g[i:i + n] *= factor
    return Imu(t[keep], g[keep])


def markdown(rows):
    head = ("| # | camera | motion (dir °) | mags | PSF (σ_eff px) | sensor | noise Hz / hot | "
            "ev/frame per star | bound px | default mean / med / max | along bias | frames | "
            "false/100 | err/σ med | mean: mean / med / max | along bias | frames | false/100 |")
    lines = [head, "|" + "---|" * 18]
    for r in rows:
        d, m = r["default"], r["mean"]
        cells = [str(r["scene"]), r["camera"], f"{r['motion']} ({r['direction']:g})",
                 ",".join(f"{v:g}" for v in r["mags"]), f"{r['psf']} ({r['sigma_eff_px']:.2f})",
                 r["sensor"], f"{r['noise_hz']:g} / {r['hot_pixels']}",
                 ", ".join(f"{v:.0f}" for v in r["events_per_frame"]),
                 ", ".join(f"{v:.3f}" for v in r["bound_px"])]
        for e in (d, m):
            cells += [f"{e['mean']:.3f} / {e['median']:.3f} / {e['max']:.2f}", f"{e['along']:+.3f}",
                      f"{100 * e['frames_min']:.0f} %", f"{e['false_per_100']:.1f}"]
            if e is d:
                cells.append(f"{d['z_median']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


SUBSETS = {"davis": lambda s: s[0] == "davis", "vga": lambda s: s[0] == "vga",
           "hd": lambda s: s[0] == "hd", "sine": lambda s: s[1][0] == "sine",
           "lowpass": lambda s: s[4].startswith("lowpass"), "asym": lambda s: "asym" in s[4]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", help="comma-separated scene numbers (1-based) to run")
    ap.add_argument("--only", choices=list(SUBSETS), help="a subset of the grid")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a Config setting for both estimators' runs, e.g. "
                    "estimate.vibration=false (repeatable; give --name too)")
    notes = {"vibe": "vibrating platforms; ", "vibe2": "vibrating platforms; "}
    for flag, (grid, _, prefix) in HELD_OUT.items():   # --fresh14 .. --fresh, --vibe
        ap.add_argument(f"--{flag}", action="store_true", help=f"the held-out grid "
                        f"{flag.upper()} instead ({notes.get(flag, '')}scenes {prefix}1.."
                        f"{prefix}{len(grid)}; --scenes and --only pick among them)")
    ap.add_argument("--quick", action="store_true", help="recordings shortened to 0.3 s")
    ap.add_argument("--calibrated", action="store_true", help="each scene with the lag file "
                    "evstar calibrate measures on a calibration recording of its sensor "
                    "(CALIBRATION: a gyro and a sinusoid; estimate.pixel_lag_file)")
    ap.add_argument("--imu", action="store_true", help="the scenes' gyro too, and the "
                    "pipeline compensating with it (motion.compensate imu)")
    ap.add_argument("--clock-offset-us", type=int, default=0,
                    help="with --imu: the gyro's clock this many µs behind the camera's, not told")
    ap.add_argument("--name", help="results: study_indep_NAME.* (e.g. an older evstar on "
                    "PYTHONPATH, side by side)")
    args = ap.parse_args(argv)
    held = next((flag for flag in HELD_OUT if getattr(args, flag)), None)
    grid, seed0 = HELD_OUT[held][:2] if held else (GRID, 0)
    pick = list(range(len(grid)))
    if args.scenes:
        pick = [int(v) - 1 for v in args.scenes.split(",")]
    if args.only:
        pick = [i for i in pick if SUBSETS[args.only](grid[i])]
    rows = []
    for i in pick:
        scale = 1.0 if not args.quick else 0.3 / grid[i][-1]
        settings = settings_of(args.set)
        if args.calibrated:
            settings["estimate.pixel_lag_file"] = calibration_file(grid[i][4])
        r = run_scene(i + seed0, grid[i], scale, args.imu, args.clock_offset_us, settings)
        d = r["default"]
        print(f"scene {r['scene']}: {r['events']:,} events, sim {r['sim_s']:.1f} s, default mean "
              f"{d['mean']:.3f} px, mean-estimator {r['mean']['mean']:.3f} px", flush=True)
        rows.append(r)
    subset = "".join(f"_{v}" for v in (held, args.only, "scenes-" + args.scenes.replace(",", "-")
                                       if args.scenes else None, "quick" if args.quick else None,
                                       "imu" if args.imu else None,
                                       "calibrated" if args.calibrated else None, args.name) if v)
    name = "study_indep" + subset
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"{name}.md").write_text(
        "# evstar on an independent simulator (perf/indep_sim.py)\n\n"
        "Errors in px; along bias: signed mean error along the motion (+ ahead); frames: the "
        "lowest fraction of 10 ms frames with a position over the scene's stars; false/100: "
        "rows matching no star within 3 px per 100 frames.\n\n" + markdown(rows) + "\n")
    print(markdown(rows))


if __name__ == "__main__":
    main()
