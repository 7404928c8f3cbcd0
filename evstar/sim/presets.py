"""Camera presets (true resolutions and pixel pitches) and the paper's experiments.

The paper (Liu et al. 2025, §4.1) used an iniVation DVXplorer Lite with its built-in IMU on
a precision turntable facing a single-star simulator (LED, mask, collimator) of
magnitude-3 brightness, constant rates 4–20 °/s with 500 ms streams analysed per rate,
and a 10°/1 Hz sinusoid of which two 500 ms segments were analysed. It names no lens:
evstar assumes 12 mm, which gives the 320 × 240 sensor a 27.7° × 21.0° field — wide enough
for the ±10° sinusoid to keep the star in view (±114 px about the centre).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..camera import Camera
from ..errors import ParameterError
from .sensor import SensorSpec

DEFAULT_FOCAL_LENGTH_MM = 12.0
PAPER_RATES_DPS = (4.0, 8.0, 12.0, 16.0, 20.0)


@dataclass(frozen=True)
class SensorPreset:
    name: str
    width: int
    height: int
    pixel_pitch_um: float

    def camera(self, focal_length_mm=DEFAULT_FOCAL_LENGTH_MM):
        """Pinhole camera for this sensor behind a lens of `focal_length_mm`, centred."""
        if not focal_length_mm > 0:
            raise ParameterError(f"focal_length_mm must be positive, got {focal_length_mm!r}")
        f_px = focal_length_mm * 1000.0 / self.pixel_pitch_um
        return Camera(self.width, self.height, f_px, f_px, (self.width - 1) / 2, (self.height - 1) / 2)


SENSORS = {
    "dvxplorer-lite": SensorPreset("dvxplorer-lite", 320, 240, 18.5),   # iniVation DVXplorer Lite
    "dvxplorer": SensorPreset("dvxplorer", 640, 480, 9.0),              # iniVation DVXplorer
    "davis346": SensorPreset("davis346", 346, 260, 18.5),               # iniVation DAVIS346
    "evk4": SensorPreset("evk4", 1280, 720, 4.86),                      # Prophesee EVK4 (Sony IMX636)
}
ALIASES = {"imx636": "evk4", "dvxplorer_lite": "dvxplorer-lite", "dvx-lite": "dvxplorer-lite"}


#: sensor models by name (`evstar simulate --sensor`): the default has no photoreceptor
#: bandwidth limit; dark-sky low-passes each pixel with an intensity-dependent cutoff and leaks
SENSOR_MODELS = {"default": SensorSpec, "dark-sky": SensorSpec.dark_sky}


def sensor_model(name, **overrides):
    """The SensorSpec of a named sensor model, with `overrides` of its fields."""
    if name not in SENSOR_MODELS:
        raise ParameterError(f"unknown sensor model {name!r}; known: {', '.join(SENSOR_MODELS)}")
    return SENSOR_MODELS[name](**overrides)


def sensor_preset(name):
    key = ALIASES.get(name.lower(), name.lower())
    if key not in SENSORS:
        raise ParameterError(f"unknown camera preset {name!r}; known: {', '.join(SENSORS)}")
    return SENSORS[key]


def camera_preset(name, focal_length_mm=DEFAULT_FOCAL_LENGTH_MM):
    """Camera of a named sensor preset behind a lens of `focal_length_mm`."""
    return sensor_preset(name).camera(focal_length_mm)


def paper_preset(rate_dps, *, duration_s=0.5, magnitude=3.0, camera="dvxplorer-lite",
                 focal_length_mm=DEFAULT_FOCAL_LENGTH_MM, sensor=None, axis=None,
                 **scenario_options):
    """The paper's turntable run: a magnitude-3-equivalent star, constant `rate_dps`.

    The star crosses the image centre at mid-duration, so a 0.5 s stream at 20 °/s spans
    ±5° (±57 px on the default camera). axis: the turntable's axis in the camera frame
    (the camera's up, −y, where None: the star moves along x). Keyword options override
    Scenario fields.
    """
    from .motion import UP, ConstantRate
    from .scene import Scenario
    from .targets import star_at_pixel

    cam = camera_preset(camera, focal_length_mm) if isinstance(camera, str) else camera
    motion = ConstantRate(rate_dps, UP if axis is None else axis)
    mid = motion.rotation(duration_s / 2)[0]
    stars = star_at_pixel(cam, mid, (cam.cx, cam.cy), magnitude)
    return Scenario(cam, stars, motion, duration_s, sensor=sensor or SensorSpec(), **scenario_options)


def paper_sinusoid(amplitude_deg=10.0, freq_hz=1.0, *, duration_s=1.0, magnitude=3.0,
                   camera="dvxplorer-lite", focal_length_mm=DEFAULT_FOCAL_LENGTH_MM, sensor=None,
                   axis=None, **scenario_options):
    """The paper's sinusoidal run (10° amplitude, 1 Hz): the star swings through the centre
    (about `axis` as in paper_preset)."""
    from .motion import UP, Sinusoid
    from .scene import Scenario
    from .targets import star_at_pixel

    cam = camera_preset(camera, focal_length_mm) if isinstance(camera, str) else camera
    motion = Sinusoid(amplitude_deg, freq_hz, UP if axis is None else axis)
    stars = star_at_pixel(cam, motion.rotation(0.0)[0], (cam.cx, cam.cy), magnitude)
    return Scenario(cam, stars, motion, duration_s, sensor=sensor or SensorSpec(), **scenario_options)


def field_scenario(camera, ra_deg, dec_deg, rate_dps, duration_s, *, motion="pan",
                   mag_limit=6.5, sensor="default", noise_hz=None, axis=(0.0, 1.0, 0.0)):
    """A Hipparcos field (to `mag_limit`) seen by `camera` starting at (RA, Dec): "pan", a
    constant `rate_dps` about `axis` (camera frame; default the image's up axis, (0, 0, 1)
    rolls about the boresight), "sine", a 1 Hz sinusoid about it with `rate_dps` as its
    peak rate, or "slew", rest to rest over `duration_s` peaking at `rate_dps` midway (constant
    acceleration, then deceleration). sensor: a sensor_model name; noise_hz its background
    rate (its own where None)."""
    import numpy as np

    from .motion import ConstantRate, Sinusoid, Slew, attitude_from_radec
    from .scene import Scenario
    from .targets import hipparcos_field_along

    R0 = attitude_from_radec(ra_deg, dec_deg, 0.0)
    if motion == "sine":
        move = Sinusoid(rate_dps / (2 * np.pi), 1.0, axis=axis, R0=R0)
    elif motion == "pan":
        move = ConstantRate(rate_dps, axis=axis, R0=R0)
    elif motion == "slew":
        move = Slew(rate_dps, duration_s, axis=axis, R0=R0)
    else:
        raise ParameterError(f"field motion must be 'pan', 'sine' or 'slew', got {motion!r}")
    stars = hipparcos_field_along(camera, move, duration_s, mag_limit=mag_limit)
    model = sensor_model(sensor) if noise_hz is None else sensor_model(sensor, noise_hz=noise_hz)
    return Scenario(camera, stars, move, duration_s, sensor=model)
