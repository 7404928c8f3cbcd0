"""Pipeline inputs: wrong types, inputs of different recordings and a missing IMU or camera
are evstar errors naming what is wrong (never AttributeError or NaN metrics)."""
import dataclasses

import numpy as np
import pytest

import evstar
from evstar import Config, Pipeline, io, sim
from evstar.cli import main
from evstar.accuracy import check_truth
from evstar.tracking import Tracker


@pytest.fixture(scope="module")
def scene():
    return sim.simulate(sim.paper_preset(16.0, duration_s=0.1), seed=7)


@pytest.fixture(scope="module")
def other():
    return sim.simulate(sim.paper_preset(16.0, duration_s=0.12), seed=8)


def test_wrong_argument_types_name_the_argument(scene):
    with pytest.raises(evstar.ParameterTypeError, match="events must be an evstar.Events, got ndarray"):
        Pipeline().run(np.zeros(10))
    with pytest.raises(evstar.ParameterTypeError, match="imu must be an evstar.Imu"):
        Pipeline().run(scene.events, imu=np.zeros((3, 7)))
    with pytest.raises(evstar.ParameterTypeError, match="centroids must be a structured array"):
        Tracker().link(None)
    with pytest.raises(evstar.ParameterTypeError, match="centroids"):
        Tracker().link(np.zeros(3))


def test_camera_of_another_sensor_is_a_data_error(scene):
    cam = dataclasses.replace(scene.camera, width=scene.camera.width + 2)
    cfg = Config().replace(**{"motion.compensate": "imu"})
    with pytest.raises(evstar.DataError, match="camera is 322x240 px but the events' sensor is 320x240"):
        Pipeline(cfg).run(scene.events, scene.imu, cam)


def test_truth_of_another_recording_is_a_data_error(scene, other, tmp_path):
    with pytest.raises(evstar.DataError, match="another recording"):
        Pipeline().run(scene.events, truth=other.truth)
    ev = scene.events
    n, w, h = len(ev), ev.width, ev.height
    check_truth(scene.truth, n, w, h, ev.t[[0, -1]])  # its own truth passes
    with pytest.raises(evstar.DataError, match=f"labels {len(scene.truth.labels):,} events .* {n + 1:,}"):
        check_truth(scene.truth, n + 1, w, h, None)
    with pytest.raises(evstar.DataError, match="320x240 px sensor but the events' is 640x480"):
        check_truth(scene.truth, n, 640, 480, None)
    with pytest.raises(evstar.DataError, match="covers 0..100000 µs but the events span 0..200000"):
        check_truth(scene.truth, n, w, h, [0, 200_000])
    # streamed: the label count is checked chunk by chunk and at the end
    io.write(tmp_path / "e.h5", ev)
    with pytest.raises(evstar.DataError, match="another recording"):
        Pipeline(Config(chunk_frames=3)).run_file(tmp_path / "e.h5", truth=other.truth, progress=False)


def test_cli_run_rejects_the_truth_of_another_recording(scene, other, tmp_path, capsys):
    io.write(tmp_path / "e.h5", scene.events)
    sim.save_truth(tmp_path / "other.npz", other.truth)
    assert main(["run", str(tmp_path / "e.h5"), "--truth", str(tmp_path / "other.npz"),
                 "-o", str(tmp_path / "out"), "--no-progress"]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "another recording" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name,missing", [("expelliarmus_evt2_sample.raw", "--imu FILE"),
                                          ("emlb_demo-01.aedat4", "--camera FILE")])
def test_compensation_without_imu_or_camera_says_how_to_give_it(real_dir, tmp_path, capsys, name,
                                                                missing):
    for command in (["extract", str(real_dir / name), "-o", str(tmp_path / "c.csv")],
                    ["run", str(real_dir / name), "-o", str(tmp_path / "o"), "--no-progress"]):
        assert main(command + ["--compensate", "imu"]) != 0
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "motion.compensate = 'imu' needs" in err
        assert missing in err, err
    assert list(tmp_path.iterdir()) == []



def test_events_that_all_share_one_timestamp_run():
    """Their background rate is measured over one frame, not the 1 µs floor (1.6 MHz a pixel,
    which the filter refused as a rate_hz the user never set)."""
    rng = np.random.default_rng(0)
    n = 5000
    ev = evstar.Events(np.zeros(n, np.int64), rng.integers(0, 64, n), rng.integers(0, 48, n),
                rng.integers(0, 2, n), 64, 48)
    pipe = Pipeline(Config())
    assert 0 < pipe.calibration_rate(ev, 0) == pytest.approx(n / (64 * 48) / 0.01, rel=0.05)
    assert pipe.run(ev).metrics["events"] == n


def test_a_file_without_events_streams_as_it_runs_whole(tmp_path):
    """Streamed, an empty recording said "no events" (exit 3) where the whole run gave empty
    results (exit 0)."""
    io.write(tmp_path / "e0.h5", evstar.Events(np.zeros(0, np.int64), np.zeros(0, int),
                                              np.zeros(0, int), np.zeros(0, int), 64, 48))
    whole = Pipeline(Config()).run(io.read(tmp_path / "e0.h5").events)
    streamed = Pipeline(Config()).run_file(tmp_path / "e0.h5", progress=False)
    assert len(whole.centroids) == len(streamed.centroids) == 0
    assert whole.metrics == streamed.metrics


@pytest.mark.parametrize("rows", [0, 1])
def test_an_imu_file_of_fewer_than_two_samples_is_refused_before_any_work(scene, tmp_path,
                                                                           capsys, rows):
    # it was found only after the pipeline had run, in a message naming no file
    io.write(tmp_path / "rec.h5", scene.events)
    io.write_camera(tmp_path / "camera.json", scene.camera)
    imu = scene.imu
    io.write_imu(tmp_path / "imu.csv", evstar.Imu(imu.t[:rows], imu.gyro[:rows], imu.accel[:rows]))
    code = main(["run", str(tmp_path / "rec.h5"), "-o", str(tmp_path / "out"), "--imu",
                 str(tmp_path / "imu.csv"), "--camera", str(tmp_path / "camera.json")])
    err = capsys.readouterr().err
    assert code == 3 and err.count("\n") == 1 and "imu.csv" in err and "at least 2" in err, err
    assert not (tmp_path / "out").exists()
