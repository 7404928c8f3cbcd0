"""Re-extraction along a track: pools frames of a faint star until a window holds enough
events, recovers the star's position without the prediction's offset, ignores far
events, and checks its parameters by name."""
import numpy as np
import pytest

import evstar
from evstar.smoothing import ESTIMATE_DTYPE
from evstar.track_reextraction import reextract_tracks

DT = 10_000


def line(t_us):
    t = np.asarray(t_us) * 1e-6
    return 40 + 30.0 * t, 30 + 10.0 * t


def faint_star_events(rng, n_frames=100, per_frame=2, psf=1.0, noise=0):
    """Events of a star on `line` (Gaussian PSF, `per_frame` events per frame at random
    times) plus `noise` uniform events per frame over the 128 x 96 sensor."""
    t = np.sort(rng.integers(0, n_frames * DT, n_frames * per_frame))
    x, y = line(t)
    x, y = x + rng.normal(0, psf, len(t)), y + rng.normal(0, psf, len(t))
    tn = rng.integers(0, n_frames * DT, n_frames * noise)
    t = np.r_[t, tn]
    x = np.r_[np.round(x), rng.integers(0, 128, len(tn))]
    y = np.r_[np.round(y), rng.integers(0, 96, len(tn))]
    order = np.argsort(t, kind="stable")
    return evstar.Events(t[order], x[order], y[order], np.ones(len(t), int), 128, 96)


def estimates(n_frames=100, offset=(0.0, 0.0)):
    est = np.zeros(n_frames, ESTIMATE_DTYPE)
    est["frame"] = np.arange(n_frames)
    est["t"] = est["frame"] * DT + DT // 2
    x, y = line(est["t"])
    est["x"], est["y"] = x + offset[0], y + offset[1]
    return est


def test_pools_few_events_per_frame_into_unbiased_centroids():
    rng = np.random.default_rng(0)
    ev = faint_star_events(rng, noise=5)
    cents = reextract_tracks(ev, estimates(offset=(0.4, -0.3)), DT, 0, gather_min_events=4)
    assert len(cents) > 35 and np.all(cents["n_events"] >= 4) and np.all(cents["track"] == 0)
    assert np.all(np.diff(cents["t"]) > 0)
    x, y = line(cents["t"])
    ex, ey = cents["x"] - x, cents["y"] - y
    # the prediction's 0.4 / −0.3 px offset is not inherited (rounding to pixels costs none:
    # the star's x, y are spread over many pixel phases)
    assert abs(ex.mean()) < 0.1 and abs(ey.mean()) < 0.1
    assert np.sqrt(np.mean(ex**2 + ey**2)) < 1.0    # ≈ sqrt(2/4) px for 4 events


def test_a_sparse_stretch_longer_than_max_frames_gives_nothing():
    rng = np.random.default_rng(1)
    ev = faint_star_events(rng, per_frame=1)      # ~1 event per frame: 3 need ~3 frames
    est = estimates()
    counts = {m: reextract_tracks(ev, est, DT, 0, gather_min_events=3, gather_max_frames=m)
              for m in (1, 2, 5)}
    # three events in one frame's time are rare; within five frames' they are the rule
    assert len(counts[1]) < len(counts[2]) < len(counts[5]) and len(counts[1]) < 10
    assert len(counts[5]) > 20
    assert all(np.all(c["n_events"] >= 3) for c in counts.values())


def test_events_far_from_the_track_are_not_taken():
    rng = np.random.default_rng(2)
    ev = faint_star_events(rng)
    far = estimates(offset=(20.0, 0.0))          # a track 20 px from the star
    assert len(reextract_tracks(ev, far, DT, 0)) == 0


@pytest.mark.parametrize("name, value", [("gather_radius_px", 0), ("gather_min_events", 0),
                                         ("gather_max_frames", 0.5)])
def test_bad_parameters_rejected_by_name(name, value):
    with pytest.raises(evstar.ParameterError, match=name):
        reextract_tracks(evstar.Events.empty(8, 8), estimates(), DT, 0, **{name: value})
