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


def pulse_crossing(px, py, stars):
    """(t, pairs, t_top) of pixel (px, py) as stars [(x0, y0, amp)] pass it, or None."""
    xs = np.array([x0 for x0, _, _ in stars])
    t_grid = np.arange((px - xs.max() - 8) / SPEED * 1e6, (px - xs.min() + 8) / SPEED * 1e6,
                       GRID_US)
    inten = np.ones_like(t_grid)
    for x0, y0, a in stars:
        d2 = (px - x0 - SPEED * t_grid / 1e6) ** 2 + (py - y0) ** 2
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


def field(tracks):
    """(rows, crossings): each track a list of stars (dx, dy, amplitude) about its start."""
    rows, cross = [], []
    for k, members in enumerate(tracks):
        x0, y0 = 10.0, 20.0 + 30 * k
        stars = [(x0 + dx, y0 + dy, a) for dx, dy, a in members]
        amp = np.array([a for _, _, a in stars])
        cx, cy = (np.average([s[i] for s in stars], weights=amp) for i in (0, 1))
        t = np.arange(0, SPAN_US, DT_US)
        r = np.zeros(len(t), CENTROID_DTYPE)
        r["t"], r["frame"], r["track"] = t, t // DT_US, k
        r["x"], r["y"] = cx + SPEED * t / 1e6, cy
        r["n_events"], r["sigma"], r["source"] = 20, 0.05, "measured"
        rows.append(r)
        for px in range(int(x0) + 2, int(x0 + SPEED * SPAN_US / 1e6) - 2):
            for py in range(int(round(cy)) - 2, int(round(cy)) + 3):
                got = pulse_crossing(px, py, stars)
                if got is not None:
                    cross.append((px, py, got[0], got[1], 0.0, 0.0, 0.0, got[2]))
    rows = np.concatenate(rows)
    cross = np.array(cross, CROSSING_DTYPE)
    return rows[np.lexsort((rows["x"], rows["t"]))], cross[np.argsort(cross["t"], kind="stable")]


SINGLES = [[(0.0, 0.3, a)] for a in (12.0, 14.0, 17.0, 20.0, 24.0)]


def run(rows, cross, lag=None):
    """blends.shifted with the crossings assigned to the rows' own tracks."""
    srt = rows[np.lexsort((rows["t"], rows["track"]))]
    tracks = np.zeros(len(srt), ESTIMATE_DTYPE)
    for f in ("t", "track", "x", "y"):
        tracks[f] = srt[f]
    tracks["vx"] = SPEED
    return blends.shifted(rows, cross, near_tracks(cross, tracks, 3.0), tracks, lag)


def offset(rows, track, star_x):
    """The track's rows' mean offset along x from the star (at x = star_x at t = 0)."""
    mine = rows[rows["track"] == track]
    return float(np.mean(mine["x"] - SPEED * mine["t"] / 1e6 - star_x))


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


def test_single_stars_are_left_as_they_were():
    rows, cross = field(SINGLES + [[(0.0, 0.0, 16.0)]])
    assert np.array_equal(run(rows, cross), rows)


def test_no_move_without_enough_other_tracks(blend_field):
    rows, cross = blend_field
    keep = (rows["track"] >= len(SINGLES) - blends.MIN_REFERENCES + 1)
    ys = np.unique(rows["y"][keep])
    near = np.isin(np.round(cross["y"] - 20.0) // 30, np.round(ys - 20.0) // 30)
    assert np.array_equal(run(rows[keep], cross[near]), rows[keep])


def test_a_track_that_changes_speed_is_not_moved(blend_field):
    rows, cross = blend_field
    path = paths.of(rows)
    path["vx"] = np.where(path["t"] < SPAN_US / 2, SPEED, 0.5 * SPEED)
    assert not blends._steady(path).any()
    assert blends._steady(paths.of(rows)).all()


def test_no_move_where_the_crossings_were_moved_for_a_pixel_lag(blend_field):
    from evstar.calibration import PixelLag

    rows, cross = blend_field
    lag = PixelLag(pairs=np.arange(1, 4), speed_px_s=np.array([SPEED]),
                   lag_us=np.full((3, 1), 500.0), se_us=np.full((3, 1), 50.0))
    assert np.array_equal(run(rows, cross, lag), rows)
    assert not np.array_equal(run(rows, cross), rows)
