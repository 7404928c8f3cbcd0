"""Ground truth of a simulation, and its `truth.npz` file.

* ``labels`` (int32, one per event, in event order): star id >= 0 (index into the star
  table), NOISE (−1) for background activity, HOT_PIXEL (−2) for hot-pixel events.
* the star table: world directions, magnitudes, fluxes (per-pixel background units),
  Hipparcos numbers (−1 when synthetic), RA/Dec.
* the camera attitude over time: a table at ``t_us`` of R_cw as quaternions (x, y, z, w —
  scalar last, as scipy) and the true body rate ω (camera frame, rad/s), plus each star's
  true pixel position at those times (NaN behind the camera). The same attitude as
  ``quat_icrs_cam`` (t_us, w, x, y, z — scalar first): the rotation taking camera-frame
  vectors into the world (ICRS for Hipparcos fields), R_cwᵀ — the quaternion
  :func:`evstar.attitude.identify` returns. Written from format 2 on; derived from
  ``quat_cw`` when an older file is read.
* the IMU's true biases at its samples (IMU frame) and its calibration.

``star_position(t_us)`` gives positions at any time: slerp of the attitude table, then
projection — exact for rotation at a constant rate, and within 1e-3 px at 1 kHz for the
paper's sinusoid.
"""
from __future__ import annotations

import json
import os
import uuid
import zipfile
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..camera import Camera
from ..errors import FormatError
from .targets import StarField

NOISE = -1
HOT_PIXEL = -2
FORMAT_VERSION = 2  # 2: quat_icrs_cam added (format-1 files still load)
REQUIRED = ("labels", "star_dir_world", "star_mag", "star_hip", "star_flux", "t_us", "quat_cw", "omega_cam",
            "star_xy", "hot_pixels", "camera", "imu_t_us", "gyro_bias", "accel_bias", "R_cam_imu",
            "imu_time_offset_us", "meta")


@dataclass(eq=False)
class Truth:
    labels: np.ndarray          # (n_events,) int32
    stars: StarField
    star_flux: np.ndarray       # (n_stars,) in per-pixel background units
    t_us: np.ndarray            # (n_t,) int64, camera clock
    quat_cw: np.ndarray         # (n_t, 4) x, y, z, w
    omega_cam: np.ndarray       # (n_t, 3) rad/s
    star_xy: np.ndarray         # (n_t, n_stars, 2) px
    camera: Camera
    hot_pixels: np.ndarray      # (n_hot,) pixel indices y * width + x
    imu_t_us: np.ndarray        # (n_imu,) IMU clock, as in the Imu
    gyro_bias: np.ndarray       # (n_imu, 3) rad/s, IMU frame
    accel_bias: np.ndarray      # (n_imu, 3) m/s², IMU frame
    R_cam_imu: np.ndarray = field(default_factory=lambda: np.eye(3))
    imu_time_offset_us: int = 0
    meta: dict = field(default_factory=dict)

    # -- attitude and positions at any time ---------------------------------------------
    def rotation_at(self, t_us):
        """R_cw at camera times t_us (n,) -> (n, 3, 3), slerp of the attitude table."""
        t = np.atleast_1d(np.asarray(t_us, np.float64))
        rot = Rotation.from_quat(self.quat_cw)
        i = np.clip(np.searchsorted(self.t_us, t, side="right") - 1, 0, len(self.t_us) - 2)
        frac = (t - self.t_us[i]) / (self.t_us[i + 1] - self.t_us[i])
        step = (rot[i + 1] * rot[i].inv()).as_rotvec()
        return (Rotation.from_rotvec(step * frac[:, None]) * rot[i]).as_matrix()

    def star_position(self, t_us, star=None):
        """True pixel positions at t_us: (n, n_stars, 2), or (n, 2) for one star id."""
        dirs = self.stars.directions if star is None else self.stars.directions[[star]]
        cam = np.matmul(dirs[None], self.rotation_at(t_us).transpose(0, 2, 1))   # (n, stars, 3)
        uv = self.camera.project(cam.reshape(-1, 3)).reshape(cam.shape[0], -1, 2)
        uv[cam[..., 2] <= 0] = np.nan
        return uv if star is None else uv[:, 0]

    @property
    def quat_icrs_cam(self):
        """(n_t, 5) table: t_us, then w, x, y, z of the camera -> world rotation R_cwᵀ
        (scalar first, w >= 0)."""
        x, y, z, w = np.asarray(self.quat_cw, np.float64).T
        sign = np.where(w < 0, -1.0, 1.0)   # conjugate (the inverse), then the w >= 0 hemisphere
        return np.stack([self.t_us.astype(np.float64), sign * w, -sign * x, -sign * y, -sign * z], axis=1)

    def q_icrs_cam_at(self, t_us):
        """Camera -> world quaternions (n, 4), w, x, y, z, at camera times t_us (slerp)."""
        q = Rotation.from_matrix(self.rotation_at(t_us).transpose(0, 2, 1)).as_quat()
        q = q * np.where(q[:, 3:] < 0, -1.0, 1.0)
        return q[:, [3, 0, 1, 2]]

    @property
    def n_stars(self):
        return len(self.stars)

    def __repr__(self):
        n = len(self.labels)
        sig = int((self.labels >= 0).sum())
        return (f"Truth(events={n}, star events={sig}, stars={self.n_stars}, "
                f"attitude samples={len(self.t_us)})")


def save_truth(path, truth):
    """Write truth to an .npz file atomically (temporary file in the same folder, then rename)."""
    c = truth.camera
    arrays = dict(
        format_version=np.int64(FORMAT_VERSION), labels=truth.labels.astype(np.int32),
        star_dir_world=truth.stars.directions, star_mag=truth.stars.magnitudes,
        star_hip=truth.stars.hip, star_flux=truth.star_flux, star_ra_deg=truth.stars.ra_deg,
        star_dec_deg=truth.stars.dec_deg, t_us=truth.t_us, quat_cw=truth.quat_cw,
        quat_icrs_cam=truth.quat_icrs_cam,
        omega_cam=truth.omega_cam, star_xy=truth.star_xy, hot_pixels=truth.hot_pixels,
        camera=np.array([c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.k1, c.k2]),
        imu_t_us=truth.imu_t_us, gyro_bias=truth.gyro_bias, accel_bias=truth.accel_bias,
        R_cam_imu=truth.R_cam_imu, imu_time_offset_us=np.int64(truth.imu_time_offset_us),
        meta=np.array(json.dumps(truth.meta)))
    path = os.fspath(path)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = f"{path}.{uuid.uuid4().hex}.tmp"  # same folder, so os.replace is atomic
    try:
        with open(tmp, "xb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def load_truth(path):
    """Read a truth.npz written by :func:`save_truth`."""
    from ..io.numpy_files import ZIP_MAGIC

    try:   # np.load reads anything else as a pickle, whose message asks to allow pickles
        with open(path, "rb") as f:
            if f.read(len(ZIP_MAGIC)) != ZIP_MAGIC:
                raise FormatError(path, "not a truth .npz (an .npz is a zip archive; "
                                        "evstar simulate writes truth.npz)")
    except OSError:
        pass   # np.load says what is wrong below
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise FormatError(path, "no such file") from None
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise FormatError(path, f"not a readable truth .npz ({exc})") from None
    missing = [k for k in REQUIRED if k not in d]
    if missing:
        raise FormatError(path, f"not an evstar truth file: missing {missing}")
    w, h, fx, fy, cx, cy, k1, k2 = d["camera"].tolist()
    return Truth(
        labels=d["labels"], stars=StarField(d["star_dir_world"], d["star_mag"], d["star_hip"]),
        star_flux=d["star_flux"], t_us=d["t_us"], quat_cw=d["quat_cw"], omega_cam=d["omega_cam"],
        star_xy=d["star_xy"], camera=Camera(int(w), int(h), fx, fy, cx, cy, k1, k2),
        hot_pixels=d["hot_pixels"], imu_t_us=d["imu_t_us"], gyro_bias=d["gyro_bias"],
        accel_bias=d["accel_bias"], R_cam_imu=d["R_cam_imu"],
        imu_time_offset_us=int(d["imu_time_offset_us"]), meta=json.loads(str(d["meta"])))
