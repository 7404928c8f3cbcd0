"""Pixel-lag calibration: how late a sensor's pixels report a star, by brightness.

A pixel's photoreceptor low-passes its intensity with a cutoff that grows with the light
on it, so a dim star's pixels report its passage late: every pixel crossing
(:mod:`evstar.crossings`) trails the star by a lag τ that depends on the pixel's peak
brightness. Each crossing carries that brightness as its number of level pairs k (the
pixel's peak contrast in thresholds). At a constant slew rate τ is indistinguishable from a
position offset; where the speed changes and the gyro says how (a calibration recording:
any slew whose rate varies, e.g. a sinusoid, with the IMU), it is not. This module fits
τ(k) jointly over all the recording's tracks, with no sensor model:

    u·q = u·(s0 + D(t) + b·t) − τ(k)·u·v(t)

for every crossing of pixel q at time t on a track moving along u with the gyro's image
displacement D and velocity v; per track an offset s0 and a drift b (a gyro bias), shared
by all tracks one τ per k and speed (the pulse a pixel sees is shorter for a faster star).
`evstar calibrate` writes the result as a small
JSON file that `run` and `extract` accept (`estimate.pixel_lag_file`): every crossing's
time is then moved back by τ(k) before the track smoother uses it. The file also holds the
sensor's OFF/ON threshold ratio measured on the recording (`meta.threshold_ratio`; tell
it the sensor's refractory period, estimate.refractory_us, or a fast field's dense OFF runs
lose events and read it high), which those runs pair levels with where their own level
runs are too few to measure it (a faint slow star's).
"""
from __future__ import annotations

import datetime
import json
import pathlib
from dataclasses import dataclass, field

import numpy as np

from .errors import DataError, FormatError
from .robust import robust_sigma

FORMAT = "evstar-pixel-lag"
VERSION = 1
#: crossings with at least this many level pairs share one τ (few pixels reach more)
MAX_PAIRS = 12
#: speed bins (px/s, edges): a short pulse (a fast star) is delayed differently from a long
#: one; slower crossings tell little and are left out of the fit
SPEED_EDGES = (25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0)
#: a crossing lies this much further behind its track (px) than across or ahead of it and
#: is still the track's: a lag puts it there (an EVK4's faint flank crossings at 1100 px/s
#: lag 2.2 ms, 2.4 px, and lie up to 2.5 px across: beyond a 3 px reach, the fast k = 1 cell
#: fitted the few nearer ones, −0.44 ms)
BEHIND_PX = 6.0
#: a (k, speed) cell needs this many crossings (and a track this many) to enter the fit
MIN_CROSSINGS = 30
_ROBUST_PASSES = 4
#: a cell known less precisely than this (µs) is filled from its neighbours instead
MAX_CELL_SE_US = 100.0
_UNKNOWN_SE = 1e9   # σ of a cell filled from its neighbours (no crossings of its own)
#: a file's |τ| beyond this (µs) is corrupt: a photoreceptor lags a star by ms, never 1 s
#: (small negative τ are real: on an ideal sensor crossings come 50-150 µs early)
MAX_LAG_US = 1e6
# what each numeric field of a file must hold: (dimensions, test of finite values, wording)
_FILE_FIELDS = {
    "pairs": (1, lambda v: (v >= 0) & (v == np.round(v)), "non-negative integers"),
    "speed_px_s": (1, lambda v: v > 0, "positive speeds"),
    "lag_us": (2, lambda v: np.abs(v) <= MAX_LAG_US, f"lags within ±{MAX_LAG_US:g} µs"),
    "se_us": (2, lambda v: v >= 0, "non-negative σ"),
}


@dataclass
class PixelLag:
    """τ (µs) by a crossing's number of level pairs (rows, `pairs`) and the star's image
    speed (columns, bin centres `speed_px_s`), with its σ (`se_us`; cells without crossings
    of their own are filled from their neighbours and carry σ 1e9). Between entries τ is
    interpolated (linearly in k and in log speed); beyond them the nearest entry holds.

    A lag measured on the recording's own tracks (evstar.level_lag.track_consistent) also
    holds how it grows with a crossing's outer half-width (CROSSING_DTYPE t_outer): τ per k
    is that of a crossing `width_ref_us` wide plus the time the star takes to move
    `width_ref_px` (both per row of `pairs`), and a crossing w µs wider lags `width_slope`
    (per row) · w more. Files hold no width terms."""

    pairs: np.ndarray
    speed_px_s: np.ndarray
    lag_us: np.ndarray
    se_us: np.ndarray
    meta: dict = field(default_factory=dict)
    width_slope: np.ndarray | None = None
    width_ref_us: np.ndarray | None = None
    width_ref_px: np.ndarray | None = None

    def __post_init__(self):
        self.pairs = np.asarray(self.pairs, np.int64)
        self.speed_px_s = np.asarray(self.speed_px_s, np.float64)
        self.lag_us = np.asarray(self.lag_us, np.float64)
        self.se_us = np.asarray(self.se_us, np.float64)
        shape = (len(self.pairs), len(self.speed_px_s))
        if 0 in shape or self.lag_us.shape != shape or self.se_us.shape != shape:
            raise DataError(f"pixel lag table: lag_us and se_us must be {shape[0]} rows (pairs) "
                            f"x {shape[1]} columns (speeds) with both >= 1, got "
                            f"{self.lag_us.shape} and {self.se_us.shape}")
        if np.any(np.diff(self.pairs) <= 0) or np.any(np.diff(self.speed_px_s) <= 0) \
                or np.any(self.speed_px_s <= 0):
            raise DataError("pixel lag table: pairs and speed_px_s must increase (speeds > 0)")
        if not np.all(np.isfinite(self.lag_us)):
            raise DataError("pixel lag table: lag_us must be finite")
        r = self.meta.get("threshold_ratio")
        if r is not None and not (isinstance(r, (int, float)) and 0.25 <= r <= 4):
            raise DataError(f"pixel lag table: meta.threshold_ratio must be a number in "
                            f"[0.25, 4], got {r!r:.40}")

    @property
    def threshold_ratio(self):
        """The sensor's OFF/ON threshold ratio the calibration paired levels with (measured
        on its recording, or the one it was told), None where it had too few changes."""
        return self.meta.get("threshold_ratio")

    def summary(self):
        """{source, lag_ms: [least, largest]} for a run's report: where the table came from
        (the recording's own level profiles, or a calibration file) and its span of lags."""
        source = "level profiles" if self.meta.get("source") == "level profiles" else "file"
        return {"source": source, "lag_ms": [round(float(np.min(self.lag_us)) / 1e3, 2),
                                             round(float(np.max(self.lag_us)) / 1e3, 2)]}

    def lag_at(self, pairs, speed_px_s, width_us=None):
        """τ in µs for crossings of `pairs` level pairs by a star moving at `speed_px_s`, and
        of outer half-widths `width_us` (µs) where given and the table has width terms."""
        tau = self._at(self.lag_us, pairs, speed_px_s)
        if width_us is None or self.width_slope is None:
            return tau
        ref = self.width_at(pairs, speed_px_s)
        slope = np.interp(np.asarray(pairs, np.float64), self.pairs, self.width_slope)
        wider = np.asarray(width_us, np.float64) - ref
        return np.maximum(tau + np.nan_to_num(slope * wider), 0.0)   # a low-pass only delays

    def width_at(self, pairs, speed_px_s):
        """The reference outer half-width (µs) of crossings of `pairs` at `speed_px_s`: a
        passage's own part, which scales as 1 / speed, and the pixel's, which does not."""
        k = np.asarray(pairs, np.float64)
        px = np.interp(k, self.pairs, self.width_ref_px)
        return (np.interp(k, self.pairs, self.width_ref_us)
                + px / np.maximum(np.asarray(speed_px_s, np.float64), 1e-9) * 1e6)

    def _at(self, L, pairs, speed_px_s):
        """The table `L` (pairs × speeds) at (pairs, speed_px_s), interpolated as τ is."""
        fk = np.interp(np.asarray(pairs, np.float64), self.pairs, np.arange(len(self.pairs)))
        fs = np.interp(np.log(np.maximum(np.asarray(speed_px_s, np.float64), 1e-9)),
                       np.log(self.speed_px_s), np.arange(len(self.speed_px_s)))
        k0 = np.minimum(np.floor(fk).astype(np.int64), len(self.pairs) - 1)
        s0 = np.minimum(np.floor(fs).astype(np.int64), len(self.speed_px_s) - 1)
        k1, s1 = np.minimum(k0 + 1, len(self.pairs) - 1), np.minimum(s0 + 1, len(self.speed_px_s) - 1)
        wk, ws = fk - k0, fs - s0
        return ((1 - wk) * ((1 - ws) * L[k0, s0] + ws * L[k0, s1])
                + wk * ((1 - ws) * L[k1, s0] + ws * L[k1, s1]))

    def to_json(self):
        return json.dumps({"format": FORMAT, "version": VERSION, "pairs": self.pairs.tolist(),
                           "speed_px_s": np.round(self.speed_px_s, 3).tolist(),
                           "lag_us": np.round(self.lag_us, 3).tolist(),
                           "se_us": np.round(self.se_us, 3).tolist(), "meta": self.meta}, indent=1)

    def save(self, path):
        from .io.atomic import atomic_path

        with atomic_path(path) as tmp:
            pathlib.Path(tmp).write_text(self.to_json() + "\n")
        return path

    @classmethod
    def load(cls, path):
        """Read a file `evstar calibrate` wrote; FormatError naming the file and field."""
        try:
            doc = json.loads(pathlib.Path(path).read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise FormatError(path, f"not a pixel-lag file ({e})") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise FormatError(path, f"format must be {FORMAT!r}, got "
                              f"{doc.get('format') if isinstance(doc, dict) else doc!r}")
        if doc.get("version") != VERSION:
            raise FormatError(path, f"version must be {VERSION}, got {doc.get('version')!r}")
        fields = {}
        for key, (ndim, ok, what) in _FILE_FIELDS.items():
            try:
                v = fields[key] = np.asarray(doc[key], np.float64)
            except (KeyError, TypeError, ValueError):
                raise FormatError(path, f"field {key!r} must be numbers, got "
                                  f"{doc.get(key)!r:.80}") from None
            if v.ndim != ndim:
                raise FormatError(path, f"field {key!r} must be a {'list' if ndim == 1 else 'list of rows'}"
                                  f" of numbers, got shape {v.shape}")
            bad = np.argwhere(~(np.isfinite(v) & ok(v)))
            if len(bad):
                at = "".join(f"[{j}]" for j in bad[0])
                raise FormatError(path, f"field {key!r} must hold finite {what}, got "
                                  f"{key}{at} = {v[tuple(bad[0])]:g}")
        meta = doc.get("meta") or {}
        if not isinstance(meta, dict):
            raise FormatError(path, f"field 'meta' must be an object, got {meta!r:.80}")
        try:
            return cls(**fields, meta=meta)
        except DataError as e:
            raise FormatError(path, f"{e}") from None


def fit_pixel_lag(crossings, tracks, velocity_prior, max_pairs=MAX_PAIRS,
                  speed_edges=SPEED_EDGES, min_crossings=MIN_CROSSINGS, behind_px=BEHIND_PX):
    """PixelLag from one recording's crossings (evstar.crossings.CROSSING_DTYPE), its tracks
    (rows with t, track, x, y, vx, vy, sorted by track then time) and the gyro's image
    velocity (evstar.smoothing.imu_velocity_prior); a crossing is a track's as _assigned
    says with `behind_px`. DataError when the recording cannot tell the lag (too few
    crossings, or no change of speed)."""
    got, owner, u = _assigned(crossings, tracks, behind_px)
    blocks = [b for tid in np.unique(owner)
              if (b := _track_rows(crossings, got[owner == tid], u[owner == tid],
                                   velocity_prior, max_pairs, speed_edges)) is not None
              and len(b[0]) >= min_crossings]
    if not blocks:
        raise DataError(f"pixel lag: no track with {min_crossings} or more pixel crossings")
    n_s = len(speed_edges) - 1
    cell = np.concatenate([b[2] for b in blocks])
    counts = np.bincount(cell[cell >= 0], minlength=(max_pairs + 1) * n_s)
    cells = np.flatnonzero(counts >= min_crossings)
    if not len(cells):
        raise DataError(f"pixel lag: no brightness and speed with {min_crossings} crossings")
    A, y = _design(blocks, cells)
    sol, se = _robust_lstsq(A, y)
    tau, tau_se = sol[-len(cells):], se[-len(cells):]
    good = np.isfinite(tau_se) & (tau_se <= MAX_CELL_SE_US)
    if not good.any():
        raise DataError("pixel lag: the recording does not tell the lag apart from a position "
                        "offset (a constant slew rate?): calibrate on a slew whose rate changes")
    return _table(cells[good], tau[good], tau_se[good], max_pairs, speed_edges,
                  {"crossings": int(len(y)), "tracks": len(blocks)})


def _assigned(crossings, tracks, behind_px):
    """(indices into crossings, their track ids, the tracks' unit directions (n, 2)): the
    crossings within REACH_PX of their nearest track's position at their time or of a point
    up to behind_px behind it along its motion (where a lag puts them; 0: the reach alone,
    evstar.crossings.along_track's)."""
    from .assignment import REACH_PX
    from .crossings import near_tracks

    ci, tid, dx, dy, ux, uy = near_tracks(crossings, tracks, REACH_PX + behind_px)
    along = dx * ux + dy * uy
    back = along - np.clip(along, -behind_px, 0.0)       # along, from the nearest such point
    k = np.flatnonzero(np.sqrt(back * back + (dx * uy - dy * ux) ** 2) < REACH_PX)
    return ci[k], tid[k], np.column_stack([ux[k], uy[k]])


def tracks_with_velocity(centroids):
    """Rows (t, track, x, y, vx, vy) of the tracked rows of a pipeline's centroids; the
    velocity by finite differences along each track (for assigning crossings to tracks)."""
    c = centroids[centroids["track"] >= 0]
    c = c[np.lexsort((c["t"], c["track"]))]
    if len(c):
        c = c[np.r_[True, (np.diff(c["track"]) != 0) | (np.diff(c["t"]) > 0)]]  # one row per time
    out = np.zeros(len(c), [("t", "<f8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
                            ("vx", "<f8"), ("vy", "<f8")])
    for f in ("t", "track", "x", "y"):
        out[f] = c[f]
    for rows in np.split(np.arange(len(c)), np.flatnonzero(np.diff(c["track"])) + 1):
        if len(rows) >= 2:
            ts = c["t"][rows] * 1e-6
            out["vx"][rows], out["vy"][rows] = (np.gradient(c["x"][rows], ts),
                                                np.gradient(c["y"][rows], ts))
    return out


def calibrate(events, imu, camera, config=None, progress=None):
    """PixelLag of a calibration recording (events with an IMU whose rate changes): the
    pipeline (IMU compensation, crossings estimator) finds the stars, their tracks and
    crossings, then :func:`fit_pixel_lag`."""
    from . import Config, Pipeline
    from .estimation import chunk_crossings, velocity_prior

    missing = [name for name, v in (("IMU", imu), ("camera", camera)) if v is None]
    if missing:
        raise DataError(f"calibration needs the recording's IMU and camera; no {' and no '.join(missing)} "
                        "was given (--imu imu.csv, --camera camera.json, or a file that holds them)")
    config = (config or Config()).replace(**{"motion.compensate": "imu",
                                             "estimate.estimator": "crossings",
                                             "estimate.pixel_lag_file": None})
    result = Pipeline(config).run(events, imu, camera)
    if not (result.centroids["track"] >= 0).any():   # the error alone, before any progress
        raise DataError("pixel lag: the calibration recording gave no star track (no star, or no "
                        "motion: a still event camera sees none); calibrate on a star field "
                        "slewing at a changing rate")
    if progress:
        progress(f"{result.metrics['tracks']} track(s), {result.metrics['centroids']:,} rows")
    crossings, ratio = chunk_crossings(events, result.keep, config.estimate.crossing_radius_px,
                                       config.estimate.threshold_ratio, with_ratio=True,
                                       refractory_us=config.estimate.refractory_us,
                                       background_hz=Pipeline(config).calibration_rate(
                                           events, int(events.t[0])))
    lag = fit_pixel_lag(crossings, tracks_with_velocity(result.centroids),
                        velocity_prior(config, imu, camera, events.t))
    # runs that read the file pair levels with this ratio unless told one: a faint star's
    # few runs measure it poorly
    lag.meta.update(threshold_ratio=None if ratio is None else round(float(ratio), 4),
                    events=len(events), duration_s=events.duration_us / 1e6,
                    created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"))
    return lag


# -- the least-squares fit ------------------------------------------------------------------
def _track_rows(crossings, idx, u, prior, max_pairs, speed_edges):
    """(u·(q − D), regressors [u, u·t], cell k·S + speed bin (−1: none), −u·v) of one track's
    crossings, time-sorted (evstar.smoothing.lag_regression)."""
    from .smoothing import lag_regression

    if len(idx) < 2:
        return None
    order = np.argsort(crossings["t"][idx], kind="stable")
    idx, u = idx[order], u[order]
    q = np.column_stack([crossings["x"][idx], crossings["y"][idx]]).astype(np.float64)
    y, local, lag_col, v = lag_regression(crossings["t"][idx], q, u, prior)
    k = np.minimum(crossings["pairs"][idx], max_pairs)
    s_bin = np.searchsorted(speed_edges, np.hypot(v[:, 0], v[:, 1]), side="right") - 1
    n_s = len(speed_edges) - 1
    cell = np.where((s_bin >= 0) & (s_bin < n_s), k * n_s + s_bin, -1)
    return y, local, cell, lag_col * 1e-6   # τ in µs


def _design(blocks, cells):
    """One row per crossing of a fitted cell: 4 columns per track (offset, drift), one per
    (k, speed) cell (crossings of a cell too rare to fit are left out)."""
    n_t, col = len(blocks), {int(c): i for i, c in enumerate(cells)}
    A_parts, y_parts = [], []
    for j, (yj, local, cell, dv) in enumerate(blocks):
        ok = np.isin(cell, cells)
        A = np.zeros((int(ok.sum()), 4 * n_t + len(cells)))
        A[:, 4 * j:4 * j + 4] = local[ok]
        A[np.arange(len(A)), 4 * n_t + np.array([col[int(c)] for c in cell[ok]], np.int64)] = dv[ok]
        A_parts.append(A)
        y_parts.append(yj[ok])
    return np.vstack(A_parts), np.concatenate(y_parts)


def _robust_lstsq(A, y):
    """Least squares dropping residuals beyond 5 robust σ (a few passes): solution, σ."""
    keep = np.ones(len(y), bool)
    for _ in range(_ROBUST_PASSES):
        sol, *_ = np.linalg.lstsq(A[keep], y[keep], rcond=None)
        r = y - A @ sol
        keep = np.abs(r) <= 5 * robust_sigma(r[keep], 0.0) + 1e-12
    dof = max(int(keep.sum()) - A.shape[1], 1)
    s2 = float((r[keep] ** 2).sum()) / dof
    cov = s2 * np.linalg.pinv(A[keep].T @ A[keep])
    return sol, np.sqrt(np.maximum(np.diag(cov), 0.0))


def _table(cells, tau, se, max_pairs, speed_edges, meta):
    """The PixelLag of fitted cells: rows k that have any, speed columns that have any; a
    missing cell from its row's neighbours in log speed (else its column's in k). No shape
    is imposed: a dim pixel's lag is not monotonic in k (a slow photoreceptor's delay is
    capped by the pulse's length, so the dimmest crossings can lag less than brighter ones)."""
    n_s = len(speed_edges) - 1
    k_of, s_of = cells // n_s, cells % n_s
    rows, cols = np.unique(k_of), np.unique(s_of)
    L = np.full((len(rows), len(cols)), np.nan)
    S = np.full(L.shape, _UNKNOWN_SE)
    L[np.searchsorted(rows, k_of), np.searchsorted(cols, s_of)] = tau
    S[np.searchsorted(rows, k_of), np.searchsorted(cols, s_of)] = se
    edges = np.asarray(speed_edges, np.float64)
    centres = np.sqrt(edges[cols] * edges[cols + 1])
    for grid, axis_x in ((L, np.log(centres)), (L.T, rows.astype(float))):
        for line in grid:
            have = np.isfinite(line)
            if have.any() and not have.all():
                line[~have] = np.interp(axis_x[~have], axis_x[have], line[have])
    return PixelLag(rows, centres, L, S, meta)
