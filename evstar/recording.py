"""Recording: what a file holds — events, and the IMU and camera when the file has them."""
from __future__ import annotations

from dataclasses import dataclass

from .camera import Camera
from .events import Events
from .imu import Imu


@dataclass
class Recording:
    events: Events
    imu: Imu | None = None
    camera: Camera | None = None
