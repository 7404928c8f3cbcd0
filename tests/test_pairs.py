"""evstar.pairs: unresolved close pairs split by their crossings' spread across the motion.

Synthetic crossings: stars moving along +x at SPEED px/s, one crossing per pixel whose peak
log contrast ln(1 + A·exp(−d²/2σ²)) (d: the pixel's distance across) reaches a level pair
of contrast C, weighted by that many level pairs, at the time the star passed the pixel's
column. The tracks' rows follow each track's (amplitude-weighted) centre every 10 ms.
"""
import numpy as np
import pytest

from evstar import pairs, paths
from evstar.crossings import CROSSING_DTYPE, near_tracks
from evstar.extract import CENTROID_DTYPE

SPEED, SIGMA, C, DT_US, SPAN_US = 400.0, 1.2, 0.2, 10_000, 500_000


def star_crossings(x0, y0, amp):
    """One star's crossings: the pixels of each column it passes while in view."""
    xs = np.arange(int(np.ceil(x0)), int(x0 + SPEED * SPAN_US / 1e6))
    ys = np.arange(int(y0) - 8, int(y0) + 9)
    levels = np.floor(np.log1p(amp * np.exp(-0.5 * ((ys - y0) / SIGMA) ** 2)) / C).astype(int)
    ys, levels = ys[levels > 0], levels[levels > 0]
    out = np.zeros(len(xs) * len(ys), CROSSING_DTYPE)
    out["x"] = np.repeat(xs, len(ys))
    out["y"] = np.tile(ys, len(xs))
    out["t"] = (out["x"] - x0) / SPEED * 1e6
    out["pairs"] = np.tile(levels, len(xs))
    return out


def track_rows(track, x0, y0):
    t = np.arange(0, SPAN_US, DT_US)
    rows = np.zeros(len(t), CENTROID_DTYPE)
    rows["t"], rows["frame"], rows["track"] = t, t // DT_US, track
    rows["x"], rows["y"] = x0 + SPEED * t / 1e6, y0
    rows["n_events"], rows["sigma"], rows["source"] = 20, 0.05, "measured"
    return rows


def field(stars):
    """(rows, crossings) of tracks; each track a list of stars (dx, dy, amplitude) about
    its start (the track follows the stars' amplitude-weighted centre)."""
    rows, cross = [], []
    for k, members in enumerate(stars):
        x0, y0 = 10.0, 20.0 + 30 * k
        amp = np.array([a for _, _, a in members], float)
        cx = x0 + np.average([dx for dx, _, _ in members], weights=amp)
        cy = y0 + np.average([dy for _, dy, _ in members], weights=amp)
        rows.append(track_rows(k, cx, cy))
        cross += [star_crossings(x0 + dx, y0 + dy, a) for dx, dy, a in members]
    rows = np.concatenate(rows)
    cross = np.concatenate(cross)
    return rows[np.lexsort((rows["x"], rows["t"]))], cross[np.argsort(cross["t"], kind="stable")]


SINGLES = [[(0.0, 0.3, a)] for a in (4.0, 6.0, 9.0, 13.0, 20.0)]


def split(rows, cross):
    """pairs.split with the crossings assigned to the rows' own tracks (as the estimator
    assigns them, to its tracks: rows with velocities, sorted by track then time)."""
    from evstar.smoothing import ESTIMATE_DTYPE

    srt = rows[np.lexsort((rows["t"], rows["track"]))]
    tracks = np.zeros(len(srt), ESTIMATE_DTYPE)
    for f in ("t", "track", "x", "y"):
        tracks[f] = srt[f]
    tracks["vx"] = SPEED
    return pairs.split(rows, cross, near_tracks(cross, tracks, pairs.REACH_PX), tracks)


def positions(rows, track):
    mine = rows[rows["track"] == track]
    return mine["x"] - SPEED * mine["t"] / 1e6, mine["y"]


def test_single_stars_are_left_as_they_were():
    rows, cross = field(SINGLES)
    out = split(rows, cross)
    assert np.array_equal(out, rows)


@pytest.mark.parametrize("dx, dy", [(0.0, 4.0), (1.5, 3.5), (0.0, -5.0)])
def test_a_pair_across_the_motion_becomes_its_two_stars(dx, dy):
    rows, cross = field(SINGLES + [[(0.0, 0.0, 12.0), (dx, dy, 7.0)]])
    out = split(rows, cross)
    tracks = np.unique(out["track"])
    assert len(tracks) == len(SINGLES) + 2
    x0, y0 = 10.0, 20.0 + 30 * len(SINGLES)
    for track, (tx, ty) in ((len(SINGLES), (x0, y0)), (tracks.max(), (x0 + dx, y0 + dy))):
        x, y = positions(out, track)
        assert np.all(np.hypot(x - tx, y - ty) < 0.35), (track, x[0] - tx, y[0] - ty)
        assert np.all(out["split"][out["track"] == track])
    # the brighter keeps the track and most events; the other tracks are untouched
    brighter = out[out["track"] == len(SINGLES)]["n_events"]
    fainter = out[out["track"] == tracks.max()]["n_events"]
    assert np.all(brighter > fainter)
    assert np.array_equal(out[out["track"] < len(SINGLES)], rows[rows["track"] < len(SINGLES)])


def test_no_split_without_enough_other_tracks_to_measure_a_single_star():
    rows, cross = field(SINGLES[:pairs.MIN_REFERENCES - 1] + [[(0.0, 0.0, 12.0), (0.0, 4.0, 7.0)]])
    assert np.array_equal(split(rows, cross), rows)


def test_three_stars_in_one_track_are_not_split_into_two():
    rows, cross = field(SINGLES + [[(0.0, -4.5, 8.0), (0.0, 0.0, 12.0), (0.0, 4.5, 8.0)]])
    assert np.array_equal(split(rows, cross), rows)


@pytest.mark.parametrize("dy", [1.0, 6.6])
def test_pairs_closer_or_further_than_the_split_takes_are_not_split(dy):
    rows, cross = field(SINGLES + [[(0.0, 0.0, 12.0), (0.0, dy, 8.0)]])
    assert np.array_equal(split(rows, cross), rows)


def test_the_estimator_splits_unless_told_not_to():
    from evstar import Config, estimation

    rows, cross = field(SINGLES + [[(0.0, 0.0, 12.0), (0.0, 4.0, 7.0)]])
    n_tracks = []
    for on in (True, False):
        cfg = Config().replace(**{"estimate.split_pairs": on})
        out = estimation.estimate(rows, cfg, 0, crossings=cross)
        n_tracks.append(len(np.unique(out["track"][out["track"] >= 0])))
    assert n_tracks == [len(SINGLES) + 2, len(SINGLES) + 1]


#: (brightness, across variance) of the tracks of an Orion roll at 20 °/s on evstar's
#: simulator (perf/study_field.py --axis roll, 1.5 Hz, seed 61); the last is the brightest
#: star, single (no other star within 22 px); the 7.8 / 2.92 one a pair 3.2 px apart
MEASURED = [(3.5, 0.69), (4.2, 0.57), (4.7, 0.71), (4.9, 0.63), (5.1, 0.58), (5.2, 0.67),
            (5.2, 0.63), (5.3, 0.77), (5.7, 0.59), (5.8, 0.62), (6.1, 1.26), (6.8, 0.74),
            (7.2, 0.69), (7.6, 0.73), (7.6, 0.73), (7.8, 2.92), (8.9, 0.75), (9.3, 0.75),
            (9.3, 0.8), (9.6, 0.89), (9.9, 0.77), (11.1, 0.86), (11.2, 0.85), (11.4, 0.79),
            (11.6, 0.91), (11.7, 0.92), (11.8, 0.92), (12.3, 0.93), (12.6, 0.89), (12.7, 0.98),
            (13.5, 1.43), (14.2, 0.89), (14.4, 0.96), (14.7, 2.17), (15.1, 1.02), (15.6, 0.94),
            (16.3, 0.95), (16.9, 0.99), (17.0, 2.21), (17.5, 1.12), (18.2, 1.07), (21.1, 1.1),
            (21.1, 1.11), (22.4, 1.16), (24.2, 1.19), (24.7, 1.96), (25.3, 2.42), (32.6, 3.04),
            (37.5, 1.72), (45.9, 2.09), (46.7, 2.18), (68.4, 3.05)]


def test_the_brightest_single_star_is_not_called_wide():
    # a bright star's profile widens faster than the faint bulk's power law predicts
    b, var = np.array(MEASURED).T
    logb = np.log(b)
    ref = pairs._singles(var, logb)
    single = pairs._expected(var, logb, ref)
    wide = pairs._stands_out(var, single)
    assert not wide[-1] and wide[15]
    assert pairs._stands_out(var, pairs._power_law(var[ref], logb[ref])(logb))[-1]


def test_tracks_the_estimator_never_held_are_not_moved():
    rows = track_rows(5, 10.0, 20.0)
    earlier = np.zeros(2, [("t", "<i8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8")])
    earlier["track"], earlier["t"] = 1, [0, DT_US]
    assert np.array_equal(paths.moved_by(paths.of(rows), earlier), np.zeros((1, 2)))


def test_run_neighbours_are_the_rows_before_and_after_in_a_track():
    from evstar.frames import run_neighbours

    prv, nxt = run_neighbours(np.array([3, 3, 3, 5, 7, 7]))
    assert prv.tolist() == [0, 0, 1, 3, 4, 4]
    assert nxt.tolist() == [1, 2, 2, 3, 5, 5]
