"""Bad command-line options found by fuzzing: each ends in one line on stderr with exit 2
(a usage error) or 4 (an output that must not be written), before any work, and no file is
lost or overwritten. Inputs are tiny simulated recordings (`evstar simulate --duration 0.1`)."""
import hashlib
import json
import os
import subprocess
import sys

import pytest

from conftest import cli_fails as fails
from evstar.cli import main


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    """A simulated folder: events.h5, imu.csv, camera.json, truth.npz."""
    d = tmp_path_factory.mktemp("rec") / "s1"
    assert main(["simulate", str(d), "--duration", "0.1"]) == 0
    return d


def digest(folder):
    return {f.name: hashlib.sha256(f.read_bytes()).hexdigest()
            for f in sorted(folder.iterdir()) if f.is_file()}




# -- 1: --dt-ms inf / 1e400 / nan: a range error, no OverflowError ------------------------------
@pytest.mark.parametrize("value", ["inf", "1e400", "nan"])
@pytest.mark.parametrize("command", ["extract", "denoise", "run", "calibrate"])
def test_non_finite_dt_ms_is_a_range_error(rec, tmp_path, capsys, command, value):
    out = tmp_path / ("o.h5" if command == "denoise" else "o.csv")
    argv = [command, rec / "events.h5", *([out] if command == "denoise" else ["-o", out])]
    fails(capsys, [*argv, "--dt-ms", value], 2, "argument --dt-ms: must be a number in",
          f"got {value}")
    assert not out.exists()


@pytest.mark.parametrize("argv,text", [
    (["--radius", "inf"], "argument --radius"), (["--alpha", "nan"], "argument --alpha"),
    (["--rate-hz", "1e400"], "argument --rate-hz"), (["--coast-ms", "inf"], "argument --coast-ms"),
])
def test_other_float_options_reject_inf_and_nan(rec, tmp_path, capsys, argv, text):
    fails(capsys, ["extract", rec / "events.h5", "-o", tmp_path / "c.csv", *argv], 2, text)


# -- 2: simulate --events-name never replaces another file ---------------------------------------
@pytest.mark.parametrize("name", ["imu.csv", "truth.npz", "camera.json", "IMU.csv", "sub/ev.h5"])
def test_events_name_must_not_be_another_output(tmp_path, capsys, name):
    fails(capsys, ["simulate", tmp_path / "s", "--duration", "0.05", "--events-name", name], 2,
          "--events-name")
    assert not (tmp_path / "s").exists()


def test_simulate_never_replaces_a_file_it_did_not_write(tmp_path, capsys):
    d = tmp_path / "s"
    d.mkdir()
    (d / "notes.txt").write_text("mine\n")
    fails(capsys, ["simulate", d, "--duration", "0.05", "--events-name", "notes.txt"], 4,
          "notes.txt", "not written by evstar simulate")
    assert (d / "notes.txt").read_text() == "mine\n" and sorted(p.name for p in d.iterdir()) == ["notes.txt"]
    (d / "imu.csv").write_text("mine\n")   # simulate's fixed names too, in a folder not its own
    fails(capsys, ["simulate", d, "--duration", "0.05"], 4, "imu.csv")
    assert (d / "imu.csv").read_text() == "mine\n"


def test_simulate_reruns_replace_its_own_files_only(tmp_path, capsys):
    d = tmp_path / "s"
    d.mkdir()
    (d / "notes.txt").write_text("mine\n")
    for _ in range(2):   # the second run replaces what the first wrote
        assert main(["simulate", str(d), "--duration", "0.05", "--events-name", "ev.csv", "--seed", "3"]) == 0
    assert sorted(p.name for p in d.iterdir()) == ["camera.json", "ev.csv", "imu.csv", "notes.txt", "truth.npz"]
    assert (d / "notes.txt").read_text() == "mine\n" and (d / "ev.csv").read_text().count("\n") > 100


# -- 3: denoise --mask-out OUT --------------------------------------------------------------------
def test_mask_out_must_not_be_out(rec, tmp_path, capsys):
    out = tmp_path / "o.h5"
    fails(capsys, ["denoise", rec / "events.h5", out, "--mask-out", tmp_path / "." / "o.h5"], 2,
          "--mask-out", "is OUT")
    assert not out.exists()


# -- 4: bench -o ----------------------------------------------------------------------------------
def test_bench_writes_json_only_and_never_over_another_file(rec, tmp_path, capsys):
    before = digest(rec)
    fails(capsys, ["bench", "--events", "1000", "-o", rec / "events.h5"], 2, ".json")
    fails(capsys, ["bench", "--events", "1000", "-o", rec / "camera.json"], 4,
          "not an evstar bench result")
    fails(capsys, ["bench", "--events", "1000", "-o", f"{tmp_path}/b.json/"], 4, "folder")
    assert digest(rec) == before and not (tmp_path / "b.json").exists()


def test_bench_may_replace_its_own_results(tmp_path):
    from evstar.cli.bench import check_results_path

    path = tmp_path / "bench.json"
    path.write_text(json.dumps({"machine": {}, "meta": {}, "rows": []}))
    check_results_path(path)   # no error: an earlier result
    path.write_text(json.dumps({"rows": []}))
    with pytest.raises(OSError, match="not an evstar bench result"):
        check_results_path(path)


# -- 5: a sine's peak rate is bounded as --rate is -----------------------------------------------
def test_sine_peak_rate_is_bounded_like_rate(tmp_path, capsys):
    fails(capsys, ["simulate", tmp_path / "a", "--sine", "10", "1e6", "--duration", "0.01"], 2,
          "--sine", "peak rate", "3600")
    fails(capsys, ["simulate", tmp_path / "a", "--sine", "573", "1", "--duration", "0.01"], 2, "--sine")
    assert not (tmp_path / "a").exists()
    fails(capsys, ["simulate", tmp_path / "a", "--rate", "3601"], 2, "--rate")
    assert main(["simulate", str(tmp_path / "b"), "--sine", "572", "1", "--duration", "0.01"]) == 0


# -- 6: help texts name the defaults the commands use --------------------------------------------
def help_of(command, capsys):
    assert main([command, "--help"]) == 0
    return " ".join(capsys.readouterr().out.split())


def test_help_defaults_are_the_real_ones(capsys):
    demo = help_of("demo", capsys)
    assert "random seed (particle filter) (default 1)" in demo
    assert "--compensate {none,imu,pf} motion compensation (imu, pf need an IMU and a camera) (default pf)" in demo
    assert "(default mr-ndsef)" in help_of("denoise", capsys)


def test_denoise_without_method_uses_the_default(rec, tmp_path, capsys):
    out = tmp_path / "o.h5"
    assert main(["denoise", str(rec / "events.h5"), str(out)]) == 0
    assert "with mr-ndsef" in capsys.readouterr().out and out.exists()
    fails(capsys, ["denoise", rec / "events.h5", tmp_path / "p.h5", "--threshold", "3"], 2,
          "--threshold is for --method ndsef")


# -- 7: demo --rate 0 -----------------------------------------------------------------------------
def test_demo_at_rate_0_falls_back_to_the_imu(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--rate", "0"]) == 0
    text = capsys.readouterr().out
    assert "compensating with the IMU alone" in text
    assert 'compensate = "imu"' in (out / "config.toml").read_text()
    assert {"events.h5", "imu.csv", "truth.npz", "metrics.json"} <= {p.name for p in out.iterdir()}
    assert main(["demo", "-o", str(out), "--rate", "0"]) == 0   # its own files: replaced


def test_demo_replaces_no_file_it_did_not_write_and_writes_nothing_first(tmp_path, capsys):
    """A user's imu.csv in OUTDIR (or centroids.csv in OUTDIR/field) is refused before the
    demo simulates or writes anything: it had replaced the recording files unasked, and
    written them before refusing a foreign centroids.csv."""
    for folder, name in (("demo", "imu.csv"), ("demo/field", "centroids.csv")):
        out = tmp_path / folder
        out.mkdir(parents=True)
        (out / name).write_text("mine\n")
        before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
        fails(capsys, ["demo", "-o", tmp_path / "demo"], 4, name, "evstar")
        assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
        (out / name).unlink()


def test_a_span_or_sensor_too_large_for_memory_is_refused_before_allocating(tmp_path, capsys):
    """Events an hour of hours apart, or a header's 65536 x 65536 sensor: extract and run
    had ended in "out of memory (26.8 GiB)"; now the span's frames or the sensor's pixels
    are refused up front, as denoise refused the span."""
    span = tmp_path / "span.csv"
    span.write_text("t,x,y,p\n# width=320 height=240\n0,10,10,1\n3600000000000,11,10,0\n")
    big = tmp_path / "big.csv"
    big.write_text("t,x,y,p\n# width=65536 height=65536\n0,10,10,1\n10,11,10,0\n20,12,10,1\n")
    for cmd in (["extract", span, "-o", tmp_path / "a.csv"], ["run", span, "-o", tmp_path / "r"]):
        fails(capsys, cmd, 3, "360000001 frames", "corrupt timestamp")
    for cmd in (["extract", big, "-o", tmp_path / "b.csv"], ["denoise", big, tmp_path / "d.h5"],
                ["run", big, "-o", tmp_path / "s"]):
        fails(capsys, cmd, 3, "65536x65536 px", "8192x8192")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.csv", "span.csv"]


def test_options_are_not_abbreviated_debug_goes_after_the_command_and_pointing_is_checked(
        rec, tmp_path, capsys):
    """`--forc` had been taken for --force (and replaced a file); `--debug` after the command
    was an unrecognized argument though errors suggest adding it; a malformed --pointing
    passed unchecked with one star."""
    from evstar.errors import FormatError

    (tmp_path / "mine.h5").write_bytes(b"mine")
    fails(capsys, ["convert", rec / "events.h5", tmp_path / "mine.h5", "--forc"], 2,
          "unrecognized arguments: --forc")
    assert (tmp_path / "mine.h5").read_bytes() == b"mine"
    with pytest.raises(FormatError, match="no such file"):
        main(["info", str(tmp_path / "none.csv"), "--debug"])
    fails(capsys, ["simulate", tmp_path / "sim", "--pointing", "foo"], 2, "--pointing", "'foo'")
    assert not (tmp_path / "sim").exists()
    # a truth that is no .npz: said so (np.load's message had asked to allow pickles)
    (tmp_path / "t.csv").write_text("t,x\n")
    fails(capsys, ["run", rec / "events.h5", "-o", tmp_path / "r", "--truth", tmp_path / "t.csv"],
          3, "t.csv: not a truth .npz")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this system")
def test_a_named_pipe_is_refused_as_input_and_stdout_into_a_pipe_is_written(rec, tmp_path, capsys):
    """A named pipe as input had read as "file is empty" (its size), and read past that it
    would hang (a reader opens the file twice); /dev/stdout into a pipe resolved to a
    "pipe:[n]" path that does not exist and was refused."""
    fifo = tmp_path / "in.csv"
    os.mkfifo(fifo)
    fails(capsys, ["info", fifo], 3, "in.csv: is a named pipe")
    csv = tmp_path / "two.csv"
    csv.write_text("t,x,y,p\n# width=20 height=20\n100,10,10,1\n200,11,10,0\n")
    out = subprocess.run([sys.executable, "-m", "evstar", "convert", str(csv), "/dev/stdout",
                          "--to", "csv", "--force"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("t,x,y,p") and "200,11,10,0" in out.stdout


def test_an_unknown_output_extension_lists_only_what_evstar_writes(tmp_path, capsys):
    """The list had offered .npy, which is then refused (one array, no recording)."""
    err = fails(capsys, ["simulate", tmp_path / "s", "--events-name", "ev.xyz"], 2,
                "unknown extension '.xyz'", ".npz")
    assert ".npy" not in err
    (tmp_path / "cfg").mkdir()   # a folder as --config: said so (not "no extension")
    fails(capsys, ["extract", tmp_path / "x.csv", "-o", tmp_path / "o.csv", "--config",
                   tmp_path / "cfg"], 3, "cfg: is a folder, not a configuration file")


def test_an_imu_of_another_time_span_is_named(rec, tmp_path, capsys):
    """The IMU's time-span error came from its array, which knows no file: the command line
    leads it with the IMU file's name."""
    import pandas as pd

    imu = pd.read_csv(rec / "imu.csv", comment="#")
    imu["t"] += 10_000_000
    late = tmp_path / "late.csv"
    imu.to_csv(late, index=False)
    fails(capsys, ["extract", rec / "events.h5", "-o", tmp_path / "c.csv", "--compensate", "imu",
                   "--imu", late], 3, f"{late}: the IMU starts")


# -- 8, 9: bounds -----------------------------------------------------------------------------------
def test_background_rate_is_bounded(rec, tmp_path, capsys):
    fails(capsys, ["denoise", rec / "events.h5", tmp_path / "o.h5", "--rate-hz", "1e300"], 2,
          "argument --rate-hz", "[0, 1e+06]")
    cfg = tmp_path / "c.toml"
    cfg.write_text("[denoise]\nrate_hz = 1e300\n")
    fails(capsys, ["extract", rec / "events.h5", "-o", tmp_path / "c.csv", "--config", cfg], 2,
          "denoise.rate_hz")
    assert not (tmp_path / "o.h5").exists() and not (tmp_path / "c.csv").exists()


@pytest.mark.parametrize("value", ["-1", "nan", "inf"])
def test_stream_above_mb_is_bounded(rec, tmp_path, capsys, value):
    fails(capsys, ["run", rec / "events.h5", "-o", tmp_path / "out", "--stream-above-mb", value], 2,
          "argument --stream-above-mb")
    assert not (tmp_path / "out").exists()


def test_hot_pixels_at_most_the_sensor(tmp_path, capsys):
    fails(capsys, ["simulate", tmp_path / "a", "--hot-pixels", "1000000"], 2, "--hot-pixels",
          "76,800 pixels")
    assert not (tmp_path / "a").exists()


# -- 10: usage errors exit 2 ------------------------------------------------------------------------
def test_format_errors_of_options_are_usage_errors(rec, tmp_path, capsys):
    before = digest(rec)
    fails(capsys, ["info", rec / "events.h5", "--format", "bogus"], 2, "argument --format")
    fails(capsys, ["convert", rec / "events.h5", tmp_path / "x.h5", "--to", "bogus"], 2, "argument --to")
    fails(capsys, ["convert", rec / "events.h5", tmp_path / "x.h5", "--to", "dat"], 2, "argument --to")
    for ext in ("dat", "raw"):
        fails(capsys, ["convert", rec / "events.h5", tmp_path / f"x.{ext}"], 2, f"x.{ext}",
              "cannot write")
        fails(capsys, ["denoise", rec / "events.h5", tmp_path / f"x.{ext}"], 2, "cannot write")
    fails(capsys, ["simulate", tmp_path / "s", "--events-name", "ev.dat"], 2, "--events-name")
    assert digest(rec) == before and sorted(p.name for p in tmp_path.iterdir()) == []


# -- 11: a folder path for a file output ------------------------------------------------------------
@pytest.mark.parametrize("command", ["calibrate", "extract", "attitude"])
def test_a_folder_path_is_no_file_output(rec, tmp_path, capsys, command):
    fails(capsys, [command, rec / "events.h5", "-o", f"{tmp_path}/lagdir/"], 4, "folder")
    (tmp_path / "there").mkdir()
    fails(capsys, [command, rec / "events.h5", "-o", tmp_path / "there"], 4, "folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["there"]


def test_denoise_and_convert_outputs_are_files(rec, tmp_path, capsys):
    fails(capsys, ["convert", rec / "events.h5", f"{tmp_path}/c/"], 4, "folder")
    fails(capsys, ["denoise", rec / "events.h5", tmp_path / "o.h5", "--mask-out", f"{tmp_path}/m/"],
          4, "--mask-out")
    assert list(tmp_path.iterdir()) == []


# -- 12: messages name options, not Python arguments -----------------------------------------------
def evstar(cwd, *argv):
    return subprocess.run([sys.executable, "-m", "evstar", *map(str, argv)], capture_output=True,
                          text=True, cwd=cwd, timeout=300)


def test_messages_name_the_options(rec, tmp_path):
    (tmp_path / "ev.csv").write_text("t,x,y,p\n5,1,1,1\n9,2,2,0\n")
    res = evstar(tmp_path, "info", "ev.csv")
    assert res.returncode == 0 and "--sensor-size W H" in res.stderr and "sensor_size=" not in res.stderr
    res = evstar(tmp_path, "info", "ev.xyz")
    assert res.returncode == 3 and "(or pass --format)" in res.stderr and "format=" not in res.stderr
    res = evstar(tmp_path, "convert", rec / "events.h5", "out.csv")
    assert res.returncode == 0 and "holds no IMU" in res.stderr and "write_imu" not in res.stderr
    res = evstar(tmp_path, "info", "ev.csv", "--sensor-size", "0", "4")
    assert res.returncode == 2 and "argument --sensor-size" in res.stderr
