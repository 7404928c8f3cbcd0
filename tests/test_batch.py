"""evstar batch / evstar.batch.run_many on a LocalCluster of 2 worker processes: one row per
input (a corrupt or missing file fails alone), outputs byte-identical to `evstar run`,
resume after a complete or a killed batch, glob patterns, an unreachable scheduler."""
import os
import shutil

import pandas as pd
import pytest

import evstar
from evstar import Config, batch, io, sim
from evstar.cli import main

COMPARED = ("centroids.csv", "tracks.csv", "metrics.json", "config.toml")


@pytest.fixture(scope="module")
def client():
    with batch.local_client(2) as c:  # what `evstar batch --workers 2` runs on
        yield c


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Three small simulated recordings (one in a sub-folder with a repeated stem) and a
    corrupt one."""
    d = tmp_path_factory.mktemp("recordings")
    (d / "night2").mkdir()
    paths = [d / "a.h5", d / "b.csv", d / "night2" / "a.h5"]
    for seed, p in enumerate(paths):
        run = sim.simulate(sim.paper_preset(16.0, duration_s=0.1), seed=seed)
        io.write(p, run.events, imu=run.imu, camera=run.camera) if p.suffix == ".h5" \
            else io.write(p, run.events)
    (d / "corrupt.h5").write_bytes(b"not an HDF5 file" * 64)
    return d


@pytest.fixture(scope="module")
def first(client, inputs, tmp_path_factory):
    out = tmp_path_factory.mktemp("batch") / "out"
    paths = [str(inputs / "*.h5"), str(inputs / "b.csv"), str(inputs / "night2" / "*.h5"),
             str(inputs / "missing.h5")]
    return out, paths, batch.run_many(paths, Config(), out, client=client)


def test_one_row_per_input_and_failures_stay_alone(first, inputs):
    out, _, table = first
    by_name = {r["input"].replace(str(inputs) + "/", ""): r for _, r in table.iterrows()}
    assert list(by_name) == ["a.h5", "corrupt.h5", "b.csv", "night2/a.h5", "missing.h5"]
    corrupt = by_name["corrupt.h5"]
    assert corrupt["status"] == "failed"
    assert "corrupt.h5" in corrupt["error"] and "HDF5" in corrupt["error"]
    assert by_name["missing.h5"]["error"].endswith("missing.h5: no such file")
    for name in ("a.h5", "b.csv", "night2/a.h5"):
        row = by_name[name]
        assert row["status"] == "ok" and row["error"] == "" and not row["skipped"]
        assert row["events"] > 1000 and row["centroids"] > 0 and row["seconds"] > 0
    # repeated stems get their folder's name; every ok row has its complete folder
    folders = {p.name for p in out.iterdir() if (p / batch.MARKER).is_file()}
    assert folders == {f"{inputs.name}_a", "b", "night2_a"}
    csv = pd.read_csv(out / "summary.csv", keep_default_na=False)
    parquet = pd.read_parquet(out / "summary.parquet")
    assert list(csv["input"]) == list(parquet["input"]) == list(table["input"])
    assert list(parquet["status"]) == ["ok", "failed", "ok", "ok", "failed"]
    # counts are integers though the failed rows have none (they were written 25425.0)
    events = (out / "summary.csv").read_text().splitlines()[1].split(",")[csv.columns.get_loc("events")]
    assert events.isdigit(), events
    assert str(parquet["events"].dtype) == "Int64" and parquet["events"].isna().sum() == 2


def test_outputs_are_those_of_evstar_run(first, inputs, tmp_path):
    out, _, table = first
    for name in ("b.csv", "night2/a.h5"):
        row = table[table["input"] == str(inputs / name)].iloc[0]
        assert main(["run", str(inputs / name), "-o", str(tmp_path / "one"), "--no-progress"]) == 0
        for f in COMPARED:
            assert (tmp_path / "one" / f).read_bytes() == (out / row["output"] / f).read_bytes(), f


def test_rerun_skips_what_is_done_and_a_changed_config_redoes_it(first, client, tmp_path):
    out, paths, table = first
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    again = batch.run_many(paths, Config(), copy, client=client)
    ok = again["status"] == "ok"
    assert again["skipped"][ok].all() and not again["skipped"][~ok].any()
    assert list(again["events"][ok]) == list(table["events"][ok])
    changed = batch.run_many(paths[1:2], Config().replace(seed=7), copy, client=client)
    assert changed["status"].tolist() == ["ok"] and not changed["skipped"].any()
    forced = batch.run_many(paths[1:2], Config().replace(seed=7), copy, client=client, force=True)
    assert not forced["skipped"].any()
    again = batch.run_many(paths[1:2], Config().replace(seed=7), copy, client=client)
    assert again["skipped"].all()


def test_a_rerun_with_fewer_or_other_inputs_finds_each_ones_earlier_folder(first, client, inputs,
                                                                           tmp_path):
    # night2/a.h5 alone would be named "a" (its results are in night2_a: skipped there);
    # with a new a.h5 beside it, the new one is numbered
    out, _, table = first
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    alone = batch.run_many([str(inputs / "night2" / "a.h5")], Config(), copy, client=client)
    assert alone["skipped"].all() and alone["output"].iloc[0] == str(copy / "night2_a")
    assert not (copy / "a").exists()
    (tmp_path / "new").mkdir()
    shutil.copy(inputs / "a.h5", tmp_path / "new" / "a.h5")
    both = batch.run_many([str(tmp_path / "new" / "a.h5"), str(inputs / "night2" / "a.h5")],
                          Config(), copy, client=client)
    assert [os.path.basename(o) for o in both["output"]] == ["new_a", "night2_a"]
    assert both["skipped"].tolist() == [False, True]


def test_names_keep_earlier_folders_and_avoid_theirs(tmp_path):
    # y/a.h5 keeps the folder it had ("x_a"), so x/a.h5 is numbered; b.h5 takes "b", an
    # earlier input's folder (a rerun there is skipped only for the same file)
    paths = [tmp_path / "x" / "a.h5", tmp_path / "y" / "a.h5", tmp_path / "b.h5"]
    earlier = {str(paths[1]): "x_a", str(tmp_path / "z" / "b.h5"): "b"}
    assert batch.output_names(paths, earlier) == ["x_a-1", "x_a", "b"]


def test_a_killed_batch_redoes_only_the_unfinished(first, client, tmp_path):
    out, paths, _ = first
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    (copy / "b" / batch.MARKER).unlink()      # killed after writing, before the marker
    shutil.rmtree(copy / "night2_a")          # killed before anything was written
    before = (copy / "b" / "centroids.csv").read_bytes()
    table = batch.run_many(paths, Config(), copy, client=client)
    redone = {r["output"].rsplit("/", 1)[-1] for _, r in table.iterrows()
              if r["status"] == "ok" and not r["skipped"]}
    assert redone == {"b", "night2_a"}
    assert (copy / "b" / "centroids.csv").read_bytes() == before
    assert (copy / "night2_a" / batch.MARKER).is_file()


def test_an_input_rewritten_since_is_redone(first, client, inputs, tmp_path):
    out, _, _ = first
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    src = tmp_path / "b.csv"
    shutil.copy2(inputs / "b.csv", src)  # same bytes and time: the same input
    shutil.copytree(copy / "b", tmp_path / "res" / "b")
    assert batch.run_many([src], Config(), tmp_path / "res", client=client)["skipped"].all()
    os.utime(src, ns=(1, 1))  # same bytes, another modification time: redone
    assert not batch.run_many([src], Config(), tmp_path / "res", client=client)["skipped"].any()


def test_cli_on_a_running_scheduler_exits_3_with_one_line(first, client, capsys):
    out, paths, _ = first
    code = main(["batch", *paths, "-o", str(out), "--scheduler", client.scheduler.address,
                 "--no-progress"])
    assert code == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "2 of 5 recording(s) failed" in err, err


def test_unreachable_scheduler_is_one_line_error(tmp_path, capsys):
    code = main(["batch", str(tmp_path / "x.h5"), "-o", str(tmp_path / "o"),
                 "--scheduler", "tcp://127.0.0.1:9"])
    assert code == evstar.BackendError.exit_code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "cannot reach the Dask scheduler" in err, err


def test_a_pattern_matching_nothing_is_an_error(tmp_path, capsys):
    with pytest.raises(evstar.ParameterError, match="no file matches"):
        batch.expand_inputs([str(tmp_path / "*.h5")])
    assert main(["batch", str(tmp_path / "*.h5"), "-o", str(tmp_path / "o")]) == 2
    assert "no file matches" in capsys.readouterr().err


def test_patterns_expand_in_order_once_and_names_are_unique(tmp_path):
    for p in ("x/a.h5", "y/a.h5", "x/b.h5"):
        (tmp_path / p).parent.mkdir(exist_ok=True)
        (tmp_path / p).write_text("")
    paths = batch.expand_inputs([str(tmp_path / "x" / "*.h5"), str(tmp_path / "x" / "a.h5"),
                                 str(tmp_path / "*" / "a.h5")])
    assert [str(p.relative_to(tmp_path)) for p in paths] == ["x/a.h5", "x/b.h5", "y/a.h5"]
    assert batch.output_names(paths) == ["x_a", "b", "y_a"]


def test_local_workers_use_one_kernel_thread_and_the_callers_cache_folder(client):
    from evstar import backends

    settings = client.run(backends.settings)
    assert len(settings) == 2
    assert all(s["cpu_threads"] == 1 for s in settings.values())
    # the kernel caches: the libraries' per-user folders unless the caller configured one
    assert all(s["cache_dir"] == backends.settings()["cache_dir"] for s in settings.values())


def test_an_edited_input_file_is_redone_and_another_spelling_is_the_same(client, tmp_path,
                                                                          monkeypatch):
    from evstar.calibration import PixelLag

    run = sim.simulate(sim.paper_preset(16.0, duration_s=0.1), seed=3)
    monkeypatch.chdir(tmp_path)
    io.write("rec.h5", run.events, camera=run.camera)
    io.write_imu("imu.csv", run.imu)
    PixelLag([1, 2], [50.0, 200.0], [[9.0, 8.0], [5.0, 4.0]], [[1.0, 2.0], [1.0, 3.0]]).save("lag.json")

    def skipped(lag, imu="imu.csv"):
        config = Config().replace(**{"estimate.pixel_lag_file": lag})
        table = batch.run_many(["rec.h5"], config, "out", client=client, options={"imu": imu})
        assert table["status"].tolist() == ["ok"], table["error"].tolist()
        return bool(table["skipped"].iloc[0])

    assert not skipped("lag.json")
    assert skipped("./lag.json", imu=str(tmp_path / "imu.csv"))  # the same files, spelt otherwise
    io.write_imu("imu.csv", evstar.Imu(run.imu.t, run.imu.gyro * 1.01, run.imu.accel))
    assert not skipped("lag.json")  # the IMU's contents changed: redone
    assert skipped("lag.json")


@pytest.mark.parametrize("change, error, match", [
    ({"paths": None}, evstar.ParameterTypeError, "paths must be"),
    ({"paths": [None]}, evstar.ParameterTypeError, "paths must be"),
    ({"config": {}}, evstar.ParameterTypeError, "config must be an evstar.Config, got {}"),
    ({"config": None}, evstar.ParameterTypeError, "config must be"),
    ({"outdir": None}, evstar.ParameterTypeError, "outdir must be"),
    ({"client": "x"}, evstar.ParameterTypeError, "client must be .*, got 'x'"),
    ({"workers": "2"}, evstar.ParameterTypeError, "workers must be an int or None, got '2'"),
    ({"workers": 0}, evstar.ParameterError, "workers must be >= 1, got 0"),
    ({"options": [1]}, evstar.ParameterTypeError, r"options must be a dict or None, got \[1\]"),
    ({"options": {"bogus": 1}}, evstar.ParameterError, "unknown option 'bogus'"),
    ({"options": {"stream_above_mb": "0"}}, evstar.ParameterError,
     r"options\['stream_above_mb'\] must be a finite number >= 0, got '0'"),
    ({"options": {"imu": 3}}, evstar.ParameterError, r"options\['imu'\] must be a file path"),
])
def test_run_many_checks_its_arguments_before_any_work(tmp_path, change, error, match):
    args = {"paths": [str(tmp_path / "x.h5")], "config": Config(), "outdir": tmp_path / "o",
            **change}
    with pytest.raises(error, match=match) as e:
        batch.run_many(args.pop("paths"), args.pop("config"), args.pop("outdir"), **args)
    assert len(str(e.value).splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_marker_is_strict_json_with_undefined_metrics(tmp_path):
    """A recording where nothing matched has NaN / -inf metrics: the marker stores them as
    null (NaN is not JSON) and a later batch still reads the run back as complete."""
    import json

    stamp = {"input": "x.h5", "fingerprint": "abc"}
    row = {"input": "x.h5", "status": "ok", "snr": float("nan"), "error_px": float("-inf"),
           "events": 12}
    batch._write_marker(tmp_path, {**stamp, "row": row})
    text = (tmp_path / batch.MARKER).read_text()

    def refuse(name):
        raise ValueError(f"{name} in the marker")

    saved = json.loads(text, parse_constant=refuse)
    assert saved["row"]["snr"] is None and saved["row"]["error_px"] is None
    assert batch.completed(tmp_path, stamp)["events"] == 12
