"""Camera JSON {"width","height","fx","fy","cx","cy"} (+ optional "k1","k2")."""
from __future__ import annotations

import json

from ..camera import Camera
from ..errors import DataError, FormatError, ParameterTypeError
from .atomic import atomic_path
from .guard import check_readable

REQUIRED = ("width", "height", "fx", "fy", "cx", "cy")


def read_camera(path):
    check_readable(path)
    try:
        with open(path, "rb") as f:
            data = json.loads(f.read())
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise FormatError(path, f"not valid JSON ({type(exc).__name__}: {exc})") from None
    except OSError as exc:
        raise FormatError(path, f"cannot open: {exc.strerror or exc}") from None
    if not isinstance(data, dict):
        raise FormatError(path, "expected a JSON object with camera fields")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise FormatError(path, f"missing camera field(s) {missing}")
    unknown = sorted(set(data) - set(REQUIRED) - {"k1", "k2"})
    if unknown:
        raise FormatError(path, f"unknown camera field(s) {unknown}")
    not_numbers = [k for k, v in data.items() if isinstance(v, bool) or not isinstance(v, (int, float))]
    if not_numbers:
        raise FormatError(path, f"camera field(s) {not_numbers} must be numbers, got "
                                f"{[data[k] for k in not_numbers]}")
    try:
        return Camera(**data)
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def write_camera(path, camera):
    if not isinstance(camera, Camera):
        raise ParameterTypeError(f"camera must be an evstar.Camera, got {type(camera).__name__}")
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(camera.to_dict(), indent=2) + "\n")
