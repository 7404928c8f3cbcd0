"""Taichi kernels: per-frame cell grids and bit tiles (binning, prefix sums, multi-radius
counts) and the classical filter; their host side in the *_launch.py modules."""
from . import quick_decorate  # noqa: F401 (imports Taichi: before any module here does)
