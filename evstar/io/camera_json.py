"""Camera JSON {"width","height","fx","fy","cx","cy"} (+ optional "k1","k2")."""
from __future__ import annotations

import json

from ..camera import Camera
from ..errors import DataError, FormatError
from .atomic import atomic_path

REQUIRED = ("width", "height", "fx", "fy", "cx", "cy")


def read_camera(path):
    try:
        with open(path) as f:
            data = json.load(f)
    except FileNotFoundError:
        raise FormatError(path, "no such file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise FormatError(path, f"not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise FormatError(path, "expected a JSON object with camera fields")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise FormatError(path, f"missing camera field(s) {missing}")
    unknown = sorted(set(data) - set(REQUIRED) - {"k1", "k2"})
    if unknown:
        raise FormatError(path, f"unknown camera field(s) {unknown}")
    try:
        return Camera(**data)
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def write_camera(path, camera):
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(camera.to_dict(), indent=2) + "\n")
