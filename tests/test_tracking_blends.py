"""Two stars close enough to share one cluster in some frames keep their own tracks."""
import numpy as np

from evstar.extract import CENTROID_DTYPE
from evstar.tracking import BLENDED, Tracker


def centroids(frames_xy_spread):
    c = np.zeros(len(frames_xy_spread), CENTROID_DTYPE)
    for i, (f, x, y, spread) in enumerate(frames_xy_spread):
        c[i] = (f * 10_000 + 5_000, x, y, -1, 20, f, spread, False, False, 0.1, "measured", 10)
    return c[np.lexsort((c["x"], c["t"]))]


def pair(merged_frames, merged_at, merged_spread):
    """Stars A (y 50) and B (y 55) moving 1 px a frame along x for 12 frames, clusters of
    spread 1 px; in merged_frames one centroid alone, merged_at(xa, ya, xb, yb) -> its
    (x, y), of spread merged_spread."""
    rows = []
    for f in range(12):
        a, b = (10.0 + f, 50.0), (10.0 + f, 55.0)
        rows += ([(f, *merged_at(*a, *b), merged_spread)] if f in merged_frames
                 else [(f, *a, 1.0), (f, *b, 1.0)])
    return centroids(rows)


def between(xa, ya, xb, yb):
    """Two stars' blend: a magnitude-3.5/4 pair's, 0.4 of the way from the brighter."""
    return xa, ya + 0.4 * (yb - ya)


#: the spread of such a blend: 1 px clusters 5 px apart, w(1 - w)·L² = 6 px² added
BLEND_SPREAD = float(np.sqrt(1 + 0.4 * 0.6 * 25))


def test_a_centroid_between_two_confirmed_tracks_is_a_blend_and_both_coast():
    linked = Tracker().link(pair({5, 6}, between, BLEND_SPREAD))
    blend = linked["frame"] >= 5
    blend &= linked["frame"] <= 6
    assert np.all(linked["track"][blend] == BLENDED)
    star_a = linked[~blend & (linked["y"] == 50.0)]["track"]
    star_b = linked[~blend & (linked["y"] == 55.0)]["track"]
    assert len(set(star_a)) == 1 and len(set(star_b)) == 1 and star_a[0] != star_b[0]
    assert set(linked["track"]) == {star_a[0], star_b[0], BLENDED}


def test_one_star_alone_in_a_frame_is_no_blend():
    # B not seen for two frames: A's centroid sits on A's prediction and A takes it
    linked = Tracker().link(pair({5, 6}, lambda xa, ya, xb, yb: (xa, ya), 1.0))
    assert BLENDED not in set(linked["track"])
    assert len(set(linked["track"][linked["y"] == 50.0])) == 1


def test_a_centroid_between_two_tracks_as_narrow_as_its_own_star_s_is_no_blend():
    # a noisy prediction can put a star's own centroid "between" its track and a
    # neighbour's; a blend of two stars is wider than either
    linked = Tracker().link(pair({5, 6}, between, 1.0))
    assert BLENDED not in set(linked["track"])
