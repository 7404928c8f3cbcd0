"""[attitude_filter] is a Config section: `evstar run`, `evstar batch` and `evstar attitude`
write the attitude with the --config file's table (run and batch: --attitude-* options
override it; attitude: its bare options), a bad value there is a one-line error naming
attitude_filter.key, and batch redoes a recording when only that table changed."""
import json

import numpy as np
import pytest

from evstar import Config, io, parameters as P, runs, sim
from evstar.attitude import estimate, read_attitude, write_attitude
from evstar.batch import config_key, local_client, run_many
from evstar.cli import main

from conftest import cli_fails

CAM = sim.camera_preset("davis346", 16.0)


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    """A 0.15 s Orion field at 20 °/s (identifies in its first frames), with its camera, and
    a TOML whose only table is [attitude_filter], at half the default output rate."""
    d = tmp_path_factory.mktemp("run_attitude")
    traj = sim.ConstantRate(20.0, R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(CAM, traj, 0.15, mag_limit=5.0)
    run = sim.simulate(sim.Scenario(CAM, stars, traj, 0.15), seed=2)
    io.write(d / "ev.h5", run.events, camera=CAM)
    (d / "half.toml").write_text("[attitude_filter]\nrate_hz = 50.0\n")
    return d


def steps(path):
    return set(np.diff(read_attitude(path)["t"]).tolist())


def run_cli(rec, out, *extra):
    assert main(["run", str(rec / "ev.h5"), "-o", str(out), "--no-progress", *map(str, extra)]) == 0
    return out / "attitude.csv"


def test_the_config_files_table_sets_the_rate_of_run_and_attitude(rec, tmp_path):
    assert steps(run_cli(rec, tmp_path / "default")) == {10_000}
    half = run_cli(rec, tmp_path / "half", "--config", rec / "half.toml")
    assert steps(half) == {20_000}
    # the table is recorded in the run's config.toml, and an option overrides the file
    assert Config.load(tmp_path / "half" / "config.toml").attitude_filter.rate_hz == 50.0
    fast = run_cli(rec, tmp_path / "fast", "--config", rec / "half.toml", "--attitude-rate-hz", 200)
    assert steps(fast) == {5_000}
    # `evstar attitude --config` reads the same table, from a recording and a centroid file
    assert main(["attitude", str(rec / "ev.h5"), "-o", str(tmp_path / "a.csv"),
                 "--config", str(rec / "half.toml")]) == 0
    assert (tmp_path / "a.csv").read_bytes() == half.read_bytes()
    io.write_camera(tmp_path / "camera.json", CAM)
    assert main(["attitude", str(tmp_path / "half" / "centroids.csv"), "-o", str(tmp_path / "c.csv"),
                 "--camera", str(tmp_path / "camera.json"), "--config", str(rec / "half.toml")]) == 0
    assert steps(tmp_path / "c.csv") == {20_000}
    assert main(["attitude", str(tmp_path / "half" / "centroids.csv"), "-o", str(tmp_path / "d.csv"),
                 "--camera", str(tmp_path / "camera.json"), "--config", str(rec / "half.toml"),
                 "--rate-hz", "200"]) == 0                  # its option overrides the file
    assert steps(tmp_path / "d.csv") == {5_000}


def test_defaults_write_the_attitude_estimate_writes_without_options(rec, tmp_path):
    """The attitude of a default run is what it was before the section existed: the
    estimate of the run's centroids with no options at all."""
    defaults = {name: p.default for name, p in P.ATTITUDE_FILTER.items()}
    assert Config().attitude_options() == {**defaults, "repair_gyro": True}
    result = runs.run_recording(rec / "ev.h5", tmp_path / "out", Config())
    events = io.read(rec / "ev.h5").events
    write_attitude(tmp_path / "before.csv", estimate(result.centroids, CAM, events=events))
    assert (tmp_path / "out" / "attitude.csv").read_bytes() == (tmp_path / "before.csv").read_bytes()


@pytest.mark.parametrize("table, code, texts", [
    ("rate_hz = 0", 2, ["attitude_filter.rate_hz", "(0, 1000]"]),
    ("smooth = 1", 2, ["attitude_filter.smooth", "true or false"]),
    ("bogus = 1", 2, ["unknown config key 'attitude_filter.bogus'"]),
])
def test_a_bad_value_in_the_table_is_a_one_line_error(rec, tmp_path, capsys, table, code, texts):
    bad = tmp_path / "bad.toml"
    bad.write_text(f"[attitude_filter]\n{table}\n")
    cli_fails(capsys, ["run", rec / "ev.h5", "-o", tmp_path / "out", "--no-progress",
                       "--config", bad], code, "evstar run: error:", str(bad), *texts)
    assert not (tmp_path / "out").exists()
    cli_fails(capsys, ["attitude", rec / "ev.h5", "-o", tmp_path / "a.csv", "--config", bad],
              code, "evstar attitude: error:", *texts)


def test_a_bad_option_is_a_usage_error(rec, tmp_path, capsys):
    cli_fails(capsys, ["run", rec / "ev.h5", "-o", tmp_path / "out", "--attitude-rate-hz", "0"],
              2, "--attitude-rate-hz", "(0, 1000]")
    cli_fails(capsys, ["batch", rec / "ev.h5", "-o", tmp_path / "out", "--attitude-gate", "-1"],
              2, "--attitude-gate")


def test_config_round_trips_the_section(tmp_path):
    cfg = Config().replace(**{"attitude_filter.rate_hz": 250, "attitude_filter.smooth": False,
                              "attitude_filter.centroid_delay_us": -40.5})
    assert cfg.attitude_filter.rate_hz == 250.0 and cfg.attitude_options()["smooth"] is False
    (tmp_path / "c.toml").write_text(cfg.to_toml())
    (tmp_path / "c.json").write_text(cfg.to_json())
    assert Config.load(tmp_path / "c.toml") == cfg == Config.load(tmp_path / "c.json")
    assert Config.from_dict(json.loads(cfg.to_json())) == cfg
    assert "[attitude_filter]" in Config().to_toml()
    # every other section keeps its defaults: the table alone is a whole configuration
    (tmp_path / "only.toml").write_text("[attitude_filter]\nmin_stars = 4\n")
    assert Config.load(tmp_path / "only.toml") == Config().replace(**{"attitude_filter.min_stars": 4})


def test_batch_redoes_a_recording_when_only_the_table_changed(rec, tmp_path):
    assert config_key(Config(), {}) != config_key(Config().replace(**{"attitude_filter.gate": 4}), {})
    out, half = tmp_path / "out", Config.load(rec / "half.toml")
    with local_client(1) as client:
        first = run_many([rec / "ev.h5"], Config(), out, client=client)
        assert first["status"].tolist() == ["ok"] and steps(out / "ev" / "attitude.csv") == {10_000}
        assert run_many([rec / "ev.h5"], Config(), out, client=client)["skipped"].all()
        changed = run_many([rec / "ev.h5"], half, out, client=client)
        assert changed["status"].tolist() == ["ok"] and not changed["skipped"].any()
        assert steps(out / "ev" / "attitude.csv") == {20_000}
        assert run_many([rec / "ev.h5"], half, out, client=client)["skipped"].all()
        # `evstar batch` takes the option, on the same workers
        assert main(["batch", str(rec / "ev.h5"), "-o", str(out), "--no-progress",
                     "--scheduler", client.scheduler.address, "--attitude-rate-hz", "200"]) == 0
        assert steps(out / "ev" / "attitude.csv") == {5_000}
