"""Attitude from stars: lost-in-space identification of pixel centroids (identify), the
plate solver's cached database (solver), Hipparcos with proper motion (catalog), and the
attitude filter that follows identified tracks (estimator, filter, output).

    from evstar.attitude import identify, Solver
    fix = identify(xy, camera, t_us, epoch=2026.9)
    fix.ok, fix.q_icrs_cam, fix.hip, fix.residual_arcsec

    rows = evstar.attitude.estimate(result.centroids, camera, imu=None, rate_hz=100,
                                    events=events)   # events: the pooled fallback
    evstar.attitude.write_attitude("attitude.csv", rows)   # t,qw,qx,qy,qz,... (camera -> ICRS)
"""
from . import catalog
from .acquire import identify_events
from .estimator import AttitudeEstimator, estimate
from .filter import Mekf
from .identify import Fix, STATUSES, identify, matrix_to_quat, pixel_rays, quat_to_matrix, wahba
from .output import (ATTITUDE_DTYPE, COLUMNS, ROW_STATUSES, quaternion, ra_dec_roll, read_attitude,
                     rotation, write_attitude)
from .solver import Solver

__all__ = ["Fix", "STATUSES", "Solver", "catalog", "identify", "identify_events", "matrix_to_quat", "pixel_rays",
           "quat_to_matrix", "wahba",
           "AttitudeEstimator", "estimate", "Mekf", "ATTITUDE_DTYPE", "COLUMNS", "ROW_STATUSES",
           "quaternion", "ra_dec_roll", "read_attitude", "rotation", "write_attitude"]
