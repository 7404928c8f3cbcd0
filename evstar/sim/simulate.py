"""simulate(scenario, seed): events, IMU, camera and ground truth of one run.

Every random component draws from its own stream spawned from the seed (pixel thresholds,
signal jitter, hot pixels, background, dropout, IMU, shot noise), so a run is reproducible
and changing one setting does not reshuffle the others' randomness.

Events are time-sorted (ties by pixel); star events (and shot noise) come from
:mod:`.sensor`, noise, leak and hot pixels from :mod:`.noise`, which do not interact with
the star's pixels (at Hz rates the overlap is negligible). Timestamps are whole microseconds
from `t_start_us`.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..camera import Camera
from ..events import Events
from ..imu import Imu
from .imu_model import simulate_imu
from .noise import background_activity, hot_pixels, leak_events
from .render import time_grid
from .scene import Scenario
from .sensor import PixelState, merge_sorted, star_events
from .truth import HOT_PIXEL, NOISE, Truth
from ..errors import ParameterError


@dataclass(eq=False)
class Simulation:
    events: Events
    imu: Imu
    camera: Camera
    truth: Truth
    scenario: Scenario
    seed: int

    def __repr__(self):
        return f"Simulation({self.events!r}, {self.imu!r}, {self.truth!r}, seed={self.seed})"


def _to_us(t_s, t_start_us, t_end_us):
    t = t_start_us + np.floor(t_s * 1e6).astype(np.int64)
    return np.minimum(t, t_end_us - 1)


def _signal(scn, state, flux, grid, t_end_us, rng, rng_shot):
    t_s, pix, pol, star = star_events(scn.camera, scn.stars, flux, scn.trajectory, grid,
                                      scn.sensor, scn.psf_sigma_px, state, rng=rng_shot)
    if scn.sensor.jitter_us > 0:
        t_s = t_s + rng.standard_normal(len(t_s)) * (scn.sensor.jitter_us * 1e-6)
    keep = (t_s >= 0) & (t_s < scn.duration_s)
    t_s, pix, pol, star = t_s[keep], pix[keep], pol[keep], star[keep]
    t = _to_us(t_s, scn.t_start_us, t_end_us)
    # by time, then pixel: an order that does not depend on how the events were produced
    order = np.argsort(t * (scn.camera.width * scn.camera.height) + pix, kind="stable")
    return t[order], pix[order], pol[order], star[order].astype(np.int32)


def _truth_tables(scn):
    n = int(math.ceil(scn.duration_s * scn.truth_rate_hz)) + 1
    t_us = scn.t_start_us + np.rint(np.arange(n) * (1e6 / scn.truth_rate_hz)).astype(np.int64)
    t_s = (t_us - scn.t_start_us) * 1e-6
    R = scn.trajectory.rotation(t_s)
    cam = np.matmul(scn.stars.directions[None], R.transpose(0, 2, 1))   # (n, stars, 3)
    xy = scn.camera.project(cam.reshape(-1, 3)).reshape(n, -1, 2) if len(scn.stars) else np.zeros((n, 0, 2))
    xy[cam[..., 2] <= 0] = np.nan
    return t_us, Rotation.from_matrix(R).as_quat(), scn.trajectory.omega(t_s), xy


def simulate(scenario, seed=0):
    """Run `scenario` with `seed`: a :class:`Simulation` with .events, .imu, .camera, .truth."""
    if not isinstance(scenario, Scenario):
        raise ParameterError(f"scenario must be an evstar.sim.Scenario, got {type(scenario).__name__}")
    if int(seed) != seed or seed < 0:
        raise ParameterError(f"seed must be a non-negative integer, got {seed!r}")
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(7)]
    events, labels, hot_where, grid = _events(scenario, *rngs[:5], rngs[6])
    imu, gyro_bias, accel_bias = simulate_imu(scenario.trajectory, scenario.imu, scenario.duration_s,
                                              scenario.t_start_us, rngs[5])
    t_us, quat, omega, xy = _truth_tables(scenario)
    scn = scenario
    truth = Truth(labels=labels, stars=scn.stars, star_flux=scn.stars.flux(scn.flux_mag3),
                  t_us=t_us, quat_cw=quat, omega_cam=omega, star_xy=xy, camera=scn.camera,
                  hot_pixels=hot_where.astype(np.int64), imu_t_us=imu.t, gyro_bias=gyro_bias,
                  accel_bias=accel_bias, R_cam_imu=imu.R_cam_imu, imu_time_offset_us=imu.time_offset_us,
                  meta=dict(seed=int(seed), trajectory=repr(scn.trajectory), duration_s=scn.duration_s,
                            psf_sigma_px=scn.psf_sigma_px, flux_mag3=scn.flux_mag3, step_px=scn.grid_step_px,
                            grid_steps=len(grid) - 1, sensor=asdict(scn.sensor),
                            t_start_us=int(scn.t_start_us)))
    return Simulation(events, imu, scn.camera, truth, scn, int(seed))


def _events(scn, rng_thr, rng_sig, rng_hot, rng_bg, rng_drop, rng_shot):
    """All events, time-sorted, with their labels; the hot pixels; the simulation grid."""
    spec, cam = scn.sensor, scn.camera
    n_pix = cam.width * cam.height
    t_end_us = scn.t_start_us + int(round(scn.duration_s * 1e6))
    grid = time_grid(scn.trajectory, cam, scn.duration_s, scn.grid_step_px)
    state = PixelState(n_pix, spec, rng_thr)
    leak = leak_events(state.ref, state.c_on, state.c_off, spec.leak_hz, spec.threshold_on,
                       scn.duration_s)
    signal = _signal(scn, state, scn.stars.flux(scn.flux_mag3), grid, t_end_us, rng_sig, rng_shot)
    if len(leak[0]):
        signal = merge_sorted(signal, (_to_us(leak[0], scn.t_start_us, t_end_us), leak[1], leak[2],
                                 np.full(len(leak[0]), NOISE, np.int32)))
    t_hot, pix_hot, pol_hot, hot_where = hot_pixels(rng_hot, n_pix, spec.hot_pixels, spec.hot_pixel_hz,
                                                    scn.duration_s, spec.refractory_us * 1e-6)
    hot = (_to_us(t_hot, scn.t_start_us, t_end_us), pix_hot, pol_hot, np.full(len(t_hot), HOT_PIXEL, np.int32))
    t_bg, pix_bg, pol_bg = background_activity(rng_bg, n_pix, spec.noise_hz, scn.duration_s,
                                               spec.noise_on_fraction, spec.noise_growth)
    bg = (_to_us(t_bg, scn.t_start_us, t_end_us), pix_bg, pol_bg, np.full(len(t_bg), NOISE, np.int32))
    t, pix, pol, labels = merge_sorted(bg, merge_sorted(signal, hot))
    if spec.dropout > 0:
        keep = rng_drop.random(len(t)) >= spec.dropout
        t, pix, pol, labels = t[keep], pix[keep], pol[keep], labels[keep]
    x, y = (pix % cam.width).astype(np.uint16), (pix // cam.width).astype(np.uint16)
    events = Events._trusted(t, x, y, pol.astype(np.int8), cam.width, cam.height)
    return events, np.ascontiguousarray(labels, np.int32), hot_where, grid
