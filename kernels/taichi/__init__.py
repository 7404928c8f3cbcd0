"""Taichi kernels: per-frame cell grids and bit tiles (binning, prefix sums, multi-radius
counts) and the classical filter; their host side in the *_launch.py modules."""
