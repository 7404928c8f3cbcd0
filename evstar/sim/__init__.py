"""Ground-based simulation: star targets, turntable motion, event sensor, IMU, ground truth.

    from evstar import sim
    run = sim.simulate(sim.paper_preset(12.0), seed=1)   # magnitude-3 star at 12 °/s
    run.events, run.imu, run.camera, run.truth.labels

Modules: targets (stars, Hipparcos fields), presets (camera sensors, sensor models, the paper's runs, star-field pans and sinusoids),
motion (trajectories), psf, sensor (change detection), noise (background, hot pixels),
imu_model, truth (labels, attitude, star positions; truth.npz), scene (Scenario), simulate.
"""
from .imu_model import ImuSpec
from .motion import (ConstantRate, FunctionTrajectory, Jitter, SampledTrajectory, Sinusoid, Slew, Trajectory,
                     attitude_from_radec, random_pointing)
from .presets import (PAPER_RATES_DPS, SENSOR_MODELS, SENSORS, camera_preset, field_scenario,
                      paper_preset, paper_sinusoid, sensor_model, sensor_preset)
from .scene import Scenario
from .sensor import SensorSpec
from .simulate import Simulation, simulate
from .targets import (FLUX_MAG3, StarField, hipparcos_field, hipparcos_field_along, single_star,
                      star_at_pixel, star_flux)
from .truth import HOT_PIXEL, NOISE, Truth, load_truth, save_truth

__all__ = ["ImuSpec", "ConstantRate", "FunctionTrajectory", "Jitter", "SampledTrajectory", "Sinusoid", "Slew",
           "Trajectory", "attitude_from_radec", "random_pointing", "PAPER_RATES_DPS", "SENSOR_MODELS", "SENSORS",
           "camera_preset", "field_scenario", "paper_preset", "paper_sinusoid", "sensor_model", "sensor_preset",
           "Scenario", "SensorSpec", "Simulation", "simulate", "FLUX_MAG3", "StarField", "hipparcos_field",
           "hipparcos_field_along", "single_star", "star_at_pixel", "star_flux", "HOT_PIXEL", "NOISE",
           "Truth", "load_truth", "save_truth"]
