"""A track's position across its motion from every event near its path (evstar.across).

Events are drawn from a star's pixel-sampled Gaussian profile about a known path (plus
uniform background); the rows sit on the path with a known offset across it.
"""
import numpy as np
import pytest

from evstar import Config, Pipeline, across, sim
from evstar.errors import ParameterError
from evstar.extract import CENTROID_DTYPE

DT = 10_000
SENSOR = (240, 180)


def star_events(rng, start, velocity, frames, per_frame=40, psf=1.0, background=0, sensor=SENSOR):
    """(t, x, y) time-ordered: per frame `per_frame` events of a star moving from `start`
    (px) at `velocity` (px/frame), each at the pixel its PSF sample falls in; `background`
    uniform events per frame."""
    t = np.sort(rng.integers(0, frames * DT, frames * per_frame))
    pos = np.asarray(start) + np.outer(t / DT, velocity) + rng.normal(0, psf, (len(t), 2))
    tb = rng.integers(0, frames * DT, frames * background)
    xb, yb = rng.uniform(-0.5, sensor[0] - 0.5, len(tb)), rng.uniform(-0.5, sensor[1] - 0.5, len(tb))
    t, x, y = np.r_[t, tb], np.r_[pos[:, 0], xb], np.r_[pos[:, 1], yb]
    o = np.argsort(t, kind="stable")
    inside = (np.rint(x) >= 0) & (np.rint(x) < sensor[0]) & (np.rint(y) >= 0) & (np.rint(y) < sensor[1])
    o = o[inside[o]]
    return t[o].astype(np.int64), np.rint(x[o]).astype(np.uint16), np.rint(y[o]).astype(np.uint16)


def track_rows(start, velocity, frames, track=0, offset=(0.0, 0.0)):
    """One row per frame at the frame's middle: the true position + offset."""
    r = np.zeros(frames, CENTROID_DTYPE)
    r["frame"] = np.arange(frames)
    r["t"] = r["frame"] * DT + DT // 2
    pos = np.asarray(start) + np.outer(r["t"] / DT, velocity) + offset
    r["x"], r["y"] = pos.T
    r["track"], r["sigma"], r["source"] = track, 0.1, "measured"
    return r


def cat(*parts):
    t, x, y = (np.concatenate(p) for p in zip(*parts))
    o = np.argsort(t, kind="stable")
    return t[o], x[o], y[o]


def counts_of(a):
    """A one-track histogram of offsets `a`, as across.offset_counts bins them."""
    reach = across.REACH_PX + across.MAX_SHIFT_PX
    nb = int(round(2 * reach / across.BIN_PX))
    a = a[np.abs(a) < reach]
    return np.bincount(np.minimum(((a + reach) / across.BIN_PX).astype(np.int64), nb - 1),
                       minlength=nb)[None]


@pytest.mark.parametrize("centre", [0.0, 0.3, 0.5, -0.2])
@pytest.mark.parametrize("profile", [1.0, 2.5])
def test_mean_shift_finds_the_centre_of_a_symmetric_profile_on_background(centre, profile):
    rng = np.random.default_rng(1)
    star = centre + rng.normal(0, profile, 100_000)
    noise = rng.uniform(-9, 9, 20_000)
    d = across.mean_shift(counts_of(np.r_[star, noise]), 1.5)
    assert abs(d[0] - centre) < 0.03


def test_mean_shift_on_pixel_rows_does_not_lock_onto_them():
    """A star moving along a pixel row puts its events' offsets on the rows (integers less
    its across position): a flat-topped wide profile (a bright star) and a narrow one."""
    rng = np.random.default_rng(7)
    for centre in (0.2, 0.4):
        for width in (0.9, 2.5):
            rows = np.rint(centre + rng.normal(0, width, 40_000)) - centre
            assert abs(across.mean_shift(counts_of(rows), 1.5)[0]) < 0.03


def test_mean_shift_leaves_tracks_with_too_few_events_alone():
    rng = np.random.default_rng(2)
    a = 0.4 + rng.normal(0, 1.0, across.MIN_EVENTS // 2)
    assert across.mean_shift(counts_of(a), 1.5)[0] == 0


@pytest.mark.parametrize("max_launch, device_arrays", [(None, False), (700, False), (None, True)])
def test_the_histogram_kernel_equals_its_numpy_specification(monkeypatch, max_launch,
                                                             device_arrays):
    """Tracks straight and curved, fast and slow, sharing cells, with frames missing and
    rows near the edge: the Taichi counts equal the reference's bit for bit (in one launch
    or many, on the CPU's arrays or the GPU's data path)."""
    from evstar_kernels.taichi import launch

    if max_launch:
        monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", max_launch)
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    rng = np.random.default_rng(11)
    frames, parts, rows = 40, [], []
    paths = [((30.0, 40.0), (0.2, 0.05)), ((35.0, 44.0), (0.1, -0.2)), ((10.0, 150.0), (4.0, 0.3)),
             ((200.0, 3.0), (-0.5, 0.0)), ((120.0, 100.0), (1.5, 1.5))]
    for i, (start, vel) in enumerate(paths):
        parts.append(star_events(rng, start, vel, frames, per_frame=60, background=20))
        r = track_rows(start, vel, frames, track=3 * i, offset=rng.normal(0, 0.2, 2))
        r["x"] += 0.3 * np.sin(r["frame"] / 5.0) * (i == 4)          # a curved path
        rows.append(r[rng.random(frames) > 0.15])                     # frames without a row
    rows = np.concatenate(rows)
    rows = rows[np.argsort(rows["t"], kind="stable")]
    t, x, y = cat(*parts)
    sel = np.lexsort((rows["t"], rows["track"]))
    _, g = np.unique(rows["track"][sel], return_inverse=True)
    p = np.stack([rows["x"][sel], rows["y"][sel]], 1)
    tr = rows["t"][sel].astype(np.float64)
    args = (t, x, y, 0, DT, SENSOR, rows["frame"][sel], g, p, across._velocities(tr, p, g),
            across._directions(p, g), tr, 5.5)
    ref = across.offset_counts(*args, "numpy")
    got = across.offset_counts(*args, "taichi")
    assert ref.shape == (len(paths), int(round(2 * (across.REACH_PX + across.MAX_SHIFT_PX) / across.BIN_PX)))
    assert (ref.sum(axis=1)[[0, 1, 2, 4]] > 1000).all() and ref[3].sum() == 0     # 3: at the edge
    np.testing.assert_array_equal(got, ref)


@pytest.mark.parametrize("velocity", [(0.2, 0.0), (0.15, 0.1), (3.0, -1.0)])
def test_rows_offset_across_the_motion_move_onto_the_star(velocity):
    rng = np.random.default_rng(3)
    start, frames = (60.3, 90.6), 80
    t, x, y = star_events(rng, start, velocity, frames, background=3)
    u = np.asarray(velocity) / np.hypot(*velocity)
    normal = np.array([-u[1], u[0]])
    rows = track_rows(start, velocity, frames, offset=0.25 * normal)
    out = across.refine(rows, t, x, y, 0, DT, SENSOR, 1.5)
    truth = track_rows(start, velocity, frames)
    moved = np.stack([out["x"] - rows["x"], out["y"] - rows["y"]], 1)
    np.testing.assert_allclose(moved @ u, 0, atol=1e-12)       # across only
    err_before = (np.stack([rows["x"] - truth["x"], rows["y"] - truth["y"]], 1) @ normal).mean()
    err_after = (np.stack([out["x"] - truth["x"], out["y"] - truth["y"]], 1) @ normal).mean()
    assert err_before == pytest.approx(0.25)
    assert abs(err_after) < 0.05
    for f in ("t", "track", "frame", "sigma", "source"):
        np.testing.assert_array_equal(out[f], rows[f])


def test_each_track_takes_its_own_events():
    rng = np.random.default_rng(4)
    frames = 60
    a = star_events(rng, (40.0, 50.4), (0.3, 0.0), frames, per_frame=200)
    b = star_events(rng, (40.0, 120.7), (0.3, 0.0), frames, per_frame=200)
    rows = np.concatenate([track_rows((40.0, 50.4), (0.3, 0.0), frames, 0, (0, 0.3)),
                           track_rows((40.0, 120.7), (0.3, 0.0), frames, 1, (0, -0.3))])
    rows = rows[np.argsort(rows["t"], kind="stable")]
    out = across.refine(rows, *cat(a, b), 0, DT, SENSOR, 1.5)
    for track, y in ((0, 50.4), (1, 120.7)):
        assert abs(out["y"][out["track"] == track].mean() - y) < 0.05


def test_untracked_rows_edges_and_an_off_switch_are_left_alone():
    rng = np.random.default_rng(5)
    frames = 50
    t, x, y = star_events(rng, (60.0, 2.0), (0.3, 0.0), frames)      # 2 px from the edge
    rows = track_rows((60.0, 2.0), (0.3, 0.0), frames, offset=(0, 0.3))
    loose = track_rows((150.0, 90.0), (0.0, 0.0), 3, track=-1)
    both = np.concatenate([rows, loose])
    out = across.refine(both, t, x, y, 0, DT, SENSOR, 1.5)
    np.testing.assert_array_equal(out, both)
    far = star_events(rng, (60.0, 90.0), (0.3, 0.0), frames)
    rows = track_rows((60.0, 90.0), (0.3, 0.0), frames, offset=(0, 0.3))
    np.testing.assert_array_equal(across.refine(rows, *far, 0, DT, SENSOR, 0.0), rows)
    assert not np.array_equal(across.refine(rows, *far, 0, DT, SENSOR, 1.5), rows)


def dev_star(window, estimator="crossings"):
    """The accuracy grid's development 2 °/s magnitude-5 star (seed 1): its rows' mean
    offset across the motion (y) and their mean error, px."""
    run = sim.simulate(sim.paper_preset(2.0, magnitude=5.0, psf_sigma_px=1.0), seed=1)
    cfg = Config().replace(**{"estimate.across_kernel_px": window,
                              "estimate.estimator": estimator})
    c = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
    c = c[c["track"] >= 0]
    truth = run.truth.star_position(c["t"])[:, 0]
    return (c["y"] - truth[:, 1]).mean(), np.hypot(c["x"] - truth[:, 0], c["y"] - truth[:, 1]).mean()


@pytest.mark.parametrize("estimator", ["crossings", "track"])
def test_a_slow_faint_stars_offset_across_its_motion_shrinks(estimator):
    off_across, off_err = dev_star(0.0, estimator)
    on_across, on_err = dev_star(2.0, estimator)
    assert abs(off_across) > 0.08            # the density filter's flank bias
    assert abs(on_across) < abs(off_across) / 2
    assert on_err < off_err


def test_bad_window_is_rejected_naming_it():
    with pytest.raises(ParameterError, match="estimate.across_kernel_px"):
        Config().replace(**{"estimate.across_kernel_px": -1})


def test_the_events_kept_for_it_lie_about_the_centroids_on_both_sides():
    """The store is a square of STORE_RADIUS_PX about each centroid's pixel (not about
    kept events, which for a faint star can lie on one flank), hot pixels out."""
    from evstar.events import Events

    rng = np.random.default_rng(12)
    n = 20_000
    ev = Events(np.sort(rng.integers(0, 100_000, n)), rng.integers(0, 120, n).astype(np.uint16),
                rng.integers(0, 90, n).astype(np.uint16), rng.integers(0, 2, n).astype(np.int8),
                120, 90)
    cents = np.zeros(2, CENTROID_DTYPE)
    cents["x"], cents["y"] = (30.4, 80.2), (40.6, 20.0)
    t, x, y = across.near_centroids(ev, cents)
    r = across.STORE_RADIUS_PX
    inside = ((np.abs(ev.x.astype(int) - 30) <= r) & (np.abs(ev.y.astype(int) - 41) <= r)) | \
             ((np.abs(ev.x.astype(int) - 80) <= r) & (np.abs(ev.y.astype(int) - 20) <= r))
    assert len(t) == inside.sum() > 0
    np.testing.assert_array_equal(t, ev.t[inside])
    hot = np.zeros((90, 120), bool)
    hot[41, 30] = True
    t2, x2, y2 = across.near_centroids(ev, cents, hot)
    assert len(t2) == len(t) - ((x == 30) & (y == 41)).sum() and not ((x2 == 30) & (y2 == 41)).any()


def test_no_star_of_a_dark_sky_field_moves_off():
    """A dark-sky Orion field at 12 °/s, where events kept near *kept* events (one flank
    of a faint star) once moved isolated stars 0.2-0.4 px off: every star measured within
    0.2 px without the across step stays within 0.1 px of that with it (blends' tracks,
    0.5-2.6 px off, move by up to 0.3)."""
    from evstar import accuracy

    scene = sim.field_scenario(sim.camera_preset("davis346", 16.0), 83.8, -5.4, 12.0, 0.5,
                               sensor="dark-sky", noise_hz=1.5)
    run = sim.simulate(scene, seed=61)
    per_star = []
    for kernel in (0.0, 1.5):
        rows = Pipeline(Config().replace(**{"estimate.across_kernel_px": kernel})).run(
            run.events, run.imu, run.camera).centroids
        star, err = accuracy.match(rows, run.truth.star_position)
        per_star.append({i: err[star == i].mean() for i in np.unique(star[star >= 0])})
    common = sorted(set(per_star[0]) & set(per_star[1]))
    off, on = (np.array([p[i] for i in common]) for p in per_star)
    good = off < 0.2
    assert good.sum() > 80
    assert (on - off)[good].max() < 0.1
    assert np.median(on) < np.median(off)


def _there_and_back(rng, offset_image, offset_motion, frames=40, speed=0.6, per_frame=120):
    """A star moving +x for `frames` frames, then back -x half as long (a sinusoid's two
    passes about a turn), its events sampled about the path shifted by `offset_image` px in
    +y (one side of the path in the image) and `offset_motion` px to the left of its
    motion; rows on the true path. Returns (rows, t, x, y, true y of each row)."""
    start, half = np.array([60.0, 90.4]), frames // 2
    out = star_events(rng, start + (0, offset_image + offset_motion), (speed, 0.0), frames, per_frame)
    turn = start + (speed * frames, 0.0)
    back = star_events(rng, turn + (0, offset_image - offset_motion), (-speed, 0.0), half, per_frame)
    back = (back[0] + frames * DT, back[1], back[2])
    rows = np.concatenate([track_rows(start, (speed, 0.0), frames),
                           track_rows(turn, (-speed, 0.0), half)])
    rows["frame"][frames:] += frames
    rows["t"][frames:] += frames * DT
    want = np.r_[np.full(frames, 90.4 + offset_image + offset_motion),
                 np.full(half, 90.4 + offset_image - offset_motion)]
    return rows, *cat(out, back), want


@pytest.mark.parametrize("offset_image, offset_motion", [(0.3, 0.0), (0.0, 0.3)])
def test_a_reversing_track_takes_its_offset_in_the_image_or_in_the_motion_frame(
        offset_image, offset_motion):
    """A track that turns back: an offset on one side of its path in the image (a pixel
    row's threshold) appears with opposite signs across its two passes' motion, and one
    taken in the motion's frame cancelled (the sinusoids' regressed stars of the
    thirty-seventh session's turn join); one that turns with the motion stays in it.
    Either way the rows move onto the events."""
    rng = np.random.default_rng(11)
    rows, t, x, y, want = _there_and_back(rng, offset_image, offset_motion)
    out = across.refine(rows, t, x, y, 0, DT, SENSOR, 1.5)
    assert np.abs(out["y"] - want).max() < 0.06, np.abs(out["y"] - want).max()
    np.testing.assert_array_equal(out["x"], rows["x"])        # across only (x along)
