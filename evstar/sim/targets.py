"""Star targets: the single-star simulator of the paper and catalogue star fields.

Stars are at infinity: each is a fixed unit direction in the world frame. Brightness is a
stellar magnitude; :func:`star_flux` turns it into a flux in units of the per-pixel sky
background, which is what sets the contrast the event sensor sees.

Photometric calibration (a choice, documented here once): a magnitude-3 star delivers
``flux_mag3`` = 150 background-pixels of flux. With the default PSF (σ = 1 px) its brightest
pixel reaches 150 × 0.147 ≈ 22× the background, a log-intensity step of ≈ 3.1, i.e. about 15
ON and 15 OFF events per pixel it passes over at 0.2 contrast threshold — a streak of ≈ 110
events per pixel of travel, so ≈ 50 (4 °/s) to ≈ 230 (20 °/s) events per 10 ms frame on the
paper's camera (DVXplorer Lite, 12 mm lens, default sensor settings), against ≈ 1150 noise
events per frame over the whole sensor at 1.5 Hz/pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import hipparcos
from ..errors import ParameterError

#: total flux of a magnitude-3 star in units of the per-pixel sky background (see module doc)
FLUX_MAG3 = 150.0


def star_flux(magnitude, flux_mag3=FLUX_MAG3):
    """Pogson's law: flux relative to the per-pixel background, 10^(−0.4 (m − 3)) · flux_mag3."""
    return flux_mag3 * np.power(10.0, -0.4 * (np.asarray(magnitude, np.float64) - 3.0))


@dataclass(frozen=True, eq=False)
class StarField:
    """Stars as world-frame unit directions (n, 3) with magnitudes; `hip` is the Hipparcos
    number (−1 for synthetic stars). A star's id is its index here."""

    directions: np.ndarray
    magnitudes: np.ndarray
    hip: np.ndarray

    def __post_init__(self):
        d = np.asarray(self.directions, np.float64).reshape(-1, 3)
        n = len(d)
        m = np.asarray(self.magnitudes, np.float64).reshape(-1)
        h = np.asarray(self.hip, np.int64).reshape(-1)
        if len(m) != n or len(h) != n:
            raise ParameterError(f"StarField: directions ({n}), magnitudes ({len(m)}) and hip ({len(h)}) "
                             "differ in length")
        norms = np.linalg.norm(d, axis=1)
        if not (np.all(np.isfinite(d)) and np.all(norms > 0)):
            raise ParameterError("StarField: directions must be finite non-zero vectors")
        if not np.all(np.isfinite(m)):
            raise ParameterError("StarField: magnitudes must be finite")
        object.__setattr__(self, "directions", d / norms[:, None])
        object.__setattr__(self, "magnitudes", m)
        object.__setattr__(self, "hip", h)

    def __len__(self):
        return len(self.magnitudes)

    @classmethod
    def empty(cls):
        return cls(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64))

    @property
    def ra_deg(self):
        d = self.directions
        return np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360.0

    @property
    def dec_deg(self):
        return np.degrees(np.arcsin(np.clip(self.directions[:, 2], -1, 1)))

    def flux(self, flux_mag3=FLUX_MAG3):
        return star_flux(self.magnitudes, flux_mag3)

    def __repr__(self):
        mags = f", mag {self.magnitudes.min():.2f}..{self.magnitudes.max():.2f}" if len(self) else ""
        return f"StarField(n={len(self)}{mags})"


def single_star(direction=(0.0, 0.0, 1.0), magnitude=3.0):
    """One star in a world direction: the paper's LED + mask + collimator star simulator."""
    return StarField([direction], [magnitude], [-1])


def star_at_pixel(camera, R_cw, pixel, magnitude=3.0):
    """One star placed so that it images at `pixel` (u, v) when the attitude is R_cw."""
    ray_cam = camera.unproject(np.asarray(pixel, np.float64).reshape(1, 2))[0]
    return single_star(np.asarray(R_cw, np.float64).T @ ray_cam, magnitude)


def _in_view(camera, R_cw, dirs, pad_px=0.0):
    """Which world directions image inside the sensor (widened by pad_px) at attitude R_cw."""
    cam = dirs @ np.asarray(R_cw, np.float64).T
    ahead = cam[:, 2] > 0
    uv = camera.project(np.where(ahead[:, None], cam, [0.0, 0.0, 1.0]))
    return (ahead & (uv[:, 0] >= -0.5 - pad_px) & (uv[:, 0] < camera.width - 0.5 + pad_px)
            & (uv[:, 1] >= -0.5 - pad_px) & (uv[:, 1] < camera.height - 0.5 + pad_px))


def hipparcos_field(camera, R_cw, *, mag_limit=6.0, max_stars=None, margin_deg=0.0):
    """Hipparcos stars that image inside the sensor at attitude R_cw (world = ICRS).

    `margin_deg` widens the selection beyond the sensor edge (for stars that will drift in);
    `max_stars` keeps the brightest ones.
    """
    if max_stars is not None and max_stars < 0:
        raise ParameterError(f"max_stars must be >= 0, got {max_stars!r}")
    R_cw = np.asarray(R_cw, np.float64)
    corners = np.array([[-0.5, -0.5], [camera.width - 0.5, -0.5],
                        [-0.5, camera.height - 0.5], [camera.width - 0.5, camera.height - 0.5]])
    half_diag = math.degrees(np.arccos(camera.unproject(corners)[:, 2].min()))
    hip, dirs, mags = hipparcos.cone(R_cw[2], half_diag + margin_deg, mag_limit)
    inside = _in_view(camera, R_cw, dirs, math.radians(margin_deg) * max(camera.fx, camera.fy))
    return StarField(dirs[inside][:max_stars], mags[inside][:max_stars], hip[inside][:max_stars])


def hipparcos_field_along(camera, trajectory, duration_s, *, mag_limit=6.0, max_stars=None):
    """Hipparcos stars that come into view at some time of a trajectory (world = ICRS).

    The attitude is sampled whenever the camera may have turned by a quarter of its narrower
    field of view, and each sample's view is widened by that much; `max_stars` keeps the
    brightest.
    """
    if max_stars is not None and max_stars < 0:
        raise ParameterError(f"max_stars must be >= 0, got {max_stars!r}")
    fov = 2 * math.atan(min(camera.width / camera.fx, camera.height / camera.fy) / 2)
    sweep = trajectory.max_rate(0.0, duration_s) * duration_s
    times = np.linspace(0.0, duration_s, int(math.ceil(sweep / (fov / 4))) + 1)
    hip, ra, dec, mag = hipparcos.load()
    bright = np.flatnonzero(mag <= mag_limit)
    dirs = hipparcos.unit_vectors(ra[bright], dec[bright])
    seen = np.zeros(len(bright), bool)
    pad = fov / 4 * max(camera.fx, camera.fy)
    for R in trajectory.rotation(times):
        seen |= _in_view(camera, R, dirs, pad)
    order = np.argsort(mag[bright][seen], kind="stable")[:max_stars]
    return StarField(dirs[seen][order], mag[bright][seen][order], hip[bright][seen][order])
