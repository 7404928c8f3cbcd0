"""Motion compensation: IMU integration on SO(3), event warping, particle-filter bias correction.

    comp = evstar.motion.compensate(events, imu, camera, dt_us=10_000, mode="imu")
    comp.x, comp.y        # float warped coordinates (centroids)
    comp.events()         # rounded, on-sensor events for the filters (+ their indices)

    pf = evstar.motion.ParticleFilter(n_particles=4096, seed=0, device="cpu")
    result = pf.run(imu, observations, camera)   # observations: t, track, x, y centroids
    result.bias, result.q_cw, result.corrected_imu(imu)
"""
from .compensate import MODES, Compensation, compensate
from .imu_integration import (AttitudeTrack, Kinematics, check_coverage, hold_ends, integrate_accel,
                              interpolate)
from .observations import StarObservations
from .particle_filter import FilterResult, ParticleFilter
from .warping import frame_reference_times, rotate_pixels, warp_to_reference

__all__ = ["MODES", "Compensation", "compensate", "AttitudeTrack", "Kinematics", "check_coverage",
           "hold_ends", "integrate_accel", "interpolate", "StarObservations", "FilterResult", "ParticleFilter",
           "frame_reference_times", "rotate_pixels", "warp_to_reference"]
