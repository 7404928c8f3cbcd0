"""The command line keeps stdout for results and starts fast: no banners, no stray warnings,
no heavy imports before a sub-command runs (`evstar --help` time is measured in
perf/bench_startup.py)."""
import subprocess
import sys

import pytest

HEAVY = ("sklearn", "scipy", "taichi", "warp", "pandas", "h5py", "matplotlib", "faery", "dask",
         "distributed")


def run(*args):
    return subprocess.run([sys.executable, "-m", "evstar", *args], capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize("argv", [[], ["run"], ["extract"], ["denoise"], ["info"], ["convert"],
                                  ["bench"], ["demo"], ["batch"], ["attitude"]])
def test_parsing_a_command_line_imports_nothing_heavy(argv):
    code = (f"import sys; from evstar.cli import build_parser; build_parser({argv!r}); "
            f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr


def test_stdout_holds_the_result_line_only(real_dir, tmp_path):
    res = run("denoise", str(real_dir / "emlb_demo-01.aedat4"), str(tmp_path / "o.h5"),
              "--method", "ndsef")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("kept ") and res.stdout.count("\n") == 1   # no Taichi banner
    assert "CUDA" not in res.stderr and "Taichi" not in res.stderr


@pytest.mark.parametrize("argv,code,text", [
    (["denoise", "missing.h5", "o.h5", "--method", "ndsef"], 3, "missing.h5: no such file"),
    (["denoise", "a.h5", "o.h5", "--method", "median"], 2, "invalid choice: 'median'"),
    (["bench", "--device", "cuda", "--events", "1000"], 5, "no CUDA GPU"),
])
def test_failures_are_one_line_with_their_exit_code(tmp_path, argv, code, text):
    res = subprocess.run([sys.executable, "-m", "evstar", *argv], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300)
    assert res.returncode == code and text in res.stderr
    assert res.stderr.count("\n") == 1 and "Traceback" not in res.stderr


def test_debug_shows_the_traceback(tmp_path):
    res = subprocess.run([sys.executable, "-m", "evstar", "--debug", "info", "missing.h5"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode != 0 and "Traceback" in res.stderr


def test_warnings_are_one_line_each(tmp_path):
    (tmp_path / "ev.csv").write_text("t,x,y,p\n5,1,1,1\n9,2,2,0\n")
    res = subprocess.run([sys.executable, "-m", "evstar", "info", "ev.csv"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stderr == ("evstar info: warning: ev.csv: no sensor size given; inferred 3x3 from "
                          "the largest coordinates (pass --sensor-size W H or --camera)\n")


def test_a_recording_without_stars_runs_without_warnings(tmp_path):
    """No events at all: the run folder is written and stderr holds no stray library warning
    (matplotlib warned of a legend without labels)."""
    (tmp_path / "empty.csv").write_text("t,x,y,p\n")
    res = subprocess.run([sys.executable, "-m", "evstar", "run", "empty.csv", "-o", "out",
                          "--sensor-size", "10", "10", "--no-progress"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "warning" not in res.stderr.lower(), res.stderr
    assert (tmp_path / "out" / "tracks.png").exists()


def test_a_streamed_run_draws_no_progress_bar_into_a_log(tmp_path):
    """stderr is not a terminal here (a log, CI): the streaming progress bar stays off
    without --no-progress (it filled logs with carriage-return frames)."""
    (tmp_path / "ev.csv").write_text("t,x,y,p\n" + "".join(f"{i * 100},{i % 7},{i % 5},{i % 2}\n"
                                                           for i in range(2000)))
    res = subprocess.run([sys.executable, "-m", "evstar", "run", "ev.csv", "-o", "out",
                          "--sensor-size", "10", "10", "--stream-above-mb", "0"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert "\r" not in res.stderr and "ev/s" not in res.stderr, res.stderr


def test_a_streamed_file_without_a_size_warns_once(tmp_path):
    (tmp_path / "hl.txt").write_text("0.000001 1 1 1\n0.000002 2 2 0\n0.000003 3 3 1\n")
    res = subprocess.run([sys.executable, "-m", "evstar", "run", "hl.txt", "-o", "out",
                          "--stream-above-mb", "0", "--no-progress"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("no sensor size given") == 1, res.stderr


def test_an_unknown_option_is_named_with_its_command(capsys):
    from evstar.cli import main

    assert main(["attitude", "c.csv", "-o", "a.csv", "--bogus", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("evstar attitude: error: unrecognized arguments: --bogus 1")
    assert "see evstar attitude --help" in err and err.count("\n") == 1


def test_bench_refuses_a_scene_no_machine_holds(capsys):
    from evstar.cli import main
    from evstar.cli.bench import MAX_EVENTS

    assert main(["bench", "--events", str(10 * MAX_EVENTS)]) == 2
    assert "--events" in capsys.readouterr().err
