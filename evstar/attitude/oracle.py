"""Identification from simulator truth: what a perfect star identifier would report.

For studying the attitude filter apart from identification (tests, perf/study_attitude.py):
each centroid within `match_px` of a star's true position at the fix time is that star
(the simulator's world frame is ICRS); the attitude is the Wahba solution of the matched
rays, as a plate solver would give it — not the true attitude.
"""
from __future__ import annotations

import numpy as np

from .identify import Fix, wahba
from .output import quaternion


def truth_identifier(truth, match_px=2.0, min_stars=3):
    """A callable (xy (n, 2) px, t_us) -> Fix from an evstar.sim Truth."""

    def identify(xy, t_us, weight=None):
        xy = np.asarray(xy, float).reshape(-1, 2)
        true = truth.star_position([t_us])[0]                      # (n_stars, 2)
        d = np.linalg.norm(xy[:, None] - true[None], axis=2)
        d = np.where(np.isfinite(d), d, np.inf)
        star = np.argmin(d, axis=1) if true.size else np.zeros(len(xy), int)
        ok = d[np.arange(len(xy)), star] <= match_px if true.size else np.zeros(len(xy), bool)
        idx = np.flatnonzero(ok)
        idx = idx[np.unique(star[idx], return_index=True)[1]]     # one centroid per star
        if len(idx) < min_stars:
            return Fix(int(t_us), False, "too_few_stars", np.full(4, np.nan))
        rays = truth.camera.unproject(xy[idx])
        dirs = truth.stars.directions[star[idx]]
        R = wahba(rays, dirs)
        res = np.degrees(np.arccos(np.clip(np.sum((rays @ R.T) * dirs, 1), -1, 1))) * 3600
        return Fix(int(t_us), True, "ok", quaternion(R), idx, truth.stars.hip[star[idx]], dirs,
                   float(np.sqrt(np.mean(res ** 2))))

    return identify


def synthetic_run(trajectory, camera, duration_s=1.0, *, sigma_px=0.05, mag_limit=6.0,
                  frame_us=10_000, edge_px=3.0, imu_spec=None, seed=0):
    """(centroids, Truth, Imu) of stars seen along `trajectory` without simulating events:
    one centroid per star and frame at the frame's mid-time, its true position plus
    Gaussian noise of `sigma_px` per axis (field sigma), track = star id; stars within
    `edge_px` of the border are not seen. Hipparcos stars to `mag_limit` (world = ICRS)."""
    from scipy.spatial.transform import Rotation

    from .. import sim
    from ..extract import CENTROID_DTYPE
    from ..sim.imu_model import simulate_imu
    from ..sim.truth import Truth

    rng = np.random.default_rng(seed)
    stars = sim.hipparcos_field_along(camera, trajectory, duration_s, mag_limit=mag_limit)
    t_us = np.arange(0, int(duration_s * 1e6) + 1, 1000, dtype=np.int64)
    R = trajectory.rotation(t_us * 1e-6)
    cam_dirs = np.matmul(stars.directions[None], R.transpose(0, 2, 1))
    xy = camera.project(cam_dirs.reshape(-1, 3)).reshape(len(t_us), -1, 2)
    xy[cam_dirs[..., 2] <= 0] = np.nan
    imu, gyro_bias, accel_bias = simulate_imu(trajectory, imu_spec or sim.ImuSpec(), duration_s,
                                              0, np.random.default_rng(seed + 1))
    truth = Truth(labels=np.zeros(0, np.int32), stars=stars, star_flux=stars.flux(), t_us=t_us,
                  quat_cw=Rotation.from_matrix(R).as_quat(), omega_cam=trajectory.omega(t_us * 1e-6),
                  star_xy=xy, camera=camera, hot_pixels=np.zeros(0, np.int64), imu_t_us=imu.t,
                  gyro_bias=gyro_bias, accel_bias=accel_bias, R_cam_imu=imu.R_cam_imu)
    t_mid = np.arange(frame_us // 2, int(duration_s * 1e6), frame_us, dtype=np.int64)
    pos = truth.star_position(t_mid)                                # (frames, stars, 2)
    inside = ((pos[..., 0] >= edge_px) & (pos[..., 0] <= camera.width - 1 - edge_px)
              & (pos[..., 1] >= edge_px) & (pos[..., 1] <= camera.height - 1 - edge_px))
    f, s = np.nonzero(inside)
    c = np.zeros(len(f), CENTROID_DTYPE)
    c["t"], c["track"], c["frame"], c["sigma"], c["source"] = t_mid[f], s, f, sigma_px, "measured"
    c["x"], c["y"] = (pos[f, s] + rng.normal(0.0, sigma_px, (len(f), 2))).T
    c["n_events"], c["spread"] = 100, 1.0
    return c, truth, imu
