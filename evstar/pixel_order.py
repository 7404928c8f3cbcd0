"""What the order of a pixel's events near the stars says of the recording: is its polarity
the right way round, are its events given twice?

A star brightens a pixel, then dims it.
A star passing a pixel fires a run of ON events, then a run of OFF (evstar.crossings), and a
pixel it passes again starts its next ON run long after that OFF run. So among the events
near the stars, ON→OFF changes between runs of two events or more are the passages' — the
more and the quicker — and OFF→ON ones lie between passages. A recording that stores the
polarity the other way round (p = 1 for OFF) shows the reverse, and its crossings pair each
passage's falling flank with the next one's rising: positions 0.014 → 0.163 px, a dark-sky
sinusoid's 0.055 → 1.36. A scene that is no star field (things darker than what lies
behind them) may show the same order, so the run says so and changes nothing.

A pixel fires no two events of one polarity within a microsecond (its refractory period),
so an event that repeats the one before it exactly — pixel, time and polarity — is a
recording given twice (two files merged, a reader run over one stream twice): each star then
counts double in every filter and the background looks busier (9–11 false rows per 100
frames). Stamps on a coarse lattice (evstar.events.time_lattice_us) may repeat honestly.
"""
from __future__ import annotations

import numpy as np

from .events import time_lattice_us

#: changes between runs of two events or more (each way together) the verdict is read on:
#: the first spans' (a run's first 0.5 s of a 50-star field has thousands)
ENOUGH_CHANGES = 1000
#: OFF→ON changes it needs at least to say the order is the reverse
MIN_CHANGES = 30
#: ... and they must outnumber the ON→OFF ones by this factor, or outnumber them with gaps
#: this factor shorter (geometric means): a pixel passed again sees as many changes each way,
#: the passages' the quicker. Simulated stars the right way round: 258 against 19 on a
#: line, 42 against 12 at 1 °/s (its 90 ms passages slower than noise's 35), 2,747 against
#: 1,455 and 2.8 against 184 ms on a sinusoid; the EMLB real street scene 29,335 OFF→ON
#: against 26,582 and 15 against 26 ms
COUNT_LEAD, GAP_LEAD = 2.0, 4.0
#: the share of events that repeat the one before them exactly, and their number, from
#: which a recording is said to hold events twice (real samples: under 1e-5; twice: 1/2)
REPEATED_SHARE, MIN_REPEATED = 0.05, 100


class PixelOrder:
    """ON→OFF and OFF→ON changes between runs of two events or more, and events that repeat
    the one before them, gathered chunk by chunk from events in the pixel-then-time order,
    until ENOUGH_CHANGES."""

    def __init__(self):
        self.count = {"on_off": 0, "off_on": 0}
        self.log_gap = {"on_off": 0.0, "off_on": 0.0}     # sums of ln(gap µs)
        self.events = self.repeats = 0
        self.lattice_us = 0                               # time_lattice_us: 0 fine stamps

    @property
    def wanted(self):
        return sum(self.count.values()) < ENOUGH_CHANGES

    def add(self, ts, keys, ps):
        """Count the changes of events `ts` (µs), pixel `keys`, polarities `ps` (1 ON), in
        the pixel-then-time order."""
        ts, keys, ps = np.asarray(ts), np.asarray(keys), np.asarray(ps)
        same = (keys[1:] == keys[:-1]) & (ts[1:] == ts[:-1]) & (ps[1:] == ps[:-1])
        self.events += len(ts)
        self.repeats += int(same.sum())
        self.lattice_us = max(self.lattice_us, time_lattice_us(ts))
        if len(ts) < 4:
            return
        c = np.flatnonzero((keys[1:-2] == keys[2:-1]) & (ps[1:-2] != ps[2:-1])) + 1
        # a change between events c and c + 1, each the second of its run of two or more
        c = c[(keys[c - 1] == keys[c]) & (ps[c - 1] == ps[c])
              & (keys[c + 2] == keys[c]) & (ps[c + 2] == ps[c + 1])]
        gap = np.log(np.maximum(ts[c + 1] - ts[c], 1).astype(np.float64))
        for name, first in (("on_off", 1), ("off_on", 0)):
            m = ps[c] == first
            self.count[name] += int(m.sum())
            self.log_gap[name] += float(gap[m].sum())

    def reversed(self):
        """A one-line note where the changes say the polarity is the other way round, else
        None."""
        n1, n0 = self.count["on_off"], self.count["off_on"]
        if n0 < MIN_CHANGES:
            return None
        g0 = np.exp(self.log_gap["off_on"] / n0)
        g1 = np.exp(self.log_gap["on_off"] / n1) if n1 else np.inf
        if not (n0 >= COUNT_LEAD * n1 or n0 > n1 and g1 >= GAP_LEAD * g0):
            return None
        return (f"the polarity looks inverted: near the stars {n0:,} OFF runs led into ON runs "
                f"({g0 / 1e3:.1f} ms apart, geometric mean) against {n1:,} ON into OFF"
                + (f" ({g1 / 1e3:.1f} ms)" if n1 else "")
                + "; a star brightens a pixel, then dims it — if p = 1 marks OFF events in "
                "this recording, store ON as 1")

    def repeated(self):
        """A one-line note where the events repeat the one before them too often (and the
        stamps are fine), else None."""
        if self.lattice_us or self.repeats < max(MIN_REPEATED, REPEATED_SHARE * self.events):
            return None
        return (f"{self.repeats:,} of the {self.events:,} events near the stars repeat the one "
                "before them exactly (pixel, time, polarity): is the recording given twice? "
                "Each then counts double")
