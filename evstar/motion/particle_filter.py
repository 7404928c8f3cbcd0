"""ParticleFilter: attitude and gyro bias on SO(3) from the gyro and tracked star centroids.

Model (docs/design.md). Each particle holds the attitude q (R_cw) and the gyro bias b (camera
frame; the gyro reads ω + b + noise). Prediction turns each particle by the rate
(ω_meas − b) through the exponential map, block by block between two observation times
(the IMU steps preintegrated once, first order in the bias:
evstar_kernels.reference.particle_filter.block_motions); the gyro noise (density
`gyro_noise`) and the bias's random walk (density `bias_walk`) are drawn once per block,
at its end: the attitude is only looked at there. Each tracked star is a fixed direction in the world frame, set from
its first centroid and the attitude estimate at that moment (so the attitude is relative to
`q0`, the attitude at the first observation time); a particle's weight is the Gaussian
likelihood of the observed centroids (σ = `pixel_sigma`, residuals capped at `gate`·σ).
Systematic resampling runs when the effective sample size falls below
`resample_threshold`·N; the estimate is the weighted, sign-aligned quaternion mean and the
weighted mean bias.

Steps of the timeline are the IMU samples and the observation times merged; random numbers
are keyed by (seed, particle, step), so a run is reproducible for a seed on any device and
the reference (numpy) and Warp CPU backends return identical bits.
"""
from __future__ import annotations

import math

import numpy as np

from evstar_kernels.reference import particle_filter as ref
from evstar_kernels.reference import so3

from ..errors import DataError, ParameterError
from ..imu import Imu
from .imu_integration import AttitudeTrack, check_coverage, interpolate
from .observations import StarObservations
from ..parameters import GLOBAL as G, MOTION as M, PARTICLE_FILTER as PF
from .pf_engines import make_engine

DEG = math.pi / 180.0


class FilterResult:
    """Estimates after each observation time: t_us (M,), q_cw (M, 4), bias (M, 3) rad/s,
    ess (M,), resampled (M,) bool, n_stars (M,) (stars that weighed the particles), and
    stars: track id -> unit world direction."""

    def __init__(self, t_us, q_cw, bias, ess, resampled, n_stars, stars):
        self.t_us = np.asarray(t_us, dtype=np.int64)
        self.q_cw = np.asarray(q_cw, dtype=np.float64).reshape(-1, 4)
        self.bias = np.asarray(bias, dtype=np.float64).reshape(-1, 3)
        self.ess = np.asarray(ess, dtype=np.float64)
        self.resampled = np.asarray(resampled, dtype=bool)
        self.n_stars = np.asarray(n_stars, dtype=np.int64)
        self.stars = stars

    def __len__(self):
        return len(self.t_us)

    def bias_at(self, t_us):
        """Latest bias estimate at or before each time (the first one before the first update)."""
        k = np.searchsorted(self.t_us, np.asarray(t_us), side="right") - 1
        return self.bias[np.clip(k, 0, len(self) - 1)]

    def corrected_imu(self, imu, causal=True):
        """A copy of `imu` with the estimated bias removed from the gyro: at each sample the
        estimate available then (causal) or the final estimate (causal=False, offline)."""
        bias = self.bias_at(imu.t_cam) if causal else np.broadcast_to(self.bias[-1], imu.gyro.shape)
        bias_imu = bias @ imu.R_cam_imu  # camera -> IMU frame: Rᵀ b, row by row
        return Imu(imu.t, imu.gyro - bias_imu, imu.accel, R_cam_imu=imu.R_cam_imu,
                   time_offset_us=imu.time_offset_us)

    def attitude_track(self, imu, causal=True):
        """AttitudeTrack of the bias-corrected gyro, anchored to the first estimate."""
        return AttitudeTrack.from_imu(self.corrected_imu(imu, causal), q0=self.q_cw[0],
                                      t0_us=self.t_us[0])

    def __repr__(self):
        return f"FilterResult(n={len(self)}, resampled {int(self.resampled.sum())} times)"


class ParticleFilter:
    """Particle filter on SO(3) correcting gyro bias and noise with star centroids.

    n_particles: number of particles. seed: random seed (int, 0 .. 2³²−1).
    device: 'cpu' | 'cuda' | 'cuda:N'; backend: 'warp' (kernels) | 'reference' (numpy, CPU).
    gyro_noise: gyro white-noise density, rad/s/√Hz. bias_walk: bias random-walk density,
    rad/s/√s. bias_prior: initial bias spread (std per axis), rad/s. attitude_prior: initial
    attitude spread (std per axis), rad (0: the attitude at the first observation is q0 by
    definition). pixel_sigma: centroid noise, px. gate: residual cap in sigmas.
    resample_threshold: resample when ESS < resample_threshold·N.
    star_refine: a star's world direction is the mean of its first `star_refine` centroids
    rotated back by the estimate at their times (used from the first one on, then fixed;
    refined only while >= 3 stars are observed together), so one centroid's noise does
    not become a fixed offset for the star's whole track (a bias the weakly observed roll
    axis is most sensitive to); 1 uses the first centroid.
    The noise settings are the filter's model; set them somewhat above the sensor's values
    to keep the particle cloud diverse. bias_walk defaults to 0.02 °/s/√s: on extracted
    centroids (whose errors are correlated in time) 0.05 let the weakly observed roll bias
    wander more (perf/paper_fig8_motion.py).
    """

    def __init__(self, n_particles=M["n_particles"].default, *, seed=G["seed"].default,
                 device="cpu", backend=PF["backend"].default, gyro_noise=PF["gyro_noise"].default,
                 bias_walk=PF["bias_walk"].default, bias_prior=0.5 * DEG,
                 attitude_prior=PF["attitude_prior"].default, pixel_sigma=PF["pixel_sigma"].default,
                 gate=PF["gate"].default, resample_threshold=PF["resample_threshold"].default,
                 star_refine=PF["star_refine"].default):
        self.n_particles, self.seed = M.check("n_particles", n_particles), G.check("seed", seed)
        self.device, self.backend = G.check("device", device), PF.check("backend", backend)
        self.gyro_noise = PF.check("gyro_noise", gyro_noise)
        self.bias_walk = PF.check("bias_walk", bias_walk)
        bp = np.broadcast_to(np.asarray(bias_prior, dtype=np.float64), (3,))
        if not np.all(np.isfinite(bp) & (bp >= 0)):
            raise ParameterError("bias_prior must be finite and >= 0 (scalar or 3 values), "
                                 f"got {bias_prior!r}")
        self.bias_prior = bp.copy()
        self.attitude_prior = float(PF.check("attitude_prior", attitude_prior))
        self.pixel_sigma = float(PF.check("pixel_sigma", pixel_sigma))
        self.gate = float(PF.check("gate", gate))
        self.resample_threshold = float(PF.check("resample_threshold", resample_threshold))
        self.star_refine = PF.check("star_refine", star_refine)

    # -- public ---------------------------------------------------------------------------------
    def run(self, imu, observations, camera, *, q0=None, b0=None, t_start_us=None, t_stop_us=None):
        """Filter from t_start_us (default: first observation) to t_stop_us (default: last).

        imu: evstar.Imu (must cover that span); observations: StarObservations or anything
        StarObservations.from_any accepts; camera: evstar.Camera; q0: attitude at t_start
        (default identity); b0: initial bias guess (rad/s, camera frame; default 0).
        Returns a FilterResult with one row per observation time.
        """
        obs = StarObservations.from_any(observations)
        if not len(obs):
            raise DataError("the particle filter needs at least one star observation")
        t0 = int(obs.t_us[0] if t_start_us is None else t_start_us)
        t1 = int(obs.t_us[-1] if t_stop_us is None else t_stop_us)
        if t1 < t0:
            raise DataError(f"t_stop_us ({t1}) precedes t_start_us ({t0})")
        check_coverage(imu, t0, t1, what="the observations")
        keep = (obs.t_us >= t0) & (obs.t_us <= t1)
        if not keep.any():
            raise DataError(f"no star observation lies within {t0}..{t1} µs")
        obs = StarObservations(obs.t_us[keep], obs.track[keep], obs.x[keep], obs.y[keep])
        grid, omega, dt = _timeline(imu, obs.t_us, t0, t1)
        q0 = so3.quat_identity() if q0 is None else so3.quat_normalize(np.asarray(q0, np.float64))
        engine = make_engine(self.backend, self.device, *self._initial_particles(q0, b0))
        uv = _pinhole_pixels(camera, obs.x, obs.y)
        return self._filter(engine, obs, uv, grid, omega, dt, q0, camera)

    # -- steps ----------------------------------------------------------------------------------
    def _initial_particles(self, q0, b0):
        n = self.n_particles
        b0 = np.zeros(3) if b0 is None else np.broadcast_to(np.asarray(b0, np.float64), (3,))
        b = b0 + self.bias_prior * ref.counter_normals(self.seed, n, 0, ref.INIT_BIAS)
        q = np.tile(q0, (n, 1))
        if self.attitude_prior > 0:
            delta = self.attitude_prior * ref.counter_normals(self.seed, n, 0, ref.INIT_ATTITUDE)
            q = so3.quat_normalize(so3.quat_mul(so3.quat_exp(delta), q))
        return q, b

    def _filter(self, engine, obs, uv, grid, omega, dt, q_est, camera):
        stars, seen = {}, {}  # track -> world direction, centroids averaged into it
        rows = []
        groups = list(obs.groups())
        ends = np.searchsorted(grid, [t for t, _ in groups])   # block g: IMU steps
        starts = np.r_[0, ends[:-1]]                             # starts[g] .. ends[g] - 1
        motions = zip(*ref.block_motions(omega, dt, starts, ends))
        pinhole = dict(fx=camera.fx, fy=camera.fy, cx=camera.cx, cy=camera.cy,
                       pixel_sigma=self.pixel_sigma, gate=self.gate)
        for g, ((t, sl), motion) in enumerate(zip(groups, motions)):
            if ends[g] > starts[g]:
                engine.predict(*motion, gyro_noise=self.gyro_noise, bias_walk=self.bias_walk,
                               seed=self.seed, step=int(ends[g]) - 1)
            tracks, uv_g = obs.track[sl], uv[sl]
            known = np.array([k in stars for k in tracks.tolist()], dtype=bool)
            if known.any():
                dirs = np.stack([stars[k] for k in tracks[known].tolist()])
                engine.add_log_likelihood(dirs, uv_g[known], **pinhole)
            q_est, b_est, ess = ref.estimate_from_sums(engine.weight_sums(q_est))
            resampled = ess < self.resample_threshold * self.n_particles
            if resampled:
                engine.resample(ref.resample_offset(self.seed, g))
            self._refine_stars(stars, seen, tracks, uv_g, q_est, camera)
            rows.append((t, q_est, b_est, ess, resampled, int(known.sum())))
        t, q, b, ess, res, n = zip(*rows)
        return FilterResult(t, np.stack(q), np.stack(b), ess, res, n, stars)

    def _refine_stars(self, stars, seen, tracks, uv_pinhole, q_est, camera):
        """New stars get the direction of their centroid under the estimate; the first
        star_refine centroids of a star are averaged into its direction while at least two
        other stars hold the estimate (alone, a star would absorb the drift of a bias not
        yet learned: measured, 0.15 -> 0.59 px of attitude error with one star)."""
        limit = self.star_refine if len(tracks) >= 3 else 1
        young = np.array([seen.get(k, 0) < limit for k in tracks.tolist()], dtype=bool)
        if not young.any():
            return
        dirs = so3.quat_rotate(so3.quat_conj(q_est), _rays(camera, uv_pinhole[young]))
        for k, d in zip(tracks[young].tolist(), dirs):
            n = seen[k] = seen.get(k, 0) + 1
            m = d if n == 1 else stars[k] + (d - stars[k]) / n
            stars[k] = m / np.linalg.norm(m)


def _timeline(imu, t_obs, t0, t1):
    """Merged step grid (IMU samples and observation times in [t0, t1]) with the mean rate
    (camera frame, rad/s) and length (s) of each step."""
    t_imu = imu.t_cam
    inner = t_imu[(t_imu > t0) & (t_imu < t1)]
    grid = np.unique(np.concatenate([[t0, t1], inner, t_obs]).astype(np.int64))
    mids = 0.5 * (grid[1:] + grid[:-1]).astype(np.float64)
    omega, _ = interpolate(imu, mids)  # the rate is linear between samples: midpoint = mean
    return grid, omega, np.diff(grid).astype(np.float64) * 1e-6


def _pinhole_pixels(camera, x, y):
    """Centroids with lens distortion removed (pinhole pixels), (N, 2)."""
    uv = np.stack([x, y], 1).astype(np.float64)
    if not camera.has_distortion:
        return uv
    r = camera.unproject(uv)
    return np.stack([camera.fx * r[:, 0] / r[:, 2] + camera.cx,
                     camera.fy * r[:, 1] / r[:, 2] + camera.cy], 1)


def _rays(camera, uv_pinhole):
    r = np.stack([(uv_pinhole[:, 0] - camera.cx) / camera.fx,
                  (uv_pinhole[:, 1] - camera.cy) / camera.fy, np.ones(len(uv_pinhole))], 1)
    return r / np.linalg.norm(r, axis=1, keepdims=True)
