"""When a moving star's centre passes each pixel: level-paired ON/OFF event times.

A star crossing pixel q raises its log intensity to a peak and lowers it again. The pixel
fires ON events as the intensity rises through its reference levels L_top, L_top − C,
L_top − 2C, ... (read backwards from the last ON) and then OFF events as it falls through
L_top − C, L_top − 2C, ... So the j-th OFF after the polarity change and the (j+1)-th ON
before it mark the same level on the two flanks of the pixel's intensity profile, and for a
symmetric PSF moving at constant speed their mean time is the time of the peak — the time
the star's centre was closest to q. Unlike the mean position of events (ON events lead the
centre, OFF events trail it by amounts that depend on the thresholds, the PSF and the pixel's
bandwidth), this needs no model of the PSF: a count imbalance between ON and OFF or a
pixel's own threshold mismatch shifts the pairs, not their midpoints. A sensor whose OFF
threshold differs from its ON one (C_off = r·C_on, set by its biases) puts the j-th OFF
j·C_off below the top: the rising time at that level lies j·r ON steps back, interpolated
between ON events (r = 1 gives the pairs above). r is measured from the data: the ON and
OFF runs of one passage span the same log intensity (threshold_ratio_of); at r 0.6 and 1.7
the midpoints of unequal levels put the positions 0.13–0.26 px off. A noise or leak event
the pixel fired long before or after the passage, of the run's polarity, would join the run
and add a pair 0.1 s off: a run's outermost event is left out when its gap to the run is
more than STRAY_GAP_FACTOR times the passage's largest inside gap (without_strays).

A pixel low-pass delays the peak by ~1/(2π f_c), f_c growing with intensity; the number of
level pairs k (∝ the pixel's peak contrast) comes with each crossing, so that delay can be
measured against brightness downstream.
"""
from __future__ import annotations

import numpy as np

from .errors import DataError
from .frames import ranks, stable_order
from .parameters import AUTO

#: t: the mean of the level pairs' midpoints (µs); t_spread: their std; t_outer: the deepest
#: pair's half-width (outer_half_width); t_half: the pairs' RMS half-width (OFF time less
#: midpoint, µs); t_top: the top pair's midpoint (µs; the brighter star's passage where
#: two stars along the motion pass the pixel in one pulse: evstar.blends)
CROSSING_DTYPE = np.dtype([("x", "<i4"), ("y", "<i4"), ("t", "<f8"), ("pairs", "<i4"),
                           ("t_spread", "<f8"), ("t_outer", "<f8"), ("t_half", "<f8"),
                           ("t_top", "<f8")])


def pixel_crossings(t, x, y, p, max_pairs=16, threshold_ratio=AUTO):
    """One row per ON→OFF change of a pixel with at least one level pair: the pixel, the mean
    of its paired midpoint times (µs, float), the number of pairs and their std (µs).

    t, x, y, p: events (any order); p 1 = ON, 0 = OFF. threshold_ratio: C_off / C_on, or
    "auto" (measured: threshold_ratio_of).
    """
    sizes = {name: np.shape(v) for name, v in (("t", t), ("x", x), ("y", y), ("p", p))}
    if len(set(sizes.values())) > 1 or any(len(s) != 1 for s in sizes.values()):
        raise DataError(f"pixel_crossings: t, x, y and p must be 1-D arrays of one length, got "
                        f"shapes {', '.join(f'{k} {v}' for k, v in sizes.items())}")
    width = int(np.max(x, initial=0)) + 1
    key = pixel_keys(x, y, width)
    return key_crossings(np.asarray(t, np.int64), key, np.asarray(p), width, max_pairs,
                         threshold_ratio=threshold_ratio)


def pixel_keys(x, y, width):
    """y·width + x (uint32: a sensor has at most 2¹⁶ × 2¹⁶ pixels)."""
    key = np.asarray(y).astype(np.uint32)
    key *= np.uint32(width)                 # in place: these arrays are millions of events
    key += np.asarray(x).astype(np.uint32, copy=False)
    return key


#: the run lengths are counted up to this (a hot pixel's run must not cost without bound)
_RUN_CAP = 4096
#: events a change needs on each flank to count in the measured threshold ratio: the first
#: where it keeps FULL_FLANK_SHARE of the changes the second keeps, else the second
#: (_ratio_changes). The count selects passages by where their reference began (one that
#: began low fires more ON events and ends higher), which do not cancel as all of a pixel's
#: passages would: on the estimator's model the ratio came out 7.5 % high at 0.714 where 3
#: events kept 21 % of the changes that have 2, 1.5 % with 2 (0.6 % against 0.1 % where
#: they kept 86 %; a magnitude-5.5 star on a dark sky measured 0.82 with 3). Where most
#: changes have 3, more events a flank are the steadier (a noise event joined to a run
#: weighs less).
RATIO_FLANK_EVENTS = (3, 2)
FULL_FLANK_SHARE = 0.5
#: fewest such changes for a measured threshold ratio (else 1).
#: 20 changes measure it within ~6 % (standard error of the ratio estimate, slow faint stars);
#: at 6-12 it scatters 10-27 %. At 50 a slow faint star on a sensor with OFF/ON 0.6 (22-28
#: such changes) was paired at 1: its positions led by 0.2-0.4 px (0.293 -> 0.153 px at 20).
_MIN_RATIO_CHANGES = 20


def key_crossings(t, key, p, width, max_pairs=16, engine="taichi", **options):
    """pixel_crossings of events given by their pixel_keys, in any order (options: those of
    sorted_crossings)."""
    return sorted_crossings(*by_pixel_then_time(t, key, p, engine), width, max_pairs, engine,
                            **options)


def by_pixel_then_time(t, key, p, engine="taichi"):
    """(times int64, pixel keys, polarities) of events in the pixel-then-time order."""
    order = _pixel_then_time(key, t, engine)
    return np.asarray(t, np.int64)[order], np.asarray(key)[order], np.asarray(p)[order]


def sorted_crossings(ts, keys, ps, width, max_pairs=16, engine="taichi", threshold_ratio=AUTO,
                     with_ratio=False, refractory_us=0.0, profiles=None, fallback_ratio=1.0,
                     background_hz=None):
    """pixel_crossings of events in the pixel-then-time order: their times ts (int64),
    pixel_keys and polarities. engine "taichi": the level pairs by Taichi kernels
    (evstar_kernels.taichi.crossings); "numpy": their specification (the same integers; times within 1e-6 µs).
    threshold_ratio: C_off / C_on of the sensor, or "auto" (measured from the
    runs: threshold_ratio_of). refractory_us: the pixels' refractory period; > 0 counts the
    levels each event skipped (_refractory_pairs). with_ratio: return (crossings, the
    ratio: the one given, or the measured one — None where too few changes measure it and
    fallback_ratio was used). profiles: an evstar.level_lag.LevelProfiles that takes the level midpoints
    of the crossings it still wants (pairs as without a refractory period). background_hz:
    the (ON, OFF) background rates (background_rates), whose events in the runs a measured
    ratio discounts; None: not."""
    kern, (change, on_before, off_after) = _change_runs(ts, keys, ps, engine)
    pixel = keys[change]
    on_before, off_after = (kern.without_strays(change, on_before, off_after, STRAY_GAP_FACTOR)
                            if kern is not None else
                            without_strays(ts, change, on_before, off_after))
    if threshold_ratio != AUTO:
        r = float(threshold_ratio)
    else:
        levels = run_levels(ts, change, on_before, off_after, refractory_us) if refractory_us > 0 else None
        measured = _measured_ratio(on_before, off_after, levels, first_of_pixel(pixel),
                                   None if background_hz is None else (ts, keys, change, background_hz))
        r = fallback_ratio if measured is None else measured
    # pairs as without a refractory period: the profiles' and the outer width's
    plain = _pair_counts(on_before, off_after, r, max_pairs)
    if profiles is not None:
        _add_profiles(profiles, ts, change, plain, r, on_before, pixel, width)
    if refractory_us > 0:
        args = (change, on_before, off_after, r, refractory_us)
        k, sums, sq, h2 = (kern.refractory_sums(*args, MAX_LEVEL_STEP, max_pairs) if kern is not None
                           else _refractory_pairs(ts, *args, max_pairs))
        keep = k > 0
        change, k, sums, sq, h2 = change[keep], k[keep], sums[keep], sq[keep], h2[keep]
        k_plain, nb = plain[keep], on_before[keep]
    else:
        keep = plain > 0
        change, k, nb = change[keep], plain[keep], on_before[keep]
        k_plain = k
        sums, sq, h2 = (kern.sums(change, k, r, nb) if kern is not None
                        else _pair_sums(ts, change, k, r, nb))
    outer = outer_half_width(ts, change, k_plain, r, nb)
    top = top_midpoint(ts, change, k_plain, r, nb)
    mean = sums / k
    t_c = ts[change].astype(np.float64)             # sq is about the change's time
    spread = np.sqrt(np.maximum(sq / k - (mean - t_c) ** 2, 0.0))
    # sorted by time as columns: a gather of the packed rows would take as long as the sort
    by_t = stable_argsort(mean)
    pixel = pixel[keep][by_t]
    out = np.zeros(len(k), CROSSING_DTYPE)
    out["x"], out["y"] = pixel % width, pixel // width
    out["t"], out["pairs"], out["t_spread"], out["t_outer"] = (mean[by_t], k[by_t],
                                                               spread[by_t], outer[by_t])
    out["t_half"] = np.sqrt(h2[by_t] / k[by_t])
    out["t_top"] = top[by_t]
    return (out, r if threshold_ratio != AUTO else measured) if with_ratio else out


def stable_argsort(values):
    """np.argsort(values, kind="stable") of floats: first by a 16-bit key that grows with
    the value (numpy's radix sort), then numpy's stable sort of the values in that nearly
    sorted order (its merges find long runs there). On 78 k crossing times 1.2 ms, where
    numpy's quicksort with its ties put back in index order took 4.2 and its stable sort
    7.3. Equal values share a key, so they stay in index order: the same permutation.
    Non-finite values (their keys unknown): the stable sort."""
    values = np.asarray(values)
    if not len(values):
        return np.argsort(values, kind="stable")
    lo = float(values.min())
    span = float(values.max()) - lo
    # keys below 2¹⁶ − 1, with room for the product's rounding
    scale = 65000.0 / span if span > 0 else 0.0
    if not (np.isfinite(span) and np.isfinite(scale)):    # NaNs, infinities
        return np.argsort(values, kind="stable")
    order = np.argsort(((values - lo) * scale).astype(np.uint16), kind="stable")
    return order[np.argsort(values[order], kind="stable")]


#: a run's outermost event belongs to it only within this many times the largest gap inside
#: its passage (without_strays). On simulated stars a star's own outer gap exceeded 5x in
#: <= 0.5 % of runs (dark-sky sinusoids; none at 0.7-12 °/s), while noise and leak events
#: joined runs 0.1-0.5 s early or late, 45-70 % of them beyond 5x (at 12 °/s 11 % of a
#: star's ON runs began, and 21 % of its OFF runs ended, with one)
STRAY_GAP_FACTOR = 5


def without_strays(ts, change, on_before, off_after):
    """(on_before, off_after) less a stray outermost event: the ON run's first or the OFF
    run's last event, where its gap to its neighbour in the run exceeds STRAY_GAP_FACTOR times
    the largest gap between the passage's other events (from the ON run's second event to
    the OFF run's second last, the change's own gap always among them). Changes without an
    ON event before them are left as they are: they pair no level and tell no ratio."""
    nb, na = np.asarray(on_before), np.asarray(off_after)
    if not len(change):
        return nb, na
    gaps = np.append(np.diff(ts), 0)              # gaps[i]: event i to i + 1 (in the order)
    first, last = change - nb, change + na
    limit = STRAY_GAP_FACTOR * _inside_gaps(gaps, change, nb, na)
    has_on = nb >= 1
    off = has_on & (na >= 2) & (gaps[last - 1] > limit)
    return nb - (has_on & (gaps[first] > limit)), na - off


def _inside_gaps(gaps, change, on_before, off_after):
    """Per change, the largest of `gaps` (event i to i + 1 in the pixel-then-time order)
    between its passage's events from its ON run's second to its OFF run's second last (the
    change's own gap always among them)."""
    first, last = change - on_before, change + off_after
    lo = np.where(on_before >= 1, first + 1, first)
    hi = np.where(off_after >= 2, last - 1, last)       # the inside gaps: lo .. hi - 1
    return np.maximum.reduceat(gaps, np.ravel(np.column_stack([lo, hi])))[::2]


def _change_runs(ts, keys, ps, engine):
    """(the Taichi kernels' state or None, (positions of the ON→OFF changes in the
    pixel-then-time order, their ON runs before, OFF runs after)) of events in that order."""
    if engine == "taichi" and len(ts):
        from evstar_kernels.taichi import crossings_launch

        from .backends import taichi_running

        kern = crossings_launch.LevelPairs(taichi_running(), ts, keys, ps, _RUN_CAP)
        return kern, (kern.change, kern.on_before, kern.off_after)
    return None, _runs(keys, ps)


def threshold_ratio_of(on_before, off_after, levels=None, first=None):
    """C_off / C_on measured from the changes' runs. A star rising through a pixel from its
    reference level ref (y above the background) to the peak fires a ON events, one every
    C_on, to the top T = ref + a·C_on, then falls back through b = floor((a·C_on + y) / C_off)
    OFF levels to the background, where its reference ends y' = a·C_on + y − b·C_off above
    it, y' in [0, C_off): so r·b = a − (y' − y) / C_on. The next passage of the pixel starts
    from y', and over a pixel's passages these terms cancel but for its first: a reference
    uniform over its cycle, y in (−C_on, C_off), puts E[y' − y] at C_on / 2, so
    r·Σb = Σa − ½ · (first passages). (Charging every passage the ½, as the sixth to tenth
    sessions did, took the ratio 3–7 % low on star fields and sinusoids, where pixels see
    two or more passages; fresh pixels' Monte Carlo gives r within 0.5 % for r 0.375–2.5.)
    levels: (a, b) counted in levels instead of events (a pixel with a refractory period
    skips levels: run_levels). first: per change, whether it is its pixel's first (None:
    all). The changes with RATIO_FLANK_EVENTS on each flank (_ratio_changes); 1 when there
    are too few."""
    r = _measured_ratio(on_before, off_after, levels, first)
    return 1.0 if r is None else r


def first_of_pixel(pixels):
    """Per change, given the changes' pixel keys in the pixel-then-time order: whether it is
    its pixel's first."""
    k = np.asarray(pixels)
    return np.r_[True, k[1:] != k[:-1]] if len(k) else np.zeros(0, bool)


def _measured_ratio(on_before, off_after, levels=None, first=None, runs=None):
    """threshold_ratio_of, or None when too few changes tell, or the background breaks their
    runs (MAX_BREAKS_PER_RUN). runs: (ts, keys, change, (ON,
    OFF) background rates, events / pixel / s) of the changes' events in the pixel-then-time
    order: the background events their runs hold are taken off their counts
    (_background_in_runs); None: not."""
    m = _ratio_changes(np.asarray(on_before), np.asarray(off_after))
    a, b = (np.asarray(on_before) + 1, np.asarray(off_after)) if levels is None else levels
    if m.sum() < _MIN_RATIO_CHANGES:
        return None
    ons = a[m] - 0.5 * (np.ones(m.sum()) if first is None else np.asarray(first)[m])
    r = np.sum(ons) / np.sum(b[m])
    if runs is not None:
        on, off, breaks = _background_in_runs(*runs[:2], np.asarray(runs[2])[m],
                                              np.asarray(on_before)[m],
                                              np.asarray(off_after)[m], runs[3])
        # where the background breaks the runs (MAX_BREAKS_PER_RUN) neither count holds:
        # the runs do not tell the ratio (the caller's fallback stands)
        if breaks > MAX_BREAKS_PER_RUN * m.sum():
            return None
        told = (np.sum(ons) - on) / (np.sum(b[m]) - off)
        # only a shift the changes can tell from their own scatter (below it the discount
        # moved a low-pass sensor's profiles across their fit's gate: study_indep's scene 7,
        # 1.473 -> 1.483 for a true 1.5, lost its 3-6 ms lag, 0.139 -> 0.238 px)
        if abs(told - r) > np.sqrt(np.sum((ons - r * b[m]) ** 2)) / np.sum(b[m]):
            r = told
    return float(np.clip(r, 0.25, 4.0))


def _background_in_runs(ts, keys, change, on_before, off_after, rates_hz):
    """(ON, OFF, other) events of the background the changes' runs hold, expected: a pixel's noise
    or leak event inside a passage's run, or before (after) it within the stray test's
    reach (without_strays) and after the pixel's event before the run (before its event
    after it), counts as one of the star's levels — each polarity's rate (rates_hz) times
    those stretches. ON-only leak events (1.5 Hz; perf/study_indep.py's T4, a slow pan
    through a telephoto) took the measured ratio to 1.15 for a true 1, and the stars 0.14
    px ahead. other: those of the opposite polarity inside the runs (OFF in the ON run, ON
    in the OFF run), which split a run rather than join it."""
    gaps = np.append(np.diff(ts), 0)
    reach = STRAY_GAP_FACTOR * _inside_gaps(gaps, change, on_before, off_after)
    first, last = change - on_before, change + off_after
    # the stretch to the pixel's neighbouring event (none: the events' first or last time)
    before = np.where((first > 0) & (keys[np.maximum(first - 1, 0)] == keys[first]),
                      gaps[np.maximum(first - 1, 0)], ts[first] - ts.min())
    after = np.where((last + 1 < len(ts)) & (keys[np.minimum(last + 1, len(ts) - 1)] == keys[last]),
                     gaps[last], ts.max() - ts[last])
    rise, fall = ts[change] - ts[first], ts[last] - ts[change]
    stretches = (np.minimum(reach, before) + rise, np.minimum(reach, after) + fall)
    on, off = (1e-6 * float(rate) * float(np.sum(span, dtype=np.float64))
               for rate, span in zip(rates_hz, stretches))
    other = 1e-6 * (float(rates_hz[1]) * float(np.sum(rise, dtype=np.float64))
                    + float(rates_hz[0]) * float(np.sum(fall, dtype=np.float64)))
    return on, off, other


#: background events of the other polarity a passage's runs may hold, expected, for them
#: to measure the ratio (_measured_ratio): each splits its run instead of joining it, and
#: neither the raw counts nor the discounted ones hold then — a 20 Hz background, 1.5 a run,
#: took 0.978 to 1.040 discounted for a true 1; an ON-heavy one rising from 4 to 10 Hz
#: under a 4 deg/s star, 1.2 a run, read 1.243 raw and 0.926 discounted, and its crossings
#: paired by 1.243 put the star 0.22 px ahead (fresh-56 of perf/study_accuracy.py)
MAX_BREAKS_PER_RUN = 1.0
#: events of a span sampled (every k-th) for its background's ON share: ~0.3 % precision
SHARE_SAMPLE = 200_000


def background_rates(events, near, rate_hz):
    """(ON, OFF) background rates (events / pixel / s): the background's `rate_hz` split by
    the ON share of the `events` (evstar.Events; a strided sample of SHARE_SAMPLE) on
    pixels away from the stars (`near`: a (height, width) bool image of those near them),
    an even split where none is away."""
    step = max(1, len(events) // SHARE_SAMPLE)
    x, y, p = events.x[::step], events.y[::step], events.p[::step]
    away = ~near[y, x]
    share = float(np.mean(p[away] > 0)) if away.any() else 0.5
    return rate_hz * share, rate_hz * (1.0 - share)


def _ratio_changes(on_before, off_after):
    """Which changes measure the ratio: those with RATIO_FLANK_EVENTS events on each flank.
    The second count serves only where the first measures one (_MIN_RATIO_CHANGES): where
    too few changes have 3, the 20-40 with 2 of a slow wide star or coarse thresholds read
    1.16 and 0.89 for a true 1 (taking a slow σ 2.5 px star's frames 87 -> 80 %), and
    the fallback serves better."""
    full, least = ((on_before >= n - 1) & (off_after >= n) for n in RATIO_FLANK_EVENTS)
    return least if _MIN_RATIO_CHANGES <= full.sum() < FULL_FLANK_SHARE * least.sum() else full


#: how far below a run's first ON (in ON steps) a pair's rising time may be extrapolated
DEPTH_REACH = 0.25


def _pair_counts(on_before, off_after, ratio, max_pairs):
    """Level pairs per change: OFF j (level j·C_off below the change's) pairs with the rising
    time j·ratio ON steps back, which must lie within DEPTH_REACH below the run's first ON
    (extrapolated there: level_midpoints). Without that reach, at a ratio a hair above 1
    (a sensor's equal thresholds, measured) every change would lose its deepest pair at
    once: a sinusoid's errors jumped 0.069 → 0.102 px between ratios 1.000 and 1.001."""
    nb = np.asarray(on_before)
    reach = np.where(nb >= 1, DEPTH_REACH, 0.0)      # extrapolation needs two ON events
    on_levels = np.floor((nb + reach) / ratio + 1e-9).astype(np.int64)
    return np.minimum(np.minimum(on_levels, off_after), max_pairs).astype(np.int64)


def _runs(keys, ps):
    """Per ON→OFF change of a pixel, of events in the pixel-then-time order (their pixel
    keys and polarities): its position c, the ON events right before it and the OFF events
    right after it."""
    key, pol = np.asarray(keys), np.asarray(ps) > 0
    # c: last ON before an OFF at the same pixel; its ON run ends at c, its OFF run follows
    change = np.flatnonzero((key[1:] == key[:-1]) & pol[:-1] & ~pol[1:])
    runs = np.flatnonzero(np.r_[True, (key[1:] != key[:-1]) | (pol[1:] != pol[:-1]), True])
    at = np.searchsorted(runs, change, "right")          # the run after c's: c + 1 ...
    on_before = np.minimum(change - runs[at - 1], _RUN_CAP)
    off_after = np.minimum(runs[at + 1] - change - 1, _RUN_CAP)
    return change, on_before, off_after


def _pair_sums(ts, change, k, ratio, on_before):
    """Sums of the pair midpoints, of their squares about the change's own time (an hour's
    µs squared would round the spread to ~50 µs; the offsets of whole-µs midpoints square
    exactly, whatever the arithmetic contracts) and of the pairs' squared half-widths (OFF
    time less midpoint) per change (the kernel's specification): pair j is the j-th OFF after
    c and the rising time at its level, j·ratio ON steps before c, interpolated between the
    ON events around it where not whole (level_midpoints); summed in the order of j."""
    mids, falls = _level_pairs(ts, change, k, ratio, on_before)
    t_c = ts[change].astype(np.float64)
    sums, sq, h2 = np.zeros(len(change)), np.zeros(len(change)), np.zeros(len(change))
    for j in range(mids.shape[1]):
        mid = np.where(k > j, mids[:, j], 0.0)
        d = np.where(k > j, mid - t_c, 0.0)
        half = np.where(k > j, falls[:, j] - mid, 0.0)
        sums += mid
        sq += d * d
        h2 += half * half
    return sums, sq, h2


def level_midpoints(ts, change, k, ratio, on_before):
    """(n, max k) midpoint of each level pair j = 1..k of the changes (NaN beyond k), as
    _pair_sums pairs them (their mean is its sum / k). A rising time below the run's first
    ON (on_before ON events precede c; _pair_counts allows DEPTH_REACH) is extrapolated
    from its first two."""
    return _level_pairs(ts, change, k, ratio, on_before)[0]


def _level_pairs(ts, change, k, ratio, on_before):
    """(midpoints, OFF times): (n, max k) each, of level pairs j = 1..k (NaN beyond k)."""
    mids = np.full((len(change), int(k.max(initial=0))), np.nan)
    falls = mids.copy()
    row, j = np.repeat(np.arange(len(k)), k), ranks(k, 1)      # all pairs at once
    mids[row, j - 1], falls[row, j - 1] = _midpoint(ts, change[row], np.asarray(on_before)[row],
                                                    j, ratio)
    return mids, falls


def outer_half_width(ts, change, k, ratio, on_before):
    """Per change, µs from its deepest pair's midpoint (level k) to that level's OFF event
    (NaN where k is 0). A pixel's low-pass stretches its falling flank, and the more it
    does, the later its midpoints: at one k the lag grows with this width alike for a
    bright star's flank pixels and a faint star's own (EVK4 dark sky, docs/measurements.md)."""
    mid, fall = _pair_where_any(ts, change, k, k, ratio, on_before)
    return fall - mid


def top_midpoint(ts, change, k, ratio, on_before):
    """Per change, its top level pair's midpoint (µs; NaN where k is 0)."""
    return _pair_where_any(ts, change, k, 1, ratio, on_before)[0]


def _pair_where_any(ts, change, k, j, ratio, on_before):
    """_midpoint's (midpoint, OFF time) of level pair j (a number, or one per change) of
    each change with k > 0 pairs; NaN where k is 0."""
    k, on_before = np.asarray(k), np.asarray(on_before)
    if np.all(k > 0):     # the crossings' own changes: no selection to gather
        return _midpoint(ts, change, on_before, j, ratio)
    mid, fall = np.full(len(change), np.nan), np.full(len(change), np.nan)
    m = np.flatnonzero(k > 0)
    mid[m], fall[m] = _midpoint(ts, change[m], on_before[m], np.broadcast_to(j, k.shape)[m], ratio)
    return mid, fall


def _midpoint(ts, c, nb, j, ratio):
    """(midpoint, OFF time) of level pair j (a number, or one per change) of changes c
    whose ON runs have nb events (see level_midpoints). Each time is gathered only where
    it is used (the interpolation's second ON where the level is not whole): ~2x quicker
    than gathers and np.where over every change, the same operations on each."""
    x = np.broadcast_to(np.asarray(j) * ratio, np.shape(c)).astype(np.float64)
    j0 = np.floor(x + 1e-9).astype(np.int64)
    f = x - j0
    deep = x > nb + 1e-9                             # below the first ON: extrapolated
    a = np.where(deep, c, c - j0)                    # (deep: any valid index)
    rise = ts.take(a).astype(np.float64)
    between = np.flatnonzero((f >= 1e-9) & ~deep)    # between the ON events a − 1 and a
    if len(between) == len(c):
        rise = rise * (1 - f) + ts.take(a - 1).astype(np.float64) * f
    elif len(between):
        b = between
        rise[b] = rise[b] * (1 - f[b]) + ts.take(a[b] - 1).astype(np.float64) * f[b]
    if deep.any():
        first = c[deep] - nb[deep]                   # the run's first ON
        t_first = ts.take(first).astype(np.float64)
        rise[deep] = t_first - (x[deep] - nb[deep]) * (ts.take(first + 1).astype(np.float64) - t_first)
    fall = ts.take(c + j).astype(np.float64)
    return 0.5 * (rise + fall), fall


def _add_profiles(profiles, ts, change, k, ratio, on_before, pixel, width):
    """Give `profiles` the level midpoints of the changes it wants, with their pairs'
    half-widths, times and pixels (pixel: each change's pixel key)."""
    sel = profiles.wanted(k)
    if len(sel):
        mids, falls = _level_pairs(ts, change[sel], k[sel], ratio, on_before[sel])
        profiles.add(k[sel], mids, falls - mids, ts[change[sel]],
                     np.column_stack([pixel[sel] % width, pixel[sel] // width]))


#: most reference levels one event may stand for: a gap within r/3 of the refractory period
#: r means >= 3 levels skipped, and below that timestamp jitter dominates the estimate
MAX_LEVEL_STEP = 4.0


def level_step(gap_us, refractory_us):
    """Reference levels a pixel rose (or fell) by between two events of one run gap_us
    apart, given its refractory period r: blind for r after the first, the pixel is re-armed
    at the level of its release and fires one threshold later, so at a locally constant slope
    s the gap is r + C/s and the step C + s·r = C·gap / (gap − r) (1 when r = 0), at most
    MAX_LEVEL_STEP."""
    g = np.asarray(gap_us, np.float64)
    r = float(refractory_us)
    return np.where(g > r, np.minimum(g / np.maximum(g - r, 1e-9), MAX_LEVEL_STEP), MAX_LEVEL_STEP)


def run_levels(ts, change, on_before, off_after, refractory_us):
    """(a, b): the levels each change's ON run rose through in ON thresholds (up to its last
    ON) and its OFF run fell through in OFF thresholds: 1 for a run's first event and
    level_step for each later one; with no refractory period the events, on_before + 1 and
    off_after. The last ON's own gain while blind is left out: the slope falls to 0 at the
    peak, so its extrapolation from the last gap overstates it (the ratio came out 1–6 % high
    with it on ideal sensors with 0.3–1 ms refractory periods, within 0.6 % without)."""
    steps = np.r_[0.0, np.cumsum(level_step(np.diff(ts), refractory_us))]   # steps[i]: to event i
    c, nb, na = np.asarray(change), np.asarray(on_before), np.asarray(off_after)
    a = 1 + steps[c] - steps[c - nb]
    b = 1 + steps[c + np.maximum(na, 1)] - steps[c + 1]
    return a, b


def sensor_hints(events, quantile=1e-3, max_events=2_000_000):
    """(gap floor µs, OFF/ON threshold ratio) of the first `max_events` of `events`
    (evstar.Events), from one pixel-then-time order. The floor is the `quantile` of the gaps between consecutive
    same-polarity events of a pixel: a pixel with a refractory period r fires no two events
    closer than r, so it lies near r where a sensor has one (timestamp jitter spreads it both
    ways: 145 µs on the simulator's 100 µs with 20 µs jitter) — a hint for
    estimate.refractory_us; None without such gaps. The ratio is threshold_ratio_of the
    ON→OFF changes; None when too few changes tell (it would default to 1)."""
    t, x, y, p = (np.asarray(a)[:max_events] for a in (events.t, events.x, events.y, events.p))
    key = pixel_keys(x, y, events.width)
    ts, k, ps = by_pixel_then_time(t, key, p, engine="numpy")
    same = (k[1:] == k[:-1]) & (ps[1:] == ps[:-1])
    gaps = np.diff(ts)[same]
    floor = float(np.quantile(gaps, quantile)) if len(gaps) else None
    change, on_before, off_after = _runs(k, ps)
    on_before, off_after = without_strays(ts, change, on_before, off_after)
    return floor, _measured_ratio(on_before, off_after, first=first_of_pixel(k[change]))


def _refractory_pairs(ts, change, on_before, off_after, ratio, refractory_us, max_pairs):
    """Level pairs of a sensor with a refractory period (the kernel's specification): (pairs,
    sums of the midpoints, of their squares about c's time) per change c. Levels are counted down from the
    last ON (depth 0) in ON thresholds, each event's step from its gap (level_step): ON
    event c − m lies level_step-sums deep; OFF 1 lies `ratio` below the level the last ON's
    release re-armed at (its step less 1 above the last ON), OFF j one step · ratio below
    OFF j − 1. Pair j: OFF j and the rising time at its depth, interpolated between the ON
    events around it. Pairs run while an ON event is at least as deep, up to max_pairs;
    an OFF above the last ON is skipped. Also the sums of the pairs' squared half-widths."""
    c, nb, na = np.asarray(change), np.asarray(on_before), np.asarray(off_after)
    t_c = ts[c].astype(np.float64)                  # the squares are about c's time
    step = lambda a, b: level_step(ts[a] - ts[b], refractory_us)
    has = nb > 0
    m = np.zeros(len(c), np.int64)                  # ON event c − m: the deepest not below
    d_m = np.zeros(len(c))
    d_next = np.where(has, step(c, np.where(has, c - 1, c)), np.inf)
    d_off = ratio - np.where(has, d_next - 1, 0.0)
    k = np.zeros(len(c), np.int64)
    sums, sq, h2 = np.zeros(len(c)), np.zeros(len(c)), np.zeros(len(c))
    alive = na >= 1
    for j in range(1, int(na.max(initial=0)) + 1):
        if j > 1:
            d_off = d_off + np.where(alive, ratio * step(c + np.minimum(j, na), c + np.minimum(j, na) - 1), 0.0)
        while True:
            adv = alive & (m < nb) & (d_next <= d_off + 1e-9)
            if not adv.any():
                break
            m[adv] += 1
            d_m[adv] = d_next[adv]
            deeper = adv & (m < nb)
            d_next[adv] = np.inf
            d_next[deeper] = d_m[deeper] + step(c[deeper] - m[deeper], c[deeper] - m[deeper] - 1)
        beyond = alive & (m == nb) & (d_off > d_m + 1e-9)
        valid = alive & ~beyond & (d_off >= -1e-9)
        f = np.where(np.isfinite(d_next), (d_off - d_m) / np.where(np.isfinite(d_next), d_next - d_m, 1.0), 0.0)
        late, early = ts[c - m].astype(np.float64), ts[np.maximum(c - m - 1, 0)].astype(np.float64)
        rise = np.where(f < 1e-9, late, late * (1 - f) + early * f)
        fall = ts[c + np.minimum(j, na)].astype(np.float64)
        mid = 0.5 * (rise + fall)
        half = fall - mid
        sums[valid] += mid[valid]
        sq[valid] += (mid - t_c)[valid] ** 2
        h2[valid] += (half * half)[valid]
        k += valid
        alive &= ~beyond & (j < na) & (k < max_pairs)
    return k, sums, sq, h2


def _pixel_then_time(key, t, engine="taichi"):
    """The order by pixel key (< 2³²), then time (ties kept in input order). Events of a
    stream are time-sorted already: then a stable sort by key is that order — a Taichi
    counting sort (evstar_kernels.taichi.sorting), or (engine "numpy", its specification's
    fast form) two 16-bit radix passes (numpy's stable sort of 16-bit integers)."""
    if not np.all(t[1:] >= t[:-1]):
        return np.lexsort((t, key))
    if engine == "taichi" and len(key):
        from evstar_kernels.taichi import sorting_launch

        from .backends import taichi_running

        return sorting_launch.stable_order(taichi_running(), key, int(key.max()) + 1)
    return stable_order(key)


def dilate(img, radius_px):
    """Bool image `img` dilated by a square of half-width ceil(radius_px): a row dilation,
    then a column one (whole-image ORs: ~7x scipy's running maxima on a 1280x720 image at
    r = 3)."""
    r = int(np.ceil(radius_px))
    if not r:
        return img
    return _window_or(_window_or(img, r, 0), r, 1)


def _window_or(img, r, axis):
    """Per pixel, the OR of `img` within r of it along `axis` (clipped at the edges): the
    image padded by r both ways, then windows doubled by ORs of shifted copies (4 ORs for
    r = 6, where an OR per shift both ways took 12: 2-3x quicker at r = 3-6)."""
    pad = [(0, 0)] * img.ndim
    pad[axis] = (r, r)
    a = np.pad(img, pad)          # a[i] = img[i - r]; below, a[i] = OR of img[i - r, i - r + w)

    def cut(lo, hi):
        return a[(slice(None),) * axis + (slice(lo, hi),)]

    w, n = 1, a.shape[axis]
    while w < 2 * r + 1:
        s = min(w, 2 * r + 1 - w)   # the window grows by s: to 2w, or to the full 2r + 1
        a, n, w = cut(0, n - s) | cut(s, n), n - s, w + s
    return a


def along_track(crossings, tracks, max_offset_px=3.0, min_speed_px_s=1.0):
    """Assign crossings to tracks and project them on each track's motion.

    tracks: rows with t (µs), track, x, y, vx, vy (px, px/s), sorted by track then time (e.g.
    evstar.smoothing's estimates). A crossing belongs to the track whose position at the
    crossing's time (linear between its rows, np.interp's arithmetic) is nearest, within
    `max_offset_px`, while the track moves at least `min_speed_px_s` (a star that stands
    still crosses nothing); of equally near tracks the first. Returns (index into crossings,
    track id, unit motion direction (n, 2), along residual px = (pixel − track
    position)·direction) for the assigned crossings.
    """
    return within(near_tracks(crossings, tracks, max_offset_px, min_speed_px_s), max_offset_px)


def within(near, max_offset_px):
    """along_track's result from a near_tracks result of a reach >= max_offset_px: its
    crossings within max_offset_px (the nearest track within that reach is the nearest
    within any larger one, so the assignment is the same)."""
    ci, track, dx, dy, ux, uy = near
    k = np.flatnonzero(np.sqrt(dx * dx + dy * dy) < max_offset_px)
    ux, uy = ux[k], uy[k]
    return ci[k], track[k], np.column_stack([ux, uy]), dx[k] * ux + dy[k] * uy


def near_tracks(crossings, tracks, max_offset_px=3.0, min_speed_px_s=1.0):
    """along_track's assignment: (index into crossings, track id, dx, dy = pixel − track
    position (px), ux, uy = the track's unit motion direction) per assigned crossing."""
    # plain arrays: fields of packed records are slow to index
    crossings = {f: np.ascontiguousarray(crossings[f]) for f in ("t", "x", "y")}
    tracks = {f: np.ascontiguousarray(tracks[f]) for f in ("t", "track", "x", "y", "vx", "vy")}
    ci, seg = _candidates(crossings, tracks, max_offset_px)
    t = crossings["t"][ci]
    px, py, vx, vy = _interp(t, tracks["t"], [tracks[f] for f in ("x", "y", "vx", "vy")], seg)
    dx, dy = crossings["x"][ci] - px, crossings["y"][ci] - py
    # np.linalg.norm's arithmetic, without its (n, 2) temporaries
    speed, dist = np.sqrt(vx * vx + vy * vy), np.sqrt(dx * dx + dy * dy)
    ok = np.flatnonzero((dist < max_offset_px) & (speed >= min_speed_px_s))
    first = ok[_nearest(ci[ok], dist[ok], tracks["track"][seg[ok]], len(crossings["t"]))]
    return (ci[first], tracks["track"][seg[first]], dx[first], dy[first],
            vx[first] / speed[first], vy[first] / speed[first])


def _nearest(ci, dist, tid, n):
    """Per distinct crossing ci (< n, ascending) the candidate of least dist, then least tid,
    then first. A crossing mostly has one: only those with several are sorted."""
    several = np.bincount(ci, minlength=n)[ci] > 1
    best = np.full(n, -1, np.int64)
    best[ci[~several]] = np.flatnonzero(~several)
    m = np.flatnonzero(several)
    m = m[np.lexsort((tid[m], dist[m], ci[m]))]
    m = m[np.r_[True, ci[m][1:] != ci[m][:-1]]] if len(m) else m
    best[ci[m]] = m
    return best[best >= 0]


def _candidates(crossings, tracks, max_offset_px):
    """(crossing, segment) pairs with the crossing's time in the segment (rows j, j + 1 of a
    track: t_j <= t < t_j+1, or t = the track's last time) and its pixel in the segment's
    box widened by max_offset_px; segments are named by their first row j. Crossings are
    looked up by (time bin, x) in sorted order, so only those near a track are visited."""
    t_row, tr = tracks["t"], tracks["track"]
    j = np.flatnonzero(tr[:-1] == tr[1:])               # segments: rows j, j + 1
    if not len(j) or not len(crossings["t"]):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    bin_us = max(float(np.median(np.diff(t_row)[j])), 1.0)
    t0 = min(float(crossings["t"].min()), float(t_row.min()))
    x0 = int(crossings["x"].min())
    kx = int(crossings["x"].max()) - x0 + 1
    key = np.floor((crossings["t"] - t0) / bin_us).astype(np.int64) * kx + (crossings["x"] - x0)
    srt = stable_order(key)
    key = key[srt]
    # one query per segment and time bin it spans: the x range of the segment's box
    b0 = np.floor((t_row[j] - t0) / bin_us).astype(np.int64)
    b1 = np.floor((t_row[j + 1] - t0) / bin_us).astype(np.int64)
    nb = b1 - b0 + 1
    qseg = np.repeat(j, nb)
    qbin = ranks(nb, b0)
    r = max_offset_px + 1e-6                  # a hair wider: rounding of the interpolation
    x_lo = np.minimum(tracks["x"][qseg], tracks["x"][qseg + 1]) - r - x0
    x_hi = np.maximum(tracks["x"][qseg], tracks["x"][qseg + 1]) + r - x0
    lo = np.searchsorted(key, qbin * kx + np.clip(np.ceil(x_lo), 0, kx - 1).astype(np.int64))
    hi = np.searchsorted(key, qbin * kx + np.clip(np.floor(x_hi), -1, kx - 1).astype(np.int64),
                         "right")
    n = np.maximum(hi - lo, 0)
    # per candidate its place in the sorted crossings and its query's segment bounds:
    # repeated per query (sequential copies), not gathered per candidate
    at = ranks(n, lo)
    t, y = crossings["t"][srt][at], crossings["y"][srt][at]
    end = _is_last_row(tr)[qseg + 1]
    y_lo = np.minimum(tracks["y"][qseg], tracks["y"][qseg + 1]) - r
    y_hi = np.maximum(tracks["y"][qseg], tracks["y"][qseg + 1]) + r
    t_lo, t_hi = (np.repeat(v, n) for v in (t_row[qseg], t_row[qseg + 1]))
    inside = (t >= t_lo) & ((t < t_hi) | (np.repeat(end, n) & (t == t_hi)))
    inside &= (y >= np.repeat(y_lo, n)) & (y <= np.repeat(y_hi, n))
    keep = np.flatnonzero(inside)
    return srt[at[keep]], np.repeat(qseg, n)[keep]


def _is_last_row(track):
    """Per row: is it its track's last?"""
    return np.r_[track[1:] != track[:-1], True]


def _interp(t, t_row, f_rows, seg):
    """[np.interp(t, t_row, f_row) for f_row in f_rows] of each t in its segment (rows seg,
    seg + 1), with np.interp's arithmetic (its value at a row's time is the row's; the last
    row's at the segment's end); the segments' times gathered once for all fields."""
    nxt = seg + 1
    x0, x1 = t_row[seg].astype(np.float64), t_row[nxt].astype(np.float64)
    dx, dt = x1 - x0, t - x0
    at_1, at_0 = t == x1, t == x0
    out = []
    for f_row in f_rows:
        f0, f1 = f_row[seg], f_row[nxt]
        with np.errstate(divide="ignore", invalid="ignore"):
            val = (f1 - f0) / dx * dt + f0
        out.append(np.where(at_1, f1, np.where(at_0, f0, val)))
    return out
