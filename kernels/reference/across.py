"""Histograms of events' offsets across their track's motion, in plain numpy: the
specification of evstar_kernels.taichi.across (bit-exact).

An event finds its candidate tracks through the cell (2^cell_shift px square) it falls in
(`start`, `pair_track`: the tracks listed for each cell), then its frame's row of each
such track (`tracks` holds a track's first frame, last frame and the start of its slots in
`table`; `table` the row of each of its frames, -1 none). A row (`rows`: x, y, vx, vy,
ux, uy, t, usable) moved to the event's time along its velocity (px/µs) is the star's
position there; an event within `along_px` of it along the unit direction (ux, uy) and
less than `reach_px` across counts in its track's bin floor((across + reach_px) / bin_px)
(at most nb − 1). Across is the left-hand normal's side: dy·ux − dx·uy.
"""
import numpy as np


def across_counts(t, x, y, t0_us, dt_us, cell_shift, cells_w, start, pair_track, tracks, table,
                  rows, along_px, reach_px, bin_px, nb):
    """(n_tracks, nb) int64 counts (module doc); t int64 µs, x, y integer pixels."""
    n_tracks = len(tracks)
    ec = ((np.asarray(y, np.int64) >> cell_shift) * cells_w
          + (np.asarray(x, np.int64) >> cell_shift))
    n_e = start[ec + 1] - start[ec]
    ev = np.repeat(np.arange(len(t)), n_e)
    k = start[ec][ev] + np.arange(len(ev)) - np.repeat(np.cumsum(n_e) - n_e, n_e)
    g = pair_track[k].astype(np.int64)
    f = (np.asarray(t, np.int64)[ev] - t0_us) // dt_us
    ok = (f >= tracks[g, 0]) & (f <= tracks[g, 1])
    ev, g, f = ev[ok], g[ok], f[ok]
    r = table[tracks[g, 2] + f - tracks[g, 0]]
    ok = r >= 0
    ev, g, r = ev[ok], g[ok], r[ok]
    ok = rows[r, 7] > 0
    ev, g, r = ev[ok], g[ok], r[ok]
    rr = rows[r]
    lag = np.asarray(t, np.int64)[ev].astype(np.float64) - rr[:, 6]
    dx = (np.asarray(x, np.float64)[ev] - rr[:, 0]) - rr[:, 2] * lag
    dy = (np.asarray(y, np.float64)[ev] - rr[:, 1]) - rr[:, 3] * lag
    along = dx * rr[:, 4] + dy * rr[:, 5]
    across = dy * rr[:, 4] - dx * rr[:, 5]
    ok = (np.abs(along) <= along_px) & (np.abs(across) < reach_px)
    b = np.minimum(((across[ok] + reach_px) / bin_px).astype(np.int64), nb - 1)
    return np.bincount(g[ok] * nb + b, minlength=n_tracks * nb).reshape(n_tracks, nb)
