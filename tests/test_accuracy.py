import numpy as np

from evstar.accuracy import common_error, detection, false_tracks, match, summary
from evstar.extract import CENTROID_DTYPE


def _truth(t):
    t = np.asarray(t, float) * 1e-6
    return np.stack([np.stack([10 + 100 * t, 20 + 0 * t], -1), np.stack([50 + 0 * t, 40 + 50 * t], -1)], 1)


def _centroids(rows):
    out = np.zeros(len(rows), CENTROID_DTYPE)
    for i, (t, x, y, frame, track) in enumerate(rows):
        out[i] = (t, x, y, track, 10, frame, 0.5, False, False, 0.1, "measured", 5)
    return out


def test_match_errors_and_summary():
    c = _centroids([(0, 10.3, 20, 0, 0), (100_000, 20, 20.4, 10, 0), (0, 50, 40, 0, 1), (0, 90, 90, 0, 2)])
    star, err = match(c, _truth)
    assert star.tolist() == [0, 0, 1, -1]
    np.testing.assert_allclose(err[:3], [0.3, 0.4, 0.0], atol=1e-12)
    s = summary(err[:3])
    assert np.isclose(s["mean"], 0.7 / 3) and np.isclose(s["max"], 0.4) and s["n"] == 3


def test_detection_counts_only_stars_inside_and_false_tracks():
    frames = np.arange(10)
    mids = frames * 10_000 + 5_000
    rows = [(m, 10 + 100 * m * 1e-6, 20, f, 0) for f, m in zip(frames, mids) if f != 3]
    rows += [(m, 200, 100, f, 7) for f, m in zip(frames, mids)]  # a track on no star
    total, per_star = detection(_centroids(rows), _truth, frames, mids, width=64, height=64)
    assert per_star[0] == 0.9 and per_star[1] == 0.0
    assert abs(total - 9 / 20) < 1e-12
    assert false_tracks(_centroids(rows), _truth, duration_s=0.1) == 10.0


def test_common_error_is_what_all_stars_share_per_frame():
    rng = np.random.default_rng(5)
    frames, stars = np.repeat(np.arange(20), 30), np.tile(np.arange(30), 20)
    shared = np.column_stack([0.1 * np.sin(np.arange(20)), np.full(20, -0.05)])
    own = rng.normal(0.0, 0.1, (600, 2))            # each star's own error: averages out
    f, med, rms = common_error(frames, stars, own + shared[frames])
    assert np.array_equal(f, np.arange(20))
    assert np.abs(med - shared).max() < 0.08    # a median of 30: sd ~0.023 per axis
    expected = np.sqrt(np.mean((shared ** 2).sum(1)))
    assert abs(rms - expected) < 0.03
    _, _, alone = common_error(frames, stars, own)
    assert alone < 0.05 and expected > 0.07   # ~0.032 (√2 × 0.023) and 0.084
    # a frame with fewer distinct stars than min_stars does not count
    keep = (frames != 3) | (stars < 4)
    f, _, _ = common_error(frames[keep], stars[keep], own[keep], min_stars=5)
    assert 3 not in f and len(f) == 19
    assert np.isnan(common_error(np.zeros(0), np.zeros(0), np.zeros((0, 2)))[2])
