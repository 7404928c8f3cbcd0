"""Extraction: per-frame DBSCAN centroids and multi-target tracks on synthetic scenes."""
import numpy as np
import pytest

from evstar import Events, io
from evstar.extract import Extractor
from evstar.tracking import Tracker


def blob_scene(stars, width=200, height=150, duration_us=100_000, per_frame=60, noise=300,
               sigma=0.7, seed=0, dt_us=10_000):
    """Gaussian event blobs moving linearly: stars = [(x0, y0, vx px/s, vy px/s)]. Returns
    events and a truth function (star, t) -> (x, y)."""
    rng = np.random.default_rng(seed)
    ts, xs, ys = [], [], []
    n = per_frame * duration_us // dt_us
    for x0, y0, vx, vy in stars:
        t = rng.integers(0, duration_us, n)
        ts.append(t)
        xs.append(x0 + vx * t * 1e-6 + rng.normal(0, sigma, n))
        ys.append(y0 + vy * t * 1e-6 + rng.normal(0, sigma, n))
    ts.append(rng.integers(0, duration_us, noise))
    xs.append(rng.uniform(-0.5, width - 0.5, noise))
    ys.append(rng.uniform(-0.5, height - 0.5, noise))
    t, x, y = (np.concatenate(a) for a in (ts, xs, ys))
    inside = (np.round(x) >= 0) & (np.round(x) < width) & (np.round(y) >= 0) & (np.round(y) < height)
    t, x, y = t[inside], np.round(x[inside]), np.round(y[inside])
    o = np.argsort(t, kind="stable")
    ev = Events(t[o], x[o], y[o], rng.integers(0, 2, len(o)), width, height)
    return ev, lambda k, tt: (stars[k][0] + stars[k][2] * tt * 1e-6, stars[k][1] + stars[k][3] * tt * 1e-6)


def test_static_star_centroid_is_subpixel_accurate():
    ev, truth = blob_scene([(50.3, 40.7, 0, 0)], noise=50)
    c = Extractor(min_samples=8).centroids(ev)
    assert len(c) == 10  # one per frame
    assert np.all(np.abs(c["x"] - 50.3) < 0.3) and np.all(np.abs(c["y"] - 40.7) < 0.3)
    assert np.all(c["n_events"] >= 40)


def test_moving_star_mean_time_matches_truth_better_than_frame_mid():
    ev, truth = blob_scene([(20, 30, 900, 300)], per_frame=80, noise=0, seed=1)
    err = {}
    for ref in ("mean", "mid"):
        c = Extractor(min_samples=5, time_ref=ref, t_origin_us=0).centroids(ev)
        tx, ty = truth(0, c["t"])
        err[ref] = np.hypot(c["x"] - tx, c["y"] - ty).mean()
    assert err["mean"] < 0.3
    assert err["mean"] <= err["mid"] + 0.05


def test_frame_mid_time_convention():
    ev, _ = blob_scene([(50, 40, 0, 0)], noise=0)
    c = Extractor(time_ref="mid", t_origin_us=0).centroids(ev)
    assert np.array_equal(c["t"], c["frame"] * 10_000 + 5_000)


def test_empty_and_all_noise_input():
    ex = Extractor(min_samples=5)
    assert len(ex.centroids(Events.empty(10, 10))) == 0
    rng = np.random.default_rng(3)
    n = 200
    noise = Events(np.sort(rng.integers(0, 100_000, n)), rng.integers(0, 640, n),
                   rng.integers(0, 480, n), np.ones(n), 640, 480)
    assert len(ex.centroids(noise)) == 0


def test_border_flag_and_min_cluster_size():
    ev, _ = blob_scene([(0.4, 70, 0, 0), (100, 70, 0, 0)], noise=0, per_frame=30)
    c = Extractor(min_samples=4).centroids(ev)
    near = c["x"] < 5
    assert near.any() and np.all(c["border"][near]) and not np.any(c["border"][~near])
    assert len(Extractor(min_samples=4, min_cluster_size=10_000).centroids(ev)) == 0


def test_members_are_the_events_of_the_clusters_that_gave_rows():
    # a star, two close ones (split: their halves hold all their events) and noise
    ev, _ = blob_scene([(30, 30, 0, 0), (100, 50, 0, 0), (103.5, 50, 0, 0)], noise=300,
                       per_frame=150, sigma=0.5)
    ex = Extractor(eps=2.5, min_samples=5, min_cluster_size=20)
    cents, used = ex.centroids_and_members(ev)
    frames, labels = ex.labels(ev)
    assert cents["split"].any()
    assert used.sum() == cents["n_events"].sum()   # each used event is in exactly one row
    assert not used[labels < 0].any()              # DBSCAN's noise: left for the second look
    # a cluster too small for a row leaves its events too
    small = Extractor(eps=2.5, min_samples=5, min_cluster_size=10_000)
    none, unused = small.centroids_and_members(ev)
    assert len(none) == 0 and not unused.any() and (labels >= 0).any()


def test_two_stars_closer_than_eps_are_split_and_flagged():
    ev, _ = blob_scene([(60, 50, 0, 0), (63.5, 50, 0, 0)], noise=0, per_frame=150, sigma=0.5)
    merged = Extractor(eps=2.5, min_samples=5, split_valley=None).centroids(ev)
    assert np.all(np.abs(merged["x"] - 61.75) < 0.5)  # DBSCAN alone merges them
    c = Extractor(eps=2.5, min_samples=5).centroids(ev)
    assert len(c) == 20 and np.all(c["split"])
    xs = np.sort(c["x"].reshape(10, 2), axis=1)
    assert np.all(np.abs(xs[:, 0] - 60) < 0.4) and np.all(np.abs(xs[:, 1] - 63.5) < 0.4)


def test_three_stars_closer_than_eps_are_split_into_three():
    # DBSCAN merges them; one split leaves two in a half, which is split again
    truth = np.array([(60.0, 50.0), (66.0, 50.0), (63.0, 55.5)])
    ev, _ = blob_scene([(x, y, 0, 0) for x, y in truth], noise=0, per_frame=150, sigma=1.0)
    assert len(Extractor(eps=2.5, min_samples=5, split_valley=None).centroids(ev)) == 10
    c = Extractor(eps=2.5, min_samples=5).centroids(ev)
    assert len(c) == 30 and np.all(c["split"])
    xy = np.column_stack([c["x"], c["y"]])
    d = np.hypot(*(xy[:, None] - truth[None]).transpose(2, 0, 1))
    assert np.all(d.min(1) < 0.4) and np.all(np.bincount(d.argmin(1), minlength=3) == 10)
    # the reference path (scikit-learn's DBSCAN, split cluster by cluster) agrees
    ref = Extractor(eps=2.5, min_samples=5, clustering="sklearn").centroids(ev)
    assert np.allclose(np.sort(ref["x"]), np.sort(c["x"]))


@pytest.mark.parametrize("offset", [0.0, 0.3])
def test_halves_split_again_all_at_once_as_half_by_half(monkeypatch, offset):
    # the grid path splits every split's halves again in one batch (_pieces_many): the same
    # rows, bit for bit, as _pieces half by half, on pixels and on float coordinates (offset:
    # the coordinates moved as compensation moves them)
    from evstar import extract

    stars = [(60.0, 50.0, 0, 0), (66.0, 50.0, 0, 0), (63.0, 55.5, 0, 0), (120, 60, 0, 0),
             (124, 61, 0, 0), (80, 110, 0, 0), (85, 108, 0, 0), (82.5, 104, 0, 0)]
    ev, _ = blob_scene(stars, noise=200, per_frame=150, sigma=1.0, seed=4)
    rng = np.random.default_rng(5)
    xy = np.column_stack([ev.x, ev.y]) + offset * rng.uniform(-1, 1, (len(ev), 2))
    ex = Extractor(eps=2.5, min_samples=5)
    batched = ex.centroids(ev, xy=xy)
    assert (batched["split"].sum() >= 30)

    def half_by_half(self, pts, p, halves):
        return [(n, half, piece) for n, half, idx in halves
                for piece in self._pieces(pts, p, idx, extract._RESPLITS)]

    monkeypatch.setattr(Extractor, "_pieces_many", half_by_half)
    assert batched.tobytes() == ex.centroids(ev, xy=xy).tobytes()


def test_single_wide_star_is_not_split():
    ev, _ = blob_scene([(60, 50, 0, 0)], noise=0, per_frame=300, sigma=1.2)
    c = Extractor(eps=2.5, min_samples=5).centroids(ev)
    assert len(c) == 10 and not c["split"].any()


def test_weightings_differ_only_where_they_should():
    ev, _ = blob_scene([(50, 40, 0, 0)], noise=0)
    a = Extractor(weighting="events").centroids(ev)
    for w in ("pixels", "polarity"):
        b = Extractor(weighting=w).centroids(ev)
        assert np.all(np.hypot(a["x"] - b["x"], a["y"] - b["y"]) < 0.5)


def test_xy_override_uses_float_coordinates():
    ev, _ = blob_scene([(50, 40, 0, 0)], noise=0)
    shifted = np.column_stack([ev.x + 0.25, ev.y - 0.5]).astype(float)
    a, b = Extractor().centroids(ev), Extractor().centroids(ev, xy=shifted)
    np.testing.assert_allclose(b["x"] - a["x"], 0.25)
    np.testing.assert_allclose(b["y"] - a["y"], -0.5)
    with pytest.raises(ValueError, match="xy must have shape"):
        Extractor().centroids(ev, xy=shifted[:3])


@pytest.mark.parametrize("kw,name", [({"eps": 0}, "eps"), ({"min_samples": 0}, "min_samples"),
                                     ({"dt_us": -1}, "dt_us"), ({"weighting": "x"}, "weighting"),
                                     ({"time_ref": "end"}, "time_ref")])
def test_bad_parameters_name_themselves(kw, name):
    with pytest.raises(ValueError, match=name):
        Extractor(**kw)


def test_tracks_many_targets_with_gaps_and_entries():
    stars = [(20 + 15 * k, 20 + 10 * k, 300, 100) for k in range(8)] + [(-10, 120, 600, 0)]
    ev, truth = blob_scene(stars, width=300, height=200, duration_us=300_000, per_frame=40, noise=500)
    # a gap: drop star 0's events in frames 10-11
    x0 = truth(0, ev.t)[0]
    gap = (ev.t >= 100_000) & (ev.t < 120_000) & (np.abs(ev.x - x0) < 4) & (np.abs(ev.y - truth(0, ev.t)[1]) < 4)
    ev = ev[~gap]
    c = Tracker(max_gap=3).link(Extractor(min_samples=6).centroids(ev))
    good = c[c["track"] >= 0]
    # each true star maps to exactly one track id over its life
    for k in range(9):
        tx, ty = truth(k, good["t"])
        mine = good[np.hypot(good["x"] - tx, good["y"] - ty) < 1.5]
        assert len(np.unique(mine["track"])) == 1 and len(mine) >= 25
    assert mine["x"].min() < 10  # star 8 entered from the left edge and kept its id
    assert len(np.unique(good["track"])) == 9


def test_centroid_csv_round_trip(tmp_path):
    ev, _ = blob_scene([(50, 40, 100, 0), (120, 90, 0, 50)])
    c = Tracker().link(Extractor().centroids(ev))
    io.write_centroids(tmp_path / "c.csv", c)
    assert (tmp_path / "c.csv").read_text().splitlines()[0].startswith("t,x,y,track,n_events,frame")
    back = io.read_centroids(tmp_path / "c.csv")
    np.testing.assert_array_equal(back["track"], c["track"])
    np.testing.assert_allclose(back["x"], c["x"], atol=1e-4)


def lobed_star_events(x0, y0, vx, n_per_frame, rng, duration_us=100_000, lobe=1.0, sigma=0.6):
    """A star moving along x: ON events lead it by `lobe` px, OFF events trail it."""
    n = n_per_frame * duration_us // 10_000
    t = rng.integers(0, duration_us, n)
    p = rng.integers(0, 2, n)
    x = x0 + vx * t * 1e-6 + np.where(p == 1, lobe, -lobe) + rng.normal(0, sigma, n)
    y = y0 + rng.normal(0, sigma, n)
    return t, x, y, p


def test_faint_star_beside_a_bright_one_is_split_not_merged():
    # a faint star 6 px ahead of a bright one along their motion: the split is seeded at
    # the two peaks of each polarity's image (2-means would halve the bright star)
    rng = np.random.default_rng(5)
    parts = [lobed_star_events(60, 50, 200, 300, rng, lobe=1.5),
             lobed_star_events(66, 50, 200, 40, rng, lobe=1.5)]
    t, x, y, p = (np.concatenate(c) for c in zip(*parts))
    o = np.argsort(t, kind="stable")
    ev = Events(t[o], np.round(x[o]), np.round(y[o]), p[o], 200, 150)
    assert len(Extractor(split_valley=None).centroids(ev)) == 10  # DBSCAN merges them
    # polarity weighting: the faint star's 40 events split unevenly between its ON and
    # OFF lobes, which the plain mean would turn into up to ~0.7 px of error
    c = Extractor(weighting="polarity").centroids(ev)
    assert len(c) == 20 and c["split"].all()
    pairs = c[np.argsort(c["frame"] * 1000 + c["x"], kind="stable")].reshape(-1, 2)
    for k in (0, 1):
        true_x = 60 + 6 * k + 200 * pairs["t"][:, k] * 1e-6
        assert np.all(np.abs(pairs["x"][:, k] - true_x) < 0.3)
    assert np.all(pairs["n_events"][:, 0] > 3 * pairs["n_events"][:, 1])


def test_lobed_moving_star_stays_whole():
    rng = np.random.default_rng(6)
    t, x, y, p = lobed_star_events(60, 50, 300, 300, rng, lobe=1.5)
    o = np.argsort(t, kind="stable")
    ev = Events(t[o], np.round(x[o]), np.round(y[o]), p[o], 200, 150)
    c = Extractor().centroids(ev)
    assert len(c) == 10 and not c["split"].any()


def test_pixels_weighting_counts_each_distinct_pixel_once():
    # a 3x3 star centred on (20, 30) plus a hot pixel at its corner firing 40 times
    xs, ys = np.meshgrid(np.arange(19, 22), np.arange(29, 32))
    x = np.r_[xs.ravel(), np.full(40, 21)]
    y = np.r_[ys.ravel(), np.full(40, 31)]
    t = np.arange(len(x)) * 10
    ev = Events(t, x, y, np.ones(len(x), int), 64, 48)
    by_pixels = Extractor(weighting="pixels", min_samples=3).centroids(ev)
    by_events = Extractor(weighting="events", min_samples=3).centroids(ev)
    assert len(by_pixels) == len(by_events) == 1
    np.testing.assert_allclose([by_pixels["x"][0], by_pixels["y"][0]], [20.0, 30.0], atol=1e-9)
    assert by_events["x"][0] > 20.5 and by_events["y"][0] > 30.5  # pulled to the hot pixel


def lobed_stars(rows_y, vx, n_per_frame, seed, across=1.2, lobe=1.5, duration_us=100_000):
    """Events of stars at heights rows_y moving together along x at vx px/s, ON events
    `lobe` px ahead and OFF behind, their profile `across` px wide across the motion."""
    rng = np.random.default_rng(seed)
    parts = []
    for y0 in rows_y:
        t, x, _, p = lobed_star_events(40, 0, vx, n_per_frame, rng, duration_us, lobe, 0.8)
        parts.append((t, x, y0 + rng.normal(0, across, len(t)), p))
    t, x, y, p = (np.concatenate(c) for c in zip(*parts))
    o = np.argsort(t, kind="stable")
    return Events(t[o], np.round(x[o]), np.round(y[o]), p[o], 200, 150)


def test_stars_side_by_side_across_their_motion_are_split():
    # 5.5 px apart across the motion, each star's events 1.2 px wide across it: a streak
    # cut in two would need ~5.9 px (2·sqrt(3) + chance, x the halves' spread), a blob 4.4
    ev = lobed_stars((60.0, 65.5), 300, 60, seed=2)
    out = {k: Extractor(clustering=k).centroids(ev) for k in ("grid", "sklearn")}
    for c in out.values():
        assert len(c) == 20 and c["split"].all()
        y = np.sort(c["y"].reshape(10, 2), axis=1)
        assert np.all(np.abs(y[:, 0] - 60) < 0.4) and np.all(np.abs(y[:, 1] - 65.5) < 0.4)
    for name in ("t", "frame", "n_events", "n_on"):   # the batched split is the per-cluster one
        np.testing.assert_array_equal(out["grid"][name], out["sklearn"][name])
    np.testing.assert_allclose(out["grid"]["y"], out["sklearn"]["y"], rtol=0, atol=1e-9)


def test_a_single_fast_star_is_not_cut_along_or_across_its_motion():
    # 15 px per frame along x: a long streak of both polarities, 1.2 px wide across
    ev = lobed_stars((60.0,), 1500, 300, seed=3)
    for clustering in ("grid", "sklearn"):
        c = Extractor(clustering=clustering).centroids(ev)
        assert not c["split"].any() and len(c) == 10, clustering
