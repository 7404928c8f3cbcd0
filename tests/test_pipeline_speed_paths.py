"""Quicker paths of the whole pipeline give the bits of the ones they replace: the crossings'
time order (a radix sort by a coarse key, then a stable sort of the nearly sorted values) and the Kalman smoother's
tracks spread over a CPU loop's iterations (idle one-step tracks between them)."""
import numpy as np
import pytest

from evstar import kalman
from evstar.crossings import stable_argsort


@pytest.mark.parametrize("n, levels", [(0, 1), (1, 1), (7, 2), (5_000, 40), (100_000, 10**9)])
def test_the_crossings_time_order_is_numpys_stable_sort(n, levels):
    rng = np.random.default_rng(n)
    values = rng.integers(0, levels, n) / 4.0          # many ties where levels are few
    assert np.array_equal(stable_argsort(values), np.argsort(values, kind="stable"))
    if n > 2:
        values[::3] = np.nan                            # NaNs: the stable sort's order too
        values[1] = -0.0
        assert np.array_equal(stable_argsort(values), np.argsort(values, kind="stable"))


@pytest.mark.parametrize("values", [
    [3.0, 3.0, 3.0], [0.0, -0.0, 0.0, -0.0], [-1e308, 1e308, 0.0, 1e308], [np.inf, 1.0, -np.inf, 1.0],
    [5e-324, 0.0, 5e-324, 1e-323], [-2.5, -7.0, 1e6, -2.5, 3e6 + 0.25, 3e6, 3e6 + 0.25]])
def test_the_crossings_time_order_at_extreme_values(values):
    values = np.array(values)
    assert np.array_equal(stable_argsort(values), np.argsort(values, kind="stable"))


def test_the_crossings_time_order_of_clustered_times():
    rng = np.random.default_rng(3)   # a few far outliers: most times share a few keys
    values = np.r_[rng.integers(0, 50, 20_000) * 0.5 + 4e6, 0.0, 1e9]
    rng.shuffle(values)
    assert np.array_equal(stable_argsort(values), np.argsort(values, kind="stable"))


def _problems(rng, lengths):
    out = []
    for n in lengths:
        ts = np.cumsum(np.r_[0.0, rng.exponential(0.01, n - 1)])
        measured = rng.random(n) < 0.8
        measured[0] = True
        m = int(measured.sum())
        z = 100 + np.cumsum(rng.normal(0, 1, (m, 2)), 0)
        out.append(kalman.CVProblem(ts, measured, z, kalman.diagonal_covariances(
            rng.uniform(0.05, 0.5, m)), float(10 ** rng.uniform(-1, 4)), 0.1))
    return out


@pytest.mark.parametrize("device_arrays", [False, True])
def test_the_smoothers_spread_tracks_keep_their_bits(monkeypatch, device_arrays):
    # the CPU spreads a launch's tracks over 512 iterations a thread (the others idle
    # tracks of one step); the device path runs them side by side: the same kernel, the
    # same bits, and each track's as when smoothed alone
    from evstar_kernels.taichi import launch

    rng = np.random.default_rng(7)
    problems = _problems(rng, [1, 2, 5, *rng.integers(3, 300, 40)])
    together = kalman.cv_rts_taichi(problems)
    alone = [kalman.cv_rts_taichi([p])[0] for p in problems[:6]]
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    other = kalman.cv_rts_taichi(problems)
    for (x, P), (x2, P2) in zip(together, other):
        assert np.array_equal(x, x2) and np.array_equal(P, P2)
    for (x, P), (x2, P2), p in zip(together, alone, problems):
        assert x.shape == (len(p.ts), 4) and np.array_equal(x, x2) and np.array_equal(P, P2)
