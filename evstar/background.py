"""The background rate a run's density thresholds take, block by block of frames.

The calibration window (the first chunk_frames frames) gives one robust rate
(reference.denoise.background_rate). Stray light (the Moon, the Earth's limb, the Sun
coming near) moves the background within a recording: thresholds for the window's mean let
a background 1.7 × that mean through (perf/study_indep.py --fresh8 O5, a background rising
6-fold over 1 s: 590 false rows per 100 frames), and a falling one costs faint stars.

What moved is told by the events the density filter drops: nearly all background, and
steady within ±1 % from block to block on star fields whose own event count changed by
30 % as stars left and entered (the EVK4 fields of perf/bench_pipeline.py). A block whose
dropped events per pixel and second moved by more than RATE_STEP from the window's is
filtered again at the window's rate scaled by that ratio (twice: thresholds too low for the
light keep some of it, so the first ratio falls short), and its pooled look takes that rate
too. A steady background keeps the window's rate everywhere, as before. Blocks are whole
pooled frames (extract.pool_frames) and divide a streamed chunk, and the window lies in the
first chunk, so run and run_file see the same blocks and rates.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .frames import frame_offsets, stalled_us
from .parameters import MAX_PIXEL_RATE_HZ

#: a block is this many pooled frames (fewer where a streamed chunk holds no whole number of
#: them): 200 ms at the default 10 ms frames and 4-frame pooling — in which O5's
#: background rose by a tenth
RATE_BLOCK_LONG_FRAMES = 5
#: a block whose dropped events per pixel and second moved by more than this ratio from the
#: window's takes its own rate (a 20 % step in λ moves NDSEF's thresholds by about one event
#: at the default radius)
RATE_STEP = 1.2
#: ... filtered again this many times, each at the ratio the last filtering left
FOLLOW_PASSES = 2
#: a block of fewer events measures nothing (the window's rate stands)
MIN_BLOCK_EVENTS = 100


@dataclass
class Background:
    """hz: the calibration window's robust rate (events/pixel/s); window_us: its (first,
    end) µs; dropped_hz: the events the density filter dropped in it per pixel and second
    (None until the first chunk measured it); highest_hz, lowest_hz: the highest and lowest
    rates a block took so far (the estimator takes the highest: where the background was
    highest, clusters must beat it)."""
    hz: float
    window_us: tuple
    dropped_hz: float = None
    highest_hz: float = None
    lowest_hz: float = None

    def __post_init__(self):
        self.highest_hz = self.lowest_hz = self.hz

    def followed(self, t, keep, t0_us, config, n_pixels, mask_at):
        """(keep, [(first µs, end µs, rate)]): the density filter's `keep` mask of the events
        at times `t` (a chunk of a run with frame origin t0_us, filtered at the window's rate)
        with each block whose background moved filtered again at its own rate
        (mask_at(slice, rate) -> the mask of those events; n_pixels: the sensor's), and the
        runs of blocks of one rate, the first from −∞ and the last to +∞ (one run at the
        window's rate where no block moved, or denoise.rate_hz fixes the rate)."""
        if not len(t) or config.denoise.rate_hz is not None or self.hz <= 0:
            return keep, [(None, None, self.hz)]
        if self.dropped_hz is None:
            a, b = np.searchsorted(t, self.window_us)
            self.dropped_hz = _dropped_rate(t[a:b], keep[a:b], self.window_us[0], n_pixels,
                                            config.dt_us)
        block_us = block_frames(config) * config.dt_us
        first, cuts = frame_offsets(t, block_us, t0_us)
        starts_us = t0_us + (first + np.arange(len(cuts) - 1)) * block_us
        rates = [self._follow(t, keep, slice(int(a), int(b)), int(start), n_pixels, mask_at,
                               config.dt_us)
                 for a, b, start in zip(cuts[:-1], cuts[1:], starts_us)]
        self.highest_hz = max(self.highest_hz, max(rates))
        self.lowest_hz = min(self.lowest_hz, min(rates))
        change = np.flatnonzero(np.diff(rates)) + 1
        starts = [None, *(int(starts_us[k]) for k in change)]
        ends = [*(int(starts_us[k]) for k in change), None]
        return keep, [(a, b, rates[k]) for a, b, k in zip(starts, ends, [0, *change])]

    def _follow(self, t, keep, part, start_us, n_pixels, mask_at, dead_us):
        """The rate of the block `part` (a slice of t and keep) from start_us: the window's,
        unless its dropped rate moved by more than RATE_STEP; then keep[part] is replaced by
        its filtering at the moved rate."""
        t = t[part]
        if len(t) < MIN_BLOCK_EVENTS or not self.dropped_hz:
            return self.hz
        ratio = _dropped_rate(t, keep[part], start_us, n_pixels, dead_us) / self.dropped_hz
        if abs(math.log(max(ratio, 1e-9))) <= math.log(RATE_STEP):
            return self.hz
        for _ in range(FOLLOW_PASSES):
            hz = min(self.hz * ratio, MAX_PIXEL_RATE_HZ)
            keep[part] = mask_at(part, hz)
            ratio = _dropped_rate(t, keep[part], start_us, n_pixels, dead_us) / self.dropped_hz
        return hz

    def summary(self):
        """{"window", "lowest", "highest"} events/pixel/s where a block's rate moved, else None
        (Result.metrics["background_hz"])."""
        if self.lowest_hz == self.hz == self.highest_hz:
            return None
        return {"window": round(self.hz, 4), "lowest": round(self.lowest_hz, 4),
                "highest": round(self.highest_hz, 4)}


def _dropped_rate(t, keep, start_us, n_pixels, dead_us):
    """Events not kept per pixel and second, from start_us to the last event (as a streamed
    chunk's last block knows its span), less its stalls (frames.stalled_us; dead_us: a
    frame): a readout that stalled for 300 ms had halved its block's rate, whose lowered
    thresholds then kept noise."""
    if not len(t):
        return 0.0
    span_s = (int(t[-1]) + 1 - start_us - stalled_us(t, dead_us, start_us)) * 1e-6
    return (len(t) - int(np.count_nonzero(keep))) / (n_pixels * span_s)


def block_frames(config):
    """Frames of a rate block: RATE_BLOCK_LONG_FRAMES pooled frames, or the largest number of
    them that divides a streamed chunk (pipeline.chunk_span_us)."""
    pool = config.extract.pool_frames
    chunk_long = -(-config.chunk_frames // pool)
    return pool * math.gcd(chunk_long, RATE_BLOCK_LONG_FRAMES)


def windows(events, segments):
    """[(slice of `events`, rate)] of each segment (Background.followed's) holding events."""
    out = []
    for a, b, hz in segments:
        i0 = 0 if a is None else int(np.searchsorted(events.t, a))
        i1 = len(events) if b is None else int(np.searchsorted(events.t, b))
        if i1 > i0:
            out.append((slice(i0, i1), hz))
    return out
