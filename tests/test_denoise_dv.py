"""The classical filter with k = 1 is dv-processing's BackgroundActivityNoiseFilter, event for event."""
import datetime

import numpy as np
import pytest

from evstar import denoise, io
from evstar.interop import to_dv_store

dv = pytest.importorskip("dv_processing", reason="dv-processing is a test dependency (pip install .[test])")


def dv_kept(store, width, height, dt_us):
    flt = dv.noise.BackgroundActivityNoiseFilter((width, height), datetime.timedelta(microseconds=dt_us))
    flt.accept(store)
    return flt.generateEvents().numpy()


def assert_dv_mask(events, keep, kept):
    """dv returns the kept events: they must be exactly ours, in order."""
    assert keep.sum() == len(kept)
    np.testing.assert_array_equal(events.t[keep], kept["timestamp"])
    np.testing.assert_array_equal(events.x[keep], kept["x"])
    np.testing.assert_array_equal(events.y[keep], kept["y"])


@pytest.mark.parametrize("dt_us", [2_000, 10_000])
def test_real_davis_recording(real_dir, dt_us):
    path = real_dir / "emlb_demo-01.aedat4"
    events = io.read(path).events
    rec = dv.io.MonoCameraRecording(str(path))
    store = dv.EventStore()
    while (batch := rec.getNextEventBatch()) is not None:
        store.add(batch)
    assert len(store) == len(events)
    kept = dv_kept(store, events.width, events.height, dt_us)
    assert 0 < len(kept) < len(events)
    for backend in ("taichi", "reference"):
        keep = denoise.ClassicalFilter(dt_us, k=1, backend=backend).apply(events)
        assert_dv_mask(events, keep, kept)


def test_one_million_simulated_events():
    from evstar import sim

    # noise high enough for 1 M events in 1 s; the stream starts at t = 0, where dv's
    # zero-initialised timestamp map supports every event of the first dt
    scn = sim.paper_preset(12.0, duration_s=1.0, sensor=sim.SensorSpec(noise_hz=14.0))
    events = sim.simulate(scn, seed=4).events
    assert len(events) >= 1_000_000 and events.t[0] < 10_000
    kept = dv_kept(to_dv_store(events), events.width, events.height, 10_000)
    keep = denoise.ClassicalFilter(10_000).apply(events)
    assert_dv_mask(events, keep, kept)
    assert keep[events.t < events.t[0] + 1_000].all()
