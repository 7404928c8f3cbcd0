"""Motion compensation: IMU integration on SO(3), event warping, particle-filter bias correction."""
