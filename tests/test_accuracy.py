import numpy as np

from evstar.accuracy import detection, false_tracks, match, summary
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
