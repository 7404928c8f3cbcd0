"""Outputs: inputs are never overwritten, impossible output paths fail before any work with
one line, a run folder holds only this run's files, and plotting leaves pyplot alone."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import evstar
from evstar import Config, Pipeline, frames, io, metrics, outputs, report, sim
from evstar.cli import main
from evstar.io.atomic import atomic_path, check_output_dir, check_output_file, check_outputs

from conftest import random_events


@pytest.fixture(scope="module")
def scene():
    return sim.simulate(sim.paper_preset(16.0, duration_s=0.1), seed=5)


@pytest.fixture(scope="module")
def files(scene, tmp_path_factory):
    """The scene as events.h5 (with IMU and camera), events.csv and truth.npz."""
    d = tmp_path_factory.mktemp("inputs")
    sim.save_truth(d / "truth.npz", scene.truth)
    io.write(d / "events.csv", scene.events)
    io.write(d / "events.h5", scene.events, imu=scene.imu, camera=scene.camera)
    return d


def _one_line_error(capsys, *words):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "error:" in err, err
    for w in words:
        assert str(w) in err, err


# -- inputs are never overwritten -----------------------------------------------------------
def test_check_outputs_finds_an_input_by_any_name(tmp_path):
    src = tmp_path / "a.csv"
    src.write_text("x")
    os.link(src, tmp_path / "hard.csv")
    (tmp_path / "sub").mkdir()
    for same in (src, tmp_path / "sub" / ".." / "a.csv", tmp_path / "hard.csv"):
        with pytest.raises(evstar.OutputError, match="never overwrites"):
            check_outputs([tmp_path / "other.csv", same], [None, src])
    check_outputs([tmp_path / "b.csv", None], [src])  # a different file is fine


@pytest.mark.parametrize("command", [
    ["denoise", "{h5}", "{h5}", "--method", "mr-ndsef"],
    ["denoise", "{h5}", "{out}", "--method", "ndsef", "--mask-out", "{h5}"],
    ["convert", "{csv}", "{csv}"],
    ["extract", "{csv}", "-o", "{csv}"],
    ["run", "{h5}", "-o", "{h5}"],
])
def test_commands_refuse_to_overwrite_their_input(files, tmp_path, capsys, command):
    paths = {"h5": files / "events.h5", "csv": files / "events.csv", "out": tmp_path / "o.h5"}
    before = {p: p.read_bytes() for p in (paths["h5"], paths["csv"])}
    args = [a.format(**paths) for a in command]
    assert main(args) != 0
    _one_line_error(capsys, args[0])
    assert {p: p.read_bytes() for p in before} == before
    assert not paths["out"].exists()  # refused before any work


@pytest.mark.parametrize("command", [
    ["denoise", "{h5}", "{kept}", "--method", "ndsef"],
    ["denoise", "{h5}", "{other}", "--method", "ndsef", "--mask-out", "{kept}"],
    ["convert", "{csv}", "{kept}"],
    ["extract", "{csv}", "-o", "{kept}"],
])
def test_an_existing_output_file_is_replaced_only_with_force(files, tmp_path, capsys, command):
    # another recording, a table: a user's file that happens to have the output's name
    paths = {"h5": files / "events.h5", "csv": files / "events.csv",
             "kept": tmp_path / ("precious.npy" if "--mask-out" in command else
                                 "precious.csv" if "extract" in command else "precious.h5"),
             "other": tmp_path / "o.h5"}
    paths["kept"].write_bytes(b"someone's data")
    args = [a.format(**paths) for a in command]
    assert main(args) == 4
    _one_line_error(capsys, "precious", "--force")
    assert paths["kept"].read_bytes() == b"someone's data"
    assert not paths["other"].exists()           # refused before any work
    assert main(args + ["--force"]) == 0
    assert paths["kept"].read_bytes() != b"someone's data"


def test_run_refuses_a_folder_where_an_input_would_be_replaced(files, tmp_path, capsys):
    # the input is named like one of the run's outputs and sits in the output folder
    c = tmp_path / "centroids.csv"
    c.write_bytes((files / "events.csv").read_bytes())
    assert main(["run", str(c), "-o", str(tmp_path), "--no-progress"]) != 0
    _one_line_error(capsys, "centroids.csv", "never overwrites")
    assert c.read_bytes() == (files / "events.csv").read_bytes()
    # the truth, IMU and camera files are inputs too
    truth = tmp_path / "out" / "metrics.json"
    truth.parent.mkdir()
    truth.write_bytes((files / "truth.npz").read_bytes())
    assert main(["run", str(files / "events.h5"), "-o", str(truth.parent), "--truth", str(truth)]) != 0
    _one_line_error(capsys, "metrics.json")


# -- impossible output paths -------------------------------------------------------------------
def test_impossible_output_paths_are_one_line_output_errors(files, tmp_path, capsys):
    a_file = tmp_path / "file.json"
    a_file.write_text("{}")
    a_dir = tmp_path / "somedir"
    a_dir.mkdir()
    h5 = str(files / "events.h5")
    cases = [
        (["denoise", h5, "/proc/o.h5", "--method", "ndsef"], "/proc"),
        (["denoise", h5, str(a_dir), "--method", "ndsef"], "is a folder"),
        (["extract", h5, "-o", str(a_file / "out.csv")], "is a file"),
        (["convert", h5, str(a_file / "out" / "x.csv")], "is a file"),
        (["run", h5, "-o", str(a_file), "--no-progress"], "not a folder"),
        (["run", h5, "-o", str(a_file / "out"), "--no-progress"], "is a file"),
        (["run", h5, "-o", "/proc/o", "--no-progress"], "/proc"),
    ]
    for args, words in cases:
        assert main(args) != 0, args
        _one_line_error(capsys, words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.json", "somedir"]
    assert list(a_dir.iterdir()) == []


def test_output_checks_raise_output_error(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(evstar.OutputError, match="is a folder"):
        check_output_file(tmp_path)
    with pytest.raises(evstar.OutputError, match="is a folder"):   # would become a file "lagdir"
        check_output_file(f"{tmp_path / 'lagdir'}{os.sep}")
    with pytest.raises(evstar.OutputError, match="is a file"):
        check_output_file(tmp_path / "f" / "g.csv")
    with pytest.raises(evstar.OutputError, match="not a folder"):
        check_output_dir(tmp_path / "f")
    assert check_output_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # checking creates nothing


def test_atomic_writer_turns_os_errors_into_output_errors(tmp_path):
    with pytest.raises(evstar.OutputError, match="cannot write") as exc:
        with atomic_path("/proc/evstar-test.csv") as tmp:
            tmp.write_text("x")
    assert isinstance(exc.value, OSError) and exc.value.path == "/proc/evstar-test.csv"
    target = tmp_path / "d"
    target.mkdir()
    with pytest.raises(evstar.OutputError, match=str(target)):  # rename onto a folder fails
        with atomic_path(target, suffix=".tmp") as tmp:
            tmp.write_text("x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # no temporary left


def test_atomic_writer_follows_links_and_writes_pipes_in_place(tmp_path):
    """A symbolic link keeps pointing at its (rewritten) target; a named pipe stays a pipe and
    its reader gets the bytes (a rename had put a plain file in their place)."""
    import stat
    import threading

    (tmp_path / "target.csv").write_text("old")
    link = tmp_path / "link.csv"
    link.symlink_to("target.csv")
    with atomic_path(link) as tmp:
        tmp.write_text("new")
    assert link.is_symlink() and (tmp_path / "target.csv").read_text() == "new"
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    with atomic_path(fifo) as tmp:
        tmp.write_text("through the pipe")
    reader.join(timeout=10)
    assert got == ["through the pipe"] and stat.S_ISFIFO(os.stat(fifo).st_mode)


# -- the run folder ----------------------------------------------------------------------------
def test_rerun_removes_its_own_stale_files_only(files, tmp_path):
    out = tmp_path / "out"
    base = ["run", str(files / "events.h5"), "-o", str(out), "--no-progress"]
    assert main(base + ["--truth", str(files / "truth.npz")]) == 0
    assert (out / "errors.png").exists() and "snr_before_db" in json.loads((out / "metrics.json").read_text())
    (out / "notes.txt").write_text("mine")
    (out / "errors.csv").write_text("not evstar's")
    assert main(base) == 0
    assert not (out / "errors.png").exists()  # from the run with truth: would mislead
    assert (out / "notes.txt").read_text() == "mine" and (out / "errors.csv").exists()
    assert "snr_before_db" not in json.loads((out / "metrics.json").read_text())


def test_temporaries_of_killed_runs_are_removed_by_the_next_run(scene, tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".out.evstar-tmp-{dead.pid}-abc123"
    stale.mkdir()
    (stale / "centroids.csv").write_text("half written")
    live = tmp_path / f".out.evstar-tmp-{os.getppid()}-def456"  # a running process's
    live.mkdir()
    other = tmp_path / ".other.evstar-tmp-1-x"  # another output folder's
    other.mkdir()
    result = Pipeline(Config()).run(scene.events)
    outputs.write_run(tmp_path / "out", result, Config())
    assert not stale.exists() and live.exists() and other.exists()
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(["out", live.name, other.name])  # this run's temporary is gone too
    assert {p.name for p in (tmp_path / "out").iterdir()} == set(outputs.RUN_FILES) - {"errors.png", "attitude.csv"} | {outputs.OWNED}


def test_write_run_writes_the_tables_and_figures(scene, tmp_path):
    cfg = Config().replace(**{"motion.compensate": "imu"})
    result = Pipeline(cfg).run(scene.events, scene.imu, scene.camera, truth=scene.truth)
    outputs.write_run(tmp_path / "r", result, cfg, scene.truth)
    assert {p.name for p in (tmp_path / "r").iterdir()} == set(outputs.RUN_FILES) - {"attitude.csv"} | {outputs.OWNED}  # no attitude given
    tracks = (tmp_path / "r" / "tracks.csv").read_text().splitlines()
    assert tracks[0].startswith("track,t_first") and len(tracks) == 1 + result.metrics["tracks"]
    text = outputs.summary_text(result, tmp_path / "r")
    assert "centroid err" in text and f"{result.metrics['events']:,}" in text
    assert "kernel compiles included" in text      # `evstar run`'s one run is its first
    both = outputs.summary_text(result, tmp_path / "r", steady=result)
    assert "first call" in both and "steady state" in both and "compiles included" not in both


def test_per_frame_snr_is_metrics_snr_db():
    got = outputs.per_frame_snr_db([10, 0, 5, 0], [1, 4, 0, 0])
    want = [metrics.snr_db(s, n) for s, n in ((10, 1), (0, 4), (5, 0), (0, 0))]
    np.testing.assert_array_equal(got, want)
    assert got[0] == 10.0 and got[1] == -np.inf and got[2] == np.inf and np.isnan(got[3])


# -- figures -----------------------------------------------------------------------------------
def test_plotting_leaves_the_backend_and_pyplot_figures_alone(tmp_path):
    import matplotlib
    import matplotlib.pyplot as plt

    before = matplotlib.get_backend()
    plt.switch_backend("svg")  # the user's choice, which matplotlib.use("Agg") would undo
    fig = plt.figure()  # the user's own open figure
    try:
        ev = random_events()
        img = frames.accumulated(ev)
        report.plot_denoise(tmp_path / "d.png", img, img)
        report.plot_per_frame(tmp_path / "p.png", np.arange(3), {"a": np.arange(3)}, "n")
        report.plot_errors(tmp_path / "e.png", np.arange(3), np.ones(3))
        assert matplotlib.get_backend() == "svg"
        assert plt.get_fignums() == [fig.number] and plt.gcf() is fig
        assert all((tmp_path / n).read_bytes()[:4] == b"\x89PNG" for n in ("d.png", "p.png", "e.png"))
    finally:
        plt.close(fig)
        plt.switch_backend(before)


def test_accumulated_counts_events_per_pixel():
    ev = evstar.Events([0, 1, 2], [3, 3, 0], [1, 1, 2], [1, 0, 1], 4, 3)
    img = frames.accumulated(ev)
    assert img.shape == (3, 4) and img[1, 3] == 2 and img[2, 0] == 1 and img.sum() == 3


def test_an_imu_that_misses_the_events_is_refused_before_any_work(scene, files, tmp_path):
    """evstar run with an IMU 10 s late: one DataError naming the IMU file, before the
    pipeline ran and before the output folder exists (the attitude after the run refused it
    only then; before that, a run without compensation ended with a garbage attitude)."""
    from evstar import Config, runs

    late = tmp_path / "late.csv"
    imu = scene.imu
    io.write_imu(late, evstar.Imu(imu.t + 10_000_000, imu.gyro, imu.accel))
    out = tmp_path / "out"
    with pytest.raises(evstar.DataError, match="late.csv: the IMU starts"):
        runs.run_recording(files / "events.h5", out, Config(), imu=late)
    assert not out.exists()
    with pytest.raises(evstar.ParameterError, match="stream_above_mb"):
        runs.run_recording(files / "events.h5", out, Config(), stream_above_mb=float("nan"))


def test_a_run_with_nothing_matched_writes_valid_json_and_says_n_a(tmp_path, capsys):
    # a recording without a star's events: SNR and errors are undefined (NaN, -inf), which
    # JSON cannot hold; the file must still parse, with null there
    empty = sim.simulate(sim.paper_preset(0.0, duration_s=0.05), seed=3)
    d = tmp_path / "in"
    d.mkdir()
    io.write(d / "events.h5", empty.events)
    sim.save_truth(d / "truth.npz", empty.truth)
    assert main(["run", str(d / "events.h5"), "-o", str(tmp_path / "r"),
                 "--truth", str(d / "truth.npz")]) == 0
    text = (tmp_path / "r" / "metrics.json").read_text()
    metrics = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in metrics.json"))
    assert metrics["centroid_error_px"]["mean"] is None
    assert "n/a" in capsys.readouterr().out
