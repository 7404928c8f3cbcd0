"""Inertial attitude: star identification and the attitude filter.

    rows = evstar.attitude.estimate(result.centroids, camera, imu=None, rate_hz=100)
    evstar.attitude.write_attitude("attitude.csv", rows)   # t,qw,qx,qy,qz,... (camera -> ICRS)
"""
from .estimator import AttitudeEstimator, estimate
from .filter import Mekf, wahba
from .output import ATTITUDE_DTYPE, COLUMNS, STATUSES, quaternion, ra_dec_roll, read_attitude, rotation, write_attitude

__all__ = ["AttitudeEstimator", "estimate", "Mekf", "wahba", "ATTITUDE_DTYPE", "COLUMNS", "STATUSES",
           "quaternion", "ra_dec_roll", "read_attitude", "rotation", "write_attitude"]
