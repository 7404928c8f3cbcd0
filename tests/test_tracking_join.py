"""A star that stops and turns back keeps one track id."""
import numpy as np

from evstar.extract import CENTROID_DTYPE
from evstar.tracking import Tracker


def centroids(frames_x):
    c = np.zeros(len(frames_x), CENTROID_DTYPE)
    for i, (f, x) in enumerate(frames_x):
        c[i] = (f * 10_000 + 5_000, x, 50.0, -1, 20, f, 1.0, False, False, 0.1, "measured", 10)
    return c[np.lexsort((c["x"], c["t"]))]


def test_a_turnaround_with_a_stray_centroid_stays_one_track():
    # out along x for 10 frames; at frame 10 a stray centroid on the old prediction takes the
    # old track, the star itself (turning back) starts a new one that goes on alone
    rows = [(f, 10.0 + f) for f in range(10)] + [(10, 20.2), (10, 19.0)]
    rows += [(f, 19.0 - (f - 10)) for f in range(11, 20)]
    linked = Tracker().link(centroids(rows))
    assert set(linked["track"]) == {0}


def test_a_track_starting_far_from_where_another_ended_is_not_joined():
    rows = [(f, 10.0 + f) for f in range(10)] + [(f, 40.0 - (f - 10)) for f in range(10, 20)]
    linked = Tracker().link(centroids(rows))
    assert len(set(linked["track"])) == 2


def _turn_with_silence(gap_frames, speed_px=0.2, centroid_noise=0.0, seed=0):
    """A slow star (speed_px per frame) out along x, silent for gap_frames frames at its
    turn (too slow to fire its pixels), then back."""
    rng = np.random.default_rng(seed)
    out = [(f, 50.0 + speed_px * f) for f in range(20)]
    back = 20 + gap_frames
    out += [(f, 50.0 + speed_px * (2 * 19 - f + gap_frames)) for f in range(back, back + 20)]
    return [(f, x + rng.normal(0, centroid_noise)) for f, x in out]


def test_a_slow_star_silent_at_its_turn_for_longer_than_max_gap_stays_one_track():
    # 9 silent frames (max_gap 3): joined, as the star could not have left the gate
    linked = Tracker(max_gap=3).link(centroids(_turn_with_silence(9, centroid_noise=0.1)))
    assert set(linked["track"]) == {0}


def test_a_fast_track_is_not_joined_across_a_long_gap():
    # a star at 2 px per frame would be 18 px on after 9 frames: a track beginning where
    # it ended is another object
    rows = [(f, 10.0 + 2 * f) for f in range(20)] + [(f, 48.0 + 2 * (f - 29)) for f in range(29, 49)]
    linked = Tracker(max_gap=3).link(centroids(rows))
    assert len(set(linked["track"])) == 2


def test_even_a_slow_track_is_not_joined_beyond_the_slow_gap_limit():
    from evstar.tracking import _SLOW_GAPS

    gap = _SLOW_GAPS * 4 + 2                      # max_gap 3: 4 frames a unit
    linked = Tracker(max_gap=3).link(centroids(_turn_with_silence(gap, speed_px=0.05)))
    assert len(set(linked["track"])) == 2
