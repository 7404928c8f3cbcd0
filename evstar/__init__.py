"""evstar: event-camera processing for weak, fast-moving space targets.

Importing evstar is cheap: Taichi and Warp start only when a kernel is first used.
"""
import os
from importlib import import_module

# Taichi prints a banner on stdout when imported; evstar's stdout is for results
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")

from .camera import Camera
from .errors import (BackendError, DataError, EvstarError, EvstarWarning, FormatError, OutputError,
                     ParameterError, ParameterTypeError)
from .events import Events
from .imu import Imu
from .recording import Recording
from .config import Config

__version__ = "0.1.0"
_SUBMODULES = {"io", "sim", "denoise", "extract", "tracking", "motion", "metrics", "accuracy",
               "pipeline", "backends", "report", "profiling", "interop", "attitude", "runs",
               "batch", "calibration"}

__all__ = ["Camera", "Config", "Pipeline", "Events", "Imu", "Recording", "EvstarError", "DataError",
           "FormatError", "BackendError", "EvstarWarning", "OutputError", "ParameterError",
           "ParameterTypeError", *_SUBMODULES]


def __getattr__(name):
    if name == "Pipeline":
        from .pipeline import Pipeline
        return Pipeline
    if name in _SUBMODULES:
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module 'evstar' has no attribute {name!r}")
