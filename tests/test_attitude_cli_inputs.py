"""`evstar attitude CENTROIDS.csv`: impossible centroids, another camera's sensor, files that
are not centroid tables, and no output time after the fix are one-line errors (exit 3)."""
import re

import numpy as np
import pandas as pd
import pytest

from evstar import Camera, io, sim
from conftest import write_orion_pan
from evstar.cli import main

CAM = sim.camera_preset("davis346", 16.0)     # 346 x 260


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("attitude_inputs")
    write_orion_pan(d, CAM)
    io.write_camera(d / "small.json", Camera(64, 48, CAM.fx, CAM.fy, 31.5, 23.5))
    return d


def attitude(d, name, *extra, camera="camera.json"):
    # --force: the tests share one output file
    return main(["attitude", str(d / name), "-o", str(d / "out.csv"), "--camera", str(d / camera),
                 "--force", *extra])


def edited(d, name, column, value, row=2):
    frame = pd.read_csv(d / "cents.csv", dtype=str, keep_default_na=False)
    frame.loc[row, column] = value
    frame.to_csv(d / name, index=False)
    return name


@pytest.mark.parametrize("column,value,says", [
    ("x", "nan", "not a finite position"), ("y", "-inf", "not a finite position"),
    ("sigma", "-1", "must be > 0"), ("sigma", "0", "must be > 0"),
    ("x", "5000", r"off the camera's 346x260 sensor \(x must be in -8.5..353.5, 8 px beyond"),
    ("y", "-9", "off the camera's 346x260 sensor"), ("n_events", "-3", "is negative")])
def test_impossible_centroids_name_file_line_column_and_value(files, capsys, column, value, says):
    name = edited(files, f"bad_{column}.csv", column, value)
    assert attitude(files, name) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"bad_{column}.csv: line 4, row 2: column '{column}' = {value} " in err
    assert re.search(says, err)


def test_positions_just_beyond_the_edges_and_unknown_sigma_are_accepted(files):
    """`evstar run` reports stars whose centre has just left the sensor (x = -1.9 and 347.7
    on DAVIS346 fields): its own files must read back."""
    frame = pd.read_csv(files / "cents.csv", dtype=str, keep_default_na=False)
    frame.loc[0, "x"], frame.loc[1, "y"], frame.loc[2, "sigma"] = "-1.9", "262.2", "nan"
    frame.to_csv(files / "edges.csv", index=False)
    assert attitude(files, "edges.csv") == 0


def test_centroids_of_another_sensor_name_the_cameras_size(files, capsys):
    assert attitude(files, "cents.csv", camera="small.json") == 3
    err = capsys.readouterr().err
    assert "cents.csv: line " in err and "off the camera's 64x48 sensor" in err
    assert "no_solution" not in err


@pytest.mark.parametrize("layout", ["t,x,y", "semicolons"])
def test_a_csv_meant_as_centroids_says_what_a_centroid_file_needs(files, capsys, layout):
    frame = pd.read_csv(files / "cents.csv")
    if layout == "t,x,y":
        frame[["t", "x", "y"]].to_csv(files / "txy.csv", index=False)
        name = "txy.csv"
    else:
        frame.to_csv(files / "semi.csv", index=False, sep=";")
        name = "semi.csv"
    assert attitude(files, name) == 3
    err = capsys.readouterr().err
    assert "missing column 'p'" not in err
    assert f"{name}: " in err and "header t,x,y,track,n_events,frame" in err


def test_an_event_csv_is_still_a_recording(tmp_path):
    from evstar.cli.attitude import is_centroid_file

    p = tmp_path / "ev.csv"
    for text, centroids in (("t,x,y,p\n# width=4 height=4\n1,2,3,1\n", False),
                            ("timestamp;x;y;polarity\n1;2;3;1\n", False),
                            ("0.1 2 3 1\n", False), ("t,x,y\n1,2,3\n", True),
                            ("t;x;y;track;n_events;frame\n", True)):
        p.write_text(text)
        assert is_centroid_file(p) is centroids, text


def test_rate_too_low_for_any_output_after_the_fix(files, capsys):
    c = io.read_centroids(files / "cents.csv")
    first = c["frame"] == c["frame"].min()
    keep = ~first | (np.cumsum(first) <= 2)      # the first frame: too few stars to identify
    io.write_centroids(files / "late_fix.csv", c[keep])
    assert attitude(files, "late_fix.csv", "--rate-hz", "1") == 3
    err = capsys.readouterr().err
    assert "identification: " in err and " ok" in err
    assert "no output time after the first fix at " in err
    assert "--rate-hz 1 gives one output every 1000 ms" in err and "raise --rate-hz" in err
    assert attitude(files, "late_fix.csv") == 0


def test_all_centroids_at_one_time(files, capsys):
    c = io.read_centroids(files / "cents.csv")
    c["t"] = c["t"][0]
    io.write_centroids(files / "one_t.csv", c)
    assert attitude(files, "one_t.csv") == 3
    err = capsys.readouterr().err
    assert "no output time after the first fix" in err and "span 0 ms" in err


def test_an_imu_offset_without_an_imu_is_refused(files, capsys, tmp_path):
    from conftest import cli_fails

    cli_fails(capsys, ["attitude", files / "cents.csv", "--camera", files / "camera.json",
                       "--imu-offset-us", "100", "-o", tmp_path / "att.csv"], 2,
              "cents.csv", "imu_offset_us = 100", "no IMU")
    assert not (tmp_path / "att.csv").exists()
