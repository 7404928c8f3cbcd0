"""Attitude rows: the table `evstar attitude` and `evstar run` write (attitude.csv).

One row per output time after the first fix: t (µs, camera clock); the unit quaternion
qw, qx, qy, qz (scalar first, qw >= 0) of the rotation taking camera-frame vectors (x right,
y down, z boresight) into ICRS; the boresight's ra_deg, dec_deg and roll_deg (below); the
body rate wx, wy, wz (camera frame, rad/s); n_stars, the identified stars that updated the
filter within the last frame; and status:

* ``fix``: the filter was (re)started from an identification in this frame;
* ``tracking``: at least one identified star updated it within the last frame;
* ``coasting``: none did; the attitude is the prediction (gyro or constant rate).

Roll: with R_cw = Rᵀ, roll is the angle φ for which R_cw = Exp(φ ẑ) · R0(ra, dec), where
R0 is the attitude with the same boresight whose image up (−y) points to the north
celestial pole (east to the left, the sky seen from inside):
:func:`evstar.sim.attitude_from_radec` (ra, dec, roll) reproduces the quaternion. Positive
roll turns the camera about its boresight so that north, seen in the image, turns from up
towards the right (+x). Undefined at the poles (dec = ±90°), where 0 is written.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FormatError, ParameterTypeError
from ..io.atomic import atomic_path

COLUMNS = ("t", "qw", "qx", "qy", "qz", "ra_deg", "dec_deg", "roll_deg", "wx", "wy", "wz",
           "n_stars", "status")
ATTITUDE_DTYPE = np.dtype([("t", "<i8"), ("qw", "<f8"), ("qx", "<f8"), ("qy", "<f8"),
                           ("qz", "<f8"), ("ra_deg", "<f8"), ("dec_deg", "<f8"),
                           ("roll_deg", "<f8"), ("wx", "<f8"), ("wy", "<f8"), ("wz", "<f8"),
                           ("n_stars", "<i4"), ("status", "<U8")])
ROW_STATUSES = ("fix", "tracking", "coasting")


def quaternion(R):
    """(w, x, y, z), w >= 0, of rotation matrices R (..., 3, 3)."""
    q = Rotation.from_matrix(np.asarray(R, float).reshape(-1, 3, 3)).as_quat()[:, [3, 0, 1, 2]]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(np.shape(R)[:-2] + (4,))


def rotation(q):
    """Rotation matrices (n, 3, 3) of scalar-first quaternions (n, 4)."""
    q = np.asarray(q, float).reshape(-1, 4)
    return Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()


def ra_dec_roll(R):
    """Boresight (ra, dec) and roll, degrees, of rotations camera -> ICRS (3, 3) or
    (n, 3, 3) (module doc): floats, or (n,) arrays."""
    R = np.asarray(R, float)
    one = R.ndim == 2
    R = R.reshape(-1, 3, 3)
    z, x = R[:, :, 2], R[:, :, 0]
    ra = np.degrees(np.arctan2(z[:, 1], z[:, 0])) % 360.0
    dec = np.degrees(np.arcsin(np.clip(z[:, 2], -1.0, 1.0)))
    east = np.stack([-z[:, 1], z[:, 0], np.zeros(len(z))], 1)
    norm = np.linalg.norm(east, axis=1)
    east /= np.where(norm < 1e-12, 1.0, norm)[:, None]
    north = np.cross(z, east)
    # R_cw = Exp(φ ẑ) R0 with R0's rows (−east, −north, z): compare the camera x axis
    roll = np.degrees(np.arctan2(np.sum(x * north, 1), -np.sum(x * east, 1)))
    roll = np.where(norm < 1e-12, 0.0, roll)      # at a pole: undefined, 0
    if one:
        return float(ra[0]), float(dec[0]), float(roll[0])
    return ra, dec, roll


def rows(t, R, omega, n_stars, status):
    """ATTITUDE_DTYPE rows of times (n,), rotations camera -> ICRS (n, 3, 3), body rates
    (n, 3), star counts (n,) and statuses (n,)."""
    out = np.zeros(len(t), ATTITUDE_DTYPE)
    if not len(t):
        return out
    out["t"] = t
    q = quaternion(R)
    out["qw"], out["qx"], out["qy"], out["qz"] = q.T
    out["ra_deg"], out["dec_deg"], out["roll_deg"] = ra_dec_roll(R)
    out["wx"], out["wy"], out["wz"] = np.asarray(omega, float).reshape(-1, 3).T
    out["n_stars"], out["status"] = n_stars, status
    return out


def write_attitude(path, rows):
    """Write ATTITUDE_DTYPE rows as CSV (header exactly COLUMNS), atomically."""
    if not isinstance(rows, np.ndarray) or rows.dtype.names != COLUMNS:
        raise ParameterTypeError("write_attitude: rows must be an ATTITUDE_DTYPE array "
                                 f"(evstar.attitude.estimate), got {type(rows).__name__}")
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as f:
        f.write(",".join(COLUMNS) + "\n")
        for r in rows.tolist():
            f.write(f"{r[0]},{r[1]:.12f},{r[2]:.12f},{r[3]:.12f},{r[4]:.12f},{r[5]:.8f},"
                    f"{r[6]:.8f},{r[7]:.8f},{r[8]:.7f},{r[9]:.7f},{r[10]:.7f},{r[11]},{r[12]}\n")


def read_attitude(path):
    """ATTITUDE_DTYPE rows of a CSV written by write_attitude."""
    import pandas as pd

    try:
        frame = pd.read_csv(path, keep_default_na=False)
    except (OSError, ValueError) as exc:
        raise FormatError(path, f"not a readable attitude CSV ({exc})") from None
    missing = [c for c in COLUMNS if c not in frame.columns]
    if missing:
        raise FormatError(path, f"not an attitude CSV: missing columns {missing}")
    out = np.zeros(len(frame), ATTITUDE_DTYPE)
    for c in COLUMNS:
        out[c] = frame[c].to_numpy()
    return out
