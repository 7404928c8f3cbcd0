"""Bad arguments to the library's entry points are evstar's own one-line errors, found by
fuzzing the API: never a segfault, a raw exception from deep inside, or a silent result."""
import gc
import warnings

import numpy as np
import pytest

import evstar
from evstar import io, sim
from evstar.extract import Extractor
from evstar.motion import compensate
from evstar.tracking import Tracker


@pytest.fixture(scope="module")
def run():
    return sim.simulate(sim.paper_preset(20.0, duration_s=0.15), seed=1)


def test_extractor_refuses_coordinates_that_are_not_the_events_own(run):
    """NaN or far-off floats sent the cluster kernels outside their images (a segfault);
    floats within half a pixel of each event's own pixel are what xy is for."""
    ev = run.events[:4000]
    own = np.column_stack([ev.x, ev.y]).astype(float)
    for bad in (np.full((len(ev), 2), np.nan), own + 1e6, own - 1e6):
        with pytest.raises(evstar.ParameterError, match=r"xy\[0\] .* is not on the 320x240 sensor"):
            Extractor().centroids(ev, xy=bad)
    assert np.array_equal(Extractor().centroids(ev, xy=own + 0.3)["n_events"],
                          Extractor().centroids(ev)["n_events"])


def test_compensate_checks_its_arguments_as_the_pipeline_does(run):
    ev, imu, cam = run.events[:3000], run.imu, run.camera
    other = evstar.Camera(cam.width + 26, cam.height + 20, cam.fx, cam.fy, cam.cx, cam.cy)
    with pytest.raises(evstar.DataError, match="camera of another sensor"):
        compensate(ev, imu, other, 10_000, mode="imu")
    with pytest.raises(evstar.ParameterError, match="dt_us"):
        compensate(ev, imu, cam, "a", mode="imu")
    with pytest.raises(evstar.ParameterTypeError, match="events must be an evstar.Events"):
        compensate(np.zeros(3), imu, cam, 10_000, mode="imu")
    with pytest.raises(evstar.ParameterTypeError, match="camera must be an evstar.Camera"):
        compensate(ev, imu, "x", 10_000, mode="imu")
    empty = evstar.Imu(np.zeros(0, np.int64), np.zeros((0, 3)))
    with pytest.raises(evstar.DataError, match="IMU has 0 sample"):
        compensate(ev[:0], empty, cam, 10_000, mode="imu")


def test_tracker_refuses_a_centroid_without_a_position(run):
    c = Extractor().centroids(run.events[:4000])
    c["x"][0] = np.nan
    with pytest.raises(evstar.DataError, match="centroid 0 has a non-finite position"):
        Tracker().link(c)


def test_pipeline_run_names_wrong_events_and_truth(run):
    with pytest.raises(evstar.ParameterTypeError, match="events must be an evstar.Events"):
        evstar.Pipeline().run(None)
    with pytest.raises(evstar.ParameterTypeError, match="truth must be an evstar.sim Truth"):
        evstar.Pipeline().run(run.events, truth="x")


def test_io_checks_windows_and_what_it_writes(run, tmp_path):
    path = tmp_path / "e.h5"
    io.write(path, run.events)
    for bad in (float("nan"), "a", 0):
        with pytest.raises(evstar.ParameterError, match="window_us"):
            next(io.windows(path, bad))
    with pytest.raises(evstar.ParameterError, match="t_origin_us"):
        next(io.windows(path, 10_000, t_origin_us="x"))
    with pytest.raises(evstar.ParameterTypeError, match="camera must be an evstar.Camera"):
        io.write_camera(tmp_path / "c.json", "x")
    with pytest.raises(evstar.ParameterTypeError, match="imu must be an evstar.Imu"):
        io.write_imu(tmp_path / "i.csv", "x")
    assert not (tmp_path / "c.json").exists() and not (tmp_path / "i.csv").exists()
    ev = run.events[:10]
    np.savez(tmp_path / "half.npz", t=ev.t, x=ev.x, y=ev.y, p=ev.p, sensor_size=[320.5, 240])
    with pytest.raises(evstar.FormatError, match="'sensor_size' must hold whole numbers"):
        io.read(tmp_path / "half.npz")


def test_a_bad_csv_row_leaves_no_file_open(tmp_path):
    (tmp_path / "f.csv").write_text("t,x,y,p\n1,1.5,1,1\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(evstar.FormatError, match="non-integer"):
            io.read(tmp_path / "f.csv", sensor_size=(10, 10))
        gc.collect()
    assert not [w for w in caught if issubclass(w.category, ResourceWarning)]


def test_attitude_arguments(run):
    from evstar.attitude import AttitudeEstimator, identify

    assert evstar.attitude.estimate is not None       # a submodule reached as an attribute
    xy = np.array([[10.0, 20.0], [30.0, 40.0], [50.0, 60.0], [70.0, 80.0]])
    for bad in ("a", float("nan")):
        with pytest.raises(evstar.ParameterError, match="t_us must be a finite time"):
            identify(xy, run.camera, bad)
    with pytest.raises(evstar.ParameterTypeError, match="identifier must be a function"):
        AttitudeEstimator(run.camera, identifier="x")


def test_tiny_untracked_alpha_and_sparse_centroid_times(run):
    """untracked_alpha at its floor still gives a count (the per-spot probability fell below
    what the Poisson quantile computes: NaN); centroid times 1e15 µs apart are a DataError,
    not a 745 GiB allocation."""
    from evstar import estimation
    from evstar.attitude import estimate

    cfg = evstar.Config().replace(**{"estimate.untracked_alpha": 1e-12})
    assert estimation.untracked_min_events(cfg, (1280, 720), 1.0) > \
        estimation.untracked_min_events(evstar.Config(), (1280, 720), 1.0)
    c = Extractor().centroids(run.events[:4000])[:2].copy()
    c["t"] = [0, 10**15]
    with pytest.raises(evstar.DataError, match="centroids span"):
        estimate(c, run.camera, identifier=lambda xy, t, weight=None: None)


def test_a_streamed_run_uses_the_files_imu_and_camera(run, tmp_path):
    """Above stream_above_mb a run streams the file: it used to read only --imu/--camera,
    so `--compensate imu` said the input held none and no attitude was written."""
    from evstar import Config, runs

    path = tmp_path / "e.h5"
    io.write(path, run.events, imu=run.imu, camera=run.camera)
    imu, cam = io.extras(path)
    assert cam == run.camera and np.array_equal(imu.t, run.imu.t)
    cfg = Config().replace(**{"motion.compensate": "imu"})
    streamed = runs.run_recording(path, tmp_path / "s", cfg, stream_above_mb=0)
    whole = runs.run_recording(path, tmp_path / "w", cfg)
    assert len(streamed.centroids) == len(whole.centroids) > 0
    with pytest.raises(evstar.ParameterError, match="--sort .* orders a recording in memory"):
        runs.run_recording(path, tmp_path / "x", cfg, stream_above_mb=0, sort=True)


def test_writes_that_would_lose_or_garble_data(run, tmp_path):
    with pytest.raises(evstar.FormatError, match="a .npy file holds one array"):
        io.write(tmp_path / "e.npy", run.events)
    imu = evstar.Imu(run.imu.t, run.imu.gyro, run.imu.accel, time_offset_us=500)
    with pytest.warns(evstar.EvstarWarning, match="R_cam_imu and time offset"):
        io.write(tmp_path / "e.aedat4", run.events, imu=imu)
    wide = evstar.Events([0, 1], [0, 40000], [0, 1], [1, 0], 40001, 10)
    with pytest.raises(evstar.FormatError, match="AEDAT4 holds sensors below 32768"):
        io.write(tmp_path / "w.aedat4", wide)
    assert not (tmp_path / "w.aedat4").exists()


def test_calibration_without_tracks_says_so(tmp_path):
    from evstar.calibration import calibrate

    still = sim.simulate(sim.paper_preset(0.0, duration_s=0.2), seed=1)
    said = []
    with pytest.raises(evstar.DataError, match="gave no star track"):
        calibrate(still.events, still.imu, still.camera, progress=said.append)
    assert said == []          # the error alone: no "0 track(s)" line before it
