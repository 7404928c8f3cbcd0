"""A readout that stalled (no event at all for longer than a frame): the background is
measured over the time the sensor sent events, and no pixel crossing pairs levels across
the stall."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, estimation, sim
from evstar.frames import stall_gap_us, stall_starts, stalled_us, stalls


def test_stalls_are_the_gaps_beyond_a_frame():
    t = np.r_[np.arange(0, 10_000, 10), np.arange(40_000, 50_000, 10)]     # events every 10 µs
    assert list(stall_starts(t, 10_000)) == [1000]
    assert stalls(t, stall_starts(t, 10_000), 10_000).tolist() == [[9_990, 40_000]]
    assert stalls(t, stall_starts(t, 10_000), 10_000, before_us=-25_000).tolist() == \
        [[-25_000, 0], [9_990, 40_000]]
    assert stalled_us(t, 10_000) == 40_000 - 9_990 - 10_000
    assert stalled_us(t, 10_000, start_us=-25_000) == 15_000 + 20_010
    assert len(stall_starts(t[:2], 10_000)) == 0 and stalled_us(t[:2], 10_000) == 0


def test_stalls_found_by_empty_windows_are_every_gap_over_a_frame():
    """stall_starts searches half-frame windows; its specification: every gap of the sorted
    times over stall_gap_us (np.diff), on random recordings with shared timestamps."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        t = np.sort(rng.integers(0, rng.integers(10, 2_000_000), rng.integers(2, 300)))
        dt = int(rng.integers(1, 50_000))
        gap = stall_gap_us(t, dt)
        assert np.array_equal(stall_starts(t, dt), np.flatnonzero(np.diff(t) > gap) + 1)
        start = int(rng.integers(-100_000, t[0] + 1))
        d = np.diff(t, prepend=start)
        assert stalled_us(t, dt, start) == np.sum(np.where(d > gap, d - dt, 0))


def test_a_quiet_sensors_natural_gaps_are_no_stall():
    """90 events a second (a 346x260 sensor at 0.001 Hz a pixel): gaps of over a frame are
    the rule; only a gap of 20 mean intervals is a stall."""
    t = np.cumsum(np.random.default_rng(5).exponential(11_000, 900)).astype(np.int64)
    assert np.count_nonzero(np.diff(t) > 10_000) > 300
    assert len(stall_starts(t, 10_000)) == 0 and stalled_us(t, 10_000) == 0
    gapped = np.r_[t[:450], t[450:] + 2_000_000]
    assert list(stall_starts(gapped, 10_000)) == [450]


@pytest.fixture(scope="module")
def stalled():
    run = sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=4.0), seed=62)
    ev = run.events
    return run, ev[(ev.t < 400_000) | (ev.t > 700_000)]


def test_the_background_rate_is_not_diluted_by_a_stall(stalled):
    run, ev = stalled
    pipe = Pipeline(Config())
    # the calibration window (2 s) holds the whole run and its stall
    assert pipe.calibration_rate(ev, 0) == pytest.approx(pipe.calibration_rate(run.events, 0),
                                                         rel=0.05)


def test_no_crossing_pairs_levels_across_a_stall(stalled, monkeypatch):
    """(An ON event before a 300 ms stall and an OFF after it made a crossing 100 px off.)"""
    run, ev = stalled
    got = []
    real = estimation.estimate

    def seen(centroids, config, t0_us, crossings=None, *args, **kwargs):   # the run's own
        got.append(crossings)
        return real(centroids, config, t0_us, crossings, *args, **kwargs)

    monkeypatch.setattr(estimation, "estimate", seen)
    res = Pipeline(Config().replace(**{"motion.compensate": "imu"})).run(ev, run.imu, run.camera)
    t = got[0]["t"]
    assert len(t) and not np.any((t > 400_000 + 10_000) & (t < 700_000 - 10_000))
    assert res.metrics.get("background_hz") is None


def test_a_track_is_smoothed_in_pieces_across_a_stall_no_frame_is_reported_in():
    from evstar.pieces import cut as _pieces, owned as _owned
    from evstar.extract import CENTROID_DTYPE

    c = np.zeros(9, CENTROID_DTYPE)
    c["t"] = [0, 10_000, 20_000, 400_000, 410_000, 5_000, 15_000, 25_000, 30_000]
    c["track"] = [3, 3, 3, 3, 3, 7, 7, 7, -1]
    stall = np.array([[25_000, 390_000]])
    cut, owner = _pieces(c, 120_000, stall)
    assert list(cut["track"]) == [3, 3, 3, 9, 9, 7, 7, 7, -1] and owner == {9: 3}
    assert np.array_equal(_owned(cut, owner), c)
    assert _pieces(c, 400_000, stall)[1] == {}                 # a gap some frame is reported in
    assert _pieces(c, 120_000, np.zeros((0, 2), np.int64))[1] == {}   # a star's own silence
    assert _pieces(c, 120_000, np.array([[100_000, 150_000]]))[1] == {}   # a short stall


def test_a_stall_is_no_bridge_for_the_gyro(stalled):
    """The along fit across 300 ms without measurements honoured the gyro's turn over them:
    the paper's sinusoid's measured rows 0.018 -> 0.083 px; in pieces 0.063."""
    run, ev = stalled
    res = Pipeline(Config().replace(**{"motion.compensate": "imu"})).run(ev, run.imu, run.camera)
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    measured = (star >= 0) & (res.centroids["source"] == "measured")
    assert err[measured].mean() < 0.07 and set(res.centroids["track"]) == {0}


def test_a_streamed_run_sees_the_same_stall(stalled, tmp_path):
    """Chunks of 7 frames: the stall spans several, and run_file gives run's rows."""
    from evstar import io

    run, ev = stalled
    io.write(tmp_path / "events.h5", ev)
    cfg = Config(chunk_frames=7).replace(**{"motion.compensate": "imu"})
    whole = Pipeline(cfg).run(ev, run.imu, run.camera)
    streamed = Pipeline(cfg).run_file(tmp_path / "events.h5", run.imu, run.camera,
                                      progress=False)
    assert len(whole.centroids) > 50
    for f in whole.centroids.dtype.names:
        np.testing.assert_array_equal(whole.centroids[f], streamed.centroids[f])


def _piece_rows(track, t_us, x0, v, sigma=0.05):
    from evstar.smoothing import ESTIMATE_DTYPE

    rows = np.zeros(len(t_us), ESTIMATE_DTYPE)
    rows["t"], rows["track"] = t_us, track
    rows["x"], rows["y"], rows["vx"], rows["vy"] = x0 + v * (np.asarray(t_us) * 1e-6), 50.0, v, 0.0
    rows["sigma_x"] = rows["sigma_y"] = sigma
    return rows


def test_a_stall_the_gyro_carries_a_star_across_is_fitted_across():
    """A prior moving the star at 100 px/s: the piece after a 300 ms stall where it puts it
    is joined back; 1 px off (20 σ) it stays a piece."""
    from evstar.pieces import bridged as _bridged, rejoined as _relabelled
    from evstar.extract import CENTROID_DTYPE

    def prior(t_us, x, y):
        return np.column_stack([np.full(len(t_us), 100.0), np.zeros(len(t_us))])

    t_a, t_b = np.arange(0, 100_000, 10_000), np.arange(400_000, 500_000, 10_000)
    est = np.concatenate([_piece_rows(3, t_a, 10.0, 100.0), _piece_rows(9, t_b, 10.0, 100.0)])
    (track, t_a, t_b, miss, joined), = _bridged(est, {9: 3}, prior).values()
    assert (track, t_a, t_b, joined) == (3, 90_000, 400_000, True) and miss < 1e-6
    est["x"][est["track"] == 9] += 1.0
    assert _bridged(est, {9: 3}, prior)[9][3:] == (pytest.approx(1.0), False)
    assert _bridged(est, {9: 3}, None) == {}
    # a track cut twice, its first stall bridged: one piece is left, owned by the track
    c = np.zeros(6, CENTROID_DTYPE)
    c["track"] = 3
    cut = c.copy()
    cut["track"] = [3, 3, 9, 9, 10, 10]
    joined, owner = _relabelled(c, cut, {10: 3})
    assert list(joined["track"]) == [3, 3, 3, 3, 10, 10] and owner == {10: 3}


def test_rows_coasted_into_an_unbridged_stall_carry_the_gyros_miss():
    """A 1 px miss across a 300 ms stall: a row coasted 30 ms into it gets σ ≥ 0.1 px, one
    60 ms in 0.2 px; with a 0.15 px limit the latter goes."""
    from evstar.extract import CENTROID_DTYPE
    from evstar.pieces import Gap, coasted_honestly

    rows = np.zeros(4, CENTROID_DTYPE)
    rows["t"], rows["track"], rows["sigma"] = [120_000, 150_000, 200_000, 150_000], [3, 3, 3, 4], 0.01
    rows["source"] = ["coasted", "coasted", "measured", "coasted"]
    out = coasted_honestly(rows, [Gap(3, 90_000, 390_000, 1.0, False),
                                  Gap(4, 90_000, 390_000, 9.0, True)], 0.15)
    assert list(out["t"]) == [120_000, 200_000, 150_000]
    assert out["sigma"][0] == pytest.approx(np.hypot(0.01, 0.1)) and list(out["sigma"][1:]) == [0.01, 0.01]
