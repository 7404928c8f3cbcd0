"""Backend start-up: explicit arch, checked, clear errors for absent GPUs."""
import subprocess
import sys

import numpy as np
import pytest

from evstar import backends


def test_bad_device_string():
    with pytest.raises(ValueError, match="device must be 'cpu' or 'cuda'"):
        backends.check_device("tpu")


def test_available_reports_cpu():
    info = backends.available()
    assert info["cpu"] is True and "cpu" in info["warp_devices"]


def _run(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


def test_taichi_cpu_then_cuda_request_is_refused_in_same_process():
    r = _run("from evstar import backends\n"
             "ti = backends.taichi('cpu')\n"
             "assert ti.lang.impl.current_cfg().arch == ti.cpu\n"
             "try:\n    backends.taichi('cuda')\nexcept backends.BackendError as e:\n    print('ERR', e)\n")
    assert r.returncode == 0, r.stderr
    assert "already running on 'cpu'" in r.stdout


def test_missing_gpu_is_an_error_not_a_silent_cpu_run():
    if backends.available()["cuda"]:
        pytest.skip("a CUDA GPU is present: the fallback path cannot be exercised here")
    r = _run("from evstar import backends\n"
             "try:\n    backends.taichi('cuda')\nexcept backends.BackendError as e:\n    print('ERR', e)\n"
             "try:\n    backends.warp('cuda')\nexcept backends.BackendError as e:\n    print('ERR', e)\n")
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("ERR") == 2 and "fell back" in r.stdout


def test_configure_threads_and_cache(tmp_path):
    r = _run("from evstar import backends\n"
             f"backends.configure(cpu_threads=1, cache_dir={str(tmp_path)!r})\n"
             "wp, dev = backends.warp('cpu')\n"
             "print(wp.config.kernel_cache_dir)\n"
             "try:\n    backends.configure(cpu_threads=2)\nexcept backends.BackendError as e:\n    print('ERR', e)\n")
    assert r.returncode == 0, r.stderr
    assert str(tmp_path / "warp") in r.stdout and "ERR" in r.stdout


def test_configure_rejects_bad_threads():
    with pytest.raises(ValueError, match="cpu_threads"):
        backends.configure(cpu_threads=0)


_BROKEN_KERNEL = """
from evstar import backends
ti = backends.taichi('cpu')
@ti.kernel
def broken() -> ti.i32:
    return undefined_name_here + 1
try:
    broken()
except Exception as e:
    print(type(e).__name__, str(e), flush=True)
# Taichi can crash tearing down after a failed compile (taichi#6362; once in CI, rc -11,
# after this message was printed): leave without its teardown.
import os
os._exit(0)
"""


@pytest.mark.parametrize("mode", ["short", "full"])
def test_taichi_errors_still_name_file_line_and_source(mode, tmp_path):
    """evstar shortens the source excerpt Taichi formats per AST node (start-up cost); a
    kernel error must still say where it is, in both modes."""
    import os

    env = dict(os.environ, EVSTAR_TAICHI_SOURCE_INFO=mode)
    script = tmp_path / "broken.py"  # Taichi reads a kernel's source from its file
    script.write_text(_BROKEN_KERNEL)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, r.stderr
    assert "undefined_name_here" in r.stdout and "line 6" in r.stdout and "in broken" in r.stdout
    assert ("^^^" in r.stdout) == (mode == "full")


def test_taichis_class_body_check_is_patched_and_still_tells_classes_apart():
    import evstar_kernels.taichi.arrays  # noqa: F401 (installs the quick check)
    import taichi as ti
    from taichi.lang import kernel_impl

    assert kernel_impl._inside_class.__module__ == "evstar_kernels.taichi.quick_decorate"

    assert not kernel_impl._inside_class(1)        # this test's frame: not a class body

    @ti.data_oriented
    class Counter:
        @ti.kernel
        def zero(self, a: ti.types.ndarray(dtype=ti.i32, ndim=1)):
            for i in range(a.shape[0]):
                a[i] = 0

    backends.taichi("cpu")
    a = np.ones(4, np.int32)
    Counter().zero(a)                   # a class kernel still binds to its instance
    assert not a.any()


def test_configure_expands_a_home_cache_dir(tmp_path):
    """README's own example, cache_dir="~/.cache/evstar", made a folder named "~"."""
    import os

    env = {**os.environ, "HOME": str(tmp_path / "home")}
    r = subprocess.run([sys.executable, "-c",
                        "from evstar import backends\n"
                        "backends.configure(cache_dir='~/.cache/evstar')\n"
                        "print(backends.settings()['cache_dir'])\n"],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str(tmp_path / "home" / ".cache" / "evstar")
    assert not (tmp_path / "~").exists()


def test_configure_rejects_a_cache_dir_that_is_no_path():
    with pytest.raises(TypeError, match="cache_dir"):
        backends.configure(cache_dir=3)
