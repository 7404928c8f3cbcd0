"""Scratch memory of the Taichi filters: per filter, safe across threads, correct after an
interrupted call, freed on release."""
import gc
import threading
import weakref

import numpy as np
import pytest

from evstar import backends, denoise
from evstar_kernels.taichi import classical_launch, density_launch, launch
from evstar_kernels.taichi.scratch import Scratch
from test_denoise_taichi import make_events

SCHEDULES = ("lanes", "events")


def reference(flt, ev):
    """The mask and counts of flt's parameters on the numpy reference."""
    ref = type(flt)(**{**flt.get_params(), "backend": "reference", "schedule": "auto"})
    return ref.apply(ev), ref.counts_


def filters(schedule):
    return [denoise.MRNDSEF(1_000, (3, 5, 7), (2, 4, 6), schedule=schedule),
            denoise.NDSEF(1_000, 4, 3, schedule=schedule),
            denoise.ClassicalFilter(700, 2, schedule=schedule)]


def run_together(jobs):
    """Run the callables on threads started together; their results, in order."""
    start, out = threading.Barrier(len(jobs)), [None] * len(jobs)

    def work(i):
        start.wait()
        out[i] = jobs[i]()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(len(jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return out


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_two_threads_filter_different_streams_at_once(schedule, monkeypatch):
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 700)  # many launches, so the calls interleave
    streams = [make_events(21, 6000, 40, 30, max_step=40, hot=0.2), make_events(22, 5000, 40, 30, max_step=50)]
    for a, b in zip(filters(schedule), filters(schedule)):
        for _ in range(3):
            got = run_together([lambda: (a.apply(streams[0]), a.counts_.copy()),
                                lambda: (b.apply(streams[1]), b.counts_.copy())])
            for (keep, counts), ev in zip(got, streams):
                expect_keep, expect_counts = reference(a, ev)
                np.testing.assert_array_equal(keep, expect_keep)
                np.testing.assert_array_equal(counts, expect_counts)


def test_one_filter_shared_by_two_threads_gives_exact_masks(monkeypatch):
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 700)
    streams = [make_events(23, 6000, 40, 30, max_step=40, hot=0.2), make_events(24, 5000, 40, 30, max_step=50)]
    for flt in filters("events"):
        got = run_together([lambda ev=ev: flt.apply(ev) for ev in streams])
        for keep, ev in zip(got, streams):
            np.testing.assert_array_equal(keep, reference(flt, ev)[0])


class Stop(Exception):
    pass


def stop_at(n):
    """An on_launch hook that raises at its n-th call (a KeyboardInterrupt between launches)."""
    calls = []

    def hook():
        calls.append(1)
        if len(calls) == n:
            raise Stop

    return hook


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_interrupted_density_call_then_exact_results(schedule, monkeypatch):
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 500)
    ti = backends.taichi("cpu")
    ev = make_events(25, 4000, 40, 30, max_step=40, hot=0.2)
    radii, th = (3, 5, 7), (2, 4, 6)
    offsets = denoise.ref.frame_offsets(ev.t, 1_000)
    expect = denoise.MRNDSEF(1_000, radii, th, backend="reference")
    expect_keep = expect.apply(ev)
    scratch = Scratch()
    for strategy in denoise.STRATEGIES:
        args = (ti, ev.x, ev.y, ev.width, ev.height, offsets, radii, th)
        kw = dict(strategy=strategy, schedule=schedule, scratch=scratch)
        with pytest.raises(Stop):  # events: stops after binning, the grid still holds a batch
            density_launch.count_density(*args, **kw, on_launch=stop_at(3))
        assert scratch.dirty
        keep, counts = density_launch.count_density(*args, **kw)
        assert not scratch.dirty
        np.testing.assert_array_equal(keep, expect_keep)
        np.testing.assert_array_equal(counts, expect.counts_)


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_interrupted_classical_call_then_exact_results(schedule, monkeypatch):
    monkeypatch.setattr(launch, "MAX_LAUNCH_EVENTS", 500)
    ti = backends.taichi("cpu")
    ev = make_events(26, 4000, 40, 30, max_step=40)
    expect = denoise.ClassicalFilter(700, 2, backend="reference")
    expect_keep = expect.apply(ev)
    scratch = Scratch()
    args = (ti, ev.t, ev.x, ev.y, ev.width, ev.height, 700, 2)
    with pytest.raises(Stop):  # events: stops after filling, the bucket planes hold events
        classical_launch.classical_filter(*args, schedule=schedule, scratch=scratch, on_launch=stop_at(3))
    support, keep = classical_launch.classical_filter(*args, schedule=schedule, scratch=scratch)
    np.testing.assert_array_equal(keep, expect_keep)
    np.testing.assert_array_equal(support, expect.counts_)


def held_arrays(scratch):
    for arr in scratch.arrays().values():
        yield from (arr if isinstance(arr, tuple) else (arr,))


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_release_frees_the_scratch_arrays(schedule):
    ev = make_events(27, 3000, 40, 30, max_step=40)
    for flt in filters(schedule):
        keep = flt.apply(ev)
        scratch = denoise._scratch_of(flt)
        refs = [weakref.ref(arr) for arr in held_arrays(scratch)]
        assert refs
        flt.release()
        gc.collect()
        assert scratch.arrays() == {} and all(r() is None for r in refs)
        np.testing.assert_array_equal(flt.apply(ev), keep)  # made again on the next call


def test_filters_keep_their_own_scratch_and_copies_start_empty():
    import copy
    import pickle

    ev = make_events(28, 2000, 40, 30, max_step=40)
    a, b = denoise.MRNDSEF(1_000, (3, 5), (2, 3)), denoise.MRNDSEF(1_000, (3, 5), (2, 3))
    a.apply(ev)
    assert denoise._scratch_of(a).arrays() and not denoise._scratch_of(b).arrays()
    for c in (copy.deepcopy(a), pickle.loads(pickle.dumps(a))):
        assert denoise._scratch_of(c) is not denoise._scratch_of(a)
        assert not denoise._scratch_of(c).arrays()
        np.testing.assert_array_equal(c.apply(ev), a.apply(ev))


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_filters_sharing_a_scratch_reuse_its_arrays(schedule):
    """A filter made per call (the pipeline's, per run) on a shared Scratch finds the
    previous one's arrays, zeroed: the same masks and counts as its own scratch's."""
    ev = make_events(29, 3000, 40, 30, max_step=40)
    shared = Scratch()
    for make in (lambda: filters(schedule)[0], lambda: filters(schedule)[1]):
        first = make().sharing(shared)
        keep = first.apply(ev)
        held = {name: id(arr) for name, arr in shared.arrays().items()}
        assert held and denoise._scratch_of(first) is shared
        second = make().sharing(shared)
        np.testing.assert_array_equal(second.apply(ev), keep)
        np.testing.assert_array_equal(second.counts_, reference(second, ev)[1])
        assert {name: id(arr) for name, arr in shared.arrays().items()} == held
