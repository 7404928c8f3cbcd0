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
