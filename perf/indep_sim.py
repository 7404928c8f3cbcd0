"""An independent event-camera star simulator (ESIM / v2e style), numpy + scipy only.

Written from scratch to test evstar on sensor models and scenes it was not developed on: it
shares no code and no modelling choices with evstar.sim (it uses only evstar's public data
classes Events, Camera and Imu for its output).

Model, in the order a scene is simulated:

* **Scene.** A pinhole camera (width x height px, focal length f px, principal point at the
  sensor centre); 1–5 stars that all move together (the camera turns). Pixel (i, j) covers
  x in [i − ½, i + ½], so a pixel's centre is at its integer index (evstar's convention).
  Motions, as an image-plane offset added to each star's start position:
  ``Linear`` (constant rate °/s → f·rate·π/180 px/s in a direction), ``Sinusoid``
  (amplitude °, frequency Hz, along a direction), ``Accelerating`` (constant angular
  acceleration °/s² from rest), ``Circle`` (coning), ``Shaken`` (a pan with a vibration)
  and ``Rolled`` (a turn about the boresight, with a pan; projection "rotate"). The truth
  is each star's centre (x, y) as a function of time: ``truth(t_us)`` -> (len(t), n_stars, 2), NaN while the centre is off the sensor.
* **PSF** (all symmetric about the centre, so the intensity-weighted centre is the truth):
  ``Gaussian(sigma)``, ``Moffat(fwhm, beta)``, ``Defocus(radius, blur)`` (a uniform disk
  convolved with a Gaussian: exact radial profile from the non-central χ² CDF) and
  ``Elliptical(sigma_x, sigma_y, angle_deg)``. Each PSF is integrated over the pixel area by
  5x5 supersampling once, into a table of the pixel value against the pixel-centre − star
  offset (0.05 px spacing); a step reads the table bilinearly, only in a window around each
  star (the window reaches out to where F·PSF < 0.2 % of the background).
* **Photometry.** Background B = 1 (arbitrary units per pixel), star flux F = F0·10^(−0.4 m)
  (total, in the same units) with F0 = 2000: a magnitude-3 star then has F ≈ 126 B, so with
  a 1 px Gaussian its peak pixel is ≈ 19 B above the sky, a log contrast
  ln((B + F·peak)/B) ≈ 3.0 (15 ON events per crossing at C = 0.2); magnitude 5 gives 1.4
  (7 events), magnitude 6 0.8 (4 events): faint. Log intensity L = ln(I + eps), eps = 1e-3.
* **Time.** Adaptive steps such that no star moves more than 0.05 px in a step and no step is
  longer than 200 µs. The (filtered) log intensity of each pixel is linear between steps; a
  pixel fires one event per threshold crossing, each at its interpolated time, several per
  step if need be (ESIM). Pixels near a star (or still relaxing after one) are simulated;
  all others only produce noise.
* **Pixel.** ``ideal`` (the pixel sees L itself) or ``lowpass``: a first-order low-pass of L
  whose cutoff grows with intensity, f_c(I) = f_min + (f_max − f_min)·I/(I + I_half),
  integrated exactly over each step for the linear input, with f_c held at the step's mean
  intensity: V1 = L1 − k/a + (V0 − L0 + k/a)·e^(−a h), a = 2π f_c, k = (L1 − L0)/h.
* **Thresholds.** ON C_on and OFF C_off; per-pixel Gaussian mismatch (std as a fraction of
  each). The initial reference levels are uniform in (V − C_on, V + C_off) (pixels were reset
  at unknown times). Refractory rule: after an event at t_e the pixel is blind until
  t_e + R; crossings inside are lost, and at t_e + R its reference is reset to its level
  at that moment (the reset switch is held during the refractory period, as in the DVS
  pixel) — so with R = 0 the reference is exactly the crossed level. Timestamps are
  floored to 1 µs; events are sorted by time.
* **Noise.** Background activity: a Poisson process per pixel, rates log-normal (σ_ln 0.7)
  about the mean rate (optionally rising linearly to ``noise_growth`` times it by the end:
  stray light), ON with probability ``noise_on_fraction``; ``hot_pixels`` single
  pixels firing at 100–1000 Hz (half ON); optional Gaussian timestamp jitter of every event
  (readout), re-sorted.

``simulate(scene, sensor, seed)`` returns a :class:`SimRun` (events, camera, truth, labels
of the star each event came from (−1 noise), an optional evstar.Imu, info).

Projection: ``Scene.projection = "translate"`` moves every star by the motion's image-plane
offset (the rates above hold everywhere); ``"rotate"`` turns the camera instead, about the
in-image axis perpendicular to the motion by θ = offset / f, and projects the fixed stars
with the pinhole: the rates hold at the principal point and grow by up to (1 + (r/f)²)
towards the edges — what a real star field does, and what evstar's rigid-field step
(estimate.field_min_stars) assumes. Use "rotate" for fields of several stars.

IMU (``imu=True``): gyro at 1 kHz, ω_cam = (v_y / f, −v_x / f, 0) rad/s for the image-plane
velocity (v_x, v_y) px/s of the motion at the principal point — the camera turning under
fixed stars (a star's direction moves by −ω × r). Exact for ``projection="rotate"``; for
"translate" right only to first order near the centre. Sign checked against evstar's
compensation: evstar.motion.compensate(..., mode="imu") moves each event by the truth's
displacement from its time to its frame's reference time.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

B_SKY = 1.0          # background intensity per pixel
F0 = 2000.0          # flux of a magnitude-0 star (units of B · pixel)
EPS = 1e-3           # log offset
STEP_PX = 0.05       # largest star motion in one step
STEP_MAX_S = 200e-6  # longest step
TABLE_STEP = 0.05    # PSF table spacing (px)
TABLE_HALF = 14.0    # PSF table half-width (px)
WINDOW_TOL = 2e-3    # a star's window reaches out to F·PSF = WINDOW_TOL · B
RELAX_TOL = 1e-3     # a low-pass pixel outside every window is dropped when this close to L


def flux(mag):
    return F0 * 10 ** (-0.4 * mag)


# --------------------------------------------------------------------------- PSFs
class PSF:
    """A normalised intensity profile (integral 1) centred on the star."""
    name = "psf"

    def density(self, dx, dy):
        raise NotImplementedError

    def sigma_eff(self):
        """Per-axis RMS width of the profile (the square root of the mean of the two axes'
        second moments), without the pixel's own ±½ px."""
        raise NotImplementedError

    def table(self):
        if getattr(self, "_table", None) is None:
            self._table = PixelTable(self)
        return self._table


@dataclass
class Gaussian(PSF):
    sigma: float
    name = "gauss"

    def density(self, dx, dy):
        s2 = self.sigma ** 2
        return np.exp(-(dx * dx + dy * dy) / (2 * s2)) / (2 * np.pi * s2)

    def sigma_eff(self):
        return self.sigma

    def label(self):
        return f"gauss σ{self.sigma:g}"


@dataclass
class Moffat(PSF):
    fwhm: float
    beta: float = 3.0
    name = "moffat"

    @property
    def alpha(self):
        return self.fwhm / (2 * math.sqrt(2 ** (1 / self.beta) - 1))

    def density(self, dx, dy):
        a2 = self.alpha ** 2
        return (self.beta - 1) / (np.pi * a2) * (1 + (dx * dx + dy * dy) / a2) ** (-self.beta)

    def sigma_eff(self):    # <r²> = α²/(β − 2): finite for β > 2
        return self.alpha / math.sqrt(2 * (self.beta - 2))

    def label(self):
        return f"moffat FWHM{self.fwhm:g} β{self.beta:g}"


@dataclass
class Defocus(PSF):
    radius: float
    blur: float = 0.5
    name = "defocus"

    def __post_init__(self):
        from scipy.stats import ncx2

        s = self.blur
        self._r = np.linspace(0, TABLE_HALF * 1.5 + 2, 6001)
        # P(|X + r| < R) for X ~ N(0, s² I): non-central χ² with 2 dof
        p = ncx2.cdf((self.radius / s) ** 2, 2, (self._r / s) ** 2)
        self._p = p / (np.pi * self.radius ** 2)

    def density(self, dx, dy):
        return np.interp(np.hypot(dx, dy), self._r, self._p, right=0.0)

    def sigma_eff(self):
        return math.sqrt(self.radius ** 2 / 4 + self.blur ** 2)

    def label(self):
        return f"disk r{self.radius:g} ⊛ σ{self.blur:g}"


@dataclass
class Elliptical(PSF):
    sigma_x: float
    sigma_y: float
    angle_deg: float = 30.0
    name = "ellip"

    def density(self, dx, dy):
        c, s = math.cos(math.radians(self.angle_deg)), math.sin(math.radians(self.angle_deg))
        u, v = c * dx + s * dy, -s * dx + c * dy
        return (np.exp(-0.5 * ((u / self.sigma_x) ** 2 + (v / self.sigma_y) ** 2))
                / (2 * np.pi * self.sigma_x * self.sigma_y))

    def sigma_eff(self):
        return math.sqrt((self.sigma_x ** 2 + self.sigma_y ** 2) / 2)

    def label(self):
        return f"ellip σ{self.sigma_x:g}x{self.sigma_y:g} @{self.angle_deg:g}°"


class PixelTable:
    """The PSF integrated over a pixel (5x5 supersampling), tabulated against the offset
    pixel centre − star centre; bilinear look-up, 0 beyond the table."""

    def __init__(self, psf, sub=5):
        g = np.arange(-TABLE_HALF, TABLE_HALF + TABLE_STEP / 2, TABLE_STEP)
        gx, gy = np.meshgrid(g, g, indexing="xy")
        acc = np.zeros_like(gx)
        offs = (np.arange(sub) + 0.5) / sub - 0.5
        for ox in offs:
            for oy in offs:
                acc += psf.density(gx + ox, gy + oy)
        self.values = acc / sub ** 2           # [iy, ix]
        self.n = len(g)
        # largest value at Chebyshev distance >= d, d = 0, 1, ... (for window radii)
        cheb = np.maximum(np.abs(gx), np.abs(gy))
        self.beyond = np.array([self.values[cheb >= d].max(initial=0.0)
                                for d in range(int(TABLE_HALF) + 1)])

    def __call__(self, dx, dy):
        fx = (np.asarray(dx) + TABLE_HALF) / TABLE_STEP
        fy = (np.asarray(dy) + TABLE_HALF) / TABLE_STEP
        ix, iy = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
        ok = (ix >= 0) & (iy >= 0) & (ix < self.n - 1) & (iy < self.n - 1)
        ix, iy = np.where(ok, ix, 0), np.where(ok, iy, 0)
        wx, wy = fx - ix, fy - iy
        v = self.values
        out = ((1 - wy) * ((1 - wx) * v[iy, ix] + wx * v[iy, ix + 1])
               + wy * ((1 - wx) * v[iy + 1, ix] + wx * v[iy + 1, ix + 1]))
        return np.where(ok, out, 0.0)

    def radius(self, star_flux):
        """Window half-size (px, Chebyshev) beyond which F·PSF < WINDOW_TOL·B."""
        ok = star_flux * self.beyond < WINDOW_TOL * B_SKY
        d = int(np.argmax(ok)) if ok.any() else len(self.beyond) - 1
        return min(d + 1, int(TABLE_HALF) - 1)


# --------------------------------------------------------------------------- motion
def _unit(direction_deg):
    a = math.radians(direction_deg)
    return np.array([math.cos(a), math.sin(a)])


@dataclass
class Linear:
    """Constant angular rate (°/s) along `direction_deg` (from +x towards +y)."""
    rate_dps: float
    direction_deg: float = 0.0

    def offset(self, t_s, f):
        v = math.radians(self.rate_dps) * f
        return np.outer(v * np.asarray(t_s, float), _unit(self.direction_deg))

    def velocity(self, t_s, f):
        v = math.radians(self.rate_dps) * f
        return np.outer(np.full(np.shape(t_s), v), _unit(self.direction_deg))

    def label(self):
        return f"{self.rate_dps:g}°/s"


@dataclass
class Sinusoid:
    """amplitude_deg · sin(2π freq t) along `direction_deg`."""
    amplitude_deg: float
    freq_hz: float
    direction_deg: float = 0.0

    def offset(self, t_s, f):
        a = math.radians(self.amplitude_deg) * f
        return np.outer(a * np.sin(2 * np.pi * self.freq_hz * np.asarray(t_s, float)),
                        _unit(self.direction_deg))

    def velocity(self, t_s, f):
        a = math.radians(self.amplitude_deg) * f * 2 * np.pi * self.freq_hz
        return np.outer(a * np.cos(2 * np.pi * self.freq_hz * np.asarray(t_s, float)),
                        _unit(self.direction_deg))

    def label(self):
        return f"sine {self.amplitude_deg:g}°/{self.freq_hz:g} Hz"


@dataclass
class Accelerating:
    """From rest at t = 0 with a constant angular acceleration (°/s²)."""
    accel_dps2: float
    direction_deg: float = 0.0

    def offset(self, t_s, f):
        a = math.radians(self.accel_dps2) * f
        return np.outer(0.5 * a * np.asarray(t_s, float) ** 2, _unit(self.direction_deg))

    def velocity(self, t_s, f):
        a = math.radians(self.accel_dps2) * f
        return np.outer(a * np.asarray(t_s, float), _unit(self.direction_deg))

    def label(self):
        return f"accel {self.accel_dps2:g}°/s²"


@dataclass
class Circle:
    """Coning: the boresight circles at `radius_deg`, `freq_hz` turns a second — a constant
    image speed whose direction turns all the time. The offset is planar (no single
    direction): the "rotate" projection turns about a new in-image axis at every time."""
    radius_deg: float
    freq_hz: float
    planar = True

    def offset(self, t_s, f):
        a, w = math.radians(self.radius_deg) * f, 2 * np.pi * self.freq_hz * np.asarray(t_s, float)
        return np.column_stack([a * np.sin(w), a * (1 - np.cos(w))])

    def velocity(self, t_s, f):
        a, w = math.radians(self.radius_deg) * f, 2 * np.pi * self.freq_hz
        ph = w * np.asarray(t_s, float)
        return np.column_stack([a * w * np.cos(ph), a * w * np.sin(ph)])

    def label(self):
        return f"circle {self.radius_deg:g}°/{self.freq_hz:g} Hz"


@dataclass
class Shaken:
    """`base` (a Linear motion) with a `wave` (a Sinusoid, e.g. 0.05° at 20 Hz across it)
    added: a platform's vibration on top of its turn. Planar like Circle."""
    base: Linear
    wave: Sinusoid
    planar = True

    def offset(self, t_s, f):
        return self.base.offset(t_s, f) + self.wave.offset(t_s, f)

    def velocity(self, t_s, f):
        return self.base.velocity(t_s, f) + self.wave.velocity(t_s, f)

    def label(self):
        return f"{self.base.label()} + {self.wave.label()}"


@dataclass
class Rolled:
    """A turn about the boresight (roll, °/s) on top of `base` (a Linear pan, 0 °/s for a
    pure roll): stars circle the principal point, each at a speed growing with its distance
    from it, the pan's added. Planar like Circle; its rotations are its own (rotations)."""
    roll_dps: float
    base: Linear
    planar = True

    def offset(self, t_s, f):
        return self.base.offset(t_s, f)

    def velocity(self, t_s, f):   # at the principal point: the pan's
        return self.base.velocity(t_s, f)

    def rotations(self, t_s, f):
        """(T, 3, 3): the pan's turn, then the roll about the optical axis."""
        a = -math.radians(self.roll_dps) * np.asarray(t_s, float)
        Rz = np.zeros((len(a), 3, 3))
        Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a)
        Rz[:, 2, 2] = 1.0
        return Rz @ turn_matrices(self.offset(t_s, f), f)

    def label(self):
        pan = f" + {self.base.label()}" if self.base.rate_dps else ""
        return f"roll {self.roll_dps:g}°/s{pan}"


def rotations(motion, t_s, f):
    """(T, 3, 3) camera-frame rotations of fixed star directions of a planar motion."""
    if hasattr(motion, "rotations"):
        return motion.rotations(np.asarray(t_s, float), f)
    return turn_matrices(motion.offset(t_s, f), f)


def turn_matrices(off, f):
    """(T, 3, 3) camera-frame rotations of fixed star directions for image offsets off (T, 2)
    at the principal point: about the in-image axis perpendicular to each offset, by
    |offset| / f (Rodrigues)."""
    n = np.hypot(off[:, 0], off[:, 1])
    u = off / np.maximum(n, 1e-300)[:, None]
    a = np.column_stack([u[:, 1], -u[:, 0], np.zeros(len(n))])
    th = -n / f
    K = np.zeros((len(n), 3, 3))
    K[:, 0, 2], K[:, 1, 2], K[:, 2, 0], K[:, 2, 1] = a[:, 1], -a[:, 0], -a[:, 1], a[:, 0]
    K[:, 0, 1], K[:, 1, 0] = -a[:, 2], a[:, 2]
    s, c = np.sin(th)[:, None, None], np.cos(th)[:, None, None]
    return np.eye(3)[None] + s * K + (1 - c) * (K @ K)


# --------------------------------------------------------------------------- scene, sensor
@dataclass
class Scene:
    width: int = 346
    height: int = 260
    focal_px: float = 280.0
    start_xy: list = field(default_factory=lambda: [(100.0, 130.0)])   # star centres at t=0
    mags: list = field(default_factory=lambda: [4.0])
    motion: object = field(default_factory=lambda: Linear(3.0))
    psf: PSF = field(default_factory=lambda: Gaussian(1.0))
    duration_s: float = 1.0
    projection: str = "translate"   # or "rotate": the camera turns, the pinhole projects

    def __post_init__(self):
        if len(self.start_xy) != len(self.mags):
            raise ValueError("one magnitude per star")
        if self.projection not in ("translate", "rotate"):
            raise ValueError(f"projection must be 'translate' or 'rotate', got {self.projection!r}")

    @property
    def principal_point(self):
        return (self.width - 1) / 2, (self.height - 1) / 2

    def positions(self, t_s):
        """(len(t), n_stars, 2) star centres, no NaN."""
        t_s = np.atleast_1d(np.asarray(t_s, float))
        p0 = np.asarray(self.start_xy, float).reshape(1, -1, 2)
        off = self.motion.offset(t_s, self.focal_px)            # (T, 2) px at the centre
        if self.projection == "translate":
            return p0 + off[:, None]
        # a turn about the in-image axis a = (u_y, −u_x, 0) by θ = |offset| / f (signed):
        # fixed stars r0 become Rot(a, −θ) r0 in the camera frame, projected by the pinhole
        f, (cx, cy) = self.focal_px, self.principal_point
        if getattr(self.motion, "planar", False):
            r0 = np.stack([(p0[0, :, 0] - cx) / f, (p0[0, :, 1] - cy) / f, np.ones(p0.shape[1])], 1)
            r = np.einsum("tij,sj->tsi", rotations(self.motion, t_s, f), r0)
            return np.stack([cx + f * r[..., 0] / r[..., 2], cy + f * r[..., 1] / r[..., 2]], axis=-1)
        u = _unit(self.motion.direction_deg)
        theta = (off @ u) / f                                    # (T,)
        a = np.array([u[1], -u[0], 0.0])
        r0 = np.stack([(p0[0, :, 0] - cx) / f, (p0[0, :, 1] - cy) / f,
                       np.ones(p0.shape[1])], axis=1)            # (S, 3)
        c, s = np.cos(-theta)[:, None, None], np.sin(-theta)[:, None, None]
        axr = np.cross(a, r0)[None]                               # (1, S, 3)
        adr = (r0 @ a)[None, :, None]
        r = r0[None] * c + axr * s + a[None, None] * adr * (1 - c)   # Rodrigues
        return np.stack([cx + f * r[..., 0] / r[..., 2], cy + f * r[..., 1] / r[..., 2]], axis=-1)

    def truth(self, t_us):
        """(len(t), n_stars, 2) true centres at times t_us (µs); NaN off the sensor."""
        p = self.positions(np.asarray(t_us, float) * 1e-6)
        off = ((p[..., 0] < -0.5) | (p[..., 0] > self.width - 0.5)
               | (p[..., 1] < -0.5) | (p[..., 1] > self.height - 0.5))
        p[off] = np.nan
        return p

    def speed(self, t_s):
        """Fastest star's image speed (px/s) at t_s."""
        v = float(np.hypot(*self.motion.velocity(np.atleast_1d(t_s), self.focal_px)[0]))
        if self.projection == "translate" or not self.mags:
            return v
        # off the centre a turn moves stars up to (1 + (r/f)²) faster: measure it
        dt = 1e-5
        p = self.positions([t_s, t_s + dt])
        return max(v, float(np.hypot(*(p[1] - p[0]).T).max() / dt))


@dataclass
class Sensor:
    pixel: str = "ideal"            # "ideal" or "lowpass"
    f_min_hz: float = 40.0          # low-pass cutoff in the dark
    f_max_hz: float = 2000.0        # ... and for bright pixels
    i_half: float = 20.0            # intensity (units of B) at which f_c is halfway
    c_on: float = 0.2
    c_off: float = 0.2
    mismatch: float = 0.03          # per-pixel threshold std, fraction
    refractory_us: float = 100.0
    noise_hz: float = 1.0           # mean background activity per pixel
    noise_sigma_ln: float = 0.7     # log-normal spread of the per-pixel rates
    noise_on_fraction: float = 0.6
    noise_growth: float = 1.0       # background rate at the end / at the start (stray light
                                    # rising linearly over the recording)
    hot_pixels: int = 0             # single pixels at 100–1000 Hz
    jitter_us: float = 0.0          # per-event timestamp jitter (std)
    leak_hz: float = 0.0            # leak: ON events at a steady per-pixel rate (log-normal)
    gaps_s: tuple = ()              # readout gaps: (t0, t1) spans whose events are all lost
    random_reference: bool = True   # initial references uniform in (V − C_on, V + C_off)

    def cutoff_hz(self, intensity):
        return self.f_min_hz + (self.f_max_hz - self.f_min_hz) * intensity / (intensity + self.i_half)


def lowpass_step(v0, l0, l1, h, cutoff_hz):
    """Exact first-order low-pass update over a step h (s) whose input goes linearly from l0
    to l1, cutoff held constant: the filtered level at the step's end."""
    a = 2 * np.pi * np.asarray(cutoff_hz, float)
    k = (l1 - l0) / h
    return l1 - k / a + (v0 - l0 + k / a) * np.exp(-a * h)


@dataclass
class SimRun:
    events: object
    camera: object
    truth: object
    labels: np.ndarray
    imu: object = None
    info: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- simulation
def _step_times(scene):
    """Step boundaries (s): star moves <= STEP_PX per step, steps <= STEP_MAX_S."""
    t, out = 0.0, [0.0]
    while t < scene.duration_s:
        v = max(scene.speed(t), scene.speed(min(t + STEP_MAX_S, scene.duration_s)))
        h = STEP_MAX_S if v <= 0 else min(STEP_MAX_S, STEP_PX / v)
        t = min(t + h, scene.duration_s)
        out.append(t)
    return np.array(out)


class _Stars:
    """Intensity of the pixels `idx` (flat indices) at a time; star windows."""

    def __init__(self, scene):
        self.scene = scene
        self.table = scene.psf.table()
        self.flux = np.array([flux(m) for m in scene.mags])
        self.radius = [self.table.radius(F) for F in self.flux]
        self.w, self.h = scene.width, scene.height

    def contributions(self, idx, t_s):
        """(n_stars, len(idx)) F·PSF of each star at the pixels."""
        p = self.scene.positions(t_s)[0]
        px, py = idx % self.w, idx // self.w
        return np.stack([F * self.table(px - x, py - y) for F, (x, y) in zip(self.flux, p)])

    def window(self, t_s):
        """Flat indices of the pixels within each star's window (union, unique)."""
        p = self.scene.positions(t_s)[0]
        parts = []
        for r, (x, y) in zip(self.radius, p):
            cx, cy = int(round(x)), int(round(y))
            xs = np.arange(max(cx - r, 0), min(cx + r, self.w - 1) + 1)
            ys = np.arange(max(cy - r, 0), min(cy + r, self.h - 1) + 1)
            if len(xs) and len(ys):
                parts.append((ys[:, None] * self.w + xs[None]).ravel())
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)


def _signal_events(scene, sensor, rng):
    """(t_s, flat pixel, polarity 1/0, star label) of the star-induced events."""
    z = np.zeros(0)
    empty = z, z.astype(np.int64), z.astype(np.int8), z.astype(np.int64)
    if not scene.mags:
        return empty
    stars = _Stars(scene)
    npx = scene.width * scene.height
    l_bg = math.log(B_SKY + EPS)
    c_on = np.maximum(sensor.c_on * (1 + sensor.mismatch * rng.standard_normal(npx)), 0.01)
    c_off = np.maximum(sensor.c_off * (1 + sensor.mismatch * rng.standard_normal(npx)), 0.01)
    # state of every pixel: filtered level, reference, blind-until time, pending reset
    level = np.full(npx, l_bg)
    w0 = stars.window(0.0)
    level[w0] = np.log(B_SKY + stars.contributions(w0, 0.0).sum(0) + EPS)
    ref = level.copy()
    if sensor.random_reference:
        ref = level + rng.uniform(-c_on, c_off)         # V − ref in (−C_off, C_on): no event yet
    blind = np.full(npx, -np.inf)
    pending = np.zeros(npx, bool)
    live = np.zeros(npx, bool)
    R = sensor.refractory_us * 1e-6
    lowpass = sensor.pixel == "lowpass"
    if sensor.pixel not in ("ideal", "lowpass"):
        raise ValueError(f"pixel must be 'ideal' or 'lowpass', got {sensor.pixel!r}")

    out_t, out_i, out_p, out_s = [], [], [], []
    times = _step_times(scene)
    for t0, t1 in zip(times[:-1], times[1:]):
        h = t1 - t0
        win = stars.window(t1)
        live[win] = True
        idx = np.flatnonzero(live)
        c1 = stars.contributions(idx, t1)
        i1 = B_SKY + c1.sum(0)
        l1 = np.log(i1 + EPS)
        v0 = level[idx]
        if lowpass:
            i0 = B_SKY + stars.contributions(idx, t0).sum(0)
            l0 = np.log(i0 + EPS)
            v1 = lowpass_step(v0, l0, l1, h, sensor.cutoff_hz(0.5 * (i0 + i1)))
        else:
            v1 = l1
        label = np.where(c1.max(0) > 0, c1.argmax(0), -1)
        _fire(idx, t0, t1, v0, v1, ref, blind, pending, c_on, c_off, R,
              out_t, out_i, out_p, out_s, label)
        level[idx] = v1
        # pixels leave the simulated set once outside every window and settled
        keep = np.zeros(len(idx), bool)
        inwin = np.zeros(npx, bool)
        inwin[win] = True
        keep |= inwin[idx] | pending[idx] | (np.abs(v1 - l1) > RELAX_TOL)
        live[idx[~keep]] = False
    if out_t:
        return (np.concatenate(out_t), np.concatenate(out_i), np.concatenate(out_p),
                np.concatenate(out_s))
    return empty


def _fire(idx, t0, t1, v0, v1, ref, blind, pending, c_on, c_off, R,
          out_t, out_i, out_p, out_s, label):
    """Events of pixels idx in the step [t0, t1] whose level goes linearly v0 -> v1; updates
    ref, blind and pending in place (see the module docstring's refractory rule)."""
    h = t1 - t0
    slope = (v1 - v0) / h

    def level_at(k, t):
        return v0[k] + slope[k] * (t - t0)

    tcur = np.full(len(idx), t0)
    active = np.ones(len(idx), bool)
    # a pending reset: the pixel is blind until blind[]; skip steps it is blind throughout
    pend = pending[idx]
    if pend.any():
        bl = blind[idx]
        ends = pend & (bl <= t1)
        k = np.flatnonzero(ends)
        tcur[k] = np.maximum(bl[k], t0)
        ref[idx[k]] = level_at(k, tcur[k])
        pending[idx[k]] = False
        active &= ~(pend & ~ends)
    k = np.flatnonzero(active & (v1 != v0))
    while len(k):
        px = idx[k]
        up = slope[k] > 0
        target = np.where(up, ref[px] + c_on[px], ref[px] - c_off[px])
        tc = t0 + (target - v0[k]) / slope[k]
        hit = np.where(up, v1[k] >= target, v1[k] <= target) & (tc <= t1)
        k, px, up, target, tc = k[hit], px[hit], up[hit], target[hit], tc[hit]
        if not len(k):
            break
        tc = np.maximum(tc, tcur[k])
        out_t.append(tc), out_i.append(px), out_p.append(up.astype(np.int8)), out_s.append(label[k])
        ref[px] = target
        if R > 0:
            end = tc + R
            blind[px] = end
            later = end > t1
            pending[px[later]] = True
            now = ~later
            k, px, end = k[now], px[now], end[now]
            ref[px] = level_at(k, end)
            tcur[k] = end
        else:
            tcur[k] = tc


def _noise_events(scene, sensor, rng):
    npx = scene.width * scene.height
    T = scene.duration_s
    ts, ix, ps = [], [], []
    if sensor.noise_hz > 0:
        s = sensor.noise_sigma_ln
        rates = sensor.noise_hz * np.exp(s * rng.standard_normal(npx) - s * s / 2)
        a = sensor.noise_growth - 1.0           # rate ∝ 1 + a·t/T
        n = rng.poisson(rates * T * (1 + a / 2))
        ix.append(np.repeat(np.arange(npx), n))
        u = rng.uniform(0, 1, n.sum())            # inverse CDF of the linear density
        if a:
            u = (np.sqrt(1 + 2 * a * u * (1 + a / 2)) - 1) / a
        ts.append(u * T)
        ps.append((rng.random(n.sum()) < sensor.noise_on_fraction).astype(np.int8))
    if sensor.hot_pixels:
        where = rng.choice(npx, sensor.hot_pixels, replace=False)
        n = rng.poisson(rng.uniform(100, 1000, sensor.hot_pixels) * T)
        ix.append(np.repeat(where, n))
        ts.append(rng.uniform(0, T, n.sum()))
        ps.append((rng.random(n.sum()) < 0.5).astype(np.int8))
    if sensor.leak_hz > 0:   # periodic per pixel, random phase, rates spread ×/÷ 1.6
        rates = sensor.leak_hz * np.exp(0.5 * rng.standard_normal(npx))
        n = np.floor(rates * T + rng.random(npx)).astype(np.int64)
        first = rng.random(npx) / rates
        pix = np.repeat(np.arange(npx), n)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        t = first[pix] + k / rates[pix]
        keep = t < T
        ix.append(pix[keep]), ts.append(t[keep]), ps.append(np.ones(keep.sum(), np.int8))
    if not ts:
        return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int8)
    return np.concatenate(ts), np.concatenate(ix), np.concatenate(ps)


def simulate(scene, sensor=None, seed=0, imu=False):
    """Simulate `scene` on `sensor`: a SimRun (see the module docstring)."""
    import evstar

    sensor = Sensor() if sensor is None else sensor
    rng = np.random.default_rng(seed)
    st, si, sp, ss = _signal_events(scene, sensor, rng)
    nt, ni, np_ = _noise_events(scene, sensor, rng)
    t = np.concatenate([st, nt])
    i = np.concatenate([si, ni]).astype(np.int64)
    p = np.concatenate([sp, np_]).astype(np.int8)
    lab = np.concatenate([ss, np.full(len(nt), -1)]).astype(np.int64)
    for g0, g1 in sensor.gaps_s:   # the readout lost everything in a gap
        kept = (t < g0) | (t >= g1)
        t, i, p, lab = t[kept], i[kept], p[kept], lab[kept]
    t_us = t * 1e6
    if sensor.jitter_us > 0:
        t_us = np.maximum(t_us + sensor.jitter_us * rng.standard_normal(len(t_us)), 0.0)
    t_us = np.floor(t_us).astype(np.int64)
    order = np.argsort(t_us, kind="stable")
    t_us, i, p, lab = t_us[order], i[order], p[order], lab[order]
    ev = evstar.Events(t_us, i % scene.width, i // scene.width, p, scene.width, scene.height)
    f = scene.focal_px
    cam = evstar.Camera(scene.width, scene.height, f, f, (scene.width - 1) / 2, (scene.height - 1) / 2)
    info = {"flux": [flux(m) for m in scene.mags], "sigma_eff_px": scene.psf.sigma_eff(),
            "signal_events": int((lab >= 0).sum()), "noise_events": int((lab < 0).sum()),
            "per_star_events": [int((lab == s).sum()) for s in range(len(scene.mags))]}
    run = SimRun(ev, cam, scene.truth, lab, info=info)
    if imu:
        run.imu = make_imu(scene)
    return run


def make_imu(scene, rate_hz=1000.0):
    """evstar.Imu of the camera turn that moves the stars (module docstring: exact at the
    principal point only). Gyro in the camera frame, identity mounting, no clock offset."""
    import evstar

    t = np.arange(0.0, scene.duration_s + 2 / rate_hz, 1 / rate_hz)
    v = scene.motion.velocity(t, scene.focal_px)           # px/s of the stars
    f = scene.focal_px
    if getattr(scene.motion, "planar", False):   # ω from the turns themselves: Ṙ Rᵀ = −[ω]×
        h = 1e-6
        R0, R1 = (rotations(scene.motion, t + d, f) for d in (-h, h))
        W = (R1 - R0) / (2 * h) @ rotations(scene.motion, t, f).transpose(0, 2, 1)
        gyro = -np.column_stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]])
        return evstar.Imu(np.round(t * 1e6).astype(np.int64), gyro)
    gyro = np.column_stack([v[:, 1] / f, -v[:, 0] / f, np.zeros(len(t))])
    return evstar.Imu(np.round(t * 1e6).astype(np.int64), gyro)
