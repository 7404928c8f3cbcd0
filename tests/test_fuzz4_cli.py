"""Fourth fuzz round, command line: output formats are usage errors (exit 2) for every
command with a file output, calibrate creates missing folders as extract does, batch refuses
empty names and malformed scheduler addresses, a missing GPU is one line, simulate refuses
what would exhaust memory, configuration files are read by their extension only. Every
failure is one line on stderr, no traceback, and leaves no output behind."""
import json
import subprocess
import sys

import numpy as np
import pytest

import evstar.pipeline  # noqa: F401 (its libraries' import-time warnings before the tests)
from evstar import Config, FormatError, ParameterError, backends, batch, io
from conftest import cli_fails as fails
from evstar.cli import main

REAL = "/work/shared/data/real"


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    """A small simulated folder: events.h5, imu.csv, camera.json, truth.npz."""
    d = tmp_path_factory.mktemp("rec") / "s"
    assert main(["simulate", str(d), "--duration", "0.1"]) == 0
    return d




# -- part 1.1: an output format a command cannot write is a usage error, as convert's -------------
@pytest.mark.parametrize("argv,option,value", [
    (["extract", "{ev}", "-o", "{d}/ce.txt"], "-o/--output", "ce.txt"),
    (["extract", "{ev}", "-o", "{d}/ce"], "-o/--output", "ce"),
    (["attitude", "{ev}", "-o", "{d}/at.h5", "--camera", "{cam}"], "-o/--output", "at.h5"),
    (["calibrate", "{ev}", "-o", "{d}/lag.txt"], "-o/--output", "lag.txt"),
    (["denoise", "{ev}", "{d}/o.h5", "--mask-out", "{d}/m.h5"], "--mask-out", "m.h5"),
    (["bench", "--events", "1000", "-o", "{d}/b.csv"], "-o/--output", "b.csv"),
    (["convert", "{ev}", "{d}/x.foo"], "OUT", "x.foo"),
])
def test_an_unwritable_output_format_is_a_usage_error(rec, tmp_path, capsys, argv, option, value):
    paths = {"ev": rec / "events.h5", "cam": rec / "camera.json", "d": tmp_path}
    err = fails(capsys, [a.format(**paths) for a in argv], 2, option, value)
    assert err.startswith(f"evstar {argv[0]}: error: ")
    assert list(tmp_path.iterdir()) == []          # refused before any work


def test_the_output_suffix_is_case_blind(rec, tmp_path, capsys):
    assert main(["extract", str(rec / "events.h5"), "-o", str(tmp_path / "C.CSV")]) == 0
    assert io.read_centroids(tmp_path / "C.CSV").dtype.names[:3] == ("t", "x", "y")


# -- part 1.2: calibrate's output folder follows the convention of the other commands ------------
@pytest.fixture(scope="module")
def cal(tmp_path_factory):
    """A star field on a sinusoid with its IMU: what calibrate measures from."""
    d = tmp_path_factory.mktemp("cal") / "c"
    assert main(["simulate", str(d), "--preset", "davis346", "--stars", "12", "--sine", "10", "1",
                 "--duration", "0.6", "--seed", "5"]) == 0
    return d


def test_calibrate_creates_missing_folders_as_extract_does(rec, cal, tmp_path, capsys):
    assert main(["extract", str(rec / "events.h5"), "-o", str(tmp_path / "e" / "f" / "c.csv")]) == 0
    out = tmp_path / "a" / "b" / "lag.json"
    assert main(["calibrate", str(cal / "events.h5"), "-o", str(out)]) == 0
    assert json.loads(out.read_text())["format"]
    capsys.readouterr()
    (tmp_path / "file").write_text("mine")    # a file where a folder would be: exit 4, no work
    for command, name in (("extract", "c.csv"), ("calibrate", "lag.json")):
        fails(capsys, [command, rec / "events.h5", "-o", tmp_path / "file" / name], 4, "file")
    assert (tmp_path / "file").read_text() == "mine"


# -- part 1.3: batch -------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["", "  "])
def test_batch_refuses_an_empty_input_name(rec, tmp_path, capsys, name):
    fails(capsys, ["batch", rec / "events.h5", name, "-o", tmp_path / "out"], 2, "INPUT", repr(name))
    assert not (tmp_path / "out").exists()
    with pytest.raises(ParameterError, match="empty name"):
        batch.run_many([rec / "events.h5", name], Config(), tmp_path / "out")


@pytest.mark.parametrize("address", ["foo", "tcp://foo", "udp://host:8786", "tcp://host:0",
                                     "tcp://host:99999", "::1:8786", "inproc://x", ""])
def test_batch_refuses_a_malformed_scheduler_address(rec, tmp_path, capsys, address):
    err = fails(capsys, ["batch", rec / "events.h5", "-o", tmp_path / "out", "--scheduler", address],
                2, "argument --scheduler", repr(address), "tcp, tls, ws, wss")
    assert "cannot reach" not in err and not (tmp_path / "out").exists()
    with pytest.raises(ParameterError, match="scheduler must be a Dask scheduler address"):
        batch.run_many(rec / "events.h5", Config(), tmp_path / "out", scheduler=address)


@pytest.mark.parametrize("address", ["tcp://host:8786", "host:8786", "tls://a.b.org:1",
                                     "tcp://[::1]:8786", "ws://10.0.0.1:65535"])
def test_well_formed_scheduler_addresses_pass_the_check(address):
    assert batch.scheduler_address_error(address) is None


# -- part 1.4: a missing GPU is one evstar line --------------------------------------------------
@pytest.mark.skipif(backends.available()["cuda"], reason="a CUDA GPU is present")
@pytest.mark.parametrize("argv", [
    ["extract", "{ev}", "-o", "{d}/c.csv", "--device", "cuda"],
    ["denoise", "{ev}", "{d}/o.h5", "--device", "cuda"],
    ["run", "{ev}", "-o", "{d}/run", "--device", "cuda", "--no-progress"],
    ["demo", "-o", "{d}/demo", "--device", "cuda"],
])
def test_a_missing_gpu_is_one_line_before_any_work(rec, tmp_path, argv):
    args = [a.format(ev=rec / "events.h5", d=tmp_path) for a in argv]
    res = subprocess.run([sys.executable, "-m", "evstar", *args], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 5, res.stderr
    assert res.stderr.count("\n") == 1 and "no CUDA GPU" in res.stderr, res.stderr
    assert res.stderr.startswith(f"evstar {argv[0]}: error:") and res.stdout == ""
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(backends.available()["cuda"], reason="a CUDA GPU is present")
def test_taichi_on_cuda_without_a_gpu_writes_nothing_to_stderr():
    code = ("from evstar import backends\ntry:\n    backends.taichi('cuda')\n"
            "except backends.BackendError as e:\n    print('ERR', e)\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stdout.startswith("ERR "), res.stdout + res.stderr
    assert "libcuda" not in res.stderr and "falling back" not in res.stderr, res.stderr


# -- part 2: simulate at the edges ----------------------------------------------------------------
@pytest.mark.parametrize("argv,texts", [
    (["--stars", "0"], ["argument --stars"]),
    (["--axis", "0", "0", "0"], ["--axis", "non-zero"]),
    (["--psf-sigma", "1e-9"], ["time steps", "--psf-sigma"]),
    (["--focal-length", "1e-9"], ["field of view", "--focal-length"]),   # (was: time steps)
    (["--noise-hz", "1e6"], ["noise events", "--noise-hz"]),
    (["--duration", "3600"], ["noise events", "--duration"]),
    (["--events-name", "ev"], ["--events-name", "no extension"]),
])
def test_simulate_refuses_what_it_cannot_do_in_one_line(tmp_path, capsys, argv, texts):
    fails(capsys, ["simulate", tmp_path / "s", *argv], 2, *texts)
    assert not (tmp_path / "s").exists()


def test_simulate_at_extreme_legal_settings(tmp_path, capsys):
    # a tiny duration: no star event, but files that read back
    assert main(["simulate", str(tmp_path / "a"), "--duration", "1e-6", "--noise-hz", "0",
                 "--hot-pixels", "0"]) == 0
    assert len(io.read(tmp_path / "a" / "events.h5").events) == 0
    # a still camera: noise only; an axis whose norm overflows a float still names a direction
    assert main(["simulate", str(tmp_path / "b"), "--rate", "0", "--duration", "0.01"]) == 0
    assert main(["simulate", str(tmp_path / "c"), "--axis", "1e308", "1e308", "1e308",
                 "--duration", "0.01"]) == 0
    assert main(["simulate", str(tmp_path / "d"), "--axis", "1", "1", "1", "--duration", "0.01"]) == 0
    assert "warning" not in capsys.readouterr().err        # no overflow warning
    assert io.read(tmp_path / "c" / "events.h5").events == io.read(tmp_path / "d" / "events.h5").events


# -- part 2: help texts ---------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["demo", "denoise", "bench"])
def test_help_has_one_group_per_title(capsys, command):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    titles = [ln for ln in out.splitlines() if ln.endswith("options:")]
    assert len(titles) == len(set(titles)), titles


# -- part 2: configuration files ------------------------------------------------------------------
@pytest.mark.parametrize("name,text,code,message", [
    ("c.yaml", 'device = "cpu"\n', 3, "a configuration file is .toml or .json, got '.yaml'"),
    ("noext", 'device = "cpu"\n', 3, "got no extension"),
    ("e.json", "", 3, "the file is empty"),
    ("d.json", '{"denoise": {"radius": 3, "radius": 4}}', 3, "'radius' appears twice"),
    ("d.toml", "[denoise]\nradius = 3\nradius = 4\n", 3, "cannot parse configuration"),
    ("s.toml", "[denoise]\nradius = 3\n[denoise]\nalpha = 0.1\n", 3, "cannot parse configuration"),
    ("u.toml", "[foo]\nx = 1\n", 2, "unknown config key 'foo'"),
    ("k.toml", "[denoise]\nbogus = 1\n", 2, "unknown config key 'denoise.bogus'"),
    ("w.toml", '[denoise]\nradius = "three"\n', 2, "config key 'denoise.radius'"),
    ("n.toml", "denoise = 5\n", 2, "config key 'denoise' must be a table"),
    ("b.toml", "[denoise]\nradius = true\n", 2, "config key 'denoise.radius'"),
])
def test_bad_configuration_files_are_one_line(rec, tmp_path, capsys, name, text, code, message):
    cfg = tmp_path / name
    cfg.write_text(text)
    out = tmp_path / "c.csv"
    fails(capsys, ["extract", rec / "events.h5", "-o", out, "--config", cfg], code, name, message)
    assert not out.exists()


def test_configuration_edge_cases_that_are_fine(tmp_path):
    (tmp_path / "empty.toml").write_text("")
    (tmp_path / "empty.json").write_text("{}")
    (tmp_path / "UPPER.TOML").write_text('device = "cpu"\n')
    for name in ("empty.toml", "empty.json", "UPPER.TOML"):
        assert Config.load(tmp_path / name) == Config()
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(FormatError, match="dir.toml: is a folder"):
        Config.load(tmp_path / "dir.toml")


# -- part 2: Prophesee RAW with a sensor size smaller than its events -----------------------------
def test_a_raw_file_with_a_too_small_sensor_size_names_it(capsys):
    err = fails(capsys, ["info", f"{REAL}/expelliarmus_evt3_sample.raw", "--sensor-size", "640", "480"],
                3, "expelliarmus_evt3_sample.raw", "x = 874", "640x480", "--sensor-size",
                "plugin implies 1280x720")
    assert "corrupt" not in err


def test_run_on_the_real_recordings(tmp_path, capsys):
    for name in ("emlb_demo-01.aedat4", "expelliarmus_evt2_sample.raw"):
        out = tmp_path / name
        assert main(["run", f"{REAL}/{name}", "-o", str(out), "--no-progress"]) == 0
        metrics = json.loads((out / "metrics.json").read_text())
        assert metrics["events"] == len(io.read(f"{REAL}/{name}").events)
        assert np.isfinite(metrics["events_kept"])


# -- part 2: a reader that stops early (`evstar info F | head -1`) --------------------------------
def test_a_closed_stdout_ends_quietly(tmp_path):
    proc = subprocess.Popen([sys.executable, "-m", "evstar", "info", f"{REAL}/emlb_demo-01.aedat4"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()                 # before the command prints: its first write fails
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141
    assert err == "", err               # neither "error: Broken pipe" nor "Exception ignored"
