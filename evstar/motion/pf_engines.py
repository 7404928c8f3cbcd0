"""Particle-filter engines: the same particle operations on numpy (reference) or Warp.

Both expose predict / add_log_likelihood / weight_sums / resample / host, so the filter's
policy (evstar.motion.particle_filter) is written once; on the CPU they give identical bits.
"""
from __future__ import annotations

import numpy as np

from evstar_kernels.reference import particle_filter as ref

from ..errors import ParameterError
from .. import backends
from ..parameters import PARTICLE_FILTER

BACKENDS = PARTICLE_FILTER["backend"].choices


class ReferenceParticles:
    """Numpy particles with the interface of evstar_kernels.warp.particle_launch.WarpParticles."""

    def __init__(self, q, b):
        self.q = np.array(q, dtype=np.float64)
        self.b = np.array(b, dtype=np.float64)
        self.n = len(self.q)
        self.logw = np.zeros(self.n)
        self.cdf = None
        self.parent = np.arange(self.n)

    def predict(self, rotation, bias_jacobian, duration, *, gyro_noise, bias_walk, seed, step,
                gyro_normals=None, walk_normals=None):
        self.q, self.b = ref.predict(self.q, self.b, rotation, bias_jacobian, duration,
                                     gyro_noise=gyro_noise, bias_walk=bias_walk, seed=seed,
                                     step=step, gyro_normals=gyro_normals,
                                     walk_normals=walk_normals)

    def normals(self, seed, step, component0, count=3):
        return ref.counter_normals(seed, self.n, step, component0, count)

    def add_log_likelihood(self, stars_world, uv, **camera_and_noise):
        self.logw = self.logw + ref.log_likelihood(self.q, stars_world, uv, **camera_and_noise)

    def weight_sums(self, q_ref):
        self.cdf, sums = ref.weight_sums(self.logw, self.q, self.b, q_ref)
        return sums

    def resample(self, u0):
        self.parent = ref.systematic_resample(self.cdf, u0)
        self.q, self.b = self.q[self.parent], self.b[self.parent]
        self.logw = np.zeros(self.n)

    def host(self):
        return self.q.copy(), self.b.copy(), self.logw.copy()


def make_engine(backend, device, q, b):
    """Particles on `backend` ('warp' | 'reference'); the reference runs on the CPU only."""
    if backend == "reference":
        if backends.check_device(device) != "cpu":
            raise ParameterError(f"backend='reference' runs on the CPU only, got device={device!r}")
        return ReferenceParticles(q, b)
    if backend == "warp":
        _, dev = backends.warp(device)
        from evstar_kernels.warp.particle_launch import WarpParticles
        return WarpParticles(q, b, device=dev, threads=backends.cpu_threads())
    raise ParameterError(f"backend must be one of {BACKENDS}, got {backend!r}")
