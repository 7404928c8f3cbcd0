"""Lost-in-space from the pooled events of a window, for when no frame's centroids identify.

A star that moves slowly over the sensor — a slew of a degree per second on a large-pixel
sensor, or a rotation mostly about the boresight, where stars move by r·ω — fires only a
few events per 10 ms frame. The pipeline's per-frame detection (density filter with
thresholds sized for one frame, DBSCAN min_samples) rightly drops them there, and a frame
with three stars cannot be identified. Over the whole window each star has all its events.
:func:`identify_events` pools them (warped to the window's mid-time by the gyro when an IMU
is given) and detects stars with a threshold set by the window itself: the fraction p of
pixels with any event (noise, almost all of it) gives the chance that k of the 3 x 3 pixels
around a point are active by chance, binomial(9, p); a point is a star candidate when that
chance is at most alpha. Counting active pixels, not events, keeps a hot pixel to one.
The solver is tried with the strictest alpha first (fewest, surest candidates) and then
looser ones (more stars, more chance detections); its false-match probability and
evstar's verification (:func:`.identify`) decide as for frame centroids.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage, stats

from ..camera import Camera
from ..errors import ParameterError, ParameterTypeError
from ..events import Events
from .identify import identify
from .solver import Solver
from evstar_kernels.reference.pixels import pixel_counts

BOX = 3   # candidate test over BOX x BOX pixels: the core of a star of PSF sigma ~1 px


def detect(x, y, width, height, alpha):
    """Star candidates among pooled event pixels (x, y int arrays): positions (n, 2) — the
    event-count centroid of the 5 x 5 pixels around each candidate — and their event counts
    (n,), brightest first. A candidate is a local maximum of the number of active pixels in
    a 3 x 3 box whose chance under the image's own active-pixel fraction is at most alpha."""
    counts, _ = pixel_counts(x, y, width, height)
    active = (counts > 0).astype(np.int64)
    n = BOX * BOX
    chance = stats.binom.sf(np.arange(n + 1) - 1, n, active.mean())   # P(>= k of n active)
    enough = np.flatnonzero(chance <= alpha)
    if not len(enough) or not counts.any():
        return np.zeros((0, 2)), np.zeros(0)
    need = int(enough[0])
    box = ndimage.convolve(active, np.ones((BOX, BOX), np.int64), mode="constant")
    peak = (box >= need) & (box == ndimage.maximum_filter(box, BOX + 2, mode="constant"))
    labels, n_peaks = ndimage.label(peak, np.ones((3, 3)))     # a plateau is one candidate
    if n_peaks == 0:
        return np.zeros((0, 2)), np.zeros(0)
    centre = np.rint(np.array(ndimage.center_of_mass(peak, labels, range(1, n_peaks + 1)))).astype(int)
    r = BOX // 2 + 1
    xy, weight = np.zeros((n_peaks, 2)), np.zeros(n_peaks)
    for i, (cy, cx) in enumerate(centre):
        y0, x0 = max(cy - r, 0), max(cx - r, 0)
        sub = counts[y0:cy + r + 1, x0:cx + r + 1]
        yy, xx = np.mgrid[y0:y0 + sub.shape[0], x0:x0 + sub.shape[1]]
        weight[i] = sub.sum()
        if weight[i] > 0:
            xy[i] = (sub * xx).sum() / weight[i], (sub * yy).sum() / weight[i]
    # a plateau shaped as a ring (busy scenes, not stars) has its centre of mass on no event
    kept = np.flatnonzero(weight > 0)
    order = kept[np.argsort(-weight[kept], kind="stable")]
    return xy[order], weight[order]


def identify_events(events, camera, t_start_us=None, t_stop_us=None, *, imu=None, solver=None,
                    epoch=None):
    """Identify the stars of the events in [t_start_us, t_stop_us) (default: all of them)
    pooled into one image; see the module docstring. imu: an evstar.Imu covering the window
    (its gyro warps every event to the window's mid-time); solver, epoch: as
    :func:`.identify`. Returns (Fix at the window's mid-time, detected positions (n, 2) that
    the Fix's centroid_index refers to) — of the first alpha of the solver's
    ``pooled_alphas`` that identifies, else of the last one tried."""
    if not isinstance(events, Events):
        raise ParameterTypeError(f"events must be evstar.Events, got {type(events).__name__}")
    if not isinstance(camera, Camera):
        raise ParameterTypeError(f"camera must be an evstar.Camera, got {type(camera).__name__}")
    solver = Solver.of(solver, camera)
    t = events.t
    t_start = _time_us("t_start_us", t_start_us, int(t[0]) if len(t) else 0)
    t_stop = _time_us("t_stop_us", t_stop_us, int(t[-1]) + 1 if len(t) else 0)
    if t_stop < t_start:
        raise ParameterError(f"t_stop_us ({t_stop}) must not be before t_start_us ({t_start})")
    window = events.time_window(t_start, t_stop)
    t_mid = (t_start + t_stop) // 2
    x, y = window.x, window.y
    if imu is not None and len(window):
        from ..motion import compensate

        # one frame spanning the window: every event moves to the window's mid-time; only
        # the samples around it are integrated (the whole record would be, at every try)
        comp = compensate(window, imu.around(t_start, t_stop), camera,
                          dt_us=max(t_stop - t_start, 1), t0_us=t_start)
        x, y = comp.xi[comp.inside], comp.yi[comp.inside]
    fix, xy = None, np.zeros((0, 2))
    for alpha in solver.settings["pooled_alphas"]:
        xy, weight = detect(x, y, camera.width, camera.height, alpha)
        fix = identify(xy, camera, t_mid, solver=solver, epoch=epoch, weight=weight)
        if fix.ok:
            break
    return fix, xy


def _time_us(name, value, default):
    """`value` as integer µs (`default` when None); ParameterError naming it otherwise."""
    if value is None:
        return default
    try:
        return int(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a time in µs (an integer), got {value!r}") from None
