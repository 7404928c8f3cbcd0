"""Level-paired ON/OFF times mark when a star's centre passes each pixel."""
import numpy as np
import pytest

from evstar import sim
from evstar.crossings import pixel_crossings


def along_track_residuals(run, crossings):
    """(pixel − true centre at the crossing time) projected on the motion direction, px."""
    t = np.round(crossings["t"]).astype(np.int64)
    s = run.truth.star_position(t).reshape(len(t), -1)[:, :2]
    u = run.truth.star_position(t + 1000).reshape(len(t), -1)[:, :2] - s
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    q = np.column_stack([crossings["x"], crossings["y"]]).astype(float)
    return ((q - s) * u).sum(1)


def star_events(run):
    m = run.truth.labels >= 0
    ev = run.events
    return ev.t[m], ev.x[m], ev.y[m], ev.p[m]


@pytest.mark.parametrize("rate,sensor", [
    (4.0, sim.SensorSpec.ideal()),
    (12.0, sim.SensorSpec()),                                  # mismatch, jitter, refractory
    (8.0, sim.SensorSpec(threshold_on=0.15, threshold_off=0.15)),
])
def test_crossing_times_are_the_times_the_centre_passes_the_pixel(rate, sensor):
    run = sim.simulate(sim.paper_preset(rate, sensor=sensor, duration_s=0.3), seed=2)
    r = along_track_residuals(run, pixel_crossings(*star_events(run)))
    assert len(r) > 30
    assert abs(np.median(r)) < 0.05 and np.median(np.abs(r)) < 0.1


def test_crossings_beat_the_event_mean_which_leads_with_on_and_trails_with_off():
    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3), seed=4)
    t, x, y, p = star_events(run)
    s = run.truth.star_position(t).reshape(len(t), -1)[:, :2]
    u = run.truth.star_position(t + 1000).reshape(len(t), -1)[:, :2] - s
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    along = ((np.column_stack([x, y]) - s) * u).sum(1)
    assert along[p == 1].mean() > 1.0 and along[p == 0].mean() < -1.0   # the two lobes
    r = along_track_residuals(run, pixel_crossings(t, x, y, p))
    assert np.median(np.abs(r)) < 0.25 * np.abs(along).mean()


def test_one_synthetic_pixel_pairs_levels_outwards_from_the_polarity_change():
    #        ON ON ON | OFF OFF        (change between index 2 and 3)
    t = np.array([10, 20, 30, 50, 70])
    p = np.array([1, 1, 1, 0, 0])
    c = pixel_crossings(t, np.zeros(5, int), np.zeros(5, int), p, max_pairs=4)
    # pairs (20, 50) and (10, 70): midpoints 35 and 40
    assert len(c) == 1 and c["pairs"][0] == 2 and c["t"][0] == pytest.approx(37.5)
    assert c["t_spread"][0] == pytest.approx(2.5)
    assert c["t_outer"][0] == pytest.approx(70 - 40)     # the deepest pair (10, 70)
    assert c["t_half"][0] == pytest.approx(np.sqrt((15 ** 2 + 30 ** 2) / 2))   # RMS of both
    one = pixel_crossings(t, np.zeros(5, int), np.zeros(5, int), p, max_pairs=1)
    assert one["t"][0] == pytest.approx(35.0)


def test_pixels_without_both_flanks_give_no_crossing():
    t = np.arange(6)
    x = np.array([0, 0, 1, 1, 2, 2])
    p = np.array([1, 1, 0, 0, 0, 1])     # ON only; OFF only; OFF then ON (no ON->OFF change)
    assert len(pixel_crossings(t, x, np.zeros(6, int), p)) == 0


def test_frames_without_centroids_but_with_crossings_get_positions():
    from evstar import Config, Pipeline, accuracy, estimation

    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3), seed=6)
    cfg = Config().replace(**{"estimate.estimator": "mean"})
    res = Pipeline(cfg).run(run.events)
    linked = res.centroids[res.centroids["track"] >= 0]
    gap = (linked["frame"] >= 10) & (linked["frame"] < 20)   # 100 ms without centroids
    crossings = estimation.chunk_crossings(run.events, res.keep, 3.0)
    by_index = estimation.chunk_crossings(run.events, np.flatnonzero(res.keep), 3.0)
    assert by_index.tobytes() == crossings.tobytes()      # the kept events' indices alike
    rows = estimation.estimate(linked[~gap], cfg.replace(**{"estimate.estimator": "crossings"}),
                               int(run.events.t[0]), crossings)
    in_gap = (rows["frame"] >= 10) & (rows["frame"] < 20)
    assert in_gap.sum() == 10 and (rows["source"][in_gap] == "measured").all()
    _, err = accuracy.match(rows[in_gap], run.truth.star_position)
    assert err.max() < 0.1


@pytest.mark.parametrize("rate,mag,psf,direction", [(4.0, 3.0, 1.0, 0), (12.0, 5.0, 0.8, 0),
                                                    (8.0, 4.0, 1.3, 0), (8.0, 4.0, 1.1, 35),
                                                    (4.0, 4.0, 1.2, 60)])
def test_positions_beat_the_single_frame_bound_on_a_small_grid(rate, mag, psf, direction):
    """σ_PSF/√N is the best one frame of N events can do; pooled along the track with the
    crossings, the default estimator must do better than that (and than the per-frame mean),
    also where the star crosses the pixel grid diagonally (`direction` degrees from x)."""
    from evstar import Config, Pipeline, accuracy

    phi = np.radians(direction)
    run = sim.simulate(sim.paper_preset(rate, magnitude=mag, psf_sigma_px=psf, duration_s=0.3,
                                        axis=(np.sin(phi), -np.cos(phi), 0.0)), seed=11)
    v = np.diff(run.truth.star_position(np.array([100_000, 200_000])).reshape(2, -1)[:, :2], axis=0)[0]
    assert np.degrees(np.arctan2(abs(v[1]), abs(v[0]))) == pytest.approx(direction, abs=1.0)
    n_per_frame = (run.truth.labels >= 0).sum() / 30
    bound = psf / np.sqrt(n_per_frame)
    errors = {}
    for estimator in ("mean", "crossings"):
        rows = Pipeline(Config().replace(**{"estimate.estimator": estimator})).run(run.events).centroids
        star, err = accuracy.match(rows, run.truth.star_position)
        errors[estimator] = err[star >= 0].mean()
    assert errors["crossings"] < 0.5 * bound and errors["crossings"] < 0.5 * errors["mean"], errors


# -- the vectorised code against straightforward references -------------------------------
def crossings_reference(t, x, y, p, max_pairs=16, ratio=1.0):
    """pixel_crossings one pixel and one polarity change at a time; OFF j pairs with the
    rising time j·ratio ON events back (interpolated; extrapolated from the run's first two
    ON events up to DEPTH_REACH below the first); the runs less a stray outermost event."""
    from evstar.crossings import CROSSING_DTYPE, DEPTH_REACH, STRAY_GAP_FACTOR

    rows = []
    for py, px in sorted(set(zip(y.tolist(), x.tolist()))):
        idx = np.flatnonzero((y == py) & (x == px))
        idx = idx[np.argsort(t[idx], kind="stable")]
        tt, on = t[idx].astype(np.int64), p[idx] > 0
        for i in range(len(tt) - 1):
            if not (on[i] and not on[i + 1]):
                continue
            s = sq = h2 = 0.0
            k = 0
            first, last = i, i + 1              # the ON run's first event, the OFF run's last
            while first > 0 and on[first - 1]:
                first -= 1
            while last + 1 < len(tt) and not on[last + 1]:
                last += 1
            # an outermost event further from the passage than STRAY_GAP_FACTOR times its
            # largest inside gap is a stray (noise), not the star's
            inner = range(first + 1 if first < i else first, last - 1 if last > i + 1 else last)
            inside = max(tt[e + 1] - tt[e] for e in inner)
            if first < i and tt[first + 1] - tt[first] > STRAY_GAP_FACTOR * inside:
                first += 1
            if last > i + 1 and tt[last] - tt[last - 1] > STRAY_GAP_FACTOR * inside:
                last -= 1
            nb = i - first                      # ON events before i in its run
            for j in range(1, max_pairs + 1):    # the j-th OFF after, its level's ON time
                level = j * ratio
                j0 = int(np.floor(level + 1e-9))
                f = level - j0
                b = i + j
                reach = DEPTH_REACH if nb >= 1 else 0.0
                if level > nb + reach + 1e-9 or b > last:
                    break
                if level > nb + 1e-9:          # below the first ON: extrapolated
                    rise = float(tt[first]) - (level - nb) * (float(tt[first + 1]) - float(tt[first]))
                    mid = 0.5 * (rise + float(tt[b]))
                elif f < 1e-9:
                    mid = 0.5 * (tt[i - j0] + tt[b])
                else:
                    rise = float(tt[i - j0]) * (1 - f) + float(tt[i - j0 - 1]) * f
                    mid = 0.5 * (rise + float(tt[b]))
                d = mid - float(tt[i])             # squares about the change's time
                top = mid if k == 0 else top        # the top pair's midpoint
                s, sq, k = s + mid, sq + d * d, k + 1
                outer = float(tt[b]) - mid          # the deepest pair's half-width
                h2 += outer * outer
            if k:
                spread = np.sqrt(max(sq / k - (s / k - float(tt[i])) ** 2, 0.0))
                rows.append((px, py, s / k, k, spread, outer, np.sqrt(h2 / k), top))
    out = np.array(rows, CROSSING_DTYPE) if rows else np.zeros(0, CROSSING_DTYPE)
    return out[np.argsort(out["t"], kind="stable")]


@pytest.mark.parametrize("time_sorted", [True, False])
def test_pixel_crossings_equal_the_per_pixel_reference(time_sorted):
    rng = np.random.default_rng(5)
    n = 3000
    xs, ys = np.array([0, 1, 2, 700, 1279]), np.array([0, 3, 719])   # keys past 2¹⁶
    x, y = rng.choice(xs, n), rng.choice(ys, n)
    t = np.sort(rng.integers(0, 20_000, n))                         # ties included
    p = (np.sin(t / 700.0 + x) + rng.normal(0, 0.5, n) > 0).astype(np.int8)   # ON and OFF runs
    if not time_sorted:
        perm = rng.permutation(n)
        t, x, y, p = t[perm], x[perm], y[perm], p[perm]
    got, ref = pixel_crossings(t, x, y, p, threshold_ratio=1.0), crossings_reference(t, x, y, p)
    assert len(ref) > 50 and (ref["pairs"] > 1).any()
    for f in ("x", "y", "pairs"):
        np.testing.assert_array_equal(got[f], ref[f])
    np.testing.assert_allclose(got["t"], ref["t"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_spread"], ref["t_spread"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got["t_outer"], ref["t_outer"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_half"], ref["t_half"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_top"], ref["t_top"], rtol=0, atol=1e-9)


def test_the_pairs_follow_the_ratio_continuously_across_one():
    """A measured ratio a hair above 1 keeps every change's deepest pair (its rising time a
    fraction of a step below the run's first ON, extrapolated) instead of dropping them all
    at once: the crossings move by 0.1 % of a step per pair (microseconds), not by pairs."""
    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=2)
    t, x, y, p = star_events(run)
    at_one = pixel_crossings(t, x, y, p, threshold_ratio=1.0)
    above = pixel_crossings(t, x, y, p, threshold_ratio=1.001)
    assert len(at_one) > 50 and np.array_equal(at_one["pairs"], above["pairs"])
    shift = np.abs(above["t"] - at_one["t"])
    assert 0 < shift.max() < 20.0                                      # µs


@pytest.mark.parametrize("ratio", [1.0, 0.6, 1.7])
def test_pixel_crossings_of_a_simulated_star_equal_the_reference(ratio):
    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=2)
    t, x, y, p = star_events(run)
    got = pixel_crossings(t, x, y, p, threshold_ratio=ratio)
    ref = crossings_reference(t, x, y, p, ratio=ratio)
    assert len(ref) > 20
    for f in ("x", "y", "pairs"):
        np.testing.assert_array_equal(got[f], ref[f])
    if ratio == 1.0:
        assert got.tobytes() == ref.tobytes()
    np.testing.assert_allclose(got["t"], ref["t"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_outer"], ref["t_outer"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_half"], ref["t_half"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["t_top"], ref["t_top"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("engine", ["taichi", "numpy"])
@pytest.mark.parametrize("ratio", [1.0, 0.6])
def test_an_hours_offset_leaves_the_spread_as_it_was(engine, ratio):
    """The spread is a difference of squares: about t = 0 an hour's µs (~1e19 µs²) rounded
    it by tens of µs."""
    from evstar.crossings import key_crossings, pixel_keys

    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=2)
    t, x, y, p = star_events(run)
    key = pixel_keys(x, y, 346)
    near = key_crossings(t, key, p, 346, engine=engine, threshold_ratio=ratio)
    later = key_crossings(t + 3_600_000_000, key, p, 346, engine=engine, threshold_ratio=ratio)
    assert len(near) > 20 and (near["t_spread"] > 0).any()
    np.testing.assert_allclose(later["t_spread"], near["t_spread"], rtol=0, atol=1e-3)


def test_a_slow_faint_stars_few_runs_still_measure_the_ratio():
    """2 °/s, magnitude 4.5, σ 1.3 px, ON 0.25 / OFF 0.15: ~25 changes with >= 3 levels on
    both flanks. Below 50 the ratio was taken as 1, and the positions led by 0.2-0.4 px."""
    from evstar import denoise
    from evstar.crossings import _change_runs, sorted_crossings
    from evstar.estimation import _near_kept

    sensor = sim.sensor_model("default", threshold_on=0.25, threshold_off=0.15)
    run = sim.simulate(sim.paper_preset(2.0, magnitude=4.5, psf_sigma_px=1.3, sensor=sensor),
                       seed=21)
    (ts, keys, ps), _ = _near_kept(run.events, denoise.MRNDSEF().apply(run.events), 3)
    _, (_, before, after) = _change_runs(ts, keys, ps, "numpy")
    from evstar.crossings import _ratio_changes

    assert 20 <= _ratio_changes(before, after).sum() < 50
    _, r = sorted_crossings(ts, keys, ps, run.events.width, with_ratio=True)
    assert r == pytest.approx(0.6, abs=0.1)


@pytest.mark.parametrize("on,off", [(0.15, 0.25), (0.25, 0.15), (0.2, 0.2)])
def test_the_threshold_ratio_is_measured_from_the_runs(on, off):
    from evstar.crossings import _runs, by_pixel_then_time, pixel_keys, threshold_ratio_of

    sensor = sim.sensor_model("default", threshold_on=on, threshold_off=off)
    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3, sensor=sensor), seed=4)
    ev = run.events
    _, keys, ps = by_pixel_then_time(ev.t, pixel_keys(ev.x, ev.y, ev.width), ev.p)
    _, before, after = _runs(keys, ps)
    assert threshold_ratio_of(before, after) == pytest.approx(off / on, rel=0.12)
    assert threshold_ratio_of(before[:10], after[:10]) == 1.0          # too few: no claim


def test_unequal_thresholds_no_longer_shift_the_crossings():
    """ON 0.15, OFF 0.25: level pairs of equal count sit at unequal levels (0.2–0.3 px along
    the motion); pairing by level with the measured ratio removes it."""
    from evstar import Config, Pipeline, accuracy

    sensor = sim.sensor_model("default", threshold_on=0.15, threshold_off=0.25)
    run = sim.simulate(sim.paper_preset(6.0, duration_s=0.3, sensor=sensor, magnitude=3.5),
                       seed=5)
    errors = {}
    for ratio in (1.0, "auto"):
        cfg = Config().replace(**{"estimate.threshold_ratio": ratio})
        rows = Pipeline(cfg).run(run.events).centroids
        star, err = accuracy.match(rows, run.truth.star_position)
        errors[ratio] = err[star >= 0].mean()
    assert errors["auto"] < 0.08 and errors["auto"] < 0.5 * errors[1.0], errors


@pytest.mark.parametrize("radius", [0, 1, 2.5, 3, 6, 50])   # 6: across's; 50: > the image
def test_dilate_is_the_square_binary_dilation(radius):
    from scipy import ndimage

    from evstar.crossings import dilate

    rng = np.random.default_rng(int(radius * 10))
    x, y = rng.integers(0, 64, 40), rng.integers(0, 48, 40)
    x[:2], y[:2] = [0, 63], [0, 47]                                  # at the borders
    img = np.zeros((48, 64), bool)
    img[y, x] = True
    r = int(np.ceil(radius))
    ref = ndimage.binary_dilation(img, np.ones((2 * r + 1, 2 * r + 1), bool)) if r else img
    np.testing.assert_array_equal(dilate(img.copy(), radius), ref)


def along_track_reference(crossings, tracks, max_offset_px=3.0, min_speed_px_s=1.0):
    """along_track one track at a time over every crossing."""
    t = crossings["t"]
    q = np.column_stack([crossings["x"], crossings["y"]]).astype(np.float64)
    best, owner = np.full(len(t), np.inf), np.full(len(t), -1, np.int64)
    u, resid = np.zeros((len(t), 2)), np.zeros(len(t))
    for tid in np.unique(tracks["track"]):
        tr = tracks[tracks["track"] == tid]
        inside = (t >= tr["t"][0]) & (t <= tr["t"][-1])
        if not inside.any() or len(tr) < 2:
            continue
        ti = t[inside]
        pos = np.column_stack([np.interp(ti, tr["t"], tr["x"]), np.interp(ti, tr["t"], tr["y"])])
        vel = np.column_stack([np.interp(ti, tr["t"], tr["vx"]), np.interp(ti, tr["t"], tr["vy"])])
        speed = np.linalg.norm(vel, axis=1)
        d = q[inside] - pos
        dist = np.linalg.norm(d, axis=1)
        win = (dist < np.minimum(best[inside], max_offset_px)) & (speed >= min_speed_px_s)
        idx = np.flatnonzero(inside)[win]
        best[idx], owner[idx] = dist[win], tid
        u[idx] = vel[win] / speed[win, None]
        resid[idx] = (d[win] * u[idx]).sum(1)
    got = np.flatnonzero(owner >= 0)
    return got, owner[got], u[got], resid[got]


def test_along_track_equals_the_per_track_reference():
    from evstar.crossings import CROSSING_DTYPE, along_track
    from evstar.smoothing import ESTIMATE_DTYPE

    rng = np.random.default_rng(7)
    parts = []
    for tid in range(12):
        n = int(rng.integers(1, 60))
        t = np.sort(rng.choice(np.arange(0, 600_000, 5_000), n, replace=False)) + rng.integers(0, 3000)
        rows = np.zeros(n, ESTIMATE_DTYPE)
        v = rng.normal(0, 150, 2) * (tid != 3)                      # track 3 stands still
        rows["t"], rows["track"] = t, tid
        rows["x"] = 20 + tid % 4 * 6 + v[0] * t * 1e-6 + rng.normal(0, 0.2, n)
        rows["y"] = 30 + v[1] * t * 1e-6 + rng.normal(0, 0.2, n)
        jitter = rng.normal(0, 5, (n, 2)) * (tid != 3)
        rows["vx"], rows["vy"] = v[0] + jitter[:, 0], v[1] + jitter[:, 1]
        parts.append(rows)
    parts.append(parts[5].copy())                                   # a twin: ties
    parts[-1]["track"] = 12
    tracks = np.concatenate(parts)
    m = 4000
    c = np.zeros(m, CROSSING_DTYPE)
    c["x"], c["y"] = rng.integers(0, 80, m), rng.integers(0, 90, m)
    c["t"] = rng.uniform(-1e4, 6.1e5, m)
    on = rng.choice(len(tracks), m // 2)                            # half near a track's rows
    c["t"][:m // 2] = tracks["t"][on] + rng.choice([0.0, 1.0, 2500.0], m // 2)
    c["x"][:m // 2], c["y"][:m // 2] = np.round(tracks["x"][on]), np.round(tracks["y"][on])
    c = c[np.argsort(c["t"], kind="stable")]
    got, ref = along_track(c, tracks), along_track_reference(c, tracks)
    assert len(ref[0]) > 1000 and 12 not in ref[1] and 3 not in ref[1]
    for a, b in zip(got, ref):
        np.testing.assert_array_equal(a, b)
    # the same from a wider assignment (the estimator's, shared with evstar.pairs)
    from evstar.crossings import near_tracks, within

    wide = near_tracks(c, tracks, 7.0)
    assert len(wide[0]) > len(ref[0])
    for a, b in zip(within(wide, 3.0), ref):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("n_keys", [1, 7, 70_000, 921_600])
def test_the_counting_sort_kernel_equals_numpys_stable_sort(n_keys):
    from evstar import backends
    from evstar.crossings import _pixel_then_time
    from evstar_kernels.taichi import sorting_launch

    rng = np.random.default_rng(n_keys)
    key = rng.integers(0, n_keys, 50_000).astype(np.uint32)
    ref = np.argsort(key, kind="stable")
    assert np.array_equal(sorting_launch.stable_order(backends.taichi_running(), key, n_keys), ref)
    t = np.sort(rng.integers(0, 10**6, len(key)))
    assert np.array_equal(_pixel_then_time(key, t), _pixel_then_time(key, t, engine="numpy"))
    assert np.array_equal(_pixel_then_time(key, t), np.lexsort((t, key)))
    assert len(sorting_launch.stable_order(backends.taichi_running(), key[:0], n_keys)) == 0


@pytest.mark.parametrize("device_arrays", [False, True])
def test_the_counting_sort_of_no_key_is_empty_on_the_gpu_data_path(monkeypatch, device_arrays):
    # a GPU run's pooled look sorted no key: Taichi has no empty ndarray, and it failed
    from evstar import backends
    from evstar_kernels.taichi import launch, sorting_launch

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    ti = backends.taichi_running()
    assert len(sorting_launch.stable_order(ti, np.zeros(0, np.uint32), 7)) == 0
    value, counts = sorting_launch.counting_sort(ti, np.zeros(0, np.uint32), np.zeros(0, np.int64), 7)
    assert len(value) == 0 and counts.tolist() == [0] * 7


@pytest.mark.parametrize("device_arrays", [False, True])
@pytest.mark.parametrize("n_keys", [1, 7, 70_000, 921_600])
def test_the_counting_sort_of_values_equals_numpys_stable_sort(monkeypatch, device_arrays, n_keys):
    from evstar import backends
    from evstar_kernels.taichi import launch, sorting_launch

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    rng = np.random.default_rng(n_keys)
    key = rng.integers(0, n_keys, 50_000).astype(np.uint32)
    value = rng.integers(-2**62, 2**62, len(key))
    got, count = sorting_launch.counting_sort(backends.taichi_running(), key, value, n_keys)
    assert got.dtype == np.int64 and np.array_equal(got, value[np.argsort(key, kind="stable")])
    assert np.array_equal(count, np.bincount(key, minlength=n_keys))
    got, count = sorting_launch.counting_sort(backends.taichi_running(), key[:0], value[:0],
                                              n_keys)
    assert len(got) == 0 and np.array_equal(count, np.zeros(n_keys))


# -- the Taichi level-pair kernel against its numpy specification: the same bits ----------
def assert_same_crossings(t, key, p, width, max_pairs, ratio=1.0):
    from evstar.crossings import key_crossings

    got = key_crossings(t, key, p, width, max_pairs, threshold_ratio=ratio)
    ref = key_crossings(t, key, p, width, max_pairs, engine="numpy", threshold_ratio=ratio)
    assert got.dtype == ref.dtype and len(got) == len(ref)
    if ratio == 1.0:             # integer midpoints: the same bits
        for f in ref.dtype.names:
            assert np.array_equal(got[f], ref[f]), f
        return ref
    # interpolated rising times: equal to the last bits of the sums, which may reorder
    # crossings of one time
    def rows(c):
        return c[np.lexsort((c["pairs"], c["y"], c["x"], np.round(c["t"], 3)))]
    got, ref = rows(got), rows(ref)
    for f in ("x", "y", "pairs"):
        assert np.array_equal(got[f], ref[f]), f
    np.testing.assert_allclose(got["t"], ref["t"], rtol=1e-14, atol=0)
    # the spread's squares are about each change's time: no rounding of t² (an hour's µs:
    # tens of µs before); each midpoint's own rounding there (~5e-7 µs) is left, which a
    # pair far from its change (by up to t_outer) levers into the variance: ~1e-6 µs ×
    # t_outer / spread (0.017 µs on a 1 s run of random polarities)
    lever = 1e-6 * ref["t_outer"] / np.maximum(ref["t_spread"], 1.0)
    assert np.all(np.abs(got["t_spread"] - ref["t_spread"]) <= 1e-2 + lever)
    np.testing.assert_allclose(got["t_half"], ref["t_half"], rtol=0, atol=1e-5)   # the same
    return ref


@pytest.mark.parametrize("n,n_pixels,max_pairs", [
    (0, 10, 16), (1, 1, 16), (5000, 1, 16), (5000, 1, 1), (40_000, 3000, 2),
    (40_000, 300, 16), (40_000, 50, 4), (40_000, 50, 200),     # runs to 15 pairs: 4 caps
])
def test_the_level_pair_kernel_equals_the_numpy_crossings_bit_for_bit(n, n_pixels, max_pairs):
    rng = np.random.default_rng(n + n_pixels + max_pairs)
    pixels = rng.integers(0, 1280 * 720, n_pixels).astype(np.uint32)   # keys past 2¹⁶
    key = rng.choice(pixels, n)
    # repeated timestamps; an hour's offset makes the squared midpoints round (~1e19 µs²)
    t = np.sort(rng.integers(0, n // 4 + 1, n)) * 997 + 3_600_000_000
    p = (np.sin(t / 5e4 + key) + rng.normal(0, 0.7, n) > 0).astype(np.int8)   # ON and OFF runs
    ref = assert_same_crossings(t, key, p, 1280, max_pairs)
    for ratio in (0.6, 1.7, "auto"):                       # rising times interpolated
        assert_same_crossings(t, key, p, 1280, max_pairs, ratio)
    if n > 1:                   # runs long enough to pair several levels and to meet a cap
        assert len(ref) > 100
        assert (ref["pairs"].max() == max_pairs) if max_pairs <= 4 else (ref["pairs"].max() > 5)


def test_the_level_pair_kernel_takes_bool_polarities_unsorted_times_and_device_arrays(
        monkeypatch):
    from evstar_kernels.taichi import launch

    rng = np.random.default_rng(3)
    key = rng.integers(0, 200, 20_000).astype(np.uint32)
    t = np.sort(rng.integers(0, 10**6, len(key)))
    p = rng.random(len(key)) < 0.5
    assert len(assert_same_crossings(t, key, p, 64, 16)) > 100
    perm = rng.permutation(len(key))                    # the order by np.lexsort
    assert_same_crossings(t[perm], key[perm], p[perm], 64, 16)
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", True)
    assert_same_crossings(t, key, p.astype(np.int8), 64, 16)


def test_the_level_pair_kernel_equals_the_numpy_crossings_on_a_simulated_star():
    from evstar.crossings import pixel_keys

    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=2)
    ev = run.events                                          # the star's events and the noise
    ref = assert_same_crossings(ev.t, pixel_keys(ev.x, ev.y, ev.width), ev.p, ev.width, 16)
    assert len(ref) > 20


@pytest.mark.parametrize("bad", [0, 0.1, 5.0, "high"])
def test_a_bad_threshold_ratio_is_rejected_by_name(bad):
    from evstar import Config
    from evstar.errors import ParameterError

    with pytest.raises(ParameterError, match="threshold_ratio"):
        Config().replace(**{"estimate.threshold_ratio": bad})


# -- a refractory period: each event stands for the levels the pixel skipped while blind ----
def test_level_step_counts_the_levels_a_gap_stands_for():
    from evstar.crossings import MAX_LEVEL_STEP, level_step

    np.testing.assert_allclose(level_step([300.0, 200.0, 1e6], 100.0), [1.5, 2.0, 1.0001], rtol=1e-4)
    assert np.all(level_step([5.0, 50.0], 0.0) == 1.0)
    assert np.all(level_step([90.0, 100.0, 110.0], 100.0) == MAX_LEVEL_STEP)   # jitter: capped


@pytest.mark.parametrize("refractory", [300.0, 1000.0])
def test_a_known_refractory_period_removes_its_bias(refractory):
    """Blind for r after each event and re-armed where the intensity then is, a pixel skips
    levels on both flanks: the plain pairs come out hundreds of µs early (0.1–0.3 px at
    20 °/s here); counting the skipped levels from the gaps takes most of that away."""
    from evstar.crossings import pixel_keys, key_crossings

    sensor = sim.SensorSpec.ideal(refractory_us=refractory)
    run = sim.simulate(sim.paper_preset(20.0, sensor=sensor, duration_s=0.3), seed=5)
    t, x, y, p = star_events(run)
    key, width = pixel_keys(x, y, run.events.width), run.events.width
    speed = np.linalg.norm(np.diff(run.truth.star_position(np.array([0, 100_000])), axis=0)) * 10

    def along(r_us):
        c = key_crossings(t, key, p, width, refractory_us=r_us)
        return np.median(along_track_residuals(run, c[c["pairs"] >= 2]))

    plain, known = along(0.0), along(refractory)
    assert plain > 0.3 * refractory * 1e-6 * speed          # the pixel is behind: early times
    assert abs(known) < 0.25 * abs(plain)


def test_refractory_pairs_kernel_equals_its_specification():
    from evstar.crossings import pixel_keys, key_crossings

    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.3), seed=6)     # r 100 µs, jitter
    ev = run.events
    key = pixel_keys(ev.x, ev.y, ev.width)
    for r_us, ratio in ((100.0, 1.0), (250.0, 0.7), (40.0, "auto")):
        got, ref = (key_crossings(ev.t, key, ev.p, ev.width, engine=e, refractory_us=r_us,
                                  threshold_ratio=ratio) for e in ("taichi", "numpy"))
        assert len(got) > 100 and len(got) == len(ref)
        for f in ("x", "y", "pairs"):
            assert np.array_equal(got[f], ref[f]), f
        # divisions under Taichi's fast math: the last bits of the sums
        np.testing.assert_allclose(got["t"], ref["t"], rtol=0, atol=1e-6)
        np.testing.assert_allclose(got["t_spread"], ref["t_spread"], rtol=0, atol=1e-2)
        np.testing.assert_allclose(got["t_half"], ref["t_half"], rtol=0, atol=1e-6)


def test_a_vanishing_refractory_period_is_the_plain_pairing():
    from evstar.crossings import pixel_keys, key_crossings

    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3), seed=7)
    ev = run.events
    key = pixel_keys(ev.x, ev.y, ev.width)
    # a pixel's two events in one µs are a gap below any refractory period: MAX_LEVEL_STEP
    order = np.lexsort((ev.t, key))
    tie = np.zeros(len(ev), bool)
    tie[order[1:]] = (key[order[1:]] == key[order[:-1]]) & (ev.t[order[1:]] == ev.t[order[:-1]])
    ev, key = ev[~tie], key[~tie]
    plain = key_crossings(ev.t, key, ev.p, ev.width, threshold_ratio=1.0)
    tiny = key_crossings(ev.t, key, ev.p, ev.width, threshold_ratio=1.0, refractory_us=1e-9)
    assert np.array_equal(plain["pairs"], tiny["pairs"])
    np.testing.assert_allclose(plain["t"], tiny["t"], rtol=0, atol=1e-3)


@pytest.mark.parametrize("ratio", [0.375, 0.6, 1.0, 5 / 3, 2.5])
def test_threshold_ratio_formula_on_its_model(ratio):
    """A pixel's reference uniform over its cycle, a peak anywhere: the ratio from a ON and b
    OFF events per passage comes back within 1 % (the model the estimator is derived from,
    not the simulator)."""
    from evstar.crossings import threshold_ratio_of

    rng = np.random.default_rng(8)
    c_on = 0.2
    c_off = ratio * c_on
    peak = rng.uniform(0.2, 4.0, 200_000)
    ref = rng.uniform(-c_on, c_off, len(peak))
    a = np.floor((peak - ref) / c_on)
    b = np.floor((ref + a * c_on) / c_off)
    assert threshold_ratio_of(a - 1, b) == pytest.approx(ratio, rel=0.01)


@pytest.mark.parametrize("on,off", [(0.2, 0.2), (0.25, 0.15), (0.15, 0.25)])
def test_the_ratio_of_a_sinusoid_whose_pixels_see_the_star_twice(on, off):
    """Simulated, ideal sensor: a 10°/1 Hz sinusoid passes its pixels back and forth (38 %
    of the changes are a pixel's second or later); charging only first passages the ½ gives
    the ratio within 1 %, where charging every passage was 1.5–2.5 % low."""
    from evstar.crossings import _runs, by_pixel_then_time, first_of_pixel, pixel_keys
    from evstar.crossings import threshold_ratio_of

    sensor = sim.SensorSpec.ideal(threshold_on=on, threshold_off=off)
    ev = sim.simulate(sim.paper_sinusoid(magnitude=3.0, sensor=sensor, duration_s=0.6), seed=4).events
    _, keys, ps = by_pixel_then_time(ev.t, pixel_keys(ev.x, ev.y, ev.width), ev.p, "numpy")
    change, before, after = _runs(keys, ps)
    first = first_of_pixel(keys[change])
    assert 0.5 < first.mean() < 0.8
    assert threshold_ratio_of(before, after, first=first) == pytest.approx(off / on, rel=0.01)
    assert threshold_ratio_of(before, after) / (off / on) < 0.99


@pytest.mark.parametrize("ratio", [0.6, 1.0, 5 / 3])
def test_threshold_ratio_of_pixels_passed_twice(ratio):
    """A pixel's second passage starts where its first left the reference, within C_off
    above the background, not anywhere in its cycle: only first passages carry the ½ (faint
    passages, a = 3–14 ON events, where it matters most)."""
    from evstar.crossings import threshold_ratio_of

    rng = np.random.default_rng(9)
    c_on, n = 0.2, 100_000
    c_off = ratio * c_on
    ref = rng.uniform(-c_on, c_off, n)            # fresh: anywhere in the cycle
    a_all, b_all = [], []
    for _ in range(2):
        peak = rng.uniform(0.6, 3.0, n)
        a = np.floor((peak - ref) / c_on)
        b = np.floor((ref + a * c_on) / c_off)
        ref = ref + a * c_on - b * c_off          # where this passage leaves it
        a_all.append(a)
        b_all.append(b)
    a, b = np.concatenate(a_all), np.concatenate(b_all)
    first = np.r_[np.ones(n, bool), np.zeros(n, bool)]
    assert np.all(ref >= 0) and np.all(ref < c_off)
    assert threshold_ratio_of(a - 1, b, first=first) == pytest.approx(ratio, rel=0.01)
    assert threshold_ratio_of(a - 1, b) / ratio < 0.975           # every passage charged: low


def _faint_passages(ratio, peaks, c_on=0.28, n=100_000, passes=3, seed=9):
    """(on_before, off_after, first) of the ON->OFF changes of n pixels each passed `passes`
    times by peaks uniform in `peaks` (log intensity), on the ratio estimator's model."""
    rng = np.random.default_rng(seed)
    ref = rng.uniform(-c_on, ratio * c_on, n)
    a_all, b_all = [], []
    for _ in range(passes):
        peak = rng.uniform(*peaks, n)
        a = np.floor((peak - ref) / c_on)
        b = np.floor((ref + a * c_on) / (ratio * c_on))
        ref = ref + a * c_on - b * ratio * c_on
        a_all.append(a)
        b_all.append(b)
    a, b = np.concatenate(a_all), np.concatenate(b_all)
    first = np.r_[np.ones(n, bool), np.zeros((passes - 1) * n, bool)]
    ok = (a >= 1) & (b >= 1)                          # an ON->OFF change
    return (a - 1)[ok], b[ok], first[ok]


@pytest.mark.parametrize("ratio,peaks,within", [(0.714, (0.5, 1.0), 0.02), (1.4, (0.6, 1.2), 0.07)])
def test_faint_passages_measure_the_ratio_from_two_events_a_flank(monkeypatch, ratio, peaks, within):
    """A faint star's passages rise 2-4 ON steps (C_on 0.28), each pixel passed three times.
    Counting only changes with 3 events on each flank selects passages that began low and
    end high, which do not cancel: the ratio came out 7.5 % high at 0.714 (a magnitude-5.5
    star on a dark sky measured 0.82) and 16 % low at 1.4. Where 3 keep less than
    FULL_FLANK_SHARE of the changes 2 keep, the ratio counts those with 2."""
    from evstar import crossings as X

    before, after, first = _faint_passages(ratio, peaks)
    measured = X.threshold_ratio_of(before, after, first=first)
    monkeypatch.setattr(X, "RATIO_FLANK_EVENTS", (3, 3))
    three = X.threshold_ratio_of(before, after, first=first)
    assert measured == pytest.approx(ratio, rel=within)
    assert abs(three / ratio - 1) > 2 * abs(measured / ratio - 1)


def test_where_most_changes_have_three_events_a_flank_the_ratio_counts_those():
    from evstar import crossings as X

    before, after, first = _faint_passages(0.714, (0.8, 1.6))
    full, least = ((before >= n - 1) & (after >= n) for n in X.RATIO_FLANK_EVENTS)
    assert full.sum() >= X.FULL_FLANK_SHARE * least.sum()
    assert np.array_equal(X._ratio_changes(before, after), full)
    assert X.threshold_ratio_of(before, after, first=first) == pytest.approx(0.714, rel=0.01)
    few = np.where(np.arange(len(after)) % 3, np.minimum(after, 2), after)   # most: 2 OFF
    assert np.array_equal(X._ratio_changes(before, few), (before >= 1) & (few >= 2))


# -- stray events: noise or leak joining a passage's runs ------------------------------------
def passage(t0, on=5, off=5, gap=1000):
    """(t, p) of one pixel passage: `on` ON events then `off` OFF events, `gap` µs apart."""
    return t0 + gap * np.arange(on + off), np.r_[np.ones(on, np.int8), np.zeros(off, np.int8)]


@pytest.mark.parametrize("engine", ["numpy", "taichi"])
def test_a_stray_event_far_before_or_after_a_passage_leaves_its_runs(engine):
    from evstar.crossings import STRAY_GAP_FACTOR, key_crossings

    t, p = passage(1_000_000)
    far = STRAY_GAP_FACTOR * 1000 + 1                 # past the limit: a stray
    near = STRAY_GAP_FACTOR * 1000                    # at it: still the run's
    for before, after, pairs in ((far, None, 4), (near, None, 5), (None, far, 4), (far, far, 4)):
        tt, pp = t, p
        if before is not None:                          # an ON event before the ON run
            tt, pp = np.r_[t[0] - before, tt], np.r_[1, pp].astype(np.int8)
        if after is not None:                           # an OFF event after the OFF run
            tt, pp = np.r_[tt, tt[-1] + after], np.r_[pp, 0].astype(np.int8)
        c = key_crossings(tt, np.zeros(len(tt), np.uint32), pp, 1, engine=engine,
                          threshold_ratio=1.0)
        # ON run 1..5 (+1), OFF 6..10 (+1): the pairs are the shorter run's, the change's own
        # ON not counted; a stray would add one and put a pair hundreds of µs off
        assert len(c) == 1 and c["pairs"][0] == pairs, (before, after)
        if pairs == 4:                  # OFF j (t[4] + j·gap) with ON t[4] − j·gap
            assert c["t"][0] == t[4] and c["t_spread"][0] == 0


def test_ON_strays_no_longer_raise_the_measured_threshold_ratio():
    """A leaking pixel fires ON events on its own (v2e's leak); one that joins a star's ON run
    made it one longer: the measured OFF/ON ratio came out high (1.07 on a 12 °/s star with a
    2 Hz leak, 0.96 without), which moved the crossings along the motion by ~0.1 px."""
    from evstar.crossings import _change_runs, by_pixel_then_time, first_of_pixel, pixel_keys
    from evstar.crossings import _measured_ratio, without_strays

    sensor = sim.sensor_model("default", leak_hz=2.0, noise_hz=0.0)
    run = sim.simulate(sim.paper_preset(12.0, magnitude=5.0, duration_s=0.5, sensor=sensor),
                       seed=51)
    ev = run.events
    ts, keys, ps = by_pixel_then_time(ev.t, pixel_keys(ev.x, ev.y, ev.width), ev.p, "numpy")
    _, (change, nb, na) = _change_runs(ts, keys, ps, "numpy")
    first = first_of_pixel(keys[change])
    nb2, na2 = without_strays(ts, change, nb, na)
    assert (nb2 < nb).sum() > 20                           # leak events left the ON runs
    assert _measured_ratio(nb, na, first=first) > 1.03
    assert _measured_ratio(nb2, na2, first=first) == pytest.approx(1.0, abs=0.03)


def test_the_background_in_a_passages_runs_is_its_rate_times_the_stretches_open_to_it():
    """One pixel: an OFF at 0, then a passage ON 100 110 120 | OFF 130 150 160, then an ON
    at 400 (µs). The largest inside gap is 20 (130 -> 150), so the stray test reaches 100
    each way; before the passage only 100 of the 100 µs since the OFF are open, after it
    the ON at 400 leaves the whole reach: ON (100 + 20) µs, OFF (100 + 40) µs."""
    from evstar.crossings import _background_in_runs

    ts = np.array([0, 100, 110, 120, 130, 150, 160, 400], np.int64)
    keys = np.full(len(ts), 7)
    on, off, other = _background_in_runs(ts, keys, np.array([3]), np.array([2]), np.array([3]),
                                         (1e4, 2e4))
    assert on == pytest.approx(1e-6 * 1e4 * 120) and off == pytest.approx(1e-6 * 2e4 * 140)
    assert other == pytest.approx(1e-6 * (2e4 * 20 + 1e4 * 40))   # OFF in the rise, ON in the fall
    # the OFF before it 30 µs earlier: only those 30 are open
    ts2 = ts.copy()
    ts2[0] = 70
    on2, _, _ = _background_in_runs(ts2, keys, np.array([3]), np.array([2]), np.array([3]),
                                    (1e4, 2e4))
    assert on2 == pytest.approx(1e-6 * 1e4 * (30 + 20))


def test_background_rates_split_the_rate_as_the_events_away_from_the_stars():
    from evstar import Events
    from evstar.crossings import background_rates

    rng = np.random.default_rng(5)
    w, h, span = 100, 80, 2_000_000
    n_on, n_off = rng.poisson(2.0 * w * h * 2), rng.poisson(0.5 * w * h * 2)   # 2 and 0.5 Hz
    # a star's path, mostly OFF events (a sensor whose OFF threshold is below ON)
    t = np.r_[rng.integers(0, span, n_on + n_off), rng.integers(0, span, 20_000)]
    x = np.r_[rng.integers(0, w, n_on + n_off), rng.integers(40, 43, 20_000)]
    y = np.r_[rng.integers(0, h, n_on + n_off), rng.integers(10, 60, 20_000)]
    p = np.r_[np.ones(n_on), np.zeros(n_off), rng.random(20_000) < 0.2].astype(np.int8)
    o = np.argsort(t, kind="stable")
    ev = Events(t[o], x[o].astype(np.uint16), y[o].astype(np.uint16), p[o], w, h)
    near = np.zeros((h, w), bool)
    near[8:62, 38:45] = True
    on, off = background_rates(ev, near, 2.5)
    assert on == pytest.approx(2.0, rel=0.03) and off == pytest.approx(0.5, rel=0.1)
    assert background_rates(ev, np.ones((h, w), bool), 2.5) == (1.25, 1.25)  # none away


@pytest.mark.parametrize("leak_hz, noise_hz", [(3.0, 0.0), (0.0, 3.0)])
def test_a_measured_ratio_discounts_the_background_in_the_runs(leak_hz, noise_hz):
    """ON-only leak events inside and just before a slow star's ON runs count as levels:
    the measured OFF/ON ratio of equal thresholds came out 1.23. With the background's rate
    per polarity taken off, near 1; a background of both polarities is left as it was."""
    from evstar import Config, Pipeline, estimation
    from evstar.crossings import (_change_runs, _measured_ratio, first_of_pixel,
                                  without_strays)

    sensor = sim.sensor_model("default", leak_hz=leak_hz, noise_hz=noise_hz)
    run = sim.simulate(sim.paper_preset(4.0, magnitude=4.5, duration_s=1.0, sensor=sensor),
                       seed=53)
    pipe = Pipeline(Config())
    res = pipe.run(run.events, run.imu, run.camera)
    rate = pipe.calibration_rate(run.events, int(run.events.t[0]))
    (ts, keys, ps), rates = estimation._near_kept(run.events, res.keep, 3.0, background_hz=rate)
    assert rates[0] == pytest.approx(leak_hz + noise_hz / 2, rel=0.15)
    _, (change, nb, na) = _change_runs(ts, keys, ps, "numpy")
    nb, na = without_strays(ts, change, nb, na)
    first = first_of_pixel(keys[change])
    plain = _measured_ratio(nb, na, first=first)
    told = _measured_ratio(nb, na, first=first, runs=(ts, keys, change, rates))
    if leak_hz:
        assert plain > 1.15 and abs(told - 1.0) < 0.06
    else:
        assert abs(told - plain) < 0.02


def test_a_background_that_breaks_the_runs_tells_no_ratio():
    """A busy background of mostly ON events rising from 4 to 10 Hz under a slow faint star
    (fresh-56 of perf/study_accuracy.py): 1.2 events of the other polarity a run, expected.
    Its runs read 1.24 for equal thresholds (0.93 with the background taken off); they tell
    no ratio, the run takes its fallback (1), and the star is no longer led by 0.22 px."""
    from evstar import Config, Pipeline, accuracy, estimation
    from evstar.crossings import (_change_runs, _measured_ratio, first_of_pixel,
                                  without_strays)

    sensor = sim.sensor_model("default", noise_hz=4.0, noise_on_fraction=0.7, noise_growth=2.5)
    run = sim.simulate(sim.paper_preset(4.0, magnitude=4.5, duration_s=1.0, sensor=sensor,
                                        psf_sigma_px=1.3), seed=56)
    pipe = Pipeline(Config())
    res = pipe.run(run.events, run.imu, run.camera)
    rate = pipe.calibration_rate(run.events, int(run.events.t[0]))
    (ts, keys, ps), rates = estimation._near_kept(run.events, res.keep, 3.0, background_hz=rate)
    _, (change, nb, na) = _change_runs(ts, keys, ps, "numpy")
    nb, na = without_strays(ts, change, nb, na)
    first = first_of_pixel(keys[change])
    assert _measured_ratio(nb, na, first=first) > 1.15
    assert _measured_ratio(nb, na, first=first, runs=(ts, keys, change, rates)) is None
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    assert err[star >= 0].mean() < 0.1


@pytest.mark.parametrize("device_arrays", [False, True], ids=["serial-cpu", "parallel-device"])
@pytest.mark.parametrize("n, n_pixels, cap", [(0, 1, 4096), (1, 1, 4096), (2, 1, 4096),
                                              (50_000, 400, 4096), (50_000, 3, 4)])
def test_the_change_kernels_equal_their_specification(monkeypatch, device_arrays, n,
                                                      n_pixels, cap):
    from evstar import crossings
    from evstar_kernels.taichi import launch

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    monkeypatch.setattr(crossings, "_RUN_CAP", cap)               # long runs meet the cap
    rng = np.random.default_rng(n + cap)
    key = np.sort(rng.integers(0, n_pixels, n)).astype(np.uint32)
    p = (rng.random(n) < 0.5).astype(np.int8) if n > 2 else np.array([1, 0][:n], np.int8)
    t = np.arange(n)
    ref = crossings._change_runs(t, key, p, "numpy")[1]
    got = crossings._change_runs(t, key, p, "taichi")[1]
    for g, r in zip(got, ref):
        np.testing.assert_array_equal(g, r)
    assert n < 3 or (len(ref[0]) > 100 and (cap > 4 or ref[1].max() == cap == ref[2].max()))


def test_the_stray_kernel_equals_its_specification():
    from evstar.crossings import _change_runs, STRAY_GAP_FACTOR, by_pixel_then_time
    from evstar.crossings import without_strays

    rng = np.random.default_rng(11)
    n = 50_000
    key = rng.integers(0, 400, n).astype(np.uint32)
    t = np.sort(rng.exponential(20.0, n).cumsum().astype(np.int64)) + 3_600_000_000
    p = (np.sin(t / 3e3 + key) + rng.normal(0, 0.8, n) > 0).astype(np.int8)
    ts, keys, ps = by_pixel_then_time(t, key, p)
    kern, (change, nb, na) = _change_runs(ts, keys, ps, "taichi")
    got = kern.without_strays(change, nb, na, STRAY_GAP_FACTOR)
    ref = without_strays(ts, change, nb, na)
    assert (ref[0] < nb).sum() > 100 and (ref[1] < na).sum() > 100     # both sides trimmed
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_array_equal(got[1], ref[1])


@pytest.mark.parametrize("high, dtype", [(50, np.int64), (70_000, np.int64), (2**32, np.uint32),
                                         (2**40, np.int64), (100, np.int8)])
def test_stable_order_is_numpys_stable_argsort(high, dtype):
    # the radix passes give the stable sort's permutation (ties in input order), any range
    from evstar.frames import stable_order

    key = np.random.default_rng(3).integers(0, high, 20_000, dtype=np.int64).astype(dtype)
    assert np.array_equal(stable_order(key), np.argsort(key, kind="stable"))
    assert np.array_equal(stable_order(-key.astype(np.int64)), np.argsort(-key.astype(np.int64), kind="stable"))


def test_pixel_crossings_of_arrays_of_other_lengths_is_a_data_error():
    import evstar
    from evstar.crossings import pixel_crossings

    t, x = np.arange(10), np.zeros(10, int)
    with pytest.raises(evstar.DataError, match="x \\(5,\\)"):
        pixel_crossings(t, x[:5], x, x)
    assert len(pixel_crossings(t[:0], x[:0], x[:0], x[:0])) == 0
