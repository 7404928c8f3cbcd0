"""Bad input gives an EvstarError naming the file and what is wrong."""
import numpy as np
import pytest

from evstar import EvstarError, EvstarWarning, FormatError, io


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_missing_file_and_unknown_extension(tmp_path):
    with pytest.raises(FormatError, match=r"nope\.csv: no such file"):
        io.read(tmp_path / "nope.csv")
    with pytest.raises(FormatError, match=r"unknown extension '\.xyz'"):
        io.read(_write(tmp_path, "a.xyz", "1"))


def test_csv_header_any_order_and_headerless_seconds(tmp_path):
    rec = io.read(_write(tmp_path, "a.csv", "p,y,x,timestamp\n1,2,3,10\n0,4,5,20\n"), sensor_size=(8, 8))
    assert rec.events.t.tolist() == [10, 20] and rec.events.x.tolist() == [3, 5]
    rec = io.read(_write(tmp_path, "b.txt", "0.000010 3 2 1\n0.000020 5 4 -1\n"), sensor_size=(8, 8))
    assert rec.events.t.tolist() == [10, 20] and rec.events.p.tolist() == [1, 0]


def test_csv_without_sensor_size_warns_and_infers(tmp_path):
    with pytest.warns(EvstarWarning, match="inferred 6x5"):
        rec = io.read(_write(tmp_path, "a.csv", "t,x,y,p\n1,5,4,1\n"))
    assert rec.events.sensor_size == (6, 5)


@pytest.mark.parametrize("text,match", [
    ("t,x,p\n1,2,1\n", "missing column 'y'"),
    ("t,x,y,p\n1,2,3,1\n2,abc,3,1\n", "line 3: column 'x' holds a non-numeric value 'abc'"),
    ("t,x,y,p\n1,20,3,1\n", "'x' = 20 at index 0 is outside the 10x10 sensor"),
    ("t,x,y,p\n5,1,1,1\n4,1,1,1\n", "timestamps decrease at index 1"),
    ("t,x,y,p\n1,1.5,1,1\n", "non-integer value 1.5"),
])
def test_csv_errors_name_file_and_problem(tmp_path, text, match):
    p = _write(tmp_path, "bad.csv", text)
    with pytest.raises(FormatError, match=match) as err:
        io.read(p, sensor_size=(10, 10))
    assert "bad.csv" in str(err.value)


def test_unsorted_file_reads_with_sort_option(tmp_path):
    p = _write(tmp_path, "u.csv", "t,x,y,p\n5,1,1,1\n4,2,1,1\n")
    assert io.read(p, sensor_size=(4, 4), sort=True).events.x.tolist() == [2, 1]


@pytest.mark.parametrize("name,cut", [("emlb_demo-01.aedat4", 1_000_000), ("expelliarmus_evt3_sample.raw", 1001)])
def test_truncated_binary_files(tmp_path, real_dir, name, cut):
    data = (real_dir / name).read_bytes()
    p = tmp_path / name
    p.write_bytes(data[:cut])
    with pytest.raises(EvstarError, match=name.replace(".", r"\.") + ": (truncated|not a readable)"):
        io.read(p)


def test_corrupt_npz_and_hdf5(tmp_path):
    for name in ("a.npz", "a.h5"):
        with pytest.raises(FormatError, match=name):
            io.read(_write(tmp_path, name, "garbage"))
    np.savez(tmp_path / "b.npz", t=[1], x=[1])
    with pytest.raises(FormatError, match=r"missing field\(s\) \['y', 'p'\]"):
        io.read(tmp_path / "b.npz")


def test_imu_csv_errors(tmp_path):
    with pytest.raises(FormatError, match="missing IMU column"):
        io.read_imu(_write(tmp_path, "i.csv", "t,gx,gy\n1,2,3\n"))
    with pytest.raises(FormatError, match="line 3: column 'gy' is not finite"):
        io.read_imu(_write(tmp_path, "i.csv", "t,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0\n1,0,nan,0,0,0,0\n"))
    with pytest.raises(FormatError, match="line 2: column 'ax' holds a non-numeric value 'x'"):
        io.read_imu(_write(tmp_path, "i.csv", "t,gx,gy,gz,ax,ay,az\n0,0,0,0,x,0,0\n"))


def test_camera_json_errors(tmp_path):
    with pytest.raises(FormatError, match=r"missing camera field\(s\) \['cy'\]"):
        io.read_camera(_write(tmp_path, "c.json", '{"width":1,"height":1,"fx":1,"fy":1,"cx":0}'))
    with pytest.raises(FormatError, match="c.json: not valid JSON"):
        io.read_camera(_write(tmp_path, "c.json", "{"))
    with pytest.raises(FormatError, match="'height' must be a positive integer"):
        io.read_camera(_write(tmp_path, "c.json", '{"width":1,"height":0,"fx":1,"fy":1,"cx":0,"cy":0}'))


def test_raw_unknown_sensor_needs_size(tmp_path, real_dir):
    data = (real_dir / "expelliarmus_evt2_sample.raw").read_bytes().replace(b"gen3", b"genQ")
    p = tmp_path / "x.raw"
    p.write_bytes(data)
    rec = io.read(p, sensor_size=(640, 480))
    assert len(rec.events) == 539_481
