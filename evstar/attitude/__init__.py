"""Attitude from stars: lost-in-space identification of pixel centroids (identify), the
plate solver's cached database (solver), Hipparcos with proper motion (catalog).

    from evstar.attitude import identify, Solver
    fix = identify(xy, camera, t_us, epoch=2026.9)
    fix.ok, fix.q_icrs_cam, fix.hip, fix.residual_arcsec
"""
from . import catalog
from .identify import Fix, STATUSES, identify, matrix_to_quat, pixel_rays, quat_to_matrix, wahba
from .solver import Solver

__all__ = ["Fix", "STATUSES", "Solver", "catalog", "identify", "matrix_to_quat", "pixel_rays",
           "quat_to_matrix", "wahba"]
