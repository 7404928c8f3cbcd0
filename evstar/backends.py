"""One place that starts Taichi and Warp, checks what was really obtained, and reports it.

Taichi may be initialised once per process (fields from an earlier init crash the
process) and silently falls back to the CPU when CUDA is absent, so every request is
checked against the arch Taichi actually reports.
"""
from __future__ import annotations

import os
import threading

from .errors import BackendError

DEVICES = ("cpu", "cuda")
_lock = threading.Lock()
_taichi_arch = None  # "cpu" | "cuda" once initialised
_warp_ready = False
_settings = {"cpu_threads": None, "cache_dir": None}


def configure(*, cpu_threads=None, cache_dir=None):
    """Set thread count and kernel cache folder; must precede the first kernel call."""
    if cpu_threads is not None and (int(cpu_threads) != cpu_threads or cpu_threads < 1):
        raise ValueError(f"cpu_threads must be a positive integer, got {cpu_threads!r}")
    if _taichi_arch is not None or _warp_ready:
        raise BackendError("configure() must be called before any backend is initialised")
    _settings.update(cpu_threads=cpu_threads, cache_dir=cache_dir)


def check_device(device):
    """Normalise a user device string: 'cpu', 'cuda' or 'cuda:N'."""
    if not isinstance(device, str) or device.split(":")[0] not in DEVICES:
        raise ValueError(f"device must be 'cpu' or 'cuda' (or 'cuda:N'), got {device!r}")
    return device


def taichi(device="cpu"):
    """Initialise Taichi for `device` (once per process) and return the taichi module."""
    global _taichi_arch
    want = check_device(device).split(":")[0]
    import taichi as ti

    with _lock:
        if _taichi_arch is None:
            kwargs = dict(arch=ti.cuda if want == "cuda" else ti.cpu, default_ip=ti.i32,
                          offline_cache=True, log_level=ti.WARN)
            if _settings["cpu_threads"]:
                kwargs["cpu_max_num_threads"] = int(_settings["cpu_threads"])
            if _settings["cache_dir"]:
                kwargs["offline_cache_file_path"] = os.path.join(_settings["cache_dir"], "taichi")
            ti.init(**kwargs)
            got = ti.lang.impl.current_cfg().arch
            _taichi_arch = "cuda" if got == ti.cuda else "cpu"
            if _taichi_arch != want:
                raise BackendError(f"Taichi could not start on {want!r} (it fell back to "
                                   f"{_taichi_arch!r}): no usable CUDA GPU")
        elif _taichi_arch != want:
            raise BackendError(f"Taichi is already running on {_taichi_arch!r} in this process; "
                               f"it cannot switch to {want!r} (start a new process)")
    return ti


def warp(device="cpu"):
    """Initialise Warp and return (warp module, device string) after checking the device exists."""
    global _warp_ready
    device = check_device(device)
    import warp as wp

    with _lock:
        if not _warp_ready:
            if _settings["cache_dir"]:
                wp.config.kernel_cache_dir = os.path.join(_settings["cache_dir"], "warp")
            wp.config.log_level = wp.LOG_WARNING  # no start-up banner on stdout
            wp.init()
            _warp_ready = True
    names = [str(d) for d in wp.get_devices()]
    if device == "cuda":
        device = "cuda:0"
    if device not in names:
        raise BackendError(f"Warp device {device!r} is not available (have {names})")
    return wp, device


def available():
    """What this machine offers, without initialising Taichi (Warp's probe is cheap)."""
    info = {"cpu": True, "cuda": False, "warp_devices": ["cpu"], "taichi_arch": _taichi_arch}
    try:
        wp, _ = warp("cpu")
        info["warp_devices"] = [str(d) for d in wp.get_devices()]
        info["cuda"] = wp.get_cuda_device_count() > 0
    except Exception as exc:  # a broken Warp install is reported, not raised
        info["warp_error"] = str(exc)
    return info
