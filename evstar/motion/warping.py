"""Event warping: move each event to its pseudo-frame's reference time through
u' = π(K · R(t_ref ← t) · K⁻¹ ũ), with float (sub-pixel) output.

Frames follow docs/design.md: frame k holds t in [t0 + k·dt, t0 + (k+1)·dt); its reference time
is the frame's mid-time t0 + (k + ½)·dt (``reference="mid"``) or its start
(``reference="start"``). Stars are at infinity, so only rotation moves them; lens
distortion, when the camera has some, is removed before the rotation and applied after.
Backends: 'reference' (numpy, vectorised: the specification), 'taichi' (a parallel loop: every
CPU core, or CUDA) and 'warp' (one kernel launch: one CPU thread, or CUDA).
"""
from __future__ import annotations

import numpy as np

from evstar_kernels.reference import so3
from evstar_kernels.reference.pixels import rounded_pixels

from ..errors import ParameterError
from .. import backends, parameters as P
from ..frames import frame_offsets

REFERENCES = ("mid", "start")
WARP_BACKENDS = P.WARP_BACKENDS
_CHUNK = 1 << 20  # events per vectorised numpy pass: bounds the temporaries to ~100 MB
#: fixed-point steps of the distortion's inversion (Camera.unproject's iterations): 10 are
#: 5e-5 px off at a 346x260 sensor's corners behind fx 300 px, k1 -0.3, k2 0.1 (5: 0.03 px)
_UNDISTORT_ITERATIONS = 10


def frame_reference_times(t_us, dt_us, t0_us=None, reference="mid", *, frame=None):
    """(frame index int64, reference time float64 µs) of each timestamp (of each `frame`
    when given: frame indices from t0_us)."""
    if int(dt_us) != dt_us or dt_us <= 0:
        raise ParameterError(f"dt_us must be a positive integer number of µs, got {dt_us!r}")
    if reference not in REFERENCES:
        raise ParameterError(f"reference must be one of {REFERENCES}, got {reference!r}")
    t = np.asarray(t_us, dtype=np.int64)
    t0 = (int(t[0]) if len(t) else 0) if t0_us is None else int(t0_us)
    if frame is None:
        frame = (t - t0) // int(dt_us)
    t_ref = t0 + frame.astype(np.float64) * dt_us + (0.5 * dt_us if reference == "mid" else 0.0)
    return frame, t_ref


def rotate_pixels(x, y, q_rel, camera):
    """Pixels (x, y) seen along rays r move to π(R(q_rel)·r): float arrays (N,) x2; NaN where
    the rotation turns the ray behind the camera."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if camera.has_distortion:
        rays = camera.unproject(np.stack([x, y], 1), iterations=_UNDISTORT_ITERATIONS)
    else:
        rays = np.stack([(x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy,
                         np.ones_like(x)], 1)
    r = so3.quat_rotate(q_rel, rays)
    r[r[:, 2] <= 0] = np.nan
    if camera.has_distortion:
        uv = camera.project(r)
        return uv[:, 0], uv[:, 1]
    return camera.fx * r[:, 0] / r[:, 2] + camera.cx, camera.fy * r[:, 1] / r[:, 2] + camera.cy


def frame_references(t_us, dt_us, t0_us=None, reference="mid"):
    """(reference times float64 of the frames holding events, index int32 of each event's
    one) of time-sorted t_us: frame_reference_times' distinct times, found from the frames'
    bounds (no per-event float times)."""
    frame_reference_times(t_us[:1], dt_us, t0_us, reference)   # arguments checked
    t0 = (int(t_us[0]) if len(t_us) else 0) if t0_us is None else int(t0_us)
    f0, bounds = frame_offsets(t_us, int(dt_us), t0)
    counts = np.diff(bounds)
    held = np.flatnonzero(counts)
    _, refs = frame_reference_times([], dt_us, t0, reference, frame=f0 + held)
    return refs, np.repeat(np.arange(len(held), dtype=np.int32), counts[held])


def warp_to_reference(t_us, x, y, t_ref_us, attitude, camera, extrapolate_us=0.0, *,
                      backend="reference", device="cpu"):
    """Warp events (t_us, x, y) to their reference times with an AttitudeTrack: (xw, yw) float64.

    backend 'reference' | 'taichi' | 'warp' (device 'cpu' | 'cuda'); they agree to ~1e-9 px.
    """
    refs, ref_index = _distinct_times(np.asarray(t_ref_us, dtype=np.float64))
    xy = warp_indexed(t_us, x, y, refs, ref_index, attitude, camera, extrapolate_us,
                      backend=backend, device=device)
    return xy[:, 0], xy[:, 1]


def warp_indexed(t_us, x, y, refs, ref_index, attitude, camera, extrapolate_us=0.0, *,
                 sensor=None, backend="reference", device="cpu"):
    """warp_to_reference with event i's reference time given as refs[ref_index[i]]: the
    warped coordinates as one (n, 2) float64 array xy; with a sensor (width, height),
    (xy, px, py, inside): also the warped events' pixels as
    evstar_kernels.reference.pixels.rounded_pixels gives them."""
    if backend not in WARP_BACKENDS:
        raise ParameterError(f"backend must be one of {WARP_BACKENDS}, got {backend!r}")
    if backend == "taichi":  # its kernel rounds too
        out = _kernel(backend, np.asarray(t_us), x, y, refs, ref_index, attitude, camera,
                      extrapolate_us, device, sensor or (0, 0))
        return out if sensor else out[0]
    if backend == "warp":
        xw, yw = _kernel(backend, np.asarray(t_us), x, y, refs, ref_index, attitude, camera,
                         extrapolate_us, device)
    else:
        xw, yw = _reference(t_us, x, y, refs, ref_index, attitude, camera, extrapolate_us,
                            device)
    xy = np.column_stack([xw, yw])
    return xy if sensor is None else (xy, *rounded_pixels(xw, yw, *sensor))


def _reference(t_us, x, y, refs, ref_index, attitude, camera, extrapolate_us, device):
    t = attitude.check_times(t_us, extrapolate_us)
    q_ref = attitude.at(refs, extrapolate_us)
    if backends.check_device(device) != "cpu":
        raise ParameterError(f"backend='reference' runs on the CPU only, got device={device!r}")
    xw, yw = np.empty(len(t)), np.empty(len(t))
    for s in range(0, len(t), _CHUNK):
        sl = slice(s, s + _CHUNK)
        q_t = attitude.at(t[sl], extrapolate_us)
        q_rel = so3.quat_mul(q_ref[ref_index[sl]], so3.quat_conj(q_t))
        xw[sl], yw[sl] = rotate_pixels(np.asarray(x[sl]), np.asarray(y[sl]), q_rel, camera)
    return xw, yw


def _distinct_times(t_ref):
    """(distinct reference times, index of each event's one)."""
    if len(t_ref) == 0:
        return t_ref, np.zeros(0, np.int64)
    if np.all(t_ref[1:] >= t_ref[:-1]):  # time-sorted events: reference times come in runs
        starts = np.flatnonzero(np.r_[True, t_ref[1:] != t_ref[:-1]])
        index = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, len(t_ref)]))
        return t_ref[starts], index
    return np.unique(t_ref, return_inverse=True)


def _kernel(backend, t, x, y, refs, ref_index, attitude, camera, extrapolate_us, device,
            sensor=None):
    """The kernels read t of any dtype (int64 µs: no float copy)."""
    attitude.check_span(t, extrapolate_us)
    q_ref = attitude.at(refs, extrapolate_us)
    iterations = _UNDISTORT_ITERATIONS if camera.has_distortion else 0
    params = (camera.fx, camera.fy, camera.cx, camera.cy, camera.k1, camera.k2)
    track = (ref_index, q_ref, attitude.t_us, attitude.q_cw, attitude.steps, params, iterations)
    if backend == "taichi":
        from evstar_kernels.taichi.event_warp_launch import warp_to_reference as launch

        return launch(backends.taichi(device), t, x, y, *track, sensor=sensor)
    _, dev = backends.warp(device)
    from evstar_kernels.warp.event_warp_launch import warp_to_reference as launch

    return launch(t, x, y, *track, device=dev)
