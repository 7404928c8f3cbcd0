"""Launch logic of the SO(3) particle filter: device arrays, buffers and kernel launches.

`WarpParticles` holds the particle arrays on one Warp device; each method is one step of the
filter and launches the kernels of particle_kernels.py. On the CPU the weight sums run in
index order on one thread (bit-identical to the numpy reference); on a GPU they use atomics
and a parallel scan (equal to rounding). A Warp CPU launch runs on one thread, so on the
CPU the prediction (a block of IMU steps per particle: the filter's bulk) is launched over
`threads` ranges of the particles at once from a thread pool (the launch releases the GIL);
each particle's arithmetic is the same, so the bits are too. The likelihood launch is
split the same way once a frame holds >= _SPLIT_STARS stars (with fewer it is too short:
a thread hand-off costs about as much as it).
"""
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from . import particle_kernels as K

_POOLS = {}  # thread count -> ThreadPoolExecutor (shared by all filters of the process)
#: stars of a likelihood launch from which it runs over particle ranges on the CPU threads
#: (4096 particles x 16 stars ~ 0.2 ms: a thread hand-off costs ~0.05 ms)
_SPLIT_STARS = 16


def _pool(k):
    if k not in _POOLS:
        _POOLS[k] = ThreadPoolExecutor(k, thread_name_prefix="evstar-particles")
    return _POOLS[k]


class _Replay:
    """One kernel's launch recorded once and replayed with only the changed arguments reset:
    wp.launch packs every argument anew (~30 us of Python, holding the GIL, ~5 launches a
    frame); a replay costs ~4 us plus ~1.5 us an argument that changed (per-frame arrays and
    numbers; the particle arrays and constants stay)."""

    def __init__(self, kernel, device):
        self.kernel, self.device, self.cmd, self.args, self.dim = kernel, device, None, [], None

    def __call__(self, dim, inputs):
        if self.cmd is None:
            self.cmd = wp.launch(self.kernel, dim, device=self.device, inputs=inputs,
                                 record_cmd=True)
        else:
            if dim != self.dim:
                self.cmd.set_dim(dim)
            for i, (new, old) in enumerate(zip(inputs, self.args)):
                if new is not old and not (type(new) in (int, float) and new == old):
                    self.cmd.set_param_at_index(i, new)
        self.dim, self.args = dim, list(inputs)
        self.cmd.launch()


class WarpParticles:
    """Particles q (N, 4) and b (N, 3) with their log-weights on a Warp device."""

    def __init__(self, q, b, device="cpu", sequential=None, threads=1):
        """sequential: weight sums on one thread in index order (default: on the CPU only);
        threads: CPU threads of the per-particle kernels (1 on a GPU)."""
        q, b = np.asarray(q, np.float64), np.asarray(b, np.float64)
        self.n = len(q)
        self.device = device
        self.q = wp.array(q, dtype=wp.vec4d, device=device)
        self.b = wp.array(b, dtype=wp.vec3d, device=device)
        self.logw = wp.zeros(self.n, dtype=wp.float64, device=device)
        self._q2 = wp.empty_like(self.q)
        self._b2 = wp.empty_like(self.b)
        self.cdf = wp.zeros(self.n, dtype=wp.float64, device=device)
        self.parent = wp.zeros(self.n, dtype=wp.int32, device=device)
        self._sums = wp.zeros(9, dtype=wp.float64, device=device)
        self._w = wp.zeros(self.n, dtype=wp.float64, device=device)
        self._max = wp.zeros(1, dtype=wp.float64, device=device)
        is_cpu = self._is_cpu = wp.get_device(device).is_cpu
        self._sequential = is_cpu if sequential is None else bool(sequential)
        # particle ranges of one launch each: >= 256 particles a range
        k = max(1, min(int(threads), self.n // 256)) if is_cpu else 1
        self._ranges = [(self.n * j // k, self.n * (j + 1) // k) for j in range(k)]
        if k > 1:  # compiled and loaded here, not by two launches at once
            wp.load_module(K, device=device)
        self._replays = {}   # (kernel, first particle) -> _Replay

    def _run(self, kernel, dim, inputs, first=None):
        """Launch kernel (dim threads) by its replay for this particle range (`first`)."""
        key = (kernel.key, first)
        if key not in self._replays:
            self._replays[key] = _Replay(kernel, self.device)
        self._replays[key](dim, inputs if first is None else inputs + [first])

    def _launch(self, kernel, inputs):
        """kernel over every particle: inputs + [first particle], one launch per range (the
        last on this thread, which so works while the pool's threads wake up)."""
        def one(r):
            self._run(kernel, r[1] - r[0], inputs, r[0])
        others = [_pool(len(self._ranges) - 1).submit(one, r) for r in self._ranges[:-1]]
        one(self._ranges[-1])
        for f in others:
            f.result()

    def _view(self, a, dtype):
        """Host data as a Warp array: on the CPU a view of the numpy memory (a CPU launch
        returns when done, so no copy is needed: ~25 us each, 4 a frame), else a copy."""
        a = np.ascontiguousarray(a, np.float64)
        return wp.array(a, dtype=dtype, device=self.device, copy=not self._is_cpu)

    # -- prediction --------------------------------------------------------------------------
    def predict(self, rotation, bias_jacobian, duration, *, gyro_noise, bias_walk, seed, step,
                gyro_normals=None, walk_normals=None):
        """One prediction block (see reference.particle_filter.predict), one launch."""
        motion = [wp.vec4d(*np.asarray(rotation, np.float64)),
                  wp.mat33d(*np.asarray(bias_jacobian, np.float64).ravel())]
        span = np.sqrt(duration)
        sigmas = [float(gyro_noise * span), float(bias_walk * span)]
        if gyro_normals is None:
            self._launch(K.predict_counter,
                         [self.q, self.b, *motion, wp.uint32(seed & 0xFFFFFFFF),
                          wp.uint32(step & 0xFFFFFFFF), *sigmas])
        else:
            wp.launch(K.predict_given, self.n, device=self.device,
                      inputs=[self.q, self.b, *motion, self._view(gyro_normals, wp.vec3d),
                              self._view(walk_normals, wp.vec3d), *sigmas])

    def normals(self, seed, step, component0, count=3):
        """The counter-based normals the kernels draw, (N, count) on the host (for checks)."""
        out = wp.zeros((self.n, count), dtype=wp.float64, device=self.device)
        wp.launch(K.counter_normals, (self.n, count), device=self.device,
                  inputs=[wp.uint32(seed), wp.uint32(step), wp.uint32(component0), out])
        return out.numpy()

    # -- update ------------------------------------------------------------------------------
    def add_log_likelihood(self, stars_world, uv, *, fx, fy, cx, cy, pixel_sigma, gate):
        stars, uv_d = self._view(stars_world, wp.vec3d), self._view(uv, wp.vec2d)
        inputs = [self.q, stars, uv_d, float(fx), float(fy), float(cx), float(cy),
                  1.0 / pixel_sigma, float(gate) * float(gate), self.logw]
        if len(stars_world) >= _SPLIT_STARS:     # long enough to share between threads
            self._launch(K.add_log_likelihood, inputs)
        else:
            self._run(K.add_log_likelihood, self.n, inputs, 0)

    def weight_sums(self, q_ref):
        """Fill self.cdf and return the nine sums of reference.particle_filter.weight_sums."""
        q_ref = wp.vec4d(*np.asarray(q_ref, np.float64))
        if self._sequential:
            self._run(K.weight_sums_sequential, 1,
                      [self.logw, self.q, self.b, q_ref, self.cdf, self._sums])
        else:
            self._max.fill_(-np.inf)
            self._sums.zero_()
            wp.launch(K.log_weight_max, self.n, device=self.device, inputs=[self.logw, self._max])
            wp.launch(K.weight_terms, self.n, device=self.device,
                      inputs=[self.logw, self.q, self.b, q_ref, self._max, self._w, self._sums])
            wp.utils.array_scan(self._w, self.cdf, inclusive=True)
        return self._sums.numpy()

    def resample(self, u0):
        """Systematic resampling from self.cdf (call weight_sums first); resets the weights."""
        count = self.n if self._is_cpu else 1   # CPU: one thread walks the cdf once
        self._run(K.systematic_resample, (self.n + count - 1) // count,
                  [self.cdf, float(u0), self.q, self.b, self._q2, self._b2, self.parent, count])
        self.q, self._q2 = self._q2, self.q
        self.b, self._b2 = self._b2, self.b
        self.logw.zero_()

    # -- host views --------------------------------------------------------------------------
    def host(self):
        """(q, b, logw) copied to numpy."""
        return self.q.numpy(), self.b.numpy(), self.logw.numpy()
