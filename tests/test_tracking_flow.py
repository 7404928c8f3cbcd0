"""A new track moves with the field's flow: the stars' common motion, not a 40 px gate."""
import numpy as np

from evstar.extract import CENTROID_DTYPE
from evstar.tracking import Tracker


def centroids(rows):
    """rows of (frame, x, y)."""
    c = np.zeros(len(rows), CENTROID_DTYPE)
    for i, (f, x, y) in enumerate(rows):
        c[i] = (f * 10_000 + 5_000, x, y, -1, 20, f, 1.0, False, False, 0.1, "measured", 10)
    return c[np.lexsort((c["x"], c["t"]))]


def field(frames, v=(2.0, 0.0), starts=((20, 20), (20, 80), (60, 50))):
    """Bright stars seen in every frame, all moving at v px per frame."""
    return [(f, x0 + v[0] * f, y0 + v[1] * f) for f in frames for x0, y0 in starts]


def track_of(linked, f, x):
    return linked["track"][(linked["frame"] == f) & np.isclose(linked["x"], x)][0]


def test_faint_stars_seen_now_and_then_do_not_chain_into_a_track():
    # two faint stars, each seen once, 25 px apart a few frames later, and a third centroid
    # on the jump's extrapolation: standing still within 40 px, they made a track
    rows = field(range(20)) + [(10, 40.0, 30.0), (12, 65.0, 30.0), (14, 90.0, 30.0)]
    linked = Tracker().link(centroids(rows))
    faint = linked[np.isin(linked["x"], [40.0, 65.0, 90.0]) & (linked["y"] == 30.0)]
    assert (faint["track"] == -1).all()


def test_a_new_star_moving_with_the_field_is_tracked_across_gaps():
    # the field moves 5 px per frame; a faint star seen every other frame moves with it
    v = (5.0, 0.0)
    faint = [(f, 30.0 + 5.0 * f, 110.0) for f in range(6, 20, 2)]
    linked = Tracker().link(centroids(field(range(20), v) + faint))
    ids = {track_of(linked, f, x) for f, x, _ in faint}
    assert len(ids) == 1 and -1 not in ids


def test_with_no_confirmed_track_a_new_track_may_jump_up_to_init_gate():
    rows = [(f, 10.0 + 15.0 * f, 50.0) for f in range(6)]   # one fast star alone
    linked = Tracker().link(centroids(rows))
    assert len(set(linked["track"])) == 1 and linked["track"][0] >= 0


def test_a_roll_spreads_the_flow_and_widens_the_gate():
    # a roll of 0.01 rad per frame (57 °/s at 10 ms frames) about (400, 400): stars 300 px
    # out move 3 px per frame, each its own way (their median: about still); a faint star
    # between them, seen every third frame, moves 7.5 px between sightings
    w = 0.01

    def at(f, x0, y0):
        a = w * f
        dx, dy = x0 - 400.0, y0 - 400.0
        return (f, 400.0 + dx * np.cos(a) - dy * np.sin(a), 400.0 + dx * np.sin(a) + dy * np.cos(a))

    stars = [(700.0, 400.0), (400.0, 700.0), (100.0, 400.0), (400.0, 100.0)]
    rows = [at(f, *s) for f in range(16) for s in stars]
    faint = [at(f, 577.0, 577.0) for f in (5, 8, 11, 14)]
    linked = Tracker().link(centroids(rows + faint))
    ids = {track_of(linked, f, x) for f, x, _ in faint}
    assert len(ids) == 1 and -1 not in ids


def test_before_any_track_is_confirmed_new_tracks_move_with_the_field():
    # a recording's first frames: no track has min_length centroids, so no flow is known; a
    # noise cluster in frame 0 and a star first seen in frame 1, 27 px from it, were one
    # track (the 40 px init gate); the new tracks' own nearest steps give the field's flow
    starts = ((20, 20), (20, 80), (60, 50), (100, 20), (140, 80), (180, 50))
    star = [(f, 122.0 + 2.0 * f, 100.0) for f in range(1, 12)]
    rows = field(range(12), starts=starts) + [(0, 97.0, 100.0)] + star
    linked = Tracker().link(centroids(rows))
    assert track_of(linked, 0, 97.0) == -1
    ids = {track_of(linked, f, x) for f, x, _ in star}
    assert len(ids) == 1 and -1 not in ids
