"""Timestamps on a coarse lattice (a sensor stamping each readout, a file written in ms):
the run says so — positions are for the stamped times (perf/study_time_quantization.py:
a floored stamp puts stars speed × step/2 ahead)."""
import warnings

import numpy as np
import pytest

from evstar import Config, EvstarWarning, Events, Pipeline, sim
from evstar.events import MIN_LATTICE_GAPS, MIN_LATTICE_US, time_lattice_us


def test_the_lattice_step_is_the_gaps_common_divisor():
    rng = np.random.default_rng(0)
    t = np.sort(rng.integers(0, 10**6, 5000))
    assert time_lattice_us(t) == 0                           # 1 µs stamps
    assert time_lattice_us(7 + t // 500 * 500) == 500        # any origin
    assert time_lattice_us(t // 1000 * 1000 + (t % 2) * 250) == 250
    assert time_lattice_us(t // (MIN_LATTICE_US - 1) * (MIN_LATTICE_US - 1)) == 0
    few = np.arange(MIN_LATTICE_GAPS) * 1000                 # one gap short of judging
    assert time_lattice_us(few) == 0 and time_lattice_us(np.r_[few, few[-1] + 1000]) == 1000


def _run(step_us):
    run = sim.simulate(sim.paper_preset(20.0, duration_s=0.2), seed=3)
    ev = run.events
    if step_us:
        ev = Events(ev.t // step_us * step_us, ev.x, ev.y, ev.p, ev.width, ev.height)
    Pipeline(Config()).run(ev, run.imu, run.camera)


def test_a_run_on_millisecond_stamps_warns_once():
    with pytest.warns(EvstarWarning, match="1000 µs lattice.*500 µs of their motion ahead") as w:
        _run(1000)
    assert sum("lattice" in str(x.message) for x in w) == 1


def test_a_run_on_microsecond_stamps_does_not():
    with warnings.catch_warnings():
        warnings.simplefilter("error", EvstarWarning)
        _run(0)
