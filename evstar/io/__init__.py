"""Readers and writers of event, IMU and camera files."""
