"""Hipparcos star directions at an epoch: the catalogue positions moved by proper motion.

The catalogue (read by :mod:`evstar.sim.hipparcos`) gives ICRS positions at J1991.25 and
proper motions μα* = μα cos δ, μδ in mas/yr. A star moves along the tangent plane:
u(t) = u₀ + Δt (μα* e_α + μδ e_δ), renormalised — exact to first order in Δt μ, i.e. to
micro-arcseconds over a century for every star here (parallax and radial velocity, a few
mas even for Barnard's star, are ignored).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import ParameterError
from ..sim import hipparcos

EPOCH = hipparcos.EPOCH
_MAS = math.pi / (180 * 3600 * 1000)


def check_epoch(epoch, key="epoch"):
    """epoch in Julian years (e.g. 2026.9), or None for the catalogue's J1991.25."""
    if epoch is None:
        return EPOCH
    if isinstance(epoch, bool) or not isinstance(epoch, (int, float)) or not 1000 <= epoch <= 3000:
        raise ParameterError(f"{key} must be a Julian year in [1000, 3000] (e.g. 2026.9), got {epoch!r}")
    return float(epoch)


def propagate(ra_rad, dec_rad, pm_ra_cosdec, pm_dec, years):
    """Unit vectors (n, 3) of stars at (ra, dec) moved by proper motion (mas/yr) for `years`."""
    ra, dec = np.asarray(ra_rad, np.float64), np.asarray(dec_rad, np.float64)
    u = hipparcos.unit_vectors(ra, dec)
    if years == 0:
        return u
    e_ra = np.stack([-np.sin(ra), np.cos(ra), np.zeros_like(ra)], axis=-1)
    e_dec = np.stack([-np.sin(dec) * np.cos(ra), -np.sin(dec) * np.sin(ra), np.cos(dec)], axis=-1)
    step = years * _MAS * (np.asarray(pm_ra_cosdec)[..., None] * e_ra + np.asarray(pm_dec)[..., None] * e_dec)
    v = u + step
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=8)
def _stars(mag_limit, epoch):
    hip, ra, dec, mag = hipparcos.load()
    pmra, pmde = hipparcos.proper_motion()
    # a few hundred entries lack a solution (NaN or 0 position); they cannot be matched
    keep = (mag <= mag_limit) & np.isfinite(ra) & np.isfinite(dec) & np.isfinite(mag)
    pm_ok = np.isfinite(pmra) & np.isfinite(pmde)
    dirs = propagate(ra[keep], dec[keep], np.where(pm_ok, pmra, 0.0)[keep],
                     np.where(pm_ok, pmde, 0.0)[keep], epoch - EPOCH)
    order = np.argsort(mag[keep], kind="stable")
    out = hip[keep][order], dirs[order], mag[keep][order]
    for a in out:
        a.setflags(write=False)
    return out


def stars(mag_limit=math.inf, epoch=None):
    """(hip int64, directions (n, 3) ICRS at `epoch`, Hp magnitudes) of the stars at most
    `mag_limit`, brightest first (read-only arrays, cached)."""
    return _stars(float(mag_limit), check_epoch(epoch))


@functools.lru_cache(maxsize=8)
def _by_number(epoch):
    hip, dirs, _ = _stars(math.inf, epoch)
    order = np.argsort(hip)
    return hip[order], dirs[order]


def directions(hip_numbers, epoch=None):
    """ICRS unit vectors (n, 3) at `epoch` of the given Hipparcos numbers (KeyError naming
    the first one the catalogue does not hold)."""
    hip, dirs = _by_number(check_epoch(epoch))
    want = np.asarray(hip_numbers, np.int64).reshape(-1)
    at = np.clip(np.searchsorted(hip, want), 0, len(hip) - 1)
    found = hip[at] == want
    if not found.all():
        raise KeyError(f"HIP {int(want[~found][0])} is not in the catalogue")
    return dirs[at]
