"""The Taichi pixel counts are bit-exact with the numpy reference (kernels/reference/pixels)."""
import numpy as np
import pytest

from evstar import backends, frames
from evstar.events import Events
from evstar_kernels.reference.pixels import pixel_counts as reference, pixel_flags as flags_reference
from evstar_kernels.taichi import launch
from evstar_kernels.taichi.pixel_counts_launch import pixel_counts, pixel_flags


def events(seed, n, width, height):
    rng = np.random.default_rng(seed)
    x, y = rng.integers(0, width, n), rng.integers(0, height, n)
    x[: n // 3], y[: n // 3] = 1, min(2, height - 1)   # a pixel with many events
    return Events(np.arange(n), x, y, rng.integers(0, 2, n), width, height), rng.random(n) < 0.3


@pytest.mark.parametrize("device_arrays", [False, True], ids=["serial-cpu", "parallel-device"])
@pytest.mark.parametrize("n, size", [(0, (5, 4)), (1, (1, 1)), (5000, (40, 30)), (20_000, (7, 3))])
def test_pixel_counts_match_reference(monkeypatch, device_arrays, n, size):
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    ev, keep = events(n, n, *size)
    ti = backends.taichi_running()
    for k in (None, keep):
        want, got = reference(ev.x, ev.y, ev.width, ev.height, k), pixel_counts(ti, ev.x, ev.y, ev.width, ev.height, k)
        for w, g in zip(want, got):
            assert (w is None) == (g is None)
            if w is not None:
                assert g.dtype == np.int64 and g.shape == (size[1], size[0])
                np.testing.assert_array_equal(g, w)


def test_pixel_counts_over_many_launches(monkeypatch):
    ev, keep = events(3, 3000, 40, 30)
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 700)
    for k in (None, keep):
        want = reference(ev.x, ev.y, 40, 30, k)
        got = pixel_counts(backends.taichi_running(), ev.x, ev.y, 40, 30, k)
        np.testing.assert_array_equal(got[0], want[0])
        assert (got[1] is None) == (k is None)
        if k is not None:
            np.testing.assert_array_equal(got[1], want[1])


def test_accumulated_and_images_agree():
    ev, keep = events(4, 4000, 40, 30)
    before, after = frames.images(ev, keep)
    np.testing.assert_array_equal(before, frames.accumulated(ev))
    np.testing.assert_array_equal(after, frames.accumulated(ev, keep))
    assert frames.images(ev)[1] is None and before.sum() == len(ev) and after.sum() == keep.sum()


@pytest.mark.parametrize("device_arrays", [False, True], ids=["numpy", "device-arrays"])
def test_pixel_flags_are_the_mask_at_each_event(monkeypatch, device_arrays):
    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 1000)
    ev, _ = events(5, 2500, 40, 30)
    flags = np.random.default_rng(5).random((30, 40)) < 0.1
    got = pixel_flags(backends.taichi_running(), ev.x, ev.y, flags)
    assert got.dtype == bool
    np.testing.assert_array_equal(got, flags_reference(ev.x, ev.y, flags))
    np.testing.assert_array_equal(frames.on_pixels(ev, flags), got)
    assert len(pixel_flags(backends.taichi_running(), ev.x[:0], ev.y[:0], flags)) == 0


@pytest.mark.parametrize("device_arrays", [False, True], ids=["serial-cpu", "parallel-device"])
@pytest.mark.parametrize("max_launch", [None, 700])
@pytest.mark.parametrize("n, size", [(0, (5, 4)), (1, (1, 1)), (5000, (40, 30)), (20_000, (7, 3))])
def test_kept_pixels_and_events_on_flagged_pixels_match_reference(monkeypatch, device_arrays,
                                                                   max_launch, n, size):
    from evstar_kernels.reference.pixels import marked_pixels, on_flagged_pixels

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    if max_launch:
        monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", max_launch)
    ev, keep = events(n + 1, n, *size)
    marked = frames.kept_pixels(ev, keep)
    assert marked.dtype == bool and marked.shape == (size[1], size[0])
    np.testing.assert_array_equal(marked, marked_pixels(ev.x, ev.y, keep, *size))
    # the kept events' indices, where the caller has them, mark the same pixels
    np.testing.assert_array_equal(frames.kept_pixels(ev, frames.kept_indices(keep)), marked)
    flags = np.random.default_rng(n).random((size[1], size[0])) < 0.4
    got = frames.events_on_pixels(ev, flags)
    want = on_flagged_pixels([ev.t, ev.x, ev.y, ev.p], ev.x, ev.y, flags)
    assert [a.dtype for a in got] == [np.int64, np.uint16, np.uint16, np.int8]
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    assert 0 < len(got[0]) < n or n < 10


@pytest.mark.parametrize("device_arrays", [False, True], ids=["serial-cpu", "parallel-device"])
@pytest.mark.parametrize("max_launch", [None, 700])
@pytest.mark.parametrize("n, size", [(0, (5, 4)), (1, (1, 1)), (5000, (40, 30)),
                                     (20_000, (1280, 720))])    # keys past 2¹⁶
def test_events_by_pixel_match_reference(monkeypatch, device_arrays, max_launch, n, size):
    from evstar_kernels.reference.pixels import events_by_pixel

    monkeypatch.setattr(launch, "DEVICE_ARRAYS", device_arrays)
    if max_launch:
        monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", max_launch)
    ev, _ = events(n + 2, n, *size)
    rng = np.random.default_rng(n)
    # repeated times an hour in: ties stay in input order
    ev = Events(np.sort(rng.integers(0, n // 4 + 1, n)) + 3_600_000_000, ev.x, ev.y, ev.p,
                *size)
    flags = rng.random((size[1], size[0])) < 0.4
    got = frames.events_by_pixel(ev, flags)
    want = events_by_pixel(ev.t, ev.x, ev.y, ev.p, flags)
    assert [a.dtype for a in got] == [np.int64, np.uint32, np.int8]
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    assert 0 < len(got[0]) < n or n < 10
