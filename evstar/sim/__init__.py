"""Ground-based simulation: star targets, turntable motion, event sensor, IMU, ground truth."""
