"""Recording: what a file holds — events, and the IMU and camera when the file has them."""
from __future__ import annotations

from dataclasses import dataclass

from .camera import Camera
from .errors import DataError, ParameterError, ParameterTypeError
from .events import Events
from .frames import check_grid
from .imu import Imu


@dataclass
class Recording:
    events: Events
    imu: Imu | None = None
    camera: Camera | None = None


def check_parts(events, imu, camera, mode):
    """Types of a run's (or a compensation's) events, IMU and camera, what the compensation
    mode needs, matching sizes (evstar.Pipeline.run, evstar.motion.compensate)."""
    if events is not None and not isinstance(events, Events):
        raise ParameterTypeError(f"events must be an evstar.Events, got {type(events).__name__} "
                                 "(build one with evstar.Events(t, x, y, p, width, height))")
    for name, value, cls in (("imu", imu, Imu), ("camera", camera, Camera)):
        if value is not None and not isinstance(value, cls):
            raise ParameterTypeError(f"{name} must be an evstar.{cls.__name__} or None, "
                                     f"got {type(value).__name__}")
    if events is not None:
        check_grid(events.width, events.height)
    if mode != "none":
        missing = [what for what, v in (("an IMU (imu=; command line: --imu FILE, a CSV "
                                         "t,gx,gy,gz,ax,ay,az)", imu),
                                        ("a camera (camera=; command line: --camera FILE, a "
                                         "JSON width, height, fx, fy, cx, cy)", camera))
                   if v is None]
        if missing:
            raise ParameterError(f"motion.compensate = {mode!r} needs {' and '.join(missing)}; "
                                 "the input holds none")
    if events is not None and camera is not None and \
            (camera.width, camera.height) != (events.width, events.height):
        raise DataError(f"the camera is {camera.width}x{camera.height} px but the events' sensor "
                        f"is {events.width}x{events.height} px: a camera of another sensor")
