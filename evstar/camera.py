"""Camera: pinhole intrinsics with optional radial distortion (x right, y down, z forward)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .errors import DataError, ParameterError, ParameterTypeError
from .events import is_integer_value

#: from_fov's widest horizontal field of view: at 180° the focal length is 0 (tan 90° ≈ 1.6e16)
MAX_FOV_DEG = 179.0


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
            if not is_integer_value(v) or v <= 0:
                raise DataError(f"camera field '{name}' must be a positive integer, got {v!r}")
            object.__setattr__(self, name, int(v))
        for name in ("fx", "fy", "cx", "cy", "k1", "k2"):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError, OverflowError):   # OverflowError: ints beyond 1e308
                raise DataError(f"camera field '{name}' must be a number, got {v!r}") from None
            if not math.isfinite(v):
                raise DataError(f"camera field '{name}' must be finite, got {v!r}")
            object.__setattr__(self, name, v)
        if self.fx <= 0 or self.fy <= 0:
            raise DataError(f"camera focal lengths must be positive, got fx={self.fx}, fy={self.fy}")

    @classmethod
    def from_fov(cls, width, height, hfov_deg):
        """Pinhole camera centred on the sensor with horizontal field of view hfov_deg
        (0 < hfov_deg <= MAX_FOV_DEG) and square pixels."""
        if isinstance(hfov_deg, (bool, np.bool_)) or not isinstance(hfov_deg, (int, float, np.integer, np.floating)):
            raise ParameterTypeError(f"Camera.from_fov: hfov_deg must be a number of degrees, got {hfov_deg!r}")
        if not 0 < hfov_deg <= MAX_FOV_DEG:   # also NaN
            raise ParameterError(f"Camera.from_fov: hfov_deg must be in (0, {MAX_FOV_DEG:g}] degrees, "
                                 f"got {hfov_deg!r}")
        if not is_integer_value(width) or width <= 0:   # used below before __post_init__ checks it
            raise DataError(f"camera field 'width' must be a positive integer, got {width!r}")
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
        """Camera-frame directions (N, 3) -> pixel coordinates (N, 2), distortion applied;
        one direction (3,) -> (2,). NaN for directions not in front of the camera (z <= 0)."""
        dirs = _points("dirs", dirs, 3)
        return np.stack(self.project_columns(dirs[..., 0], dirs[..., 1], dirs[..., 2]), axis=-1)

    def project_columns(self, x, y, z):
        """project of directions given as three (N,) columns: (u, v) columns (NaN where z <= 0:
        a ray behind the camera has no image, its x/z would mirror it into the frame)."""
        z = np.where(z > 0, z, np.nan)      # NaN, not inf or a mirror image, and no warning
        xn, yn = x / z, y / z
        if self.has_distortion:
            r2 = xn * xn + yn * yn
            s = 1 + self.k1 * r2 + self.k2 * r2 * r2
            xn, yn = xn * s, yn * s
        return self.fx * xn + self.cx, self.fy * yn + self.cy

    def unproject(self, uv, iterations=5):
        """Pixel coordinates (N, 2) -> unit camera-frame rays (N, 3), distortion removed."""
        uv = _points("uv", uv, 2)
        return np.stack(self.unproject_columns(uv[..., 0], uv[..., 1], iterations), axis=-1)

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


def _points(name, values, k):
    """values as float64 (N, k) or one (k,) row; other shapes and non-real dtypes are errors."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:  # ragged lists
        raise DataError(f"'{name}' is not a numeric array ({exc})") from None
    if arr.dtype.kind not in "biuf":        # complex would lose its imaginary part
        raise DataError(f"'{name}' must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim not in (1, 2) or arr.shape[-1] != k:
        raise DataError(f"'{name}' must have shape (N, {k}) or ({k},), got {arr.shape}")
    return arr.astype(np.float64, copy=False)


def unit(x, y, z):
    """(x, y, z) / their norm, per row of three columns: np.linalg.norm's arithmetic
    (sqrt of x² + y² + z² summed in that order)."""
    n = np.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n
