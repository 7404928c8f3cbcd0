"""Sixth fuzz round (forty-fourth session): settings at the float's limits, a pixel-lag file
named as an output, and output folders holding files evstar did not write."""
import pytest

from evstar import Config, ParameterError, io, sim
from evstar.cli import main
from evstar.outputs import OWNED


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=3)
    io.write(d / "ev.h5", run.events, imu=run.imu, camera=run.camera)
    return d / "ev.h5"


# each ended in an internal error (exit 70): an empty disk, a division by a zero area, a
# smoother's σ overflowing to NaN
@pytest.mark.parametrize("key, value", [
    ("denoise.radius", 1e-200), ("denoise.radii", [1e-200, 3.0]), ("extract.eps", 1e-200),
    ("estimate.along_weight", 1e-12), ("estimate.sigma_floor_px", 1e160),
    ("estimate.psf_sigma_px", 1e160)])
def test_settings_at_the_floats_limits_are_refused_naming_them(key, value):
    with pytest.raises(ParameterError, match=key.split(".")[1]):
        Config().replace(**{key: value})


def test_the_smallest_radius_and_weight_allowed_run(recording, tmp_path, capsys):
    assert main(["extract", str(recording), "-o", str(tmp_path / "c.csv"), "--radius", "0.5",
                 "--eps", "0.5", "--along-weight", "0.001", "--sigma-floor-px", "64"]) == 0


def test_an_output_that_is_the_pixel_lag_file_is_refused(recording, tmp_path, capsys):
    lag = tmp_path / "lag.csv"
    lag.write_text("a lag file\n")
    code = main(["extract", str(recording), "-o", str(lag), "--force", "--pixel-lag-file", str(lag)])
    assert code == 4 and "never overwrites its inputs" in capsys.readouterr().err
    assert lag.read_text() == "a lag file\n"
    (tmp_path / "r").mkdir()
    profile = tmp_path / "r" / "profile.json"
    profile.write_text("{}")
    code = main(["run", str(recording), "-o", str(tmp_path / "r"), "--pixel-lag-file", str(profile)])
    assert code == 4 and profile.read_text() == "{}"


def test_a_run_replaces_only_files_it_wrote(recording, tmp_path, capsys):
    out = tmp_path / "u"
    out.mkdir()
    (out / "centroids.csv").write_text("precious")
    (out / "attitude.csv").write_text("mine")
    assert main(["run", str(recording), "-o", str(out), "--no-progress"]) == 4
    err = capsys.readouterr().err
    assert "attitude.csv, centroids.csv" in err and OWNED in err
    assert (out / "centroids.csv").read_text() == "precious" and (out / "attitude.csv").exists()
    # its own folder: a rerun replaces them, and a run removes what an earlier run wrote
    mine = tmp_path / "mine"
    assert main(["run", str(recording), "-o", str(mine), "--no-progress"]) == 0
    (mine / "errors.png").write_text("a user's figure")
    assert main(["run", str(recording), "-o", str(mine), "--no-progress"]) == 4
    (mine / "errors.png").unlink()
    assert main(["run", str(recording), "-o", str(mine), "--no-progress"]) == 0
    assert "centroids.csv" in (mine / OWNED).read_text().split()


def test_a_batch_leaves_a_users_summary_alone(recording, tmp_path, capsys):
    out = tmp_path / "b"
    out.mkdir()
    (out / "summary.csv").write_text("the user's")
    assert main(["batch", str(recording), "-o", str(out), "--workers", "1", "--no-progress"]) == 4
    assert (out / "summary.csv").read_text() == "the user's"


def test_frame_counts_of_two_events_days_apart_are_counted_without_a_loop_per_frame():
    """A two-event file spanning 5.8 hours (2.1 M frames of 10 ms): the per-frame counts were
    a Python loop and dict per frame (a 99 M-frame file ran out of memory after 284 s)."""
    import numpy as np

    from evstar import Events, Pipeline

    ev = Events(np.array([0, 21_000_000_000]), np.array([10, 11]), np.array([10, 10]),
                np.array([1, 0]), 64, 48)
    counts = Pipeline(Config()).run(ev).frame_counts
    assert len(counts["before"]) == 2_100_001 and counts["before"].sum() == 2
    assert counts["before"][[0, -1]].tolist() == [1, 1] and abs(counts["t_s"][-1] - 21_000.005) < 1e-6


def test_a_lens_too_short_for_a_pinhole_is_refused_naming_the_shortest(tmp_path, capsys):
    """--focal-length 1e-6 mm put every star of the sky on a few pixels (over 15 minutes)."""
    assert main(["simulate", str(tmp_path / "s"), "--duration", "0.1", "--focal-length", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "--focal-length 0.5 mm" in err and "give at least 0.991 mm" in err
    assert main(["simulate", str(tmp_path / "s"), "--duration", "0.1", "--focal-length", "1e-6"]) == 2
    assert "--focal-length 1e-06 mm" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "s"), "--duration", "0.1", "--focal-length", "1"]) == 0


@pytest.mark.parametrize("key, value", [
    ("attitude_filter.jerk_noise", 1e300), ("attitude_filter.init_sigma_arcsec", 1e-300),
    ("attitude_filter.accel_prior", 1e300), ("attitude_filter.rate_prior_tracks", 1e-300),
    ("attitude_filter.gyro_noise", 1e300), ("attitude_filter.bias_prior", 1e-300),
    ("attitude_filter.bias_walk", 1e300)])
def test_attitude_filter_spreads_that_overflowed_are_refused(key, value):
    """Each ended in an OverflowError or a singular matrix (exit 70) inside the filter."""
    with pytest.raises(ParameterError, match=key.split(".")[1]):
        Config().replace(**{key: value})


@pytest.mark.parametrize("fx", [1e7, 0.001, 1e300])
def test_a_camera_focal_length_no_lens_has_in_pixels_is_refused(fx):
    from evstar import Camera, DataError

    with pytest.raises(DataError, match="field of view, outside 0.01–179°"):
        Camera(320, 240, fx, fx, 160, 120)
    Camera(320, 240, 1.5, 1.5, 160, 120)      # 179° and 0.01°: the widest and narrowest kept
    Camera(320, 240, 1.3e6, 1.3e6, 160, 120)


def test_a_field_too_narrow_to_identify_is_one_error_and_a_run_without_attitude(tmp_path, capsys):
    """A 0.18° field (fx 1e5 px): tetra3rs refused its lattice, an internal error (exit 70)."""
    assert main(["simulate", str(tmp_path / "f"), "--duration", "0.2", "--stars", "20",
                 "--seed", "4", "--rate", "5"]) == 0
    recording = tmp_path / "f" / "events.h5"
    cam = tmp_path / "narrow.json"
    cam.write_text('{"width": 320, "height": 240, "fx": 1e5, "fy": 1e5, "cx": 160, "cy": 120}')
    out = tmp_path / "r"
    assert main(["run", str(recording), "--camera", str(cam), "-o", str(out), "--no-progress"]) == 0
    assert "no attitude: star identification cannot cover" in capsys.readouterr().err
    assert (out / "centroids.csv").exists() and not (out / "attitude.csv").exists()
    code = main(["attitude", str(out / "centroids.csv"), "--camera", str(cam), "-o",
                 str(tmp_path / "a.csv")])
    assert code == 3 and "cannot cover a 0.14–0.18° field of view" in capsys.readouterr().err


@pytest.mark.parametrize("line", ["# width=-5 height=240", "# width=0 height=240",
                                  "# width=320"])
def test_a_csv_size_line_that_is_no_size_is_named(tmp_path, line):
    """It was ignored: the size then inferred from the events, without a word."""
    from evstar import FormatError

    path = tmp_path / "e.csv"
    path.write_text(f"t,x,y,p\n{line}\n0,1,2,1\n5,3,4,0\n")
    with pytest.raises(FormatError, match=f"line 2: '{line}' is no sensor size"):
        io.read(path)


def test_a_run_folder_of_an_evstar_from_before_the_record_is_still_its_own(recording, tmp_path):
    out = tmp_path / "old"
    assert main(["run", str(recording), "-o", str(out), "--no-progress"]) == 0
    (out / OWNED).unlink()              # as an earlier evstar left it: no record
    (out / "errors.png").write_text("that run's")
    assert main(["run", str(recording), "-o", str(out), "--no-progress"]) == 0
    assert not (out / "errors.png").exists() and (out / OWNED).exists()
