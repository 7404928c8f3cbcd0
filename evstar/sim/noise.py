"""Sensor noise that no scene causes: background activity and hot pixels.

Background activity is an independent Poisson process of `noise_hz` at every pixel (or, with
stray light, a rate changing linearly to noise_growth times that by the end). Their
superposition is one Poisson process of rate noise_hz · n_pixels whose events fall on
uniformly random pixels, which is how it is drawn: exponential gaps, a cumulative sum (times
come out sorted, no sort of millions of events) and a uniform pixel per event.

A hot pixel fires far more often, as a renewal process whose gaps are the refractory period
plus an exponential wait, so that its mean rate is `hot_pixel_hz`.

Leak (v2e's model): every pixel's reference drifts down by leak_hz · θ_on (nominal) per
second, so a pixel under constant light emits an ON event each time the drift covers its own
θ_on: a periodic train at leak_hz · θ_on / (its θ_on). Trains start in steady state: each
pixel is as far into its period as its initial reference is into (−θ_off, θ_on), a uniform
fraction.
"""
from __future__ import annotations

import numpy as np

from ..frames import ranks


def _poisson_times(rng, rate_hz, duration_s, dead_s=0.0):
    """Sorted event times (s) of a renewal process on [0, duration): gaps dead + Exp."""
    if rate_hz <= 0 or duration_s <= 0:
        return np.zeros(0)
    mean_wait = 1.0 / rate_hz - dead_s
    expected = rate_hz * duration_s
    parts, t_end = [], 0.0
    while True:
        n = int(expected + 6 * np.sqrt(expected) + 16)
        gaps = rng.exponential(mean_wait, n)
        if dead_s:
            gaps += dead_s
        t = t_end + np.cumsum(gaps)
        parts.append(t[t < duration_s])
        if t[-1] >= duration_s:
            return np.concatenate(parts)
        t_end, expected = t[-1], rate_hz * (duration_s - t[-1])


def background_activity(rng, n_pixels, rate_hz, duration_s, on_fraction=0.5, growth=1.0):
    """(t seconds sorted, pixel index, polarity int8) of Poisson noise at rate_hz per pixel,
    its rate changing linearly to growth × rate_hz at duration_s (stray light): drawn at the
    higher end's rate and thinned (growth 1 draws no thinning)."""
    peak = rate_hz * max(growth, 1.0)
    t = _poisson_times(rng, peak * n_pixels, duration_s)
    if growth != 1.0:
        rate = rate_hz * (1 + (growth - 1) * t / duration_s)
        t = t[rng.random(len(t)) * peak < rate]
    pix = rng.integers(0, n_pixels, len(t))
    pol = (rng.random(len(t)) < on_fraction).astype(np.int8)
    return t, pix, pol


def hot_pixels(rng, n_pixels, count, rate_hz, duration_s, refractory_s):
    """(t seconds sorted, pixel index, polarity int8, hot pixel indices) of `count` hot pixels."""
    where = np.sort(rng.choice(n_pixels, size=min(count, n_pixels), replace=False))
    ts, ps = [], []
    for pix in where:
        t = _poisson_times(rng, rate_hz, duration_s, refractory_s)
        ts.append(t), ps.append(np.full(len(t), pix))
    if not ts:
        return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int8), where
    t, pix = np.concatenate(ts), np.concatenate(ps)
    order = np.argsort(t, kind="stable")
    pol = (rng.random(len(t)) < 0.5).astype(np.int8)
    return t[order], pix[order], pol, where


def leak_events(ref, c_on, c_off, leak_hz, theta_on, duration_s):
    """(t seconds sorted, pixel index, polarity int8) of the leak of pixels whose references
    are `ref` (background log intensity 0) and thresholds c_on, c_off at the start."""
    if leak_hz <= 0 or duration_s <= 0:
        return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int8)
    period = c_on / (leak_hz * theta_on)
    first = (c_on + ref) / (c_on + c_off) * period    # ref's place in (−θ_on, θ_off): uniform
    n = np.maximum(np.ceil((duration_s - first) / period), 0).astype(np.int64)
    pix = np.repeat(np.arange(len(ref)), n)
    k = ranks(n)
    t = first[pix] + k * period[pix]
    order = np.argsort(t, kind="stable")
    return t[order], pix[order], np.ones(len(t), np.int8)
