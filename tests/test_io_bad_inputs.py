"""Bad inputs found by fuzzing the command line: each gives one FormatError line naming the
file and the offending field and value (never a traceback, a shifted read or garbage)."""
import json

import h5py
import numpy as np
import pytest

from conftest import random_events
from evstar import DataError, FormatError, Imu, io
from evstar.calibration import PixelLag
from evstar.cli import main
from evstar.recording import Recording


def _fails(path, *parts, **kw):
    """The FormatError io.read raises for `path`, checked to be one line naming it and `parts`."""
    with pytest.raises(FormatError) as e:
        io.read(path, **kw)
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg
    for part in parts:
        assert part in msg, msg
    return msg


@pytest.mark.parametrize("rows, line", [
    ("100,2,3,1,0\n200,3,4,0,0\n", 2),        # every row: pandas took column t as an index
    ("1,2,3,1,5\n2,3,4,0\n", 2),              # only the first row
    ("1,2,3,1\n2,3,4,0,5\n3,3,4,0\n", 3),     # a later row (pandas' two-line "C error")
    ("# width=9 height=9\n1,2,3,1\n# note\n2,3,4,0,5\n", 5),  # comment lines count
])
def test_event_csv_row_with_an_extra_field_names_its_line(tmp_path, rows, line):
    path = tmp_path / "e.csv"
    path.write_text("t,x,y,p\n" + rows)
    msg = _fails(path, f"line {line} has 5 fields", sensor_size=(9, 9))
    assert msg.endswith((", expected 4", "but the header has 4")) and "C error" not in msg


@pytest.mark.parametrize("extra_on, line", [("all", 2), (3, 3)])
def test_imu_csv_row_with_an_extra_field_names_its_line(tmp_path, extra_on, line):
    rows = [f"{1000 * i},0.1,0.2,0.3,0,0,9.8" for i in range(5)]
    rows = [r + ",0" if extra_on == "all" or k + 2 == extra_on else r for k, r in enumerate(rows)]
    path = tmp_path / "imu.csv"
    path.write_text("t,gx,gy,gz,ax,ay,az\n" + "\n".join(rows) + "\n")
    with pytest.raises(FormatError, match=f"imu.csv: line {line} has 8 fields(, expected| but the header has) 7$"):
        io.read_imu(path)


def test_csv_with_a_utf8_bom_is_read(tmp_path):
    ev = tmp_path / "e.csv"
    ev.write_bytes(b"\xef\xbb\xbft,x,y,p\n100,2,3,1\n200,3,4,0\n")
    events = io.read(ev, sensor_size=(10, 10)).events
    assert events.t.tolist() == [100, 200] and events.x.tolist() == [2, 3]
    imu = tmp_path / "imu.csv"
    imu.write_bytes(b"\xef\xbb\xbft,gx,gy,gz,ax,ay,az\n0,0.5,0,0,0,0,9.8\n1000,0.5,0,0,0,0,9.8\n")
    assert io.read_imu(imu).t.tolist() == [0, 1000]


def _h5_with_imu(tmp_path, name="r.h5"):
    t = np.arange(0, 100_000, 1000)
    gyro = np.tile([0.1, 0.0, 0.0], (len(t), 1))
    path = tmp_path / name
    io.write(path, Recording(random_events(), Imu(t, gyro, np.zeros_like(gyro))))
    return path


@pytest.mark.parametrize("group", ["imu", "camera"])
def test_hdf5_group_that_is_a_dataset(tmp_path, group):
    path = _h5_with_imu(tmp_path)
    with h5py.File(path, "a") as f:
        if group in f:
            del f[group]
        f[group] = np.zeros((3, 2))
    _fails(path, f"'/{group}' is a dataset, expected a group")


def test_gyro_beyond_the_physical_bound_is_rejected(tmp_path):
    # CSV: the message names the line, the column and the value as written
    path = tmp_path / "imu.csv"
    path.write_text("t,gx,gy,gz,ax,ay,az\n0,0.1,0,0,0,0,9.8\n1000,0,-1e300,0,0,0,9.8\n")
    with pytest.raises(FormatError, match=r"imu.csv: line 3: column 'gy' = -1e300 rad/s is beyond ±100"):
        io.read_imu(path)
    # HDF5: the same bound, through Imu
    h5 = _h5_with_imu(tmp_path)
    with h5py.File(h5, "a") as f:
        f["imu/gyro"][7, 2] = 1e300
    _fails(h5, "'gyro' axis z = 1e+300 rad/s at sample 7")
    with pytest.raises(DataError, match="beyond ±100 rad/s"):
        Imu([0, 1], [[0, 0, 0], [0, 101, 0]])
    assert Imu([0, 1], [[0, 0, 0], [0, 99, 0]]).gyro[1, 1] == 99  # fast, but possible


@pytest.fixture
def lag_doc(tmp_path):
    path = PixelLag([1, 2], [50.0, 200.0], [[900.0, -80.0], [50.0, 40.0]],
                    [[1.0, 2.0], [1e9, 3.0]]).save(tmp_path / "lag.json")
    return json.loads(path.read_text())


@pytest.mark.parametrize("key, value, shown", [
    ("lag_us", [[1e300, 1], [1, 1]], "lag_us[0][0] = 1e+300"),
    ("lag_us", [[1, 1], [-1e9, 1]], "lag_us[1][0] = -1e+09"),
    ("lag_us", [[1, float("nan")], [1, 1]], "lag_us[0][1] = nan"),
    ("se_us", [[1, -5], [1, 1]], "se_us[0][1] = -5"),
    ("speed_px_s", [float("inf"), 300.0], "speed_px_s[0] = inf"),
    ("pairs", [1.5, 2], "pairs[0] = 1.5"),
])
def test_pixel_lag_file_with_absurd_values(tmp_path, lag_doc, key, value, shown):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**lag_doc, key: value}))
    with pytest.raises(FormatError) as e:
        PixelLag.load(bad)
    assert str(e.value).startswith(f"{bad}: field '{key}' must hold finite") and shown in str(e.value)


def test_pixel_lag_file_with_a_small_negative_lag_loads(tmp_path, lag_doc):
    path = tmp_path / "ok.json"
    path.write_text(json.dumps(lag_doc))
    assert PixelLag.load(path).lag_us[0, 1] == -80.0  # an ideal sensor's crossings come early


@pytest.mark.parametrize("name", ["g.npz", "g.npy"])
def test_garbage_numpy_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(bytes(range(256)) * 2)
    msg = _fails(path, "not an evstar/NumPy events archive")
    assert "pickle" not in msg


@pytest.mark.parametrize("name", ["r.h5", "r.npz", "r.csv", "r.aedat4"])
def test_sensor_size_option_must_agree_with_the_file(tmp_path, name):
    path = tmp_path / name
    io.write(path, random_events(width=64, height=48))
    _fails(path, "sensor is 64x48 px", "sensor_size 640x480", sensor_size=(640, 480))
    with pytest.raises(FormatError, match="sensor is 64x48 px"):
        io.packets(path, sensor_size=(640, 480))
    assert io.read(path, sensor_size=(64, 48)).events.sensor_size == (64, 48)


def test_sensor_size_option_serves_files_that_do_not_say(tmp_path):
    path = tmp_path / "e.csv"
    path.write_text("t,x,y,p\n100,2,3,1\n")
    assert io.read(path, sensor_size=(640, 480)).events.sensor_size == (640, 480)


def test_cli_reports_one_line(tmp_path, capsys):
    path = tmp_path / "e.csv"
    path.write_text("t,x,y,p\n100,2,3,1,0\n200,3,4,0,0\n")
    assert main(["info", str(path), "--sensor-size", "10", "10"]) == 3
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "e.csv: line 2 has 5 fields" in err
