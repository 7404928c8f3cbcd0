"""A wheel built from the repository installs and imports outside the source tree."""
import os
import pathlib
import subprocess
import sys
import sysconfig
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_wheel_installs_in_fresh_venv(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(tmp_path / "dist"), str(ROOT)], check=True, timeout=600)
    wheel = next((tmp_path / "dist").glob("evstar-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert any(n.startswith("evstar_kernels/") for n in names)
    assert not any(n.startswith("kernels/") for n in names)
    # a fresh venv that borrows the dependencies (a .pth naming this interpreter's site
    # folders; their .pth hooks, such as an editable install's, are not run) but not the source
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    site_dir = subprocess.run([py, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                              capture_output=True, text=True, check=True).stdout.strip()
    deps = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    pathlib.Path(site_dir, "deps.pth").write_text("\n".join(sorted(deps)) + "\n")
    subprocess.run([py, "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)], check=True,
                   timeout=600)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = ("import evstar, evstar_kernels, pathlib; "
            "print(pathlib.Path(evstar.__file__).parent.parent); print(evstar.Events)")
    out = subprocess.run([py, "-I", "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert out.returncode == 0, out.stderr
    assert str(venv) in out.stdout.splitlines()[0]
    cli = subprocess.run([venv / "bin" / "evstar", "--version"], capture_output=True, text=True, env=env)
    assert cli.stdout.strip() == "evstar 0.1.0", cli.stderr
