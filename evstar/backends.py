"""One place that starts Taichi and Warp, checks what was really obtained, and reports it.

Taichi may be initialised once per process (fields from an earlier init crash the
process) and silently falls back to the CPU when CUDA is absent, so every request is
checked against the arch Taichi actually reports.
"""
from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import threading

from . import parameters
from .errors import BackendError, ParameterError, ParameterTypeError

DEVICES = parameters.DEVICES
_lock = threading.Lock()
_taichi_arch = None  # "cpu" | "cuda" once initialised
_warp_ready = False
_settings = {"cpu_threads": None, "cache_dir": None}


def configure(*, cpu_threads=None, cache_dir=None):
    """Set thread count and kernel cache folder; must precede the first kernel call."""
    if cpu_threads is not None and (isinstance(cpu_threads, bool) or int(cpu_threads) != cpu_threads
                                    or cpu_threads < 1):
        raise ParameterError(f"cpu_threads must be a positive integer, got {cpu_threads!r}")
    if cache_dir is not None and not isinstance(cache_dir, (str, os.PathLike)):
        raise ParameterTypeError(f"cache_dir must be a str or os.PathLike, got {cache_dir!r}")
    if initialised():
        raise BackendError("configure() must be called before any backend is initialised")
    # "~/.cache/evstar" means the home folder's (the libraries would make a folder named ~)
    _settings.update(cpu_threads=cpu_threads,
                     cache_dir=None if cache_dir is None else os.path.expanduser(os.fspath(cache_dir)))


def settings():
    """What configure() set (a copy): cpu_threads and cache_dir, None for the defaults (the
    libraries' per-user caches, ~/.cache/taichi and ~/.cache/warp, shared by all processes)."""
    return dict(_settings)


def cpu_threads():
    """CPU threads a kernel may use: configure()'s cpu_threads, else the cores this process
    may run on."""
    if _settings["cpu_threads"]:
        return int(_settings["cpu_threads"])
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def initialised():
    """True once Taichi or Warp has started in this process (configure() is too late then)."""
    return _taichi_arch is not None or _warp_ready


def check_device(device):
    """Normalise a user device string: 'cpu', 'cuda' or 'cuda:N' (ParameterError otherwise)."""
    return parameters.check_device(device)


def require(device):
    """BackendError now, when `device` is CUDA and this machine has no usable CUDA GPU."""
    device = check_device(device)
    if device != "cpu" and not available()["cuda"]:
        raise BackendError(f"device {device!r} requested but no CUDA GPU is usable here "
                           "(use --device cpu)")
    return device


def taichi(device="cpu"):
    """Initialise Taichi for `device` (once per process) and return the taichi module."""
    global _taichi_arch
    want = check_device(device).split(":")[0]
    from evstar_kernels.taichi import quick_decorate  # noqa: F401 (Taichi's import, quicker)
    import taichi as ti

    with _lock:
        if _taichi_arch is None:
            kwargs = dict(arch=ti.cuda if want == "cuda" else ti.cpu, default_ip=ti.i32,
                          offline_cache=True, log_level=ti.WARN)
            if _settings["cpu_threads"]:
                kwargs["cpu_max_num_threads"] = int(_settings["cpu_threads"])
            if _settings["cache_dir"]:
                kwargs["offline_cache_file_path"] = os.path.join(_settings["cache_dir"], "taichi")
            # ti.init prints "[Taichi] Starting on arch=..." on stdout; evstar reports the arch.
            # Without a GPU its C++ logger writes "libcuda.so lib not found" and "falling back
            # to CPU" to stderr: evstar's BackendError below says that in one line instead
            quiet = TAICHI_NO_CUDA if want == "cuda" else ()
            with open(os.devnull, "w") as null, contextlib.redirect_stdout(null), \
                    _stderr_without(quiet):
                ti.init(**kwargs)
            if os.environ.get("EVSTAR_TAICHI_SOURCE_INFO") != "full":
                _short_taichi_source_info()
            got = ti.lang.impl.current_cfg().arch
            _taichi_arch = "cuda" if got == ti.cuda else "cpu"
            if _taichi_arch != want:
                raise BackendError(f"Taichi could not start on {want!r} (it fell back to "
                                   f"{_taichi_arch!r}): no usable CUDA GPU")
        elif _taichi_arch != want:
            raise BackendError(f"Taichi is already running on {_taichi_arch!r} in this process; "
                               f"it cannot switch to {want!r} (start a new process)")
    return ti


def _short_taichi_source_info():
    """Taichi 1.7 formats a wrapped, caret-marked source excerpt for every AST node of every
    kernel on every process start — even when the offline cache then skips the compile —
    about half of a warm first call. Error messages keep the file, line and source line;
    EVSTAR_TAICHI_SOURCE_INFO=full restores Taichi's excerpts."""
    from taichi.lang.ast import ast_transformer_utils as utils

    ctx = getattr(utils, "ASTTransformerContext", None)
    if ctx is None or not hasattr(ctx, "get_pos_info"):  # another Taichi: leave it alone
        return

    def get_pos_info(self, node):
        line = node.lineno + self.lineno_offset
        return (f'File "{self.file}", line {line}, in {self.func.func.__name__}:\n'
                f"{self.src[node.lineno - 1]}\n")

    ctx.get_pos_info = get_pos_info


def taichi_running():
    """The taichi module on the arch this process started it on (the CPU if not started yet):
    for small kernels that follow the run's other stages wherever they are."""
    return taichi(_taichi_arch or "cpu")


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
            with _stderr_without(WARP_NO_CUDA):
                wp.init()
            _warp_ready = True
    names = [str(d) for d in wp.get_devices()]
    if device == "cuda":
        device = "cuda:0"
    if device not in names:
        raise BackendError(f"Warp device {device!r} is not available (have {names})")
    return wp, device


#: what the libraries' native code writes to stderr on a machine without a usable CUDA GPU;
#: evstar reports a missing GPU itself (BackendError) when one is asked for. Warp prints its
#: line on every CPU-only start; Taichi prints its lines when asked for CUDA (then falls back)
WARP_NO_CUDA = ("Could not find or load the NVIDIA CUDA driver",)
TAICHI_NO_CUDA = ("libcuda.so lib not found", "is not supported, falling back to CPU",
                  "[cuda_driver.cpp:")


@contextlib.contextmanager
def _stderr_without(texts):
    """Capture the C-level stderr (fd 2) during the block and pass on every line that holds
    none of `texts` (no capture at all when `texts` is empty)."""
    if not texts:
        yield
        return
    try:
        saved = os.dup(2)
    except OSError:  # no usable stderr descriptor (embedded interpreters)
        yield
        return
    with tempfile.TemporaryFile() as tmp:
        sys.stderr.flush()
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            kept = [ln for ln in tmp.read().decode(errors="replace").splitlines(keepends=True)
                    if not any(t in ln for t in texts)]
            sys.stderr.write("".join(kept))


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
