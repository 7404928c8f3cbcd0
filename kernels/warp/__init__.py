"""NVIDIA Warp kernels for particles on SO(3)."""
