"""Scenario: everything a simulation needs except the seed."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..camera import Camera
from .imu_model import ImuSpec
from .motion import Trajectory
from .sensor import SensorSpec
from .targets import FLUX_MAG3, StarField
from ..errors import ParameterError


@dataclass(frozen=True, eq=False)
class Scenario:
    """A camera watching stars while it moves.

    psf_sigma_px: Gaussian PSF width; flux_mag3: flux of a magnitude-3 star in per-pixel sky
    background units (the star's contrast, see :mod:`evstar.sim.targets`); step_px: largest
    star motion between simulation grid times, None for half the PSF sigma (log intensity is
    linear between grid times: at 20 °/s and σ = 1 px, 0.5 px steps change the event count by
    0.13 % and 10 ms streak centroids by at most 0.035 px against 0.05 px steps);
    truth_rate_hz: rate of the truth tables.
    """

    camera: Camera
    stars: StarField
    trajectory: Trajectory
    duration_s: float
    sensor: SensorSpec = field(default_factory=SensorSpec)
    imu: ImuSpec = field(default_factory=ImuSpec)
    psf_sigma_px: float = 1.0
    flux_mag3: float = FLUX_MAG3
    t_start_us: int = 0
    step_px: float | None = None
    truth_rate_hz: float = 1000.0

    def __post_init__(self):
        if not isinstance(self.camera, Camera):
            raise ParameterError(f"camera must be an evstar.Camera, got {type(self.camera).__name__}")
        if not isinstance(self.stars, StarField):
            raise ParameterError(f"stars must be a StarField, got {type(self.stars).__name__}")
        if not isinstance(self.trajectory, Trajectory):
            raise ParameterError(f"trajectory must be an evstar.sim Trajectory, got {type(self.trajectory).__name__}")
        for name in ("duration_s", "psf_sigma_px", "flux_mag3", "step_px", "truth_rate_hz"):
            v = getattr(self, name)
            if name == "step_px" and v is None:
                continue
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"{name} must be a positive number, got {v!r}")
        if int(self.t_start_us) != self.t_start_us or self.t_start_us < 0:
            raise ParameterError(f"t_start_us must be a non-negative integer, got {self.t_start_us!r}")
        if self.step_px is not None and self.step_px > 1:
            raise ParameterError(f"step_px must be <= 1 (crossings are interpolated per step), got {self.step_px!r}")

    @property
    def grid_step_px(self):
        return 0.5 * self.psf_sigma_px if self.step_px is None else self.step_px

    def replace(self, **changes):
        return replace(self, **changes)
