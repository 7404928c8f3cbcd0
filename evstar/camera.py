"""Camera: pinhole intrinsics with optional radial distortion (x right, y down, z forward)."""
from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass

import numpy as np

from .errors import DataError, ParameterError, ParameterTypeError
from .events import is_integer_value

#: from_fov's widest horizontal field of view: at 180° the focal length is 0 (tan 90° ≈ 1.6e16)
MAX_FOV_DEG = 179.0
#: the narrowest field of view (°, per side) a camera may have: below, a focal length is no
#: lens's in pixels (fx 1e7 on 320 px: 0.002°; 1e300 made the rigid-field fit's SVD fail)
MIN_FOV_DEG = 0.01


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
        for name, f, side in (("fx", self.fx, self.width), ("fy", self.fy, self.height)):
            fov = 2 * math.degrees(math.atan(side / 2 / f))
            if not MIN_FOV_DEG <= fov <= MAX_FOV_DEG:
                raise DataError(f"camera focal length {name}={f:g} px gives the sensor's {side} px "
                                f"a {fov:.3g}° field of view, outside {MIN_FOV_DEG:g}–"
                                f"{MAX_FOV_DEG:g}° (a focal length in mm, not px?)")
        for name, c, side in (("cx", self.cx, self.width), ("cy", self.cy, self.height)):
            # a decentred lens may put it off the sensor, never sensors away (cx 1e9 ran,
            # every event warped off the sensor)
            if not -side <= c <= 2 * side:
                raise DataError(f"camera principal point {name}={c:g} lies more than the sensor's "
                                f"size ({side} px) outside the {self.width}x{self.height} sensor")
        if self.has_distortion:
            self._check_distortion()

    def _check_distortion(self):
        """DataError where the radial distortion folds back inside the sensor: beyond the
        normalised radius where r·(1 + k1·r² + k2·r⁴) stops growing, two rays share a pixel,
        so no pixel there has one ray (a wrong sign or a miscalibrated k1, k2); or where it
        scales the sensor's corner radius beyond _DISTORTION_SCALES (no lens this model
        describes)."""
        corner = self.corner_radius()
        rf = fold_radius(self.k1, self.k2)
        reach = radial(rf, self.k1, self.k2) if math.isfinite(rf) else math.inf
        if corner >= reach:
            raise DataError(
                f"camera distortion k1={self.k1:g}, k2={self.k2:g} folds back inside the "
                f"{self.width}x{self.height} sensor: the distorted radius stops growing at "
                f"{reach:.4g} (normalised) but the sensor's corners lie at {corner:.4g}; no "
                f"pixel beyond has one ray (check the signs and scale of k1, k2)")
        scale = 1 + self.k1 * corner ** 2 + self.k2 * corner ** 4
        if not _DISTORTION_SCALES[0] <= scale <= _DISTORTION_SCALES[1]:
            raise DataError(
                f"camera distortion k1={self.k1:g}, k2={self.k2:g} scales the "
                f"{self.width}x{self.height} sensor's corner radius by {scale:.4g}, beyond any "
                f"lens this model describes ({_DISTORTION_SCALES[0]:g}–"
                f"{_DISTORTION_SCALES[1]:g}; check the signs and scale of k1, k2)")

    def corner_radius(self):
        """The largest normalised distorted radius of the sensor's area (its pixels' outer
        corners, -0.5 .. width - 0.5)."""
        xs = ((-0.5 - self.cx) / self.fx, (self.width - 0.5 - self.cx) / self.fx)
        ys = ((-0.5 - self.cy) / self.fy, (self.height - 0.5 - self.cy) / self.fy)
        return max(math.hypot(x, y) for x in xs for y in ys)

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

    def unproject(self, uv, iterations=None):
        """Pixel coordinates (N, 2) -> unit camera-frame rays (N, 3), distortion removed.
        iterations: None (default) inverts the distortion to machine precision (project
        gives uv back); an integer runs that many fixed-point steps instead, the motion
        kernels' inversion (10 steps are 5e-5 px off at the corners of a 346x260 sensor
        behind fx 300 px with k1 -0.3, k2 0.1; 5 steps 0.03 px)."""
        uv = _points("uv", uv, 2)
        return np.stack(self.unproject_columns(uv[..., 0], uv[..., 1], iterations), axis=-1)

    def project_turned(self, x, y, z, wx, wy, wz, scale=1.0):
        """project_columns of directions (x, y, z) columns a small turn w·scale (rad, camera
        frame) of the camera moves: a fixed star's direction goes to d − (w × d)·scale
        (ḋ = −ω × d, to first order)."""
        return self.project_columns(x - (wy * z - wz * y) * scale, y - (wz * x - wx * z) * scale,
                                    z - (wx * y - wy * x) * scale)

    def unproject_columns(self, u, v, iterations=None):
        """unproject of pixel coordinates given as two (N,) columns: (x, y, z) columns (no
        (N, 3) temporaries: the velocity prior unprojects every crossing)."""
        xd, yd = (u - self.cx) / self.fx, (v - self.cy) / self.fy
        xn, yn = xd, yd
        if self.has_distortion and iterations is not None:   # the kernels' fixed point
            for _ in range(iterations):
                r2 = xn * xn + yn * yn
                s = 1 + self.k1 * r2 + self.k2 * r2 * r2
                xn, yn = xd / s, yd / s
        elif self.has_distortion:
            rd = np.sqrt(xd * xd + yd * yd)
            r = undistorted_radius(rd, self.k1, self.k2, self.corner_radius())
            with np.errstate(divide="ignore", invalid="ignore"):
                scale = np.where(rd > 0, r / rd, 1.0)
            xn, yn = xd * scale, yd * scale
        return unit(xn, yn, np.ones_like(xn))


#: the radial scale 1 + k1·r² + k2·r⁴ a lens may give the sensor's corner (a wide-angle
#: lens's k1 -0.3, k2 0.1 give ~0.9; k1 1e6 ran, every event warped far off the sensor)
_DISTORTION_SCALES = (0.25, 4.0)


def radial(r, k1, k2):
    """The distorted normalised radius r·(1 + k1·r² + k2·r⁴) of an undistorted one."""
    s = r * r
    return r * (1 + k1 * s + k2 * s * s)


def fold_radius(k1, k2):
    """The smallest undistorted radius > 0 where radial() stops growing (its slope
    1 + 3·k1·r² + 5·k2·r⁴ reaches 0), or inf where it grows everywhere."""
    a, b = 5.0 * k2, 3.0 * k1            # a·s² + b·s + 1 = 0 in s = r²
    if a == 0:
        roots = [-1.0 / b] if b < 0 else []
    else:
        disc = b * b - 4 * a
        q = math.sqrt(disc) if disc >= 0 else None
        roots = [] if q is None else [s for s in ((-b - q) / (2 * a), (-b + q) / (2 * a)) if s > 0]
    return math.sqrt(min(roots)) if roots else math.inf


#: samples of the radial distortion that undistorted_radius interpolates before Newton
_TABLE = 4097


@functools.lru_cache(maxsize=32)
def _inverse_table(k1, k2, reach):
    """(distorted, undistorted) radii sampled over the monotone range 0 .. r_end that covers
    distorted radii up to `reach` (or up to the fold)."""
    rf = fold_radius(k1, k2)
    r_end = max(reach, 1e-6)
    while radial(r_end, k1, k2) < reach and r_end < rf:
        r_end = min(2 * r_end, rf)
    r_end = min(r_end, rf)
    r = np.linspace(0.0, r_end, _TABLE)
    return np.maximum.accumulate(radial(r, k1, k2)), r


def undistorted_radius(rd, k1, k2, reach=1.0, newton=3):
    """The undistorted normalised radius r >= 0 with radial(r) = rd, per element: from a
    table of the monotone branch covering radii up to `reach` (the sensor's corners), then
    Newton steps (a fixed number: each element's result depends on itself alone). Radii
    beyond a fold (off the sensor) stay at the fold."""
    rd = np.asarray(rd, np.float64)
    fd, fr = _inverse_table(float(k1), float(k2), float(reach))
    rf = fold_radius(k1, k2)
    r = np.interp(rd, fd, fr)
    beyond = rd > fd[-1]
    if beyond.any() and not math.isfinite(rf):     # off the table, still monotone
        r = np.where(beyond, rd * (fr[-1] / fd[-1]), r)
    for _ in range(newton):
        s = r * r
        slope = 1 + 3 * k1 * s + 5 * k2 * s * s
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (r * (1 + k1 * s + k2 * s * s) - rd) / slope
        r = np.clip(np.where(slope > 0, r - step, r), 0.0, rf)
    return r


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
