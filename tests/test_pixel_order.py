"""A recording whose polarity is stored the other way round, or whose events are given twice,
is told from the order of the events at the stars' pixels (evstar.pixel_order) and
reported, not changed."""
import warnings

import numpy as np
import pytest

from evstar import Config, EvstarWarning, Pipeline, sim
from evstar.pixel_order import COUNT_LEAD, MIN_CHANGES, PixelOrder


def inverted(ev):
    return ev.__class__(ev.t, ev.x, ev.y, (1 - ev.p).astype(np.int8), ev.width, ev.height)


def test_changes_between_runs_of_two_or_more_are_counted_each_way():
    # pixel 7: ON ON OFF OFF ON ON (an ON->OFF change and an OFF->ON one, 10 and 500 µs);
    # pixel 9: ON OFF OFF (a lone ON: no run of two before its change)
    keys = np.array([7, 7, 7, 7, 7, 7, 9, 9, 9])
    ts = np.array([0, 5, 15, 20, 520, 530, 0, 3, 6])
    ps = np.array([1, 1, 0, 0, 1, 1, 1, 0, 0])
    order = PixelOrder()
    order.add(ts, keys, ps)
    assert order.count == {"on_off": 1, "off_on": 1}
    assert order.log_gap["on_off"] == pytest.approx(np.log(10))
    assert order.log_gap["off_on"] == pytest.approx(np.log(500))


def test_the_verdict_needs_enough_reversed_changes_and_a_lead():
    order = PixelOrder()
    order.count = {"on_off": 10, "off_on": MIN_CHANGES - 1}
    order.log_gap = {"on_off": 10 * np.log(1e5), "off_on": (MIN_CHANGES - 1) * np.log(1e3)}
    assert order.reversed() is None                       # too few
    order.count["off_on"] = MIN_CHANGES
    order.log_gap["off_on"] = MIN_CHANGES * np.log(1e3)
    assert "inverted" in order.reversed()
    # as many each way, the OFF->ON ones quicker: a pixel passed again by a reversed star
    order.count = {"on_off": 100, "off_on": 101}
    order.log_gap = {"on_off": 100 * np.log(1e5), "off_on": 101 * np.log(2e3)}
    assert "inverted" in order.reversed()
    order.log_gap["off_on"] = 101 * np.log(1e5 / 3)       # not quick enough to tell
    assert order.reversed() is None
    order.count = {"on_off": 100, "off_on": int(COUNT_LEAD * 100) - 1}   # just short of
    order.log_gap = {k: n * np.log(1e4) for k, n in order.count.items()}   # the lead
    assert order.reversed() is None
    order.count["off_on"] += 1
    order.log_gap["off_on"] += np.log(1e4)
    assert "inverted" in order.reversed()


def metrics_as_given_and_damaged(run, damaged, match):
    """(a run's metrics on the recording as simulated: no pixel-order warning; on
    `damaged` events: the warning `match`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", EvstarWarning)
        right = Pipeline(Config()).run(run.events, run.imu, run.camera).metrics
    with pytest.warns(EvstarWarning, match=match):
        wrong = Pipeline(Config()).run(damaged, run.imu, run.camera).metrics
    return right, wrong


@pytest.mark.parametrize("scene", ["line", "sinusoid"])
def test_a_reversed_polarity_is_reported_and_the_right_one_is_not(scene):
    s = (sim.paper_preset(8.0, duration_s=0.5) if scene == "line"
         else sim.paper_sinusoid(10.0, 1.0, duration_s=1.0))
    run = sim.simulate(s, seed=1)
    right, wrong = metrics_as_given_and_damaged(run, inverted(run.events),
                                                "polarity looks inverted")
    assert "polarity" not in right and "store ON as 1" in wrong["polarity"]


def twice(ev):
    """Every event given twice, as two merged copies of one recording."""
    from evstar import Events

    i = np.repeat(np.arange(len(ev)), 2)
    return Events(ev.t[i], ev.x[i], ev.y[i], ev.p[i], ev.width, ev.height)


def test_events_given_twice_are_reported_and_a_recording_given_once_is_not():
    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.5), seed=1)
    once, doubled = metrics_as_given_and_damaged(run, twice(run.events), "given twice")
    assert "repeated" not in once and "repeat the one before" in doubled["repeated"]


def test_repeats_on_a_coarse_time_lattice_are_not_taken_for_a_copy():
    from evstar.pixel_order import MIN_REPEATED

    order = PixelOrder()
    keys = np.repeat(np.arange(2 * MIN_REPEATED), 2)
    ts = np.repeat(np.arange(2 * MIN_REPEATED) * 1000, 2)         # a 1 ms lattice
    order.add(ts, keys, np.ones(len(ts), np.int8))
    assert order.repeats == 2 * MIN_REPEATED and order.lattice_us == 1000
    assert order.repeated() is None
    order.lattice_us = 0                                           # fine stamps
    assert "given twice" in order.repeated()
