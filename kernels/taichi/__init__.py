"""Taichi kernels for dense per-frame grids (binning, prefix sums, multi-radius counts)."""
