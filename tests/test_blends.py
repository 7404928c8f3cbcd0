"""evstar.blends: two stars along the motion, one pulse per pixel, the track moved onto the
brighter by its crossings' top level pairs.

Synthetic crossings from the pulse a pixel sees: stars moving along +x at SPEED px/s with
Gaussian profiles (σ SIGMA px) of amplitude A over a background of 1; the pixel's log
intensity rises through reference levels C apart and falls through them again, and its
level pairs are the times it stays above each level (numerically, on a 20 µs grid). One
crossing per pixel of the tracks' rows ±2 (its pulse: all stars together), its mean level
midpoint `t` and its top one `t_top`. A track's rows follow its stars' amplitude-weighted
centre every 10 ms, as a blend's track does.
"""
import numpy as np
import pytest

from evstar import blends, paths
from evstar.crossings import CROSSING_DTYPE, near_tracks
from evstar.extract import CENTROID_DTYPE
from evstar.smoothing import ESTIMATE_DTYPE

SPEED, SIGMA, C, DT_US, SPAN_US = 400.0, 1.0, 0.25, 10_000, 500_000
GRID_US = 20.0


def moved(t_us, acc):
    """How far the stars have moved along x at t_us (µs) from SPEED px/s, gaining acc px/s²."""
    t = np.asarray(t_us, np.float64) / 1e6
    return SPEED * t + 0.5 * acc * t * t


def when(d_px, acc):
    """The time (µs) at which the stars have moved d_px along x (moved's inverse)."""
    if acc == 0:
        return d_px / SPEED * 1e6
    return (np.sqrt(SPEED ** 2 + 2 * acc * d_px) - SPEED) / acc * 1e6


def pulse_crossing(px, py, stars, acc=0.0):
    """(t, pairs, t_top) of pixel (px, py) as stars [(x0, y0, amp)] pass it, or None."""
    xs = np.array([x0 for x0, _, _ in stars])
    t_grid = np.arange(when(px - xs.max() - 8, acc), when(px - xs.min() + 8, acc),
                       GRID_US)
    inten = np.ones_like(t_grid)
    for x0, y0, a in stars:
        d2 = (px - x0 - moved(t_grid, acc)) ** 2 + (py - y0) ** 2
        inten += a * np.exp(-0.5 * d2 / SIGMA ** 2)
    log_i = np.log(inten)
    k = int(np.floor(log_i.max() / C))
    if k < 1:
        return None
    mids = []
    for j in range(1, k + 1):          # level j below the top: (k - j + 1)·C
        above = np.flatnonzero(log_i >= (k - j + 1) * C)
        mids.append(0.5 * (t_grid[above[0]] + t_grid[above[-1]]))
    return float(np.mean(mids)), k, mids[0]


def field(tracks, acc=0.0, span_us=SPAN_US):
    """(rows, crossings): each track a list of stars (dx, dy, amplitude) about its start,
    moving along x at SPEED px/s gaining acc px/s², seen for span_us."""
    rows, cross = [], []
    for k, members in enumerate(tracks):
        x0, y0 = 10.0, 20.0 + 30 * k
        stars = [(x0 + dx, y0 + dy, a) for dx, dy, a in members]
        amp = np.array([a for _, _, a in stars])
        cx, cy = (np.average([s[i] for s in stars], weights=amp) for i in (0, 1))
        t = np.arange(0, span_us, DT_US)
        r = np.zeros(len(t), CENTROID_DTYPE)
        r["t"], r["frame"], r["track"] = t, t // DT_US, k
        r["x"], r["y"] = cx + moved(t, acc), cy
        r["n_events"], r["sigma"], r["source"] = 20, 0.05, "measured"
        rows.append(r)
        for px in range(int(x0) + 2, int(x0 + moved(span_us, acc)) - 2):
            for py in range(int(round(cy)) - 2, int(round(cy)) + 3):
                got = pulse_crossing(px, py, stars, acc)
                if got is not None:
                    cross.append((px, py, got[0], got[1], 0.0, 0.0, 0.0, got[2]))
    rows = np.concatenate(rows)
    cross = np.array(cross, CROSSING_DTYPE)
    return rows[np.lexsort((rows["x"], rows["t"]))], cross[np.argsort(cross["t"], kind="stable")]


SINGLES = [[(0.0, 0.3, a)] for a in (12.0, 14.0, 17.0, 20.0, 24.0)]


def estimates_of(rows):
    """The rows as the estimator's tracks (ESTIMATE_DTYPE, sorted by track then time)."""
    srt = rows[np.lexsort((rows["t"], rows["track"]))]
    tracks = np.zeros(len(srt), ESTIMATE_DTYPE)
    for f in ("t", "track", "x", "y"):
        tracks[f] = srt[f]
    tracks["vx"] = SPEED
    return tracks


def run(rows, cross, lag=None, stray_px=0.0):
    """blends.shifted with the crossings assigned to the rows' own tracks, those
    standing 1–2 stray_px ahead or behind along the motion for the first 60 % of their
    time and 1.5 times as far the other way after it (the estimator's first path, before
    the crossings refine it, strays so on a slew)."""
    tracks = estimates_of(rows)
    step = stray_px * (-1.0) ** tracks["track"] * (1 + 0.5 * (tracks["track"] % 3))   # per track
    tracks["x"] += np.where(tracks["t"] < 0.6 * SPAN_US, step, -1.5 * step)
    return blends.shifted(rows, cross, near_tracks(cross, tracks, 3.0 + 3 * stray_px), lag)


def offset(rows, track, star_x, acc=0.0):
    """The track's rows' mean offset along x from the star (at x = star_x at t = 0)."""
    mine = rows[rows["track"] == track]
    return float(np.mean(mine["x"] - moved(mine["t"], acc) - star_x))


@pytest.fixture(scope="module")
def blend_field():
    return field(SINGLES + [[(0.0, 0.0, 16.0), (-3.0, 0.0, 5.0)]])


def test_the_top_pair_times_the_brighter_star_of_a_pulse():
    t, k, top = pulse_crossing(0, 0, [(0.0, 0.0, 16.0), (-3.0, 0.0, 5.0)])
    assert k >= 3 and abs(top) < 300 and t > 1000     # the blend's mean: later (the fainter trails)
    t, k, top = pulse_crossing(0, 0, [(0.0, 0.0, 16.0)])
    assert abs(t) < GRID_US and abs(top) < GRID_US


def test_a_blend_along_the_motion_moves_onto_its_brighter_star(blend_field):
    rows, cross = blend_field
    out = run(rows, cross)
    k = len(SINGLES)
    before, after = offset(rows, k, 10.0), offset(out, k, 10.0)
    assert before < -0.6                                 # the track trails at the blend
    assert abs(after) < 0.4 * abs(before), (before, after)
    mine = out["track"] == k
    assert np.all(out["sigma"][mine] > rows["sigma"][mine])
    assert np.array_equal(out[~mine], rows[~mine])       # single stars stay


def test_the_offsets_are_taken_from_the_tracks_own_path(blend_field):
    # the estimator's earlier path assigns the crossings, and its errors stay out
    rows, cross = blend_field
    plain, strayed = run(rows, cross, stray_px=0.0), run(rows, cross, stray_px=1.0)
    assert not np.array_equal(plain, rows)
    assert np.array_equal(strayed, plain)


def test_single_stars_are_left_as_they_were():
    rows, cross = field(SINGLES + [[(0.0, 0.0, 16.0)]])
    assert np.array_equal(run(rows, cross), rows)


def test_blends_are_no_reference_for_single_stars():
    # two blends among four tracks: as references they would put each single star
    # their offset away (the median of three others), and move it
    blend = [(0.0, 0.0, 16.0), (-3.0, 0.0, 5.0)]
    rows, cross = field([SINGLES[1], blend, SINGLES[3], blend])
    singles = np.isin(rows["track"], [0, 2])
    assert np.array_equal(run(rows, cross)[singles], rows[singles])


def test_no_move_without_enough_other_tracks(blend_field):
    rows, cross = blend_field
    keep = (rows["track"] >= len(SINGLES) - blends.MIN_REFERENCES + 1)
    ys = np.unique(rows["y"][keep])
    near = np.isin(np.round(cross["y"] - 20.0) // 30, np.round(ys - 20.0) // 30)
    assert np.array_equal(run(rows[keep], cross[near]), rows[keep])


def test_a_slewing_blend_moves_and_its_single_stars_stay():
    # speeding up from SPEED to 3·SPEED px/s: the path's own positions at the top pairs'
    # times hold whatever the speed does
    acc = 4 * SPEED / (SPAN_US / 1e6)
    rows, cross = field(SINGLES + [[(0.0, 0.0, 16.0), (-3.0, 0.0, 5.0)]], acc)
    out = run(rows, cross)
    k = len(SINGLES)
    before, after = offset(rows, k, 10.0, acc), offset(out, k, 10.0, acc)
    assert before < -0.6
    assert abs(after) < 0.4 * abs(before), (before, after)
    mine = out["track"] == k
    assert np.array_equal(out[~mine], rows[~mine])


def test_a_short_blend_moves_and_its_single_stars_stay():
    # 30 px of path (a roll's, a slow pan's): a few dozen centre-line crossings
    rows, cross = field(SINGLES + [[(0.0, 0.0, 16.0), (-3.0, 0.0, 5.0)]], span_us=75_000)
    k = len(SINGLES)
    centre = cross[np.abs(cross["y"] - (20.0 + 30 * k)) < 1]
    assert blends.MIN_CROSSINGS <= len(centre) < 60
    out = run(rows, cross)
    before, after = offset(rows, k, 10.0), offset(out, k, 10.0)
    assert before < -0.6 and abs(after) < 0.4 * abs(before), (before, after)
    mine = out["track"] == k
    assert np.array_equal(out[~mine], rows[~mine])


def test_a_track_that_turns_is_not_moved(blend_field):
    rows, cross = blend_field
    near = near_tracks(cross, estimates_of(rows), 3.0)
    path = paths.of(rows)
    k = len(SINGLES)
    assert blends.track_shifts(path, cross, near)[k] != 0
    turn = (path["g"] == k) & (path["t"] > SPAN_US / 2)
    path["vx"][turn], path["vy"][turn] = 0.5 * SPEED, 0.5 * SPEED     # 45° off
    assert blends.track_shifts(path, cross, near)[k] == 0


def test_no_move_where_the_crossings_were_moved_for_a_pixel_lag(blend_field):
    from evstar.calibration import PixelLag

    rows, cross = blend_field
    lag = PixelLag(pairs=np.arange(1, 4), speed_px_s=np.array([SPEED]),
                   lag_us=np.full((3, 1), 500.0), se_us=np.full((3, 1), 50.0))
    assert np.array_equal(run(rows, cross, lag), rows)
    assert not np.array_equal(run(rows, cross), rows)
