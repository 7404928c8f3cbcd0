"""Lost-in-space star identification: pixel centroids of one short window -> attitude.

The pattern search is tetra3rs (a maintained Rust plate solver; docs/attitude.md says why
this one). evstar keeps everything around it: the camera model (centroids are undistorted
here and handed to the solver as an ideal pinhole image), the catalogue (Hipparcos with
proper motion, :mod:`.catalog`, so the answer names HIP numbers), and the verification.
The solver only proposes which centroid is which star; the attitude is then fitted here
(SVD solution of Wahba's problem) from the rays and the catalogue directions at the epoch,
more stars are matched by projecting the catalogue, the fit is repeated, and the solution
is accepted only when enough stars match with a small RMS angle and the solver's
false-match probability is small.

Frames: camera x right, y down, z along the boresight; ``q_icrs_cam`` (w, x, y, z) rotates
camera-frame vectors into ICRS, the transpose of the simulator's R_cw.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..camera import Camera
from ..errors import DataError, ParameterError, ParameterTypeError
from . import catalog
from .solver import Solver

_ARCSEC = 180 * 3600 / math.pi
STATUSES = ("ok", "too_few_stars", "no_solution", "rejected")


@dataclass(eq=False)
class Fix:
    """One identification. `ok` only for a verified solution; otherwise `status` says why
    and q_icrs_cam is NaN (the matches of a rejected solution are kept for inspection)."""

    t_us: int
    ok: bool
    status: str
    q_icrs_cam: np.ndarray
    centroid_index: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    hip: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dir_icrs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    residual_arcsec: float = math.nan
    false_match_probability: float = math.nan  # the solver's, NaN without a solution
    solve_ms: float = 0.0                       # wall time of identify()

    @property
    def n_matches(self):
        return len(self.hip)

    @property
    def R_icrs_cam(self):
        """3x3 rotation matrix taking camera vectors into ICRS (NaN when not ok)."""
        return quat_to_matrix(self.q_icrs_cam)

    def __repr__(self):
        what = f"{self.n_matches} stars, {self.residual_arcsec:.1f}\" rms" if self.n_matches else ""
        return f"Fix(t_us={self.t_us}, {self.status}{', ' + what if what else ''})"


def pixel_rays(xy, camera):
    """Unit camera-frame rays (n, 3) of pixel positions (n, 2), lens distortion removed."""
    if not isinstance(camera, Camera):
        raise ParameterTypeError(f"camera must be an evstar.Camera, got {type(camera).__name__}")
    return camera.unproject(_xy(xy))


def identify(xy, camera, t_us=0, *, epoch=None, solver=None, weight=None):
    """Identify the stars among pixel centroids `xy` (n, 2) of `camera` and fit the attitude.

    t_us: the time the centroids refer to (copied into the Fix); epoch: Julian year of the
    observation for proper motion (None: the catalogue's J1991.25); solver: a
    :class:`Solver` to reuse (default: Solver.for_camera(camera), cached per process);
    weight: optional brightness per centroid (e.g. event counts) — the solver builds its
    patterns from the brightest, otherwise from the first centroids given.
    Non-finite rows are ignored. Never raises for a field it cannot solve: the Fix's status
    says why.
    """
    start = time.perf_counter()
    if isinstance(t_us, bool) or not isinstance(t_us, (int, float, np.integer, np.floating)) \
            or not np.isfinite(t_us):
        raise ParameterError(f"t_us must be a finite time in µs, got {t_us!r}")
    xy = _xy(xy)
    epoch = catalog.check_epoch(epoch)
    solver = Solver.of(solver, camera)
    if weight is not None:
        weight = np.asarray(weight, np.float64).reshape(-1)
        if len(weight) != len(xy):
            raise DataError(f"weight must have one value per centroid ({len(xy)}), got {len(weight)}")
    fix = _identify(xy, camera, int(t_us), epoch, solver, weight)
    fix.solve_ms = (time.perf_counter() - start) * 1e3
    return fix


def _identify(xy, camera, t_us, epoch, solver, weight):
    cfg = solver.settings
    usable = np.flatnonzero(np.all(np.isfinite(xy), axis=1))
    if len(usable) < max(4, cfg["min_matches"]):
        return _failed(t_us, "too_few_stars")
    rays = pixel_rays(xy[usable], camera)
    order = np.arange(len(usable))
    if weight is not None:  # brightest first; NaN weights last
        order = np.argsort(-np.nan_to_num(weight[usable], nan=-np.inf), kind="stable")
    found = solver.solve(rays[order], camera)
    if found is None:
        return _failed(t_us, "no_solution")
    local, hip, probability = found
    local = order[local]
    dirs = catalog.directions(hip, epoch)   # the database holds the same Hipparcos stars
    R = wahba(rays[local], dirs)
    # the solver fits the scale too: its matches must also fit the calibrated camera
    solver_rms = _rms(_angles(rays[local], dirs, R))
    # more stars: every catalogue star that projects near a centroid, then refit
    local, hip, dirs = _match(rays, R, solver, epoch, camera, cfg["match_radius_px"])
    if len(local) >= 3:
        R = wahba(rays[local], dirs)
    rms = _rms(_angles(rays[local], dirs, R))
    limit = cfg["max_residual_px"] / max(camera.fx, camera.fy)
    status = "ok"
    if (len(local) < cfg["min_matches"] or max(rms, solver_rms) > limit
            or probability > cfg["max_false_match"]):
        status = "rejected"
    q = matrix_to_quat(R) if status == "ok" else np.full(4, np.nan)
    return Fix(t_us, status == "ok", status, q, usable[local].astype(np.int64), hip.astype(np.int64),
               dirs, rms * _ARCSEC, float(probability))


def _match(rays, R, solver, epoch, camera, radius_px):
    """Centroids paired with the nearest catalogue star within radius_px (each star once)."""
    hip, dirs, _ = catalog.stars(solver.mag_limit, epoch)
    boresight = R[:, 2]
    corners = camera.unproject(np.array([[-0.5, -0.5], [camera.width - 0.5, camera.height - 0.5],
                                         [-0.5, camera.height - 0.5], [camera.width - 0.5, -0.5]]))
    cos_half = math.cos(math.acos(corners[:, 2].min()) + 2 * radius_px / camera.fx)
    near = np.flatnonzero(dirs @ boresight >= cos_half)
    cam = dirs[near] @ R  # into the camera frame (R takes camera into ICRS)
    radius = radius_px / max(camera.fx, camera.fy)
    ang = np.arccos(np.clip(rays @ cam.T, -1, 1))        # (centroids, stars)
    if ang.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3))
    best = np.argmin(ang, axis=1)
    ok = ang[np.arange(len(rays)), best] <= radius
    pairs = sorted(((ang[i, best[i]], i, best[i]) for i in np.flatnonzero(ok)))
    used, local, star = set(), [], []
    for _, i, j in pairs:
        if j not in used:
            used.add(j)
            local.append(i)
            star.append(near[j])
    local, star = np.array(local, np.int64), np.array(star, np.int64)
    sort = np.argsort(local)
    return local[sort], hip[star[sort]], dirs[star[sort]]


def _rms(angles):
    return float(np.sqrt(np.mean(angles ** 2))) if len(angles) else math.inf


def _failed(t_us, status):
    return Fix(t_us, False, status, np.full(4, np.nan))


def _xy(xy):
    a = np.asarray(xy, np.float64)
    if a.ndim != 2 or a.shape[1] != 2:
        raise DataError(f"xy must be an (n, 2) array of pixel positions, got shape {a.shape}")
    return a


def _angles(rays, dirs, R):
    """Angles (rad) between camera rays taken into ICRS by R and catalogue directions."""
    return np.arccos(np.clip(np.einsum("ij,ij->i", rays @ R.T, dirs), -1, 1))


def wahba(rays_cam, dirs_icrs):
    """The rotation R (3x3) minimising sum |dirs - R rays|² (SVD solution of Wahba's problem)."""
    from ..field import wahba_batch

    return wahba_batch((np.asarray(dirs_icrs).T @ np.asarray(rays_cam))[None])[0]


def matrix_to_quat(R):
    """Rotation matrix -> unit quaternion (w, x, y, z), scalar first, w >= 0."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    q = np.array([w, x, y, z])
    return q if w >= 0 else -q


def quat_to_matrix(q):
    """Unit quaternion (w, x, y, z) -> rotation matrix (NaN in, NaN out)."""
    q = np.asarray(q, np.float64)
    if not np.all(np.isfinite(q)):
        return np.full((3, 3), np.nan)
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()
