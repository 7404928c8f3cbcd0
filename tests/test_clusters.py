"""Grid DBSCAN: the numpy reference equals scikit-learn's weighted DBSCAN, the Taichi kernels
equal the reference, and the Extractor gives the same centroids with either backend."""
import numpy as np
import pytest
from sklearn.cluster import DBSCAN

import evstar
from evstar import Config, ParameterError
from evstar.extract import Extractor
from evstar_kernels.reference import clusters as ref
from evstar_kernels.taichi import clusters_launch, launch
from evstar_kernels.taichi.scratch import Scratch

EPS = [0.5, 1.0, 1.5, 2.5, 3.2, 7.5]


def ti():
    return evstar.backends.taichi("cpu")


def random_frames(seed, n, n_frames=4, width=40, height=25, hot=0.3):
    """Events spread over frames; a share piled on a few pixels (weights > 1) and negative x."""
    rng = np.random.default_rng(seed)
    frame = np.sort(rng.integers(0, n_frames, n))
    x, y = rng.integers(-3, width, n), rng.integers(0, height, n)
    on = rng.random(n) < hot
    x[on], y[on] = rng.integers(5, 9, on.sum()), rng.integers(5, 9, on.sum())
    return frame, x, y


def star_frames(seed, n_frames=6, stars=8, per_star=60, noise=150, width=120, height=90):
    """Gaussian blobs (some pairs close enough to touch) plus uniform noise, per frame."""
    rng = np.random.default_rng(seed)
    fs, xs, ys = [], [], []
    for f in range(n_frames):
        centres = rng.uniform(5, [width - 5, height - 5], (stars, 2))
        centres[1] = centres[0] + (3.5, 0.5)  # a close pair
        pts = np.concatenate([c + rng.normal(0, 0.8, (per_star, 2)) for c in centres])
        pts = np.concatenate([pts, rng.uniform(0, [width, height], (noise, 2))])
        fs.append(np.full(len(pts), f))
        xs.append(np.round(pts[:, 0]))
        ys.append(np.round(pts[:, 1]))
    return (np.concatenate(a).astype(np.int64) for a in (fs, xs, ys))


def sklearn_labels(frame, x, y, eps, min_samples):
    cf, cx, cy, weight, inverse = ref.cells(frame, x, y)
    pts = np.column_stack([cx, cy, cf * 1e6]).astype(np.float64)
    labels = DBSCAN(eps=eps, min_samples=min_samples).fit_predict(pts, sample_weight=weight)
    return labels[inverse]


@pytest.mark.parametrize("seed", range(12))
def test_reference_equals_sklearn_on_random_frames(seed):
    rng = np.random.default_rng(100 + seed)
    frame, x, y = random_frames(seed, int(rng.integers(1, 500)))
    eps, min_samples = float(rng.choice(EPS)), int(rng.integers(1, 12))
    labels = ref.dbscan_events(frame, x, y, eps, min_samples)
    # the tie rule (a border cell joins the cluster whose first core comes first) is
    # scikit-learn's own: labels are equal, border cells included
    np.testing.assert_array_equal(labels, sklearn_labels(frame, x, y, eps, min_samples))
    assert labels.max() >= 0 or min_samples > 1


@pytest.mark.parametrize("seed,eps,min_samples", [(0, 2.5, 5), (1, 2.5, 8), (2, 1.5, 3), (3, 3.2, 12)])
def test_reference_equals_sklearn_on_star_frames(seed, eps, min_samples):
    frame, x, y = star_frames(seed)
    labels = ref.dbscan_events(frame, x, y, eps, min_samples)
    np.testing.assert_array_equal(labels, sklearn_labels(frame, x, y, eps, min_samples))
    assert labels.max() >= 5 * 6  # most stars of the six frames are found


def test_reference_border_tie_goes_to_the_first_cluster():
    # cores A (0, 0) and B (2, 2), each made core by a partner C cannot see; the border
    # cell C (2, 0) is 2 px from both and joins A's cluster (first core in (y, x) order)
    cells = {(-1, 0): 5, (0, 0): 4, (2, 2): 4, (2, 3): 5, (2, 0): 1}
    x = np.repeat([c[0] for c in cells], list(cells.values()))
    y = np.repeat([c[1] for c in cells], list(cells.values()))
    frame = np.zeros(len(x), int)
    labels = ref.dbscan_events(frame, x, y, 2.0, 10)
    np.testing.assert_array_equal(labels, [0] * 9 + [1] * 9 + [0])
    np.testing.assert_array_equal(labels, sklearn_labels(frame, x, y, 2.0, 10))
    np.testing.assert_array_equal(run_kernels(frame, x, y, 2.0, 10)[0], labels)


def offsets_of(frame):
    return np.searchsorted(frame, np.arange(frame[0], frame[-1] + 2))


def run_kernels(frame, x, y, eps, min_samples, scratch=None, schedule="auto"):
    labels, first, roots = clusters_launch.dbscan(ti(), offsets_of(frame), x, y, eps, min_samples,
                                                  scratch=scratch or Scratch(), schedule=schedule)
    # each cluster's root: the first event of its first cell, in (frame, y, x) order
    np.testing.assert_array_equal(labels[roots], np.arange(len(roots)))
    assert np.all(first[roots] == roots)
    assert np.all(np.diff(frame[roots] * 10**6 + y[roots] * 1000 + x[roots]) > 0)
    return labels, first


@pytest.fixture
def small_launches(monkeypatch):
    """Many launches, many batches of planes, and the device-array (CUDA) data path."""
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 150)
    monkeypatch.setattr(clusters_launch, "GRID_BYTES", 2_000)
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", True)


@pytest.mark.parametrize("schedule,layout", [("lanes", "plain"), ("lanes", "small_launches"),
                                             ("events", "plain"), ("events", "small_launches")])
@pytest.mark.parametrize("seed", range(5))
def test_kernels_equal_reference(seed, schedule, layout, request):
    if layout == "small_launches":
        request.getfixturevalue("small_launches")
    rng = np.random.default_rng(200 + seed)
    frame, x, y = random_frames(seed, int(rng.integers(1, 600)), n_frames=int(rng.integers(1, 6)))
    eps, min_samples = EPS[seed % len(EPS)], int(rng.integers(1, 12))
    labels, first = run_kernels(frame, x, y, eps, min_samples, schedule=schedule)
    np.testing.assert_array_equal(labels, ref.dbscan_events(frame, x, y, eps, min_samples))
    # first: the cell's first event
    assert np.all(first <= np.arange(len(x)))
    assert np.all((x[first] == x) & (y[first] == y) & (frame[first] == frame))
    # moments: integer sums exact (integer coordinates are summed exactly too)
    t = np.sort(rng.integers(0, 50_000, len(x))) + 10**12
    p = rng.integers(0, 2, len(x)).astype(np.int8)
    frame_t0 = 10**12 + np.arange(frame[-1] - frame[0] + 1) * 10_000
    k = int(labels.max()) + 1
    want = ref.cluster_moments(labels, frame - frame[0], x, y, t, p, frame_t0,
                               first == np.arange(len(x)))
    got = clusters_launch.moments(ti(), offsets_of(frame), labels, first, x.astype(float),
                                  y.astype(float), t, p, frame_t0, k)
    assert set(got) == set(want)
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_kernel_float_coordinates_and_scratch_reuse():
    frame, x, y = star_frames(4)
    scratch = Scratch()
    for eps, schedule in ((2.5, "lanes"), (1.5, "events"), (2.5, "events"), (1.5, "lanes")):
        # scratch planes come back clean after every call
        labels, first = run_kernels(frame, x, y, eps, 5, scratch, schedule)
        np.testing.assert_array_equal(labels, ref.dbscan_events(frame, x, y, eps, 5))
    rng = np.random.default_rng(0)
    xf, yf = x + rng.uniform(-0.5, 0.5, len(x)), y + rng.uniform(-0.5, 0.5, len(x))
    t, p = np.arange(len(x)), rng.integers(0, 2, len(x)).astype(np.int8)
    frame_t0 = np.zeros(frame[-1] + 1, np.int64)
    k = int(labels.max()) + 1
    want = ref.cluster_moments(labels, frame, xf, yf, t, p, frame_t0, first == np.arange(len(x)))
    got = clusters_launch.moments(ti(), offsets_of(frame), labels, first, xf, yf, t, p, frame_t0, k)
    for name in want:
        np.testing.assert_allclose(got[name], want[name], rtol=1e-12, err_msg=name)


def test_empty_and_all_noise():
    z = np.zeros(0, np.int64)
    labels, first, roots = clusters_launch.dbscan(ti(), np.zeros(1, np.int64), z, z, 2.5, 5,
                                                  scratch=Scratch())
    assert len(labels) == len(first) == len(roots) == 0
    labels, _ = run_kernels(np.zeros(3, int), np.array([0, 10, 20]), np.zeros(3, int), 2.5, 2)
    np.testing.assert_array_equal(labels, [-1, -1, -1])
    assert clusters_launch.moments(ti(), np.array([0, 3]), labels, np.arange(3), np.zeros(3),
                                   np.zeros(3), np.zeros(3, np.int64), np.zeros(3, np.int8),
                                   np.zeros(1, np.int64), 0)["n"].shape == (0, 2)


@pytest.mark.parametrize("device_arrays", [False, True])
def test_peak_screen_passes_every_cluster_with_two_peaks(device_arrays, monkeypatch):
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    frame, x, y = star_frames(5, n_frames=8, per_star=80)
    labels, first = run_kernels(frame, x, y, 2.5, 5)
    k = int(labels.max()) + 1
    p = np.random.default_rng(0).integers(0, 2, len(x)).astype(np.int8)
    m = ref.cluster_moments(labels, frame, x, y, np.zeros(len(x), np.int64), p,
                            np.zeros(frame[-1] + 1, np.int64))
    every = np.ones(k, bool)
    maybe, both = clusters_launch.peak_screen(ti(), offsets_of(frame), labels, x, y, p, m["box"],
                                              every, every)
    pts = np.column_stack([x, y]).astype(float)

    def exact(c, q=None):
        sel = (labels == c) & ((p == q) if q is not None else True)
        return sel.any() and ref.two_peaks(pts[sel]) is not None

    two = np.array([exact(c) for c in range(k)])
    slack = np.array([ref.maybe_two_peaks(pts[labels == c]) for c in range(k)])
    assert np.all(maybe[two]) and np.all(slack[two])  # never rules out a split
    np.testing.assert_array_equal(maybe, slack)
    assert two.any() and not maybe.all()  # it does rule out some
    two_each = np.array([exact(c, 0) and exact(c, 1) for c in range(k)])
    assert np.all(both[two_each & two]) and not np.any(both & ~maybe)
    assert (both & ~two_each).sum() < both.sum()
    # clusters not screened, or not asked for their polarities
    none = np.zeros(k, bool)
    assert not any(a.any() for a in clusters_launch.peak_screen(
        ti(), offsets_of(frame), labels, x, y, p, m["box"], none, every))
    assert not clusters_launch.peak_screen(ti(), offsets_of(frame), labels, x, y, p, m["box"],
                                           every, none)[1].any()


def blob_events(seed=0, stars=((50, 40, 0, 0), (120, 60, 300, 100), (60, 90, 0, 0), (63.5, 90, 0, 0)),
                per_frame=120, noise=300):
    rng = np.random.default_rng(seed)
    ts, xs, ys = [], [], []
    for x0, y0, vx, vy in stars:
        t = rng.integers(0, 100_000, per_frame * 10)
        ts.append(t)
        xs.append(x0 + vx * t * 1e-6 + rng.normal(0, 0.6, len(t)))
        ys.append(y0 + vy * t * 1e-6 + rng.normal(0, 0.6, len(t)))
    ts.append(rng.integers(0, 100_000, noise))
    xs.append(rng.uniform(0, 199, noise))
    ys.append(rng.uniform(0, 149, noise))
    t, x, y = (np.concatenate(a) for a in (ts, xs, ys))
    o = np.argsort(t, kind="stable")
    return evstar.Events(t[o], np.round(x[o]), np.round(y[o]), rng.integers(0, 2, len(o)), 200, 150)


@pytest.mark.parametrize("kw", [{}, {"weighting": "pixels"}, {"weighting": "polarity"},
                                {"time_ref": "mid", "t_origin_us": -5}, {"split_valley": None},
                                {"eps": 1.5, "min_samples": 3, "min_cluster_size": 20}])
def test_extractor_backends_agree(kw):
    ev = blob_events()
    grid = Extractor(clustering="grid", **kw).centroids(ev)
    skl = Extractor(clustering="sklearn", **kw).centroids(ev)
    assert len(grid) == len(skl) > 0
    for name in ("t", "frame", "n_events", "border", "split", "track", "source"):
        np.testing.assert_array_equal(grid[name], skl[name], err_msg=name)
    for name in ("x", "y", "spread"):
        np.testing.assert_allclose(grid[name], skl[name], rtol=0, atol=1e-9, err_msg=name)
    if kw.get("split_valley", 0.35) is not None:
        assert grid["split"].sum() >= 10  # the close pair is split in every frame


def test_extractor_backends_agree_on_float_coordinates():
    ev = blob_events(1)
    rng = np.random.default_rng(1)
    xy = np.column_stack([ev.x, ev.y]) + rng.uniform(-0.49, 0.49, (len(ev), 2))
    for w in ("events", "pixels"):
        grid = Extractor(weighting=w).centroids(ev, xy=xy)
        skl = Extractor(weighting=w, clustering="sklearn").centroids(ev, xy=xy)
        np.testing.assert_array_equal(grid["n_events"], skl["n_events"])
        np.testing.assert_allclose(grid["x"], skl["x"], atol=1e-9)
        np.testing.assert_allclose(grid["spread"], skl["spread"], atol=1e-9)


def test_extractor_labels_equal():
    ev = blob_events(2)
    f1, a = Extractor().labels(ev)
    f2, b = Extractor(clustering="sklearn").labels(ev)
    np.testing.assert_array_equal(f1, f2)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("kw,name", [({"clustering": "dbscan"}, "clustering"),
                                     ({"clustering": None}, "clustering"),
                                     ({"device": "tpu"}, "device"), ({"eps": -1}, "eps"),
                                     ({"min_samples": 0}, "min_samples")])
def test_bad_parameters_are_rejected(kw, name):
    with pytest.raises(ParameterError, match=name):
        Extractor(**kw)


def test_config_declares_the_clustering_backend():
    assert Config().extract.clustering == "grid"
    assert Config().replace(**{"extract.clustering": "sklearn"}).extract.clustering == "sklearn"
    with pytest.raises(ParameterError, match="clustering"):
        Config().replace(**{"extract.clustering": "kmeans"})


def clustered_points(seed, **frames):
    """(points grouped by DBSCAN cluster, each cluster's start and stop) of star_frames."""
    frame, x, y = star_frames(seed, **frames)
    labels = ref.dbscan_events(frame, x, y, 2.5, 5)
    order = np.argsort(labels, kind="stable")
    order = order[labels[order] >= 0]
    pts = np.column_stack([x, y]).astype(float)[order]
    bounds = np.flatnonzero(np.r_[True, np.diff(labels[order]) != 0, True])
    return pts, bounds[:-1], bounds[1:]


def test_batched_split_steps_equal_the_per_cluster_ones():
    from evstar import splitting
    from evstar.extract import _two_means

    pts, starts, stops = clustered_points(7, n_frames=10, per_star=120)
    has, a, b = splitting.two_peaks_many(pts, starts, stops)
    lab = splitting.two_means_many(pts, starts, stops, a, b)
    n_two = 0
    for j, (s, e) in enumerate(zip(starts, stops)):
        seeds = ref.two_peaks(pts[s:e])
        assert has[j] == (seeds is not None)
        if seeds is not None:
            n_two += 1
            np.testing.assert_array_equal(a[j], seeds[0])
            np.testing.assert_array_equal(b[j], seeds[1])
            np.testing.assert_array_equal(lab[s:e], _two_means(pts[s:e], *seeds))
    assert 5 <= n_two < len(starts)
    # sub-pixel (compensated) coordinates: the same peaks (their image is of rounded
    # pixels) and the same 2-means labels (centres equal to the last bits)
    fpts = pts + np.random.default_rng(3).uniform(-0.49, 0.49, pts.shape)
    has_f, a_f, b_f = splitting.two_peaks_many(fpts, starts, stops)
    np.testing.assert_array_equal(has_f, has)
    lab_f = splitting.two_means_many(fpts, starts, stops, a_f, b_f, integral=False)
    for j, (s, e) in enumerate(zip(starts, stops)):
        if has[j]:
            np.testing.assert_array_equal(lab_f[s:e], _two_means(fpts[s:e], a_f[j], b_f[j]))


@pytest.mark.parametrize("device_arrays", [False, True])
def test_two_means_kernel_equals_numpy(device_arrays, monkeypatch):
    """The Taichi 2-means (a thread per cluster) gives the numpy batched form's labels, on
    whole pixels and on sub-pixel points."""
    from evstar import backends, splitting
    from evstar_kernels.taichi import clusters_launch, launch

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    frame, x, y = star_frames(8, n_frames=10, per_star=120)
    labels = ref.dbscan_events(frame, x, y, 2.5, 5)
    order = np.argsort(labels, kind="stable")
    order = order[labels[order] >= 0]
    bounds = np.flatnonzero(np.r_[True, np.diff(labels[order]) != 0, True])
    starts, stops = bounds[:-1], bounds[1:]
    ti = backends.taichi("cpu")
    for pts, integral in ((np.column_stack([x, y]).astype(float)[order], True),
                          (np.column_stack([x, y])[order] + np.random.default_rng(4).uniform(
                              -0.49, 0.49, (len(order), 2)), False)):
        has, a, b = splitting.two_peaks_many(pts, starts, stops)
        want = splitting.two_means_many(pts, starts, stops, a, b, integral=integral)
        got = clusters_launch.two_means(ti, pts, starts, stops, a, b)
        keep = np.repeat(has, stops - starts)   # clusters with two seeds
        np.testing.assert_array_equal(got[keep], want[keep])
        assert 0 < got[keep].mean() < 1


def test_whole_pixel_float_coordinates_give_the_pixel_results():
    # the pipeline passes uncompensated coordinates as floats: the same centroids
    ev = blob_events(3)
    xy = np.column_stack([ev.x, ev.y]).astype(float)
    a, b = Extractor().centroids(ev), Extractor().centroids(ev, xy=xy)
    c = Extractor(clustering="sklearn").centroids(ev, xy=xy)
    assert a["split"].any()
    for name in ("t", "x", "y", "n_events", "split", "spread"):
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
        np.testing.assert_array_equal(b[name], c[name], err_msg=name)


def peak_clusters(seed):
    """Point sets whose smoothed images have every kind of maxima: Gaussian blobs, close
    pairs, symmetric count patterns (exact ties) and single pixels."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(300):
        n = int(rng.integers(1, 150))
        kind = i % 4
        if kind == 0:
            pts = rng.normal(0, rng.uniform(0.3, 3), (n, 2))
        elif kind == 1:
            pts = np.concatenate([rng.normal(0, 0.8, (n, 2)),
                                  rng.normal(0, 0.8, (n // 2 + 1, 2)) + rng.uniform(1, 6, 2)])
        elif kind == 2:  # mirror-symmetric: equal smoothed values at mirrored pixels
            base = rng.integers(0, 4, (max(1, n // 10), 2))
            pts = np.concatenate([base, -base, base * [1, -1], base * [-1, 1]]).astype(float)
        else:
            pts = np.zeros((int(rng.integers(1, 4)), 2))
        out.append(np.round(pts) + rng.integers(10, 30, 2))
    return out


@pytest.mark.parametrize("seed", range(3))
def test_certain_two_peaks_is_two_peaks_where_decided(seed):
    status = []
    for pts in peak_clusters(seed):
        s, a, b = ref.certain_two_peaks(pts)
        want = ref.two_peaks(pts)
        status.append(s)
        if s == ref.PEAKS_NONE:
            assert want is None
        elif s == ref.PEAKS_FOUND:
            np.testing.assert_array_equal(a, want[0])
            np.testing.assert_array_equal(b, want[1])
    status = np.array(status)
    # symmetric patterns leave some undecided; blobs and pairs are decided
    assert (status == ref.PEAKS_UNSURE).any() and (status == ref.PEAKS_FOUND).sum() > 100
    assert (status == ref.PEAKS_NONE).sum() > 50


@pytest.mark.parametrize("device_arrays", [False, True])
def test_peak_screen_peaks_equal_the_reference(device_arrays, monkeypatch):
    """The screen's certain peaks (all events, OFF, ON) are certain_two_peaks' of the same
    events; where the screen rules an image out, two_peaks is None."""
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    groups = peak_clusters(7)
    rng = np.random.default_rng(8)
    pts = np.concatenate(groups)
    k = len(groups)
    labels = np.repeat(np.arange(k), [len(g) for g in groups])
    x, y = pts[:, 0].astype(np.int64), pts[:, 1].astype(np.int64)
    p = rng.integers(0, 2, len(x)).astype(np.int8)
    m = ref.cluster_moments(labels, np.zeros(len(x), np.int64), x, y, np.zeros(len(x), np.int64),
                            p, np.zeros(1, np.int64))
    every, polarities = np.ones(k, bool), m["n"].min(1) > 0
    maybe, both, peaks = clusters_launch.peak_screen(ti(), np.array([0, len(x)]), labels, x, y, p,
                                                     m["box"], every, polarities, peaks=True)
    seen = np.zeros(3, int)
    for c in range(k):
        for s, sel in enumerate((labels == c, (labels == c) & (p == 0), (labels == c) & (p == 1))):
            status = peaks[c, s, 0]
            if s and not (maybe[c] and polarities[c]):  # polarities not looked at
                assert status == ref.PEAKS_UNSURE
                continue
            if s and status == ref.PEAKS_UNSURE:  # undecided, or the ON image not looked at
                continue  # (the OFF one ruled out by the screen)
            want, a, b = ref.certain_two_peaks(pts[sel])
            if status == ref.PEAKS_NONE and want != ref.PEAKS_NONE:  # ruled out by the screen
                assert ref.two_peaks(pts[sel]) is None
                continue
            assert status == want, (c, s)
            seen[status] += 1
            if want == ref.PEAKS_FOUND:
                np.testing.assert_array_equal(peaks[c, s, 1:3], a)
                np.testing.assert_array_equal(peaks[c, s, 3:5], b)
    assert seen.min() > 0
    assert not maybe.all() and np.all(peaks[~maybe, 0, 0] == ref.PEAKS_NONE)


def test_two_means_kernel_counts_the_halves():
    from evstar import splitting

    pts, starts, stops = clustered_points(9, n_frames=6, per_star=100)
    p = np.random.default_rng(9).integers(0, 2, len(pts)).astype(np.int8)
    _, a, b = splitting.two_peaks_many(pts, starts, stops)
    lab, halves = clusters_launch.two_means(ti(), pts, starts, stops, a, b, p=p)
    np.testing.assert_array_equal(lab, clusters_launch.two_means(ti(), pts, starts, stops, a, b))
    seg = np.repeat(np.arange(len(starts)), stops - starts)
    np.testing.assert_array_equal(halves[:, :2], np.bincount(seg * 2 + lab, minlength=2 * len(starts))
                                  .reshape(-1, 2))
    np.testing.assert_array_equal(halves[:, 2:], np.bincount(seg * 2 + lab, weights=p, minlength=2
                                                             * len(starts)).reshape(-1, 2))


def test_two_means_reads_the_points_in_place_through_their_indices():
    """two_means_at on every point's columns (pixels or floats) through a scattered index
    gives two_means' labels and halves on the points gathered in that order."""
    from evstar import splitting

    pts, starts, stops = clustered_points(11, n_frames=6, per_star=100)
    p = np.random.default_rng(11).integers(0, 2, len(pts)).astype(np.int8)
    _, a, b = splitting.two_peaks_many(pts, starts, stops)
    want = clusters_launch.two_means(ti(), pts, starts, stops, a, b, p=p)
    # the points scattered over a longer array, with others between them
    at = np.random.default_rng(12).permutation(3 * len(pts))[:len(pts)]
    for dtype in (np.uint16, np.float64):
        x, y = np.zeros(3 * len(pts), dtype), np.zeros(3 * len(pts), dtype)
        x[at], y[at] = pts[:, 0], pts[:, 1]
        got = clusters_launch.two_means_at(ti(), x, y, at, starts, stops, a, b, p=p)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
    assert 0 < want[0].mean() < 1


@pytest.mark.parametrize("float_coords", [False, True])
def test_split_from_the_screen_peaks_equals_the_split_without(float_coords, monkeypatch):
    """The extractor's split seeded by the screen's certain peaks gives the centroids of the
    split that computes every seed itself (numpy two_peaks), field for field."""
    from evstar import extract

    ev = blob_events(4)
    xy = None
    if float_coords:
        xy = np.column_stack([ev.x, ev.y]) + np.random.default_rng(4).uniform(-0.49, 0.49,
                                                                              (len(ev), 2))
    for kw in ({}, {"weighting": "polarity"}, {"eps": 1.5, "min_samples": 3}):
        got = Extractor(**kw).centroids(ev, xy=xy)
        screen = extract.Extractor._screen

        def undecided(self, *a):
            maybe, both, peaks = screen(self, *a)
            peaks[:, :, 0] = ref.PEAKS_UNSURE
            return maybe, both, peaks

        with monkeypatch.context() as mp:
            mp.setattr(extract.Extractor, "_screen", undecided)
            want = Extractor(**kw).centroids(ev, xy=xy)
        assert got["split"].sum() >= 10
        for name in want.dtype.names:
            np.testing.assert_array_equal(got[name], want[name], err_msg=name)


@pytest.mark.parametrize("float_coords", [False, True])
def test_batched_halves_test_equals_the_per_cluster_one(float_coords):
    from evstar import splitting

    pts, starts, stops = clustered_points(7, n_frames=10, per_star=120)
    if float_coords:
        pts = pts + np.random.default_rng(3).uniform(-0.49, 0.49, pts.shape)
    has, a, b = splitting.two_peaks_many(pts, starts, stops)
    lab = splitting.two_means_many(pts, starts, stops, a, b, integral=not float_coords)
    keep = np.flatnonzero(has)
    st = np.r_[0, np.cumsum(stops[keep] - starts[keep])]
    idx = np.concatenate([np.arange(starts[j], stops[j]) for j in keep])
    ex = Extractor()
    got = splitting.halves_many(pts[idx], st[:-1], st[1:], lab[idx], ex.min_cluster_size,
                                ex.split_valley)
    want = [ex._halves(pts[starts[j]:stops[j]], (a[j], b[j]), lab[starts[j]:stops[j]]) is not None
            for j in keep]
    np.testing.assert_array_equal(got, want)
    assert 0 < got.sum() < len(got)


def lobed_pair_events(seed, gap):
    """Two stars `gap` px apart across their motion (+x, 400 px/s), each firing ON events
    ahead of its centre and OFF events behind: the first split test sees the lobes, only
    the per-polarity one the pair."""
    rng = np.random.default_rng(seed)
    ts, xs, ys, ps = [], [], [], []
    for y0 in (40.0, 40.0 + gap):
        t = rng.integers(0, 100_000, 1500)
        along = rng.normal(0, 1.0, len(t))
        ts.append(t)
        xs.append(30 + 400e-6 * t + along)
        ys.append(y0 + rng.normal(0, 0.6, len(t)))
        ps.append((along > 0).astype(int))
    t, x, y, p = (np.concatenate(v) for v in (ts, xs, ys, ps))
    o = np.argsort(t, kind="stable")
    return evstar.Events(t[o], np.round(x[o]), np.round(y[o]), p[o], 120, 90)


def test_batched_split_equals_the_per_cluster_split(monkeypatch):
    """The grid extractor's batched split (first test, then each polarity apart) gives the
    centroids of the scikit-learn path's split cluster by cluster, and the second test
    splits some pairs the first one leaves whole."""
    from evstar import extract

    second = []
    polarity_halves = extract.Extractor._polarity_halves

    def spy(self, *a):
        out = polarity_halves(self, *a)
        second.append(len(out))
        return out

    monkeypatch.setattr(extract.Extractor, "_polarity_halves", spy)
    for gap in (3.0, 4.0):
        ev = lobed_pair_events(5, gap)
        grid = Extractor().centroids(ev)
        skl = Extractor(clustering="sklearn").centroids(ev)
        assert grid["split"].sum() >= 4
        for name in ("t", "frame", "n_events", "n_on", "split"):
            np.testing.assert_array_equal(grid[name], skl[name], err_msg=name)
        np.testing.assert_allclose(grid["x"], skl["x"], rtol=0, atol=1e-9)
    assert sum(second) > 0


def test_motion_axes_point_from_the_off_lobe_to_the_on_lobe():
    from evstar import splitting

    pts = np.array([[10.0, 5], [11, 5], [14, 6], [15, 6],      # OFF behind, ON ahead (+x)
                    [3, 3], [3, 4],                            # one polarity only
                    [7, 7], [7.5, 7]], float)                  # lobes 0.5 px apart
    p = np.array([0, 0, 1, 1, 1, 1, 0, 1])
    lab = np.array([0, 0, 0, 0, 1, 1, 2, 2])
    m = ref.cluster_moments(lab, np.zeros(8, np.int64), pts[:, 0], pts[:, 1],
                            np.zeros(8, np.int64), p, np.zeros(1, np.int64))
    ax, wide = splitting.cluster_axes(m)
    np.testing.assert_allclose(ax[0], np.array([4.0, 1.0]) / np.hypot(4, 1))
    assert np.isnan(ax[1:]).all()
    assert not wide.any()                      # spread along the lobes; no axis: unknown


def test_across_labels_part_two_rows_across_the_motion():
    from evstar import splitting

    rng = np.random.default_rng(0)
    x = rng.uniform(0, 20, 60)                                 # streaks along x ...
    y = np.r_[np.full(30, 10.0), np.full(30, 16.0)] + rng.normal(0, 0.5, 60)  # ... 6 px apart
    lab = splitting.across_labels(np.column_stack([x, y]), np.array([0]), np.array([60]),
                                  np.array([[1.0, 0.0]]))
    assert len(np.unique(lab[:30])) == 1 and len(np.unique(lab[30:])) == 1
    assert lab[0] != lab[-1]
