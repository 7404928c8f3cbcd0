"""Camera: pinhole intrinsics with optional radial distortion (x right, y down, z forward)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .errors import DataError


@dataclass(frozen=True)
class Camera:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    k1: float = 0.0
    k2: float = 0.0

    def __post_init__(self):
        for name in ("width", "height"):
            v = getattr(self, name)
            if int(v) != v or v <= 0:
                raise DataError(f"camera field '{name}' must be a positive integer, got {v!r}")
            object.__setattr__(self, name, int(v))
        for name in ("fx", "fy", "cx", "cy", "k1", "k2"):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise DataError(f"camera field '{name}' must be a number, got {v!r}") from None
            if not math.isfinite(v):
                raise DataError(f"camera field '{name}' must be finite, got {v!r}")
            object.__setattr__(self, name, v)
        if self.fx <= 0 or self.fy <= 0:
            raise DataError(f"camera focal lengths must be positive, got fx={self.fx}, fy={self.fy}")

    @classmethod
    def from_fov(cls, width, height, hfov_deg):
        f = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2)

    @property
    def K(self):
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    @property
    def has_distortion(self):
        return self.k1 != 0.0 or self.k2 != 0.0

    def to_dict(self):
        d = asdict(self)
        if not self.has_distortion:
            d.pop("k1"), d.pop("k2")
        return d

    def project(self, dirs):
        """Camera-frame directions (N, 3) -> pixel coordinates (N, 2), distortion applied."""
        dirs = np.asarray(dirs, dtype=np.float64)
        return np.stack(self.project_columns(dirs[:, 0], dirs[:, 1], dirs[:, 2]), axis=1)

    def project_columns(self, x, y, z):
        """project of directions given as three (N,) columns: (u, v) columns."""
        xn, yn = x / z, y / z
        if self.has_distortion:
            r2 = xn * xn + yn * yn
            s = 1 + self.k1 * r2 + self.k2 * r2 * r2
            xn, yn = xn * s, yn * s
        return self.fx * xn + self.cx, self.fy * yn + self.cy

    def unproject(self, uv, iterations=5):
        """Pixel coordinates (N, 2) -> unit camera-frame rays (N, 3), distortion removed."""
        uv = np.asarray(uv, dtype=np.float64)
        return np.stack(self.unproject_columns(uv[:, 0], uv[:, 1], iterations), axis=1)

    def unproject_columns(self, u, v, iterations=5):
        """unproject of pixel coordinates given as two (N,) columns: (x, y, z) columns (no
        (N, 3) temporaries: the velocity prior unprojects every crossing)."""
        xd, yd = (u - self.cx) / self.fx, (v - self.cy) / self.fy
        xn, yn = xd, yd
        if self.has_distortion:  # fixed-point inversion, ample for mild radial distortion
            for _ in range(iterations):
                r2 = xn * xn + yn * yn
                s = 1 + self.k1 * r2 + self.k2 * r2 * r2
                xn, yn = xd / s, yd / s
        return unit(xn, yn, np.ones_like(xn))


def unit(x, y, z):
    """(x, y, z) / their norm, per row of three columns: np.linalg.norm's arithmetic
    (sqrt of x² + y² + z² summed in that order)."""
    n = np.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n
