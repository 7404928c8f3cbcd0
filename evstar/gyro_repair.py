"""A damaged gyro record repaired before motion compensation reads it: spikes removed, long
gaps filled.

Everything downstream (the IMU warp, the particle filter, the estimator's velocity prior)
takes the gyro as exact between samples, so one bad stretch moves every star:

* A **spike** is a sample whose rate departs from the median of the SPIKE_HALF_WINDOW
  samples either side by more than SPIKE_MADS of their robust deviation (MAD × 1.4826; at
  least the gyro's own noise) and by more than SPIKE_FLOOR_RAD_S (Hampel's filter), each
  window less its trend. A smooth rate never trips it: within a window a smooth rate's
  centre departs from the median by at most ~1.4 deviations, a step or a ramp not at all.
  Runs of up to a quarter of the window (12 samples) are caught. On the paper's 1 Hz
  sinusoid, ten samples at 50× their rate had put the star 0.121 px off with 7 false
  rows; removed, 0.020 and none.
* A **gap** (samples more than GAP_INTERVALS median intervals apart; a removed spike leaves
  one) is filled at the median interval by a cubic smoothing spline through the samples
  within GAP_CONTEXT gap lengths on either side (scipy's make_smoothing_spline: its
  smoothness chosen by generalised cross-validation, i.e. from the gyro's own noise), on
  the axes where it leaves the straight line between the gap's ends by more than GAP_SIGMAS
  robust spreads of its residuals (elsewhere the line stays: across a 40 ms gap of a 200 Hz
  gyro a spline fitted on its noise put the star 0.13 px off where the line put it 0.06).
  Straight-line interpolation across a 100 ms gap of that sinusoid put the rate up to
  3.5 °/s off and the star 0.162 px (the spline: 0.022).

A fill is a guess of smooth motion: a manoeuvre that starts or stops inside a gap is not
recovered (evstar.motion.imu_integration.warn_gaps still names gaps in what the run reads).
"""
from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from .errors import EvstarWarning, ParameterTypeError
from .imu import Imu
from .robust import MAD_TO_SIGMA, robust_sigma

SPIKE_HALF_WINDOW = 25       # samples either side of the median a sample is compared with
SPIKE_MADS = 6.0             # robust deviations beyond which a sample is a spike ...
SPIKE_FLOOR_RAD_S = 0.01     # ... and rad/s (0.57 °/s: for one sample, moves no star measurably)
GAP_INTERVALS = 5            # median sample intervals beyond which a gap is filled
GAP_CONTEXT = 2.0            # gap lengths of samples either side the fill is fitted on
GAP_SIGMAS = 5.0             # robust spreads by which a fill must leave the straight line
_MIN_FIT_SIDE = 5            # samples either side a fill needs at least (taken if fewer lie near)
_CHUNK = 20_000              # samples per block of the spike test (bounds its window array)


class Repair(NamedTuple):
    """What repaired() changed: spike samples removed, gaps filled (their lengths, µs)."""
    spikes: int
    gaps_us: tuple

    def summary(self):
        """One line for a warning, or '' when nothing changed."""
        parts = []
        if self.spikes:
            parts.append(f"{self.spikes} spike sample(s) removed")
        if self.gaps_us:
            parts.append(f"{len(self.gaps_us)} gap(s) up to {max(self.gaps_us) / 1e6:.3g} s "
                         "filled by a smoothing spline")
        return "; ".join(parts)


def repaired(imu):
    """`imu` without its spikes and with its long gaps filled (the same mounting and clock
    offset), an EvstarWarning saying what changed; `imu` itself (None for None) when nothing
    needed it."""
    if imu is None:
        return None
    if not isinstance(imu, Imu):
        raise ParameterTypeError(f"imu must be an evstar.Imu, got {type(imu).__name__}")
    out, repair = repair_of(imu)
    if repair.summary():
        warnings.warn(f"the IMU record was repaired: {repair.summary()}", EvstarWarning)
    return out


def repair_of(imu):
    """(Imu, Repair): repaired() without the warning."""
    bad = spikes(imu.gyro)
    t, gyro, accel = imu.t[~bad], imu.gyro[~bad], imu.accel[~bad]
    t_new, values, gaps = filled(t, np.hstack([gyro, accel]))
    if not bad.any() and not gaps:
        return imu, Repair(0, ())
    out = Imu(t_new, values[:, :3], values[:, 3:], R_cam_imu=imu.R_cam_imu,
              time_offset_us=imu.time_offset_us)
    return out, Repair(int(bad.sum()), tuple(gaps))


def spikes(gyro):
    """Per sample of an (n, 3) rate array: is it a spike (see the module docstring)?"""
    n, h = len(gyro), SPIKE_HALF_WINDOW
    width = min(2 * h + 1, n)
    out = np.zeros(n, bool)
    if width < 5:
        return out
    windows = np.lib.stride_tricks.sliding_window_view(gyro, width, axis=0)   # (n-w+1, 3, w)
    half = width // 2
    # a window's spread, from few samples, can read far below the gyro's noise: then 3σ
    # noise stood 6 spreads out (one sample in four grids' clean 1 kHz records)
    noise = rate_noise(gyro)
    for lo in range(0, n, _CHUNK):
        i = np.arange(lo, min(lo + _CHUNK, n))
        # each sample's window centred on it, shifted inwards at the record's ends
        start = np.clip(i - h, 0, n - width)
        win = windows[start]
        at = i - start                        # the sample's place in its window
        # less its trend (the slope between its halves' medians: a corrupt run of under a
        # quarter of the window moves neither), so that a slew's steady change of rate does
        # not count as spread (at 200 Hz a 1 Hz sinusoid's rate moved 0.6 rad/s in one);
        # not where the window cannot centre on the sample (a curve's end leaves any line)
        slope = (_median(win[..., width - half:]) - _median(win[..., :half])) / (width - half)
        slope[at != half] = 0.0
        win = win - slope[..., None] * (np.arange(width) - at[:, None, None])
        med = _median(win)
        mad = _median(np.abs(win - med[..., None]))
        off = np.abs(gyro[i] - med)
        out[i] = np.any((off > SPIKE_MADS * np.maximum(MAD_TO_SIGMA * mad, noise))
                        & (off > SPIKE_FLOOR_RAD_S), axis=1)
    return out


def _median(a):
    """np.median over the last axis: by one partition where its length is odd (6x quicker
    on a 4 s record's windows)."""
    k = a.shape[-1]
    return np.partition(a, k // 2, axis=-1)[..., k // 2] if k % 2 else np.median(a, axis=-1)


def rate_noise(gyro):
    """Per axis, an (n, 3) rate array's white noise (its units a sample): the robust spread
    (MAD) of its second differences, which white noise gives 6 × its variance and a slew's
    rate, hardly changing from one sample to the next, next to nothing."""
    d2 = gyro[2:] - 2 * gyro[1:-1] + gyro[:-2]
    return robust_sigma(d2, axis=0) / np.sqrt(6)


def filled(t, values):
    """(t, values, gap lengths µs): the int64 µs times `t` and their (n, k) `values` with every
    gap longer than GAP_INTERVALS median intervals filled where a straight line would not do
    (see the module docstring); the lengths of the gaps filled."""
    if len(t) < 2 * _MIN_FIT_SIDE:
        return t, values, []
    step = np.diff(t)
    dt = float(np.median(step))
    ts, vs, gaps = [t], [values], []
    for i in np.flatnonzero(step > GAP_INTERVALS * dt):
        new = np.arange(t[i] + dt, t[i + 1] - dt / 2, dt).round().astype(np.int64)
        fill = _fill(t, values, i, new, dt)
        if fill is not None:
            ts.append(new)
            vs.append(fill)
            gaps.append(int(step[i]))
    t_all = np.concatenate(ts)
    order = np.argsort(t_all, kind="stable")
    return t_all[order], np.concatenate(vs)[order], gaps


def _fill(t, values, i, new, dt):
    """Values at the times `new` inside the gap after sample i, or None where a straight line
    does: per column, a smoothing spline through the samples near the gap (GAP_CONTEXT gap
    lengths, at least _MIN_FIT_SIDE samples either side) where it departs from the line
    between the gap's ends by over GAP_SIGMAS of its residuals' robust spread, else that
    line; held within the samples' range widened by half of it (a gap of several turns of a
    fast vibration is no smooth arc: there a spline can swing 5x beyond it)."""
    from scipy.interpolate import make_smoothing_spline

    reach = GAP_CONTEXT * (t[i + 1] - t[i])
    lo = min(int(np.searchsorted(t, t[i] - reach)), max(i + 1 - _MIN_FIT_SIDE, 0))
    hi = max(int(np.searchsorted(t, t[i + 1] + reach, side="right")),
             min(i + 1 + _MIN_FIT_SIDE, len(t)))
    # time in sample intervals: in seconds the cross-validation picked a near-straight
    # spline on a noise-free cosine (0.14 rad/s off mid-gap; in intervals 0.0003)
    s = (t[lo:hi] - t[i]) / dt
    at = (new - t[i]) / dt
    near = values[lo:hi]
    line = values[i] + (values[i + 1] - values[i]) * (at / ((t[i + 1] - t[i]) / dt))[:, None]
    out, curved = line.copy(), False
    for k in range(near.shape[1]):
        spline = make_smoothing_spline(s, near[:, k])
        resid = near[:, k] - spline(s)
        spread = robust_sigma(resid)
        arc = spline(at)
        if np.max(np.abs(arc - line[:, k]), initial=0.0) > GAP_SIGMAS * spread:
            out[:, k], curved = arc, True
    if not curved:
        return None
    span = near.max(axis=0) - near.min(axis=0)
    return np.clip(out, near.min(axis=0) - span / 2, near.max(axis=0) + span / 2)
