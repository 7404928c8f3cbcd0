"""Taichi (CPU) filters are bit-exact with the numpy reference: masks and counts."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import evstar
from evstar import denoise
from evstar_kernels.taichi import density_launch, launch

SENSORS = [(1, 1), (7, 5), (40, 30)]
# (sensor, radii) pairs: each pair compiles its own kernels, so the list is kept short
GEOMETRIES = [((1, 1), (3,)), ((7, 5), (1.5,)), ((7, 5), (2, 4.5)), ((40, 30), (3,)),
              ((40, 30), (3, 5, 7, 9, 11))]


def make_events(seed, n, width, height, max_step=400, t_start=0, hot=None):
    rng = np.random.default_rng(seed)
    t = t_start + np.cumsum(rng.integers(0, max_step + 1, n))
    x, y = rng.integers(0, width, n), rng.integers(0, height, n)
    if hot is not None:  # a share of the events on a few pixels, so counts pile up
        on = rng.random(n) < hot
        x[on], y[on] = rng.integers(0, min(width, 2), on.sum()), rng.integers(0, min(height, 2), on.sum())
    return evstar.Events(t, x, y, rng.integers(0, 2, n), width, height)


def assert_same(flt_ref, flt_ti, ev):
    m_ref, m_ti = flt_ref.apply(ev), flt_ti.apply(ev)
    assert m_ti.dtype == bool and m_ti.shape == (len(ev),)
    np.testing.assert_array_equal(m_ti, m_ref)
    np.testing.assert_array_equal(flt_ti.counts_, flt_ref.counts_)
    assert flt_ti.counts_.dtype == flt_ref.counts_.dtype


def mr_pair(radii, thresholds, dt_us=1_000, **kw):
    return (denoise.MRNDSEF(dt_us, radii, thresholds, backend="reference"),
            denoise.MRNDSEF(dt_us, radii, thresholds, **kw))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 400), geometry=st.sampled_from(GEOMETRIES),
       strategy=st.sampled_from(denoise.STRATEGIES), th=st.lists(st.integers(1, 9), min_size=5, max_size=5),
       hot=st.sampled_from([None, 0.3]))
def test_density_counts_match_reference(seed, n, geometry, strategy, th, hot):
    size, radii = geometry
    ev = make_events(seed, n, *size, hot=hot)
    assert_same(*mr_pair(radii, th[:len(radii)], strategy=strategy), ev)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 400), size=st.sampled_from(SENSORS),
       dt=st.sampled_from([1, 50, 1_000, 10_000]), k=st.integers(1, 8),
       t_start=st.sampled_from([0, 7, 3_000, -20_000, 10**15]))
def test_classical_matches_reference(seed, n, size, dt, k, t_start):
    ev = make_events(seed, n, *size, max_step=300, t_start=t_start)
    assert_same(denoise.ClassicalFilter(dt, k, backend="reference"), denoise.ClassicalFilter(dt, k), ev)


def test_edge_and_corner_pixels():
    w, h = 40, 30
    border = [(x, y) for x in range(w) for y in range(h) if x in (0, 1, w - 2, w - 1) or y in (0, 1, h - 2, h - 1)]
    rng = np.random.default_rng(5)
    pick = rng.integers(0, len(border), 3000)
    xy = np.array(border)[pick]
    ev = evstar.Events(np.sort(rng.integers(0, 30_000, 3000)), xy[:, 0], xy[:, 1], np.ones(3000), w, h)
    for strategy in denoise.STRATEGIES:
        assert_same(*mr_pair((3, 5, 7, 9, 11), (2, 3, 4, 6, 8), strategy=strategy), ev)
    assert_same(denoise.ClassicalFilter(500, backend="reference"), denoise.ClassicalFilter(500), ev)


def test_empty_stream_empty_frames_and_one_event_frames():
    empty = evstar.Events.empty(40, 30)
    for flt in (denoise.MRNDSEF(thresholds=(1,) * 5), denoise.NDSEF(threshold=1), denoise.ClassicalFilter()):
        keep = flt.apply(empty)
        assert keep.shape == (0,) and keep.dtype == bool and len(flt.counts_) == 0
    # frames of one event separated by long empty stretches, then a busy frame
    t = np.r_[0, 50_000, 51_000, 400_000, 900_000 + np.arange(50)]
    rng = np.random.default_rng(2)
    ev = evstar.Events(t, rng.integers(0, 40, len(t)), rng.integers(0, 30, len(t)), np.ones(len(t)), 40, 30)
    for strategy in denoise.STRATEGIES:
        assert_same(*mr_pair((3, 5, 7, 9, 11), (1, 2, 2, 3, 3), dt_us=10_000, strategy=strategy), ev)
    assert_same(denoise.ClassicalFilter(10_000, backend="reference"), denoise.ClassicalFilter(10_000), ev)


def test_streams_longer_than_one_launch(monkeypatch):
    ev = make_events(11, 5000, 40, 30, max_step=40)
    ref_mr = mr_pair((3, 5, 7), (2, 4, 6))[0]
    ref_cl = denoise.ClassicalFilter(700, 2, backend="reference")
    expect_mr, expect_cl = ref_mr.apply(ev), ref_cl.apply(ev)
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 333)
    mr = denoise.MRNDSEF(1_000, (3, 5, 7), (2, 4, 6))
    cl = denoise.ClassicalFilter(700, 2)
    np.testing.assert_array_equal(mr.apply(ev), expect_mr)
    np.testing.assert_array_equal(mr.counts_, ref_mr.counts_)
    np.testing.assert_array_equal(cl.apply(ev), expect_cl)
    np.testing.assert_array_equal(cl.counts_, ref_cl.counts_)
    assert len(list(launch.frame_launches(denoise.ref.frame_offsets(ev.t, 1_000)))) > 5


def test_frames_too_big_for_16_bit_cells():
    # > 65535 events in one frame switch the grid to 32-bit cells; counts pile up on 4 pixels
    ev = make_events(3, 70_000, 40, 30, max_step=0, hot=0.9)
    for strategy in ("sparse", "dense"):
        assert_same(*mr_pair((1, 3), (5, 20_000), strategy=strategy), ev)
    assert mr_pair((1, 3), (5, 20_000))[1].apply(ev).sum() > 0


def test_ndsef_and_auto_thresholds_match_reference():
    ev = make_events(8, 20_000, 40, 30, max_step=3)
    a = denoise.NDSEF(10_000, 4, "auto", backend="reference")
    b = denoise.NDSEF(10_000, 4, "auto")
    assert_same(a, b, ev)
    assert a.threshold_ == b.threshold_ and a.rate_hz_ == b.rate_hz_
    c, d = denoise.MRNDSEF(backend="reference"), denoise.MRNDSEF()
    assert_same(c, d, ev)
    assert c.thresholds_ == d.thresholds_


@pytest.fixture(params=[False, True], ids=["numpy-arrays", "device-arrays"])
def device_arrays(request, monkeypatch):
    """The event-parallel (GPU) form, with the CUDA data path (Taichi ndarrays) run on CPU."""
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", request.param)
    return request.param


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 400), geometry=st.sampled_from(GEOMETRIES),
       strategy=st.sampled_from(denoise.STRATEGIES), th=st.lists(st.integers(1, 9), min_size=5, max_size=5))
def test_event_parallel_counts_match_reference(seed, n, geometry, strategy, th):
    size, radii = geometry
    ev = make_events(seed, n, *size, hot=0.2)
    assert_same(*mr_pair(radii, th[:len(radii)], strategy=strategy, schedule="events"), ev)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 400), size=st.sampled_from(SENSORS),
       dt=st.sampled_from([1, 50, 1_000, 10_000]), k=st.integers(1, 8),
       t_start=st.sampled_from([0, 7, 3_000, -20_000, 10**15]), max_step=st.sampled_from([0, 300, 30_000]))
def test_event_parallel_classical_matches_reference(seed, n, size, dt, k, t_start, max_step):
    ev = make_events(seed, n, *size, max_step=max_step, t_start=t_start)
    assert_same(denoise.ClassicalFilter(dt, k, backend="reference"),
                denoise.ClassicalFilter(dt, k, schedule="events"), ev)


def test_event_parallel_data_path_batches_and_launches(device_arrays, monkeypatch):
    ev = make_events(12, 6000, 40, 30, max_step=40)
    ref_mr = mr_pair((3, 5, 7), (2, 4, 6))[0]
    ref_cl = denoise.ClassicalFilter(700, 2, backend="reference")
    expect_mr, expect_cl = ref_mr.apply(ev), ref_cl.apply(ev)
    # small scratch budgets and launches: many batches of frames / buckets per launch
    monkeypatch.setattr(launch, "EVENT_GRID_BYTES", 100_000)
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 1_000)
    for strategy in denoise.STRATEGIES:
        mr = denoise.MRNDSEF(1_000, (3, 5, 7), (2, 4, 6), strategy=strategy, schedule="events")
        np.testing.assert_array_equal(mr.apply(ev), expect_mr)
        np.testing.assert_array_equal(mr.counts_, ref_mr.counts_)
    cl = denoise.ClassicalFilter(700, 2, schedule="events")
    np.testing.assert_array_equal(cl.apply(ev), expect_cl)
    np.testing.assert_array_equal(cl.counts_, ref_cl.counts_)
    # buckets of ~2500 events: one bucket spans several launches
    wide_ref = denoise.ClassicalFilter(100_000, 3, backend="reference")
    wide = denoise.ClassicalFilter(100_000, 3, schedule="events")
    np.testing.assert_array_equal(wide.apply(ev), wide_ref.apply(ev))


# radius 1 from bit tiles (r1 >= 3.5), with survivors; a box wider than the unrolled 4 x 4 tiles
TILE_GEOMETRIES = [((40, 30), (5,)), ((40, 30), (4, 6, 9)), ((40, 30), (20,))]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 600), geometry=st.sampled_from(TILE_GEOMETRIES),
       strategy=st.sampled_from(denoise.STRATEGIES), th=st.lists(st.integers(1, 12), min_size=3, max_size=3),
       hot=st.sampled_from([None, 0.1, 0.5]))
def test_tile_counts_match_reference(seed, n, geometry, strategy, th, hot):
    size, radii = geometry
    ev = make_events(seed, n, *size, hot=hot)
    assert_same(*mr_pair(radii, th[:len(radii)], strategy=strategy), ev)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 600),
       geometry=st.sampled_from(GEOMETRIES[1:] + TILE_GEOMETRIES),
       strategy=st.sampled_from(denoise.STRATEGIES), schedule=st.sampled_from(["lanes", "events"]),
       th=st.lists(st.integers(1, 12), min_size=5, max_size=5), share=st.sampled_from([0.0, 0.3, 1.0]),
       full=st.booleans())
def test_selected_and_mask_only_counts_match_reference(seed, n, geometry, strategy, schedule, th,
                                                       share, full):
    size, radii = geometry
    ev = make_events(seed, n, *size, hot=0.2)
    select = np.random.default_rng(seed).random(n) < share
    a, b = mr_pair(radii, th[:len(radii)], strategy=strategy, schedule=schedule)
    method = "apply" if full else "mask"
    np.testing.assert_array_equal(getattr(b, method)(ev, select=select),
                                  getattr(a, method)(ev, select=select))
    if full:
        np.testing.assert_array_equal(b.counts_, a.counts_)
    else:
        assert a.counts_ is None and b.counts_ is None


def test_every_survivor_layout_matches_reference():
    """Sparse frames whose survivors are counted in each layout the cost model can pick:
    tiles (survivors on few pixels), full counts folded from the tiles, and row prefix sums."""
    from evstar_kernels.taichi import frame_costs, frame_grids
    from evstar_kernels.taichi.disk_reads import disk_padding

    w, h, radii = 120, 90, (4, 6, 9)
    disks = density_launch.disks(radii)
    geo = frame_grids.Geometry(w, h, disk_padding(disks))
    costs = frame_costs.disk_costs(disks, geo, "u16x4")
    n = costs.dense_min - 1  # the biggest sparse frame
    # survivor pixels from which folding pays, and from which prefix sums do
    to_full = costs.fold * n / (costs.rest_sparse - costs.rest_direct)
    to_prefix = costs.plane / (costs.rest_direct - costs.rest_prefix)
    assert costs.tiles and to_full < to_prefix < 500, (to_full, to_prefix)
    rng = np.random.default_rng(4)
    for n_events, (bw, bh) in [(300, (3, 3)), (n, (20, -(-int(to_full + to_prefix) // 40))),
                               (n, (25, -(-int(to_prefix + 30) // 25)))]:
        # survivors: a block of bw x bh pixels, one event each; the other events alone on a
        # lattice 5 px apart (> radius 1) away from the block, each pixel at most m times
        block = [(40 + i, 30 + j) for i in range(bw) for j in range(bh)]
        lattice = [(x, y) for x in range(0, w, 5) for y in range(0, h, 5)
                   if not (36 <= x < 44 + bw and 26 <= y < 34 + bh)]
        rest = n_events - len(block)
        xy = np.array(block + [lattice[i % len(lattice)] for i in range(rest)])[rng.permutation(n_events)]
        th1 = -(-rest // len(lattice)) + 1
        ev = evstar.Events(np.arange(n_events), xy[:, 0], xy[:, 1], np.ones(n_events), w, h)
        for strategy in ("auto", "sparse"):
            ref, fast = mr_pair(radii, (th1, 3, 3), dt_us=10 * n_events, strategy=strategy)
            assert_same(ref, fast, ev)
            assert (fast.counts_[:, 1] >= 0).sum() == len(block)


def test_one_frame_stream_keeps_scratch_small():
    """A stream that is one big frame: the per-pixel lists are sized by the sensor, not by
    the events, and the counts still match the reference."""
    import tracemalloc

    ev = make_events(9, 200_000, 40, 30, max_step=0, hot=0.2)
    ref, fast = mr_pair((3, 5), (3, 40), dt_us=10**6, strategy="sparse")
    assert_same(ref, fast, ev)
    tracemalloc.start()
    fast.apply(ev)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    outputs = ev.__len__() * (4 * 2 + 1)  # counts (n, 2) int32 + keep
    assert peak < outputs + 1_000_000, (peak, outputs)


def test_simulated_star_scene_matches_reference():
    """The paper's scene (320x240, background, hot pixels, a star at 20 °/s): the frames are
    sparse, the star and hot pixels repeat, survivors share pixels — every path at full size."""
    from evstar import sim

    ev = sim.simulate(sim.paper_preset(20.0, duration_s=0.2), seed=3).events
    for strategy in denoise.STRATEGIES:
        assert_same(denoise.NDSEF(backend="reference"), denoise.NDSEF(strategy=strategy), ev)
        ref, fast = denoise.MRNDSEF(backend="reference"), denoise.MRNDSEF(strategy=strategy)
        assert_same(ref, fast, ev)
        assert 0 < fast.n_kept_ < len(ev)


@pytest.mark.parametrize("t_start", [0, 777])
def test_kept_among_is_the_mask_of_the_selection(t_start):
    """kept_among (the pooled look's: the selection's pixels, the stream's frame bounds)
    keeps what mask() keeps of the selected events alone; without t0_us or a rate for auto
    thresholds it takes that selection itself."""
    ev = make_events(31, 30_000, 40, 30, max_step=10, t_start=t_start)
    among = np.random.default_rng(31).random(len(ev)) < 0.7
    among[-50:] = False                         # the selection ends before the stream
    filters = [denoise.NDSEF(4_000, 4, "auto", rate_hz=50.0, t0_us=0),
               denoise.MRNDSEF(3_000, (2, 4), (3, 6), t0_us=t_start),
               denoise.NDSEF(4_000, 4, "auto", t0_us=0),              # rate measured
               denoise.NDSEF(4_000, 4, 8),                            # no t0_us
               denoise.NDSEF(4_000, 4, 8, t0_us=0, backend="reference")]
    for flt in filters:
        got = flt.kept_among(ev, among)
        want = np.flatnonzero(among)[flt.mask(ev[among])]
        np.testing.assert_array_equal(got, want)
        assert 0 < len(got) < among.sum() and flt.n_events_ == among.sum()
    assert len(denoise.NDSEF(4_000, 4, 3, t0_us=0).kept_among(ev, np.zeros(len(ev), bool))) == 0
