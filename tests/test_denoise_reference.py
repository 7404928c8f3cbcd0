"""The numpy reference filters against their definitions, written as plainly as possible."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.stats import poisson

from evstar_kernels.reference import denoise as ref


def stream(draw_or_rng, n, width, height, max_step, t_start=0):
    rng = draw_or_rng
    t = t_start + np.cumsum(rng.integers(0, max_step + 1, n)).astype(np.int64)
    return t, rng.integers(0, width, n), rng.integers(0, height, n)


def classical_loop(t, x, y, width, height, dt):
    """The classical filter of docs/kernels.md, literally: one event at a time, map starting at 0."""
    last = np.zeros((height, width), np.int64)
    support = []
    for ti, xi, yi in zip(t, x, y):
        s = 0
        for dx, dy in ref.NEIGHBOURS_8:
            nx, ny = xi + dx, yi + dy
            if 0 <= nx < width and 0 <= ny < height and ti - last[ny, nx] < dt:
                s += 1
        support.append(s)
        last[yi, xi] = ti
    return np.array(support)


def counts_brute(frame, x, y, radius):
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    same = frame[:, None] == frame[None, :]
    return ((d2 < radius * radius) & same).sum(axis=1)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 120), dt=st.integers(1, 60),
       t_start=st.sampled_from([0, 3, 1_000, -50]), size=st.sampled_from([(1, 1), (2, 3), (6, 5)]))
def test_classical_parallel_form_equals_sequential_loop(seed, n, dt, t_start, size):
    rng = np.random.default_rng(seed)
    t, x, y = stream(rng, n, *size, max_step=20, t_start=t_start)
    expect = classical_loop(t, x, y, *size, dt)
    got = ref.classical_support(t, x, y, *size, dt)
    np.testing.assert_array_equal(got, expect)
    for k in (1, 3):
        np.testing.assert_array_equal(ref.classical_mask(t, x, y, *size, dt, k), expect >= k)


def test_classical_zero_initial_map_supports_early_events():
    # dv's time surface starts at 0: an event at t < dt is supported by any neighbour
    t, x, y = np.array([5, 20_000]), np.array([3, 3]), np.array([3, 3])
    np.testing.assert_array_equal(ref.classical_support(t, x, y, 8, 8, 10_000), [8, 0])
    # corner pixel: only 3 neighbours exist
    np.testing.assert_array_equal(ref.classical_support([5], [0], [0], 8, 8, 10_000), [3])


@pytest.mark.parametrize("radius", [0.5, 1, 1.5, 2, 2.2360679775, 3, 5, 7, 9, 11, 12.7])
def test_disk_rows_are_the_strict_lattice_disk(radius):
    dys, ws = ref.disk_rows(radius)
    inside = {(dx, dy) for dy in range(-14, 15) for dx in range(-14, 15) if dx * dx + dy * dy < radius ** 2}
    rows = {(dx, dy) for dy, w in zip(dys, ws) for dx in range(-w, w + 1)}
    assert rows == inside
    assert ref.disk_area(radius) == len(inside)


def test_disk_areas_of_the_default_radii():
    assert [ref.disk_area(r) for r in (3, 5, 7, 9, 11)] == [25, 69, 145, 249, 373]


def test_frame_index_and_offsets_agree():
    rng = np.random.default_rng(1)
    t = np.sort(rng.integers(100, 50_000, 500))
    for t0 in (None, 0, 100):
        f = ref.frame_index(t, 1_000, t0)
        off = ref.frame_offsets(t, 1_000, t0)
        base = t[0] if t0 is None else t0
        np.testing.assert_array_equal(f, (t - base) // 1_000)
        for k in range(len(off) - 1):
            assert np.all(f[off[k]:off[k + 1]] == k)
        assert off[0] == 0 and off[-1] == len(t)
    with pytest.raises(ValueError, match="t0_us"):
        ref.frame_offsets(t, 1_000, t0_us=int(t[0]) + 1)
    assert ref.frame_offsets(np.zeros(0, np.int64), 10).tolist() == [0]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 150), radius=st.sampled_from([1, 1.5, 3, 4.2, 6]))
def test_disk_counts_equal_brute_force(seed, n, radius):
    rng = np.random.default_rng(seed)
    t, x, y = stream(rng, n, 9, 7, max_step=30)
    frame = ref.frame_index(t, 100)
    np.testing.assert_array_equal(ref.disk_counts(frame, x, y, 9, 7, radius), counts_brute(frame, x, y, radius))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 200), th=st.lists(st.integers(1, 12), min_size=3, max_size=3))
def test_mr_ndsef_screening_gives_the_full_evaluation_mask(seed, n, th):
    rng = np.random.default_rng(seed)
    t, x, y = stream(rng, n, 12, 10, max_step=15)
    frame = ref.frame_index(t, 200)
    radii = (1.5, 3, 5)
    full = np.stack([counts_brute(frame, x, y, r) for r in radii], axis=1)
    keep, counts = ref.mr_ndsef(frame, x, y, 12, 10, radii, th)
    np.testing.assert_array_equal(keep, np.all(full >= np.array(th), axis=1))
    evaluated = counts >= 0
    np.testing.assert_array_equal(counts[evaluated], full[evaluated])
    # radius k is evaluated exactly for the survivors of radii < k
    for k in range(len(radii)):
        np.testing.assert_array_equal(evaluated[:, k], np.all(full[:, :k] >= np.array(th[:k]), axis=1))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 200), th=st.lists(st.integers(1, 12), min_size=3, max_size=3))
def test_mr_ndsef_select_tests_only_the_selected(seed, n, th):
    rng = np.random.default_rng(seed)
    t, x, y = stream(rng, n, 12, 10, max_step=15)
    frame, radii, select = ref.frame_index(t, 200), (1.5, 3, 5), rng.random(n) < 0.4
    keep, counts = ref.mr_ndsef(frame, x, y, 12, 10, radii, th)
    keep_s, counts_s = ref.mr_ndsef(frame, x, y, 12, 10, radii, th, select)
    np.testing.assert_array_equal(keep_s, keep & select)
    np.testing.assert_array_equal(counts_s[select], counts[select])
    assert np.all(counts_s[~select] == -1)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 200), th=st.lists(st.integers(1, 12), min_size=3, max_size=3))
def test_mr_ndsef_mask_only_stops_counting_once_decided(seed, n, th):
    rng = np.random.default_rng(seed)
    t, x, y = stream(rng, n, 12, 10, max_step=15)
    frame, radii = ref.frame_index(t, 200), (1.5, 3, 5)
    keep, counts = ref.mr_ndsef(frame, x, y, 12, 10, radii, th)
    keep_m, counts_m = ref.mr_ndsef(frame, x, y, 12, 10, radii, th, full=False)
    np.testing.assert_array_equal(keep_m, keep)
    counted = counts_m >= 0
    np.testing.assert_array_equal(counts_m[counted], counts[counted])
    # radius k is left out exactly where an earlier radius rejected or decided the event
    for k in range(1, len(radii)):
        decided = np.any(counts_m[:, :k] >= np.maximum.accumulate(th[::-1])[::-1][1:k + 1], axis=1)
        np.testing.assert_array_equal(counted[:, k], counted[:, k - 1] & (counts[:, k - 1] >= th[k - 1])
                                      & ~decided)


@pytest.mark.parametrize("rate_hz", [0.5, 2.0, 100.0])
@pytest.mark.parametrize("alpha", [1e-3, 0.05])
def test_poisson_thresholds_are_the_smallest_with_tail_below_alpha(rate_hz, alpha):
    radii = (3, 5, 11)
    th = ref.poisson_thresholds(rate_hz, 10_000, radii, alpha)
    for r, n in zip(radii, th):
        mu = rate_hz * 0.01 * ref.disk_area(r)
        assert poisson.sf(n - 1, mu) <= alpha          # P[X >= n] <= alpha
        assert n == 1 or poisson.sf(n - 2, mu) > alpha  # and n - 1 would not do
    assert np.all(np.diff(th) >= 0)


def test_background_rate_ignores_hot_pixels_and_a_bright_track():
    rng = np.random.default_rng(3)
    width, height, duration_us, rate = 64, 48, 2_000_000, 5.0
    n = rng.poisson(rate * width * height * duration_us * 1e-6)
    t = rng.integers(0, duration_us, n)
    x, y = rng.integers(0, width, n), rng.integers(0, height, n)
    hot_t = rng.integers(0, duration_us, 4000)            # one pixel firing at 2 kHz
    track = rng.integers(0, duration_us, 3000)            # a target crossing 30 pixels
    t = np.concatenate([t, hot_t, track])
    x = np.concatenate([x, np.full(4000, 7), 10 + track * 30 // duration_us])
    y = np.concatenate([y, np.full(4000, 9), np.full(3000, 20)])
    order = np.argsort(t, kind="stable")
    est = ref.background_rate(t[order], x[order], y[order], width, height)
    assert est == pytest.approx(rate, rel=0.05)
    naive = len(t) / (width * height) / (duration_us * 1e-6)
    assert naive > 1.2 * rate  # the robust estimate is needed here
