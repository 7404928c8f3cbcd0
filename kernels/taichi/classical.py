"""Classical spatio-temporal correlation filter (dv's BackgroundActivityNoiseFilter), exact.

Lane-parallel form for CPUs: the stream is cut into event ranges [lo, hi); each range is
filtered sequentially on a private timestamp map after replaying, without decisions, the
events [lookback, lo) that can still support it (t > t_lo − dt; from the stream start when
t_lo < dt, where dv's zero-initialised map matters). Older events cannot support any event
of the range, and neither can the zero a cleared map holds: t − 0 >= t_lo >= dt. So every
range sees exactly the state dv's sequential loop would — no sequential pass over the whole
stream, no per-event atomics. Maps have a one-pixel border holding BORDER (never supports);
their interior is cleared back to 0 by un-binning the range's events.

support[i] = number of the 8 neighbours with t_i − ts < dt; keep[i] = support[i] >= k_min.
"""
import taichi as ti

from . import slots
from .arrays import i32_1d, i64_1d, i64_3d, i8_1d, u16_1d, u8_1d

BORDER = -(1 << 62)


@ti.kernel
def classical_ranges(t: i64_1d, x: u16_1d, y: u16_1d, unit_lb: i32_1d, unit_lo: i32_1d,
                     unit_hi: i32_1d, dt: ti.i64, k_min: ti.i32, maps: i64_3d, busy: i32_1d,
                     support: i8_1d, keep: u8_1d):
    """Filter each unit's range after replaying its lookback (see the module doc).

    Specification: `evstar_kernels.reference.denoise.classical_support` (keep: >= k_min)."""
    n_slots = busy.shape[0]
    for u in range(unit_lo.shape[0]):
        if unit_hi[u] > unit_lo[u]:
            slot = slots.claim(busy, n_slots)
            for i in range(unit_lb[u], unit_lo[u]):  # replay: state only
                maps[slot, ti.cast(y[i], ti.i32) + 1, ti.cast(x[i], ti.i32) + 1] = t[i]
            for i in range(unit_lo[u], unit_hi[u]):
                r = ti.cast(y[i], ti.i32) + 1
                c = ti.cast(x[i], ti.i32) + 1
                ti_ = t[i]
                s = 0
                for dy in ti.static(range(-1, 2)):
                    for dx in ti.static(range(-1, 2)):
                        if ti.static(dx != 0 or dy != 0):
                            s += ti.cast(ti_ - maps[slot, r + dy, c + dx] < dt, ti.i32)
                support[i] = ti.cast(s, ti.i8)
                keep[i] = ti.cast(s >= k_min, ti.u8)
                maps[slot, r, c] = ti_
            for i in range(unit_lb[u], unit_hi[u]):  # un-bin: back to dv's initial 0
                maps[slot, ti.cast(y[i], ti.i32) + 1, ti.cast(x[i], ti.i32) + 1] = 0
            slots.release(busy, slot)
