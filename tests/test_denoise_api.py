"""Filter objects: validated parameters, apply/filter semantics, inspection attributes."""
import numpy as np
import pytest

import evstar
from evstar import denoise
from evstar.errors import BackendError


def events(n=3000, width=40, height=30, seed=0):
    rng = np.random.default_rng(seed)
    return evstar.Events(np.sort(rng.integers(0, 50_000, n)), rng.integers(0, width, n),
                         rng.integers(0, height, n), rng.integers(0, 2, n), width, height)


@pytest.mark.parametrize("make, param", [
    (lambda: denoise.ClassicalFilter(dt_us=0), "dt_us"),
    (lambda: denoise.ClassicalFilter(dt_us=2.5), "dt_us"),
    (lambda: denoise.ClassicalFilter(k=0), "k"),
    (lambda: denoise.ClassicalFilter(k=9), "k"),
    (lambda: denoise.ClassicalFilter(backend="numba"), "backend"),
    (lambda: denoise.ClassicalFilter(device="tpu"), "device"),
    (lambda: denoise.ClassicalFilter(backend="reference", device="cuda"), "device"),
    (lambda: denoise.NDSEF(radius=0), "radius"),
    (lambda: denoise.NDSEF(radius=float("nan")), "radius"),
    (lambda: denoise.NDSEF(threshold=0), "threshold"),
    (lambda: denoise.NDSEF(threshold="high"), "threshold"),
    (lambda: denoise.NDSEF(alpha=1.5), "alpha"),
    (lambda: denoise.NDSEF(rate_hz=-1), "rate_hz"),
    (lambda: denoise.NDSEF(strategy="fast"), "strategy"),
    (lambda: denoise.MRNDSEF(radii=()), "radii"),
    (lambda: denoise.MRNDSEF(radii=(5, 3)), "radii"),
    (lambda: denoise.MRNDSEF(radii=(3, 3)), "radii"),
    (lambda: denoise.MRNDSEF(radii=(3, 5), thresholds=(4,)), "thresholds"),
    (lambda: denoise.MRNDSEF(radii=(3, 5), thresholds=(4, 0)), "thresholds"),
    (lambda: denoise.MRNDSEF(thresholds="adaptive"), "thresholds"),
    (lambda: denoise.MRNDSEF(alpha=0), "alpha"),
    (lambda: denoise.MRNDSEF(t0_us="now"), "t0_us"),
    (lambda: denoise.MRNDSEF(schedule="threads"), "schedule"),
    (lambda: denoise.ClassicalFilter(schedule="lanes", device="cuda"), "schedule"),
])
def test_bad_parameters_raise_value_error_naming_them(make, param):
    with pytest.raises(ValueError, match=param):
        make()


def test_constructor_only_stores_parameters():
    f = denoise.MRNDSEF(5_000, [3, 6], [2, 3], alpha=0.01, backend="reference")
    assert f.get_params() == dict(dt_us=5_000, radii=(3, 6), thresholds=(2, 3), alpha=0.01, rate_hz=None,
                                  t0_us=None, backend="reference", device="cpu", strategy="auto",
                                  schedule="auto")
    assert not hasattr(f, "counts_")
    assert "MRNDSEF(dt_us=5000" in repr(f)


def test_apply_returns_mask_and_filter_the_kept_events():
    ev = events()
    f = denoise.MRNDSEF(10_000, (2, 4), (2, 4))
    keep = f.apply(ev)
    assert keep.dtype == bool and keep.shape == (len(ev),)
    assert 0 < keep.sum() < len(ev)
    kept = f.filter(ev)
    assert kept == ev[keep]
    assert f.n_events_ == len(ev) and f.n_kept_ == keep.sum()
    assert f.counts_.shape == (len(ev), 2) and f.counts_.dtype == np.int32
    # a rejected event at radius 1 was never counted at radius 2
    rejected1 = f.counts_[:, 0] < 2
    assert np.all(f.counts_[rejected1, 1] == -1)
    assert np.all(keep == np.all(f.counts_ >= [2, 4], axis=1))
    with pytest.raises(TypeError, match="Events"):
        f.apply(np.zeros(3))
    # select: only those events are tested (keep False, counts -1 for the others)
    half = np.arange(len(ev)) % 2 == 0
    np.testing.assert_array_equal(f.apply(ev, select=half), keep & half)
    assert np.all(f.counts_[~half] == -1)
    with pytest.raises(ValueError, match="select"):
        f.apply(ev, select=half[1:])
    # mask: the same mask, counting only what it needs
    np.testing.assert_array_equal(f.mask(ev), keep)
    np.testing.assert_array_equal(f.mask(ev, select=half), keep & half)
    assert f.counts_ is None and f.n_kept_ == (keep & half).sum()


def test_ndsef_counts_and_threshold_semantics():
    ev = events(seed=1)
    f = denoise.NDSEF(10_000, radius=3, threshold=3)
    keep = f.apply(ev)
    assert f.counts_.shape == (len(ev),)
    np.testing.assert_array_equal(keep, f.counts_ >= 3)
    assert f.threshold_ == 3 and f.counts_.min() >= 1  # every event counts itself


def test_auto_thresholds_follow_the_background_rate():
    ev = events(20_000, seed=2)
    f = denoise.MRNDSEF(10_000)
    f.apply(ev)
    rate = 20_000 / (40 * 30) / 0.05
    assert f.rate_hz_ == pytest.approx(rate, rel=0.1)
    assert f.thresholds_ == tuple(denoise.ref.poisson_thresholds(f.rate_hz_, 10_000, f.radii, 1e-3))
    g = denoise.MRNDSEF(10_000, rate_hz=1.0)
    g.apply(ev)
    assert g.rate_hz_ == 1.0 and g.thresholds_ < f.thresholds_


def test_frame_origin_changes_the_frames():
    ev = events(seed=3)
    a = denoise.NDSEF(10_000, 3, 1, t0_us=0).apply(ev)
    f = denoise.NDSEF(10_000, 3, 1, t0_us=int(ev.t[0]) - 5_000)
    f.apply(ev)
    g = denoise.NDSEF(10_000, 3, 1, t0_us=0)
    g.apply(ev)
    assert a.all() and not np.array_equal(f.counts_, g.counts_)


def test_classical_counts_are_supporting_neighbours():
    ev = events(seed=4)
    f = denoise.ClassicalFilter(3_000, k=2)
    keep = f.apply(ev)
    assert f.counts_.dtype == np.int8 and f.counts_.max() <= 8
    np.testing.assert_array_equal(keep, f.counts_ >= 2)


def test_cuda_without_gpu_is_an_error_not_a_cpu_run():
    import warp as wp
    if wp.get_cuda_device_count() > 0:
        pytest.skip("a CUDA GPU is present: the error path cannot be exercised")
    for flt in (denoise.NDSEF(device="cuda"), denoise.ClassicalFilter(device="cuda")):
        with pytest.raises(BackendError):
            flt.apply(events())


def test_auto_rate_of_long_streams_comes_from_a_sample_of_frames(monkeypatch):
    rng = np.random.default_rng(5)
    n, rate = 60_000, 50.0                       # 50 Hz/pixel on 40x30 for 1 s
    ev = evstar.Events(np.sort(rng.integers(0, 1_000_000, n)), rng.integers(0, 40, n),
                       rng.integers(0, 30, n), np.ones(n), 40, 30)
    full = denoise.MRNDSEF()
    full.apply(ev)
    monkeypatch.setattr(denoise, "_RATE_SAMPLE_EVENTS", 5_000)
    sampled, sampled_ref = denoise.MRNDSEF(), denoise.MRNDSEF(backend="reference")
    sampled.apply(ev)
    sampled_ref.apply(ev)
    assert sampled.rate_hz_ != full.rate_hz_ and sampled.rate_hz_ == sampled_ref.rate_hz_
    assert sampled.rate_hz_ == pytest.approx(rate, rel=0.1) and full.rate_hz_ == pytest.approx(rate, rel=0.05)
