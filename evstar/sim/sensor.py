"""Event-sensor model: settings, and log-intensity change detection of moving stars.

Each pixel remembers a reference log intensity. When the log intensity L rises to the
reference + θ_on (falls to reference − θ_off) the pixel emits an ON (OFF) event and moves
its reference by that threshold; θ_on, θ_off vary from pixel to pixel (mismatch). After an
event the pixel is held in reset for the refractory period: crossings are lost and, on
release, the reference restarts from the log intensity of that moment.

Only the pixels a star's PSF touches are simulated (:mod:`evstar.sim.render`): on a time
grid fine enough that no star moves more than `step_px` between grid times, each pixel of a
star's window gets its log intensity; L is linear between grid times, so crossing times are
found exactly on that line, in closed form. Pixel state lives in dense per-sensor arrays, so
windows can come and go. Initial references sit a uniform random fraction of a threshold
away from the current level (the state a pixel is left in by its last event), so event
counts vary smoothly with contrast.

Photoreceptor bandwidth (off unless SensorSpec.cutoff_hz_max is set): the detector sees
each pixel's log intensity through a first-order low-pass whose cutoff follows the pixel's
intensity I (sky background = 1), f_c = clip(cutoff_hz_background · I, cutoff_hz_background,
cutoff_hz_max), as a photoreceptor's bandwidth follows its photocurrent (v2e). A dim pixel
responds late and relaxes slowly, so a moving star's events trail it. Filtered values are
exact at the grid times for the linear input; pixels start settled, and a pixel a window has
left is followed with background samples until its output has relaxed.

Pixels are independent, so a chunk of grid steps is processed column by column: column c
holds every pixel's c-th sample in the chunk. A moving star visits a pixel for a few dozen
grid steps, so a chunk of thousands of steps costs a few dozen vectorised passes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from ..errors import ParameterError
from .psf import pixel_profile, window_half_width
from .render import Chunk, render_chunks
from .truth import NOISE

@dataclass(frozen=True)
class SensorSpec:
    """Settings of the simulated event sensor (thresholds in natural-log intensity units)."""

    threshold_on: float = 0.2
    threshold_off: float = 0.2
    threshold_mismatch: float = 0.02   # std. dev. of per-pixel thresholds
    refractory_us: float = 100.0
    jitter_us: float = 20.0            # std. dev. of Gaussian timestamp jitter of signal events
    dropout: float = 0.0               # probability that any event is lost
    noise_hz: float = 1.5              # background activity, events / pixel / s (both polarities)
    noise_on_fraction: float = 0.5
    noise_growth: float = 1.0          # background at the end / at the start: stray light
                                       # rising (or fading) linearly over the recording
    hot_pixels: int = 5
    hot_pixel_hz: float = 100.0        # mean rate of each hot pixel
    min_log_change: float = 0.01       # log-intensity changes below this are not rendered
    cutoff_hz_background: float = 30.0  # photoreceptor cutoff at the sky background (with cutoff_hz_max)
    cutoff_hz_max: float | None = None  # cutoff of bright pixels; None: no photoreceptor low-pass
    leak_hz: float = 0.0               # ON events / pixel / s from the reference's leak
    shot_noise_hz: float = 0.0         # noise events / pixel / s per background unit of star light

    def __post_init__(self):
        positive = ("threshold_on", "threshold_off", "min_log_change", "cutoff_hz_background",
                    "noise_growth")
        nonneg = ("threshold_mismatch", "refractory_us", "jitter_us", "noise_hz", "hot_pixel_hz",
                  "leak_hz", "shot_noise_hz")
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "cutoff_hz_max" and v is None:
                continue
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"SensorSpec.{f.name} must be a finite number, got {v!r}")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ParameterError(f"SensorSpec.{name} must be > 0, got {getattr(self, name)!r}")
        for name in nonneg:
            if getattr(self, name) < 0:
                raise ParameterError(f"SensorSpec.{name} must be >= 0, got {getattr(self, name)!r}")
        for name in ("dropout", "noise_on_fraction"):
            if not 0 <= getattr(self, name) <= 1:
                raise ParameterError(f"SensorSpec.{name} must lie in [0, 1], got {getattr(self, name)!r}")
        if self.dropout == 1:
            raise ParameterError("SensorSpec.dropout must be < 1 (1 drops every event)")
        if int(self.hot_pixels) != self.hot_pixels or self.hot_pixels < 0:
            raise ParameterError(f"SensorSpec.hot_pixels must be a non-negative integer, got {self.hot_pixels!r}")
        if self.hot_pixels and self.hot_pixel_hz * self.refractory_us * 1e-6 >= 1:
            raise ParameterError("SensorSpec.hot_pixel_hz must be below 1 / refractory period")
        if self.lowpass and self.cutoff_hz_max < self.cutoff_hz_background:
            raise ParameterError(f"SensorSpec.cutoff_hz_max ({self.cutoff_hz_max!r}) must be >= "
                                 f"cutoff_hz_background ({self.cutoff_hz_background!r})")

    @property
    def lowpass(self):
        """Whether the photoreceptor low-pass is on."""
        return self.cutoff_hz_max is not None

    def cutoff_hz(self, intensity):
        """Photoreceptor cutoff (Hz) at `intensity` (units of the sky background): proportional
        to the photocurrent, cutoff_hz_background · I, clipped to [cutoff_hz_background,
        cutoff_hz_max]; infinite without the low-pass."""
        i = np.asarray(intensity, np.float64)
        if not self.lowpass:
            return np.full(i.shape, np.inf)
        return np.clip(self.cutoff_hz_background * i, self.cutoff_hz_background, self.cutoff_hz_max)

    @classmethod
    def ideal(cls, **overrides):
        """No mismatch, refractory, jitter, dropout, noise or hot pixels (for tests)."""
        base = dict(threshold_mismatch=0.0, refractory_us=0.0, jitter_us=0.0, dropout=0.0,
                    noise_hz=0.0, hot_pixels=0)
        base.update(overrides)
        return cls(**base)

    @classmethod
    def dark_sky(cls, **overrides):
        """A DVS under a dark sky: photoreceptor low-pass of 30 Hz at the sky background rising
        with intensity to 2 kHz (a magnitude-3 star's peak pixel, 23× the sky, reaches 690 Hz),
        and a 0.1 Hz leak (v2e's typical rate); the other settings are the defaults."""
        base = dict(cutoff_hz_background=30.0, cutoff_hz_max=2000.0, leak_hz=0.1)
        base.update(overrides)
        return cls(**base)


class PixelState:
    """Dense per-pixel state: thresholds, reference, trigger levels, last log intensity.

    hi = ref + θ_on and lo = ref − θ_off make the test of every sample two gathers and two
    compares; a pixel held in reset after an event has hi = +inf, lo = −inf and the time of
    its release in `held_until` (−inf when free).
    """

    def __init__(self, n_pixels, spec, rng):
        lo = 0.01  # a threshold cannot vanish, whatever the mismatch draws
        self.c_on = np.maximum(spec.threshold_on + spec.threshold_mismatch * rng.standard_normal(n_pixels), lo)
        self.c_off = np.maximum(spec.threshold_off + spec.threshold_mismatch * rng.standard_normal(n_pixels), lo)
        # L − ref uniform in (−θ_off, θ_on): background log intensity is 0 (intensity 1)
        self.ref = -(rng.random(n_pixels) * (self.c_on + self.c_off) - self.c_off)
        self.hi = self.ref + self.c_on
        self.lo = self.ref - self.c_off
        self.last_L = np.zeros(n_pixels)
        self.held_until = np.full(n_pixels, -np.inf)
        self.n_held = 0
        self.filter = _Photoreceptor(n_pixels, spec) if spec.lowpass else None

    def set_ref(self, pix, ref):
        self.ref[pix] = ref
        self.hi[pix] = ref + self.c_on[pix]
        self.lo[pix] = ref - self.c_off[pix]

    def hold(self, pix, until):
        self.hi[pix], self.lo[pix] = np.inf, -np.inf
        self.held_until[pix] = until
        self.n_held += len(pix)

    def adapt(self, pix, L):
        """The sensor has adapted to the scene it starts in: references follow L."""
        self.set_ref(pix, self.ref[pix] + L - self.last_L[pix])
        self.last_L[pix] = L
        if self.filter is not None:  # and the photoreceptor has settled there
            self.filter.raw[pix] = L


class _Photoreceptor:
    """First-order low-pass of each pixel's log intensity, cutoff set by its intensity.

    The input (raw log intensity) is linear between a pixel's samples, so each step uses the
    exact response of dy/dt = ω (u − y) to a ramp u0 → u1 over Δt at constant ω = 2π f_c
    (f_c at the intensity of the step's middle, e^((u0 + u1)/2)): with x = ωΔt,
    y1 = u1 + (y0 − u0) e^−x − (u1 − u0)(1 − e^−x)/x, valid for any x. Between a pixel's
    samples the input is held at its last value (the pixel lies outside every window).
    """

    def __init__(self, n_pixels, spec):
        self.spec = spec
        self.raw = np.zeros(n_pixels)      # last input sample; the output lives in last_L
        self.t_last = np.zeros(n_pixels)   # time of the last sample

    def step(self, p, y, u1, t_prev, t_k):
        """Outputs of pixels p (last outputs y) at t_prev and at t_k, where the input is u1."""
        u0 = self.raw[p]
        i0 = np.exp(u0)
        gap = t_prev - self.t_last[p]
        y0 = np.where(gap > 0, u0 + (y - u0) * np.exp(-2 * math.pi * self.spec.cutoff_hz(i0) * gap), y)
        x = 2 * math.pi * self.spec.cutoff_hz(np.exp(0.5 * (u0 + u1))) * (t_k - t_prev)
        y1 = u1 + (y0 - u0) * np.exp(-x) + (u1 - u0) * (np.expm1(-x) / x)
        self.raw[p], self.t_last[p] = u1, t_k
        return y0, y1

    def tail_s(self, flux, sigma_px):
        """Per star, how long a pixel it leaves (outside its window) must still be followed:
        until the output, at most the star's peak log intensity, has relaxed to within
        min_log_change of the background at the background cutoff."""
        peak = np.log1p(np.asarray(flux, np.float64) * float(pixel_profile(0.0, 0.0, 1, sigma_px)[0]) ** 2)
        ratio = np.maximum(peak / self.spec.min_log_change, 1.0)
        return np.log(ratio) / (2 * math.pi * self.spec.cutoff_hz_background)


class _Emitted:
    def __init__(self):
        self.t, self.pix, self.p, self.star = [], [], [], []

    def add(self, t, pix, p, star):
        self.t.append(t), self.pix.append(pix), self.p.append(p), self.star.append(star)

    def arrays(self):
        if not self.t:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int8), np.zeros(0, np.int64)
        return (np.concatenate(self.t), np.concatenate(self.pix),
                np.concatenate(self.p).astype(np.int8), np.concatenate(self.star))


def _advance(state, p, L, s, t_prev, t_k, refractory_s, out):
    """Move distinct pixels p to their next sample: L runs linearly from the last sample
    (at t_prev) to L (at t_k); release pixels whose reset ends, emit the events."""
    if state.filter is not None:  # the detector sees the photoreceptor's output
        state.last_L[p], L = state.filter.step(p, state.last_L[p], L, t_prev, t_k)
    hi, lo = state.hi[p], state.lo[p]
    t_start = t_prev
    if state.n_held:
        held = np.flatnonzero(hi == np.inf)
        rel = held[state.held_until[p[held]] < t_k[held]]
        if len(rel):  # re-armed at the log intensity of the moment of release
            pr, tp = p[rel], t_prev[rel]
            tb = np.maximum(state.held_until[pr], tp)
            L0 = state.last_L[pr]
            state.set_ref(pr, L0 + (tb - tp) / (t_k[rel] - tp) * (L[rel] - L0))
            state.held_until[pr] = -np.inf
            state.n_held -= len(rel)
            hi[rel], lo[rel] = state.hi[pr], state.lo[pr]
            t_start = t_prev.copy()
            t_start[rel] = tb
    act = np.flatnonzero((L >= hi) | (L <= lo))
    L0 = state.last_L[p[act]]
    state.last_L[p] = L
    if len(act):
        _fire(state, p[act], L0, L[act], s[act], t_start[act], t_prev[act], t_k[act], refractory_s, out)


def _fire(state, pf, L0, Lf, sf, t_start, t_prev, t_k, refractory_s, out):
    """Emit every event of pixels pf whose L runs linearly from L0 (t_prev) to Lf (t_k).

    Closed form, no loop over events: the first crossing is where L reaches ref ± θ after
    t_start; without a refractory period the others follow every θ of log intensity, with
    one every refractory + θ/|slope| (blind, then re-armed at the level of the release).
    """
    dt = t_k - t_prev
    r = state.ref[pf]
    up = Lf > r
    theta = np.where(up, state.c_on[pf], state.c_off[pf])
    sign = np.where(up, 1.0, -1.0)
    slope_dt = dt / np.where(Lf == L0, 1.0, Lf - L0)              # seconds per unit of L
    t_first = np.minimum(np.maximum(t_prev + (r + sign * theta - L0) * slope_dt, t_start), t_k)
    tau = theta * np.abs(slope_dt)                                # time between crossings
    if refractory_s > 0:
        period = refractory_s + tau
        n = 1 + np.floor((t_k - t_first) / period).astype(np.int64)
        release = t_first + (n - 1) * period + refractory_s
        held = release >= t_k
        state.hold(pf[held], release[held])
        live = ~held
        r_end = L0 + (release - t_prev) / dt * (Lf - L0)          # re-armed at release
    else:
        period = tau
        n = np.maximum(np.floor(sign * (Lf - r) / theta).astype(np.int64), 1)
        live = np.ones(len(pf), bool)
        r_end = r + sign * theta * n
    first = np.cumsum(n) - n
    m = np.arange(int(n.sum())) - np.repeat(first, n)
    t = np.minimum(np.repeat(t_first, n) + m * np.repeat(period, n), np.repeat(t_k, n))
    out.add(t, np.repeat(pf, n), np.repeat(up, n), np.repeat(sf, n))
    state.set_ref(pf[live], r_end[live])


def _columns(pix):
    """Per sample (step-major), how many earlier samples its pixel has in the chunk."""
    order = np.argsort(pix, kind="stable")
    sorted_pix = pix[order]
    start = np.flatnonzero(np.insert(sorted_pix[1:] != sorted_pix[:-1], 0, True))
    run = np.diff(np.append(start, len(pix)))
    col = np.empty(len(pix), np.int64)
    col[order] = np.arange(len(pix)) - np.repeat(start, run)
    return col


#: below this many samples per grid step a chunk is processed column by column (per-step
#: overhead dominates); above it step by step (no reordering, the work is in the data)
COLUMN_LAYOUT_BELOW = 2000


def star_events(camera, stars, flux, trajectory, grid, spec, sigma_px, state, layout="auto", rng=None):
    """Events of all stars: (t seconds, pixel index, polarity int8, star index), unsorted.

    Shot noise (spec.shot_noise_hz, drawn from `rng`) comes with star index NOISE. layout
    "steps" or "columns" forces one processing order (the results are the same).
    """
    out = _Emitted()
    if len(stars) == 0:
        return out.arrays()
    if spec.shot_noise_hz > 0 and rng is None:
        raise ParameterError("star_events: shot noise needs a random generator (rng)")
    half = np.array([window_half_width(f, sigma_px, spec.min_log_change) for f in flux])
    refractory_s = spec.refractory_us * 1e-6
    tails = _Tails(state.filter.tail_s(flux, sigma_px), grid) if state.filter is not None else None
    for chunk in render_chunks(camera, stars.directions, flux, half, sigma_px, spec.min_log_change,
                               trajectory, grid):
        if spec.shot_noise_hz > 0:
            _shot_noise(rng, chunk, grid, spec.shot_noise_hz, out)
        if tails is not None:
            chunk = tails.add(chunk)
        pix, L, star, step = chunk.pix, np.log1p(chunk.contrib), chunk.star, chunk.step
        if len(step) and step[0] == 0:  # the first grid time: nothing has changed yet
            first = step == 0
            state.adapt(pix[first], L[first])
            pix, L, star, step = pix[~first], L[~first], star[~first], step[~first]
        if len(pix):
            _process(state, pix, L, star, step, grid, refractory_s, out, layout)
    return out.arrays()


def _shot_noise(rng, chunk, grid, rate_hz, out):
    """Noise events on the star's pixels: Poisson, rate_hz per background unit of star light
    (rate ∝ intensity − background) over each sample's grid step, either polarity."""
    k = chunk.step
    dt = np.where(k > 0, grid[k] - grid[np.maximum(k - 1, 0)], 0.0)
    n = rng.poisson(rate_hz * chunk.contrib * dt)
    if n.any():
        i = np.repeat(np.arange(len(k)), n)
        t = grid[k[i]] - rng.random(len(i)) * dt[i]
        out.add(t, chunk.pix[i], rng.random(len(i)) < 0.5, np.full(len(i), NOISE))


class _Tails:
    """Follows each pixel for tail_s[star] after a star's window leaves it, with background samples
    (contrib 0) at the grid times, so that its low-passed log intensity relaxes through the
    detector: the OFF events that trail a star. Tails crossing a chunk's end carry over."""

    def __init__(self, tail_s, grid):
        self.tail_s, self.grid = tail_s, grid
        self.carry = (np.zeros(0, np.int64),) * 3      # pixel, star, last step of the tail

    def add(self, chunk):
        """The chunk with the tail samples of its grid steps, step-major."""
        k_first, k_last = chunk.span
        big = len(self.grid) + 1
        order = np.argsort(chunk.pix, kind="stable")        # by pixel, then step (step-major)
        ps, ks, ss = chunk.pix[order].astype(np.int64), chunk.step[order], chunk.star[order]
        ends = np.ones(len(ps), bool)                    # where a pixel's run of steps ends
        ends[:-1] = (ps[1:] != ps[:-1]) | (ks[1:] != ks[:-1] + 1)
        tail_end = np.searchsorted(self.grid, self.grid[ks[ends]] + self.tail_s[ss[ends]], side="right") - 1
        cp, cs, ce = self.carry
        pix = np.concatenate([cp, ps[ends]])
        star = np.concatenate([cs, ss[ends]])
        k0 = np.concatenate([np.full(len(cp), k_first - 1), ks[ends]])
        end = np.concatenate([ce, tail_end])
        keys = np.append(ps * big + ks, -1)                  # -1: no pixel's key, past the end
        nxt = keys[np.searchsorted(keys[:-1], pix * big + k0, side="right")]  # pixel's next sample
        has_next = nxt // big == pix
        stop = np.minimum(np.where(has_next, nxt % big - 1, end), end).clip(max=k_last)
        more = ~has_next & (end > k_last)
        self.carry = (pix[more], star[more], end[more])
        n = np.maximum(stop - k0, 0)
        if not n.any():
            return chunk
        first = np.cumsum(n) - n
        steps = np.repeat(k0, n) + 1 + np.arange(int(n.sum())) - np.repeat(first, n)
        by_step = np.argsort(steps, kind="stable")
        step, pix_, contrib, star_ = merge_sorted(
            (chunk.step, chunk.pix, chunk.contrib, chunk.star),
            (steps[by_step], np.repeat(pix, n)[by_step], np.zeros(len(steps)), np.repeat(star, n)[by_step]))
        return Chunk(pix_, contrib, star_, step, chunk.span)


def merge_sorted(big, small):
    """Merge two tuples of arrays sorted by their first; the small one is spliced in, after
    equal keys of the big one."""
    tb, ts = big[0], small[0]
    pos = np.searchsorted(tb, ts, side="right") + np.arange(len(ts))
    n = len(tb) + len(ts)
    from_big = np.ones(n, bool)
    from_big[pos] = False
    out = []
    for a, b in zip(big, small):
        col = np.empty(n, np.result_type(a.dtype, b.dtype))
        col[from_big], col[pos] = a, b
        out.append(col)
    return tuple(out)


def _process(state, pix, L, star, step, grid, refractory_s, out, layout):
    """Advance every sample of one chunk (step-major arrays), in columns or in steps."""
    offsets = np.concatenate([[0], np.flatnonzero(np.diff(step)) + 1, [len(step)]])
    if layout == "columns" or (layout == "auto" and len(pix) < COLUMN_LAYOUT_BELOW * (len(offsets) - 1)):
        col = _columns(pix)
        order = np.argsort(col.astype(np.int16) if col.max() < 32767 else col, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(np.bincount(col))])
        for a, b in zip(bounds[:-1], bounds[1:]):
            i = order[a:b]
            k = step[i]
            _advance(state, pix[i], L[i], star[i], grid[k - 1], grid[k], refractory_s, out)
    else:
        for a, b in zip(offsets[:-1], offsets[1:]):
            k, n = step[a], b - a
            _advance(state, pix[a:b], L[a:b], star[a:b], np.full(n, grid[k - 1]), np.full(n, grid[k]),
                     refractory_s, out)
