"""The background rate block by block (evstar.background): a steady background keeps the
calibration window's rate; stray light rising over a recording is followed, so its
background does not pass the density filters as false stars; streamed runs see the same
blocks as whole ones."""
import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, io, sim
from evstar.background import Background, block_frames
from evstar.outputs import summary_text
from evstar.pipeline import chunk_span_us


def _stray(growth, noise_hz=0.5):
    """The scene with its background rising linearly from noise_hz to growth × noise_hz."""
    spec = sim.SensorSpec(noise_hz=noise_hz, noise_growth=growth)
    return sim.simulate(sim.paper_preset(8.0, duration_s=1.0, magnitude=4.5, sensor=spec),
                        seed=5)


@pytest.fixture(scope="module")
def stray():
    return _stray(16.0)


@pytest.fixture(scope="module")
def scene():
    return _stray(1.0)


def _followed(events, cfg=Config()):
    """(Background, keep, rate runs) of a whole run's filter on `events` (uncompensated)."""
    pipe = Pipeline(cfg)
    t0 = int(events.t[0])
    rate, _ = pipe.calibration(events, t0)
    bg = pipe._background(t0, rate)
    keep = pipe.make_filter(t0, rate).mask(events)
    keep, runs = bg.followed(events.t, keep, t0, cfg, events.width * events.height,
                             lambda part, hz: pipe.make_filter(t0, hz).mask(events[part]))
    return bg, keep, runs


def test_a_steady_background_keeps_the_window_rate(scene):
    bg, keep, runs = _followed(scene.events)
    assert runs == [(None, None, bg.hz)] and bg.summary() is None
    result = Pipeline(Config()).run(scene.events, scene.imu, scene.camera)
    assert "background_hz" not in result.metrics
    assert "background" not in summary_text(result, "out")


def test_a_readout_stall_is_no_change_of_background(scene):
    """300 ms without a single event (a stalled readout): the blocks it cuts keep the window's
    rate (over the whole block it had halved one's)."""
    ev = scene.events
    stalled = ev[(ev.t < ev.t[0] + 420_000) | (ev.t > ev.t[0] + 720_000)]
    bg, _, runs = _followed(stalled)
    assert bg.summary() is None and [hz for _, _, hz in runs] == [bg.hz]


def test_rising_stray_light_is_followed_block_by_block(stray):
    ev = stray.events
    bg, keep, runs = _followed(ev)
    rates = [hz for _, _, hz in runs]
    assert len(runs) >= 4 and np.all(np.diff(rates) > 0)
    assert rates[0] < 0.6 * bg.hz < bg.hz < 0.7 * rates[-1] == 0.7 * bg.highest_hz
    # 0.5 -> 8 events/pixel/s: the last block (0.8-1 s) holds 7.25 on average, the first 1.25
    assert rates[-1] == pytest.approx(7.25, rel=0.15)
    assert rates[0] == pytest.approx(1.25, rel=0.15)
    # the blocks taken at their own rate were filtered at it (the window's let more through)
    window = Pipeline(Config()).make_filter(int(ev.t[0]), bg.hz).mask(ev)
    late = ev.t >= runs[-1][0]
    assert np.count_nonzero(keep[late]) < 0.8 * np.count_nonzero(window[late])
    # a fixed rate (denoise.rate_hz) is the user's: no block moves it
    fixed = Config().replace(**{"denoise.rate_hz": 2.0})
    assert _followed(ev, fixed)[2] == [(None, None, bg.hz)]


def test_stray_light_passes_no_false_stars(stray):
    """With the window's rate throughout (the rate the run measured, fixed), the light at
    the end passes the filters as false tracks; followed, not."""
    ev, scene = stray.events, stray
    bg = _followed(ev)[0]
    n_frames = (int(ev.t[-1]) - int(ev.t[0])) // Config().dt_us + 1
    false = {}
    for name, cfg in (("followed", Config()),
                      ("window", Config().replace(**{"denoise.rate_hz": bg.hz}))):
        result = Pipeline(cfg).run(ev, scene.imu, scene.camera)
        rows = result.centroids
        star, err = accuracy.match(rows, scene.truth.star_position)
        false[name] = 100 * np.count_nonzero(star < 0) / n_frames
        if name == "followed":
            assert np.count_nonzero(star >= 0) >= 0.95 * n_frames and err[star >= 0].mean() < 0.2
            moved = result.metrics["background_hz"]    # what the run says it followed
            assert moved["lowest"] < 0.6 * bg.hz and moved["highest"] > 1.4 * bg.hz
            assert "thresholds followed it" in summary_text(result, "out")
        else:
            assert "background_hz" not in result.metrics
    assert false["followed"] <= 1.0 < 10 * false["followed"] + 5 <= false["window"]


def test_a_streamed_run_sees_the_same_blocks(stray, tmp_path):
    ev = stray.events
    io.write(tmp_path / "events.h5", ev)
    cfg = Config(chunk_frames=7).replace(**{"estimate.estimator": "mean"})
    whole = Pipeline(cfg).run(ev)
    streamed = Pipeline(cfg).run_file(tmp_path / "events.h5", progress=False)
    assert len(whole.centroids) > 50
    for f in whole.centroids.dtype.names:
        np.testing.assert_array_equal(whole.centroids[f], streamed.centroids[f])


@pytest.mark.parametrize("pool", [1, 3, 4, 6])
def test_rate_blocks_are_whole_pooled_frames_within_a_chunk(pool):
    for chunk in range(1, 60):
        cfg = Config(chunk_frames=chunk).replace(**{"extract.pool_frames": pool})
        frames = block_frames(cfg)
        assert frames >= 1 and (chunk_span_us(cfg) // cfg.dt_us) % frames == 0
        assert frames % pool == 0


def test_a_chunk_without_events_measures_no_change():
    bg = Background(1.0, (0, 2_000_000))
    keep = np.zeros(0, bool)
    assert bg.followed(np.zeros(0, np.int64), keep, 0, Config(), 64 * 48, None) == (
        keep, [(None, None, 1.0)])
