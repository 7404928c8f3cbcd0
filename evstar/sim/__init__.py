"""Ground-based simulation: star targets, turntable motion, event sensor, IMU, ground truth.

    from evstar import sim
    run = sim.simulate(sim.paper_preset(12.0), seed=1)   # magnitude-3 star at 12 °/s
    run.events, run.imu, run.camera, run.truth.labels

Modules: targets (stars, Hipparcos fields), presets (camera sensors, sensor models, the paper's runs),
motion (trajectories), psf, sensor (change detection), noise (background, hot pixels),
imu_model, truth (labels, attitude, star positions; truth.npz), scene (Scenario), simulate.
"""
from importlib import import_module

# name -> the module of this package that defines it
_EXPORTS = {
    "ImuSpec": "imu_model",
    "ConstantRate": "motion",
    "FunctionTrajectory": "motion",
    "SampledTrajectory": "motion",
    "Sinusoid": "motion",
    "Trajectory": "motion",
    "attitude_from_radec": "motion",
    "PAPER_RATES_DPS": "presets",
    "SENSOR_MODELS": "presets",
    "SENSORS": "presets",
    "camera_preset": "presets",
    "paper_preset": "presets",
    "paper_sinusoid": "presets",
    "sensor_model": "presets",
    "sensor_preset": "presets",
    "Scenario": "scene",
    "SensorSpec": "sensor",
    "Simulation": "simulate",
    "simulate": "simulate",
    "FLUX_MAG3": "targets",
    "StarField": "targets",
    "hipparcos_field": "targets",
    "hipparcos_field_along": "targets",
    "single_star": "targets",
    "star_at_pixel": "targets",
    "star_flux": "targets",
    "HOT_PIXEL": "truth",
    "NOISE": "truth",
    "Truth": "truth",
    "load_truth": "truth",
    "save_truth": "truth",
}
__all__ = list(_EXPORTS)


def __getattr__(name):
    # lazy: `import evstar.sim` (and the CLI's option tables) must not import scipy
    if name in _EXPORTS:
        return getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module 'evstar.sim' has no attribute {name!r}")
