"""Reader and writer checks found by outside testing: time range, rounding, duplicate columns,
sensor size in CSV, writing a Recording, centroid formats, and only evstar errors on bad input."""
import warnings

import h5py
import numpy as np
import pandas as pd
import pytest

import evstar
from evstar import (Camera, DataError, EvstarError, EvstarWarning, Events, FormatError, Imu,
                    ParameterTypeError, Recording, io)
from evstar.cli import main
from evstar.events import T_LIMIT_US
from conftest import random_events

INT64_MIN = -2 ** 63


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


# -- 1. timestamps inside ±2**61 µs ---------------------------------------------------------
@pytest.mark.parametrize("t", ["99999999999999999999999", str(INT64_MIN), "inf", "1e30"])
def test_csv_time_beyond_range_names_file_column_and_value(tmp_path, t):
    p = _write(tmp_path, "big.csv", f"t,x,y,p\n1,1,1,1\n{t},1,1,1\n")
    with pytest.raises(FormatError, match=rf"big\.csv: line 3: column 't' = {t} is outside the valid time range"):
        io.read(p, sensor_size=(4, 4))


def test_headerless_seconds_beyond_range(tmp_path):
    with pytest.raises(FormatError, match=r"line 1: column 1 \(t, seconds\) = 1e13 is outside"):
        io.read(_write(tmp_path, "big.txt", "1e13 1 1 1\n"), sensor_size=(4, 4))


@pytest.mark.parametrize("t", [T_LIMIT_US + 1, INT64_MIN, np.uint64(2 ** 64 - 1), 1e23])
def test_events_reject_times_beyond_range(t):
    with pytest.raises(DataError, match=r"events field 't' = .* is outside the valid range"):
        Events(np.array([t]), [0], [0], [1], 2, 2)
    Events([-T_LIMIT_US, T_LIMIT_US], [0, 0], [0, 0], [1, 1], 2, 2)  # the limits are valid


@pytest.mark.parametrize("ext", ["npz", "h5"])
def test_binary_readers_reject_int64_min(tmp_path, ext):
    t = np.array([INT64_MIN, 0], np.int64)
    if ext == "npz":
        np.savez(tmp_path / "a.npz", t=t, x=[0, 1], y=[0, 1], p=[0, 1], sensor_size=[4, 4])
    else:
        with h5py.File(tmp_path / "a.h5", "w") as f:
            for k, v in dict(t=t, x=[0, 1], y=[0, 1], p=[0, 1]).items():
                f[f"events/{k}"] = v
    with pytest.raises(FormatError, match=rf"a\.{ext}: events field 't' = {INT64_MIN} at index 0 is outside"):
        io.read(tmp_path / f"a.{ext}", sensor_size=(4, 4))


def test_imu_csv_time_beyond_range(tmp_path):
    p = _write(tmp_path, "i.csv", "t,gx,gy,gz,ax,ay,az\n99999999999999999999999,0,0,0,0,0,0\n")
    with pytest.raises(FormatError, match=r"i\.csv: line 2: column 't' = 99999999999999999999999 is outside"):
        io.read_imu(p)


# -- 2. rounding to whole µs is announced -------------------------------------------------
def test_fractional_microseconds_warn_with_count_and_largest_change(tmp_path):
    p = _write(tmp_path, "f.csv", "t,x,y,p\n1.25,1,1,1\n2.5,1,1,1\n3,1,1,1\n")
    with pytest.warns(EvstarWarning, match=r"f\.csv: column 't' has 2 value\(s\) with fractional µs, "
                                           r"rounded to whole µs \(largest change 0\.5 µs\)"):
        rec = io.read(p, sensor_size=(4, 4))
    assert rec.events.t.tolist() == [1, 2, 3]


def test_sub_microsecond_seconds_warn_and_exact_ones_do_not(tmp_path):
    with pytest.warns(EvstarWarning, match=r"column 1 \(t, seconds\) has 1 value\(s\) with sub-µs digits"):
        io.read(_write(tmp_path, "s.txt", "0.0000104 1 1 1\n0.000020 1 1 0\n"), sensor_size=(4, 4))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = io.read(_write(tmp_path, "e.txt", "0.000010 1 1 1\n1700000000.123456 1 1 0\n"),
                      sensor_size=(4, 4))
    assert rec.events.t.tolist() == [10, 1_700_000_000_123_456]


# -- 3. each field once -------------------------------------------------------------------
@pytest.mark.parametrize("header,field", [("t,x,y,x,p", "x"), ("t,timestamp,x,y,p", "t"), ("t,X,x,y,p", "x")])
def test_duplicated_columns_are_an_error(tmp_path, header, field):
    p = _write(tmp_path, "d.csv", f"{header}\n" + ",".join(["1"] * 5) + "\n")
    with pytest.raises(FormatError, match=rf"d\.csv: column '{field}' appears 2 times in the header"):
        io.read(p, sensor_size=(4, 4))


def test_duplicated_imu_columns_are_an_error(tmp_path):
    p = _write(tmp_path, "i.csv", "t,gx,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,0,0\n")
    with pytest.raises(FormatError, match=r"\['gx'\] appear more than once"):
        io.read_imu(p)


# -- 4. write() takes a Recording ---------------------------------------------------------
def _recording():
    ev = random_events(200, 64, 48, seed=1)
    t = np.arange(0, 100_000, 5000)
    imu = Imu(t, np.full((len(t), 3), 0.2), np.full((len(t), 3), 9.8), time_offset_us=7)
    return Recording(ev, imu, Camera(64, 48, 40.0, 41.0, 31.5, 23.5))


@pytest.mark.parametrize("ext", ["h5", "npz"])
def test_write_a_recording_keeps_events_imu_and_camera(tmp_path, ext):
    rec = _recording()
    io.write(tmp_path / f"w.{ext}", rec)
    back = io.read(tmp_path / f"w.{ext}")
    assert back.events == rec.events and back.imu == rec.imu and back.camera == rec.camera


@pytest.mark.parametrize("bad", [np.zeros(3), [1, 2], "events", None])
def test_write_anything_else_is_a_parameter_type_error(tmp_path, bad):
    with pytest.raises(ParameterTypeError, match=r"write: argument 'events' must be evstar\.Events or evstar\.Recording"):
        io.write(tmp_path / "w.h5", bad)
    assert not (tmp_path / "w.h5").exists()
    with pytest.raises(ParameterTypeError, match="argument 'imu'"):
        io.write(tmp_path / "w.h5", _recording().events, imu=np.zeros((2, 7)))


# -- 5. CSV keeps the sensor size ---------------------------------------------------------
def test_csv_round_trip_keeps_sensor_size_and_stays_plain_csv(tmp_path):
    ev = Events([1, 2, 3], [0, 599, 5], [0, 475, 5], [1, 0, 1], 640, 480)
    io.write(tmp_path / "s.csv", ev)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "inferred sensor size" warning
        assert io.read(tmp_path / "s.csv").events == ev
    frame = pd.read_csv(tmp_path / "s.csv", comment="#")
    assert frame.columns.tolist() == ["t", "x", "y", "p"] and frame["x"].tolist() == [0, 599, 5]
    table = np.genfromtxt(tmp_path / "s.csv", delimiter=",", names=True, dtype=np.int64)
    assert table["y"].tolist() == [0, 475, 5]
    w, h, gen = io.packets(tmp_path / "s.csv")
    assert (w, h) == (640, 480) and sum(len(p[0]) for p in gen) == 3


def test_leading_size_comment_is_read_too(tmp_path):
    p = _write(tmp_path, "l.csv", "# width=100 height=90\nt,x,y,p\n1,2,3,1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert io.read(p).events.sensor_size == (100, 90)
    assert io.read(p, sensor_size=(100, 90)).events.sensor_size == (100, 90)
    with pytest.raises(FormatError, match=r"100x90 px but sensor_size 10x10"):  # only for files that do not say
        io.read(p, sensor_size=(10, 10))


# -- 6. unsorted input: sort=True / --sort ------------------------------------------------
def test_unsorted_error_names_option_and_flag_and_cli_sort_works(tmp_path, capsys):
    p = _write(tmp_path, "u.csv", "t,x,y,p\n5,1,1,1\n4,2,1,1\n")
    with pytest.raises(FormatError, match=r"pass sort=True \(command line: --sort\)"):
        io.read(p, sensor_size=(4, 4))
    assert main(["info", str(p), "--sensor-size", "4", "4"]) != 0
    assert "--sort" in capsys.readouterr().err
    assert main(["info", str(p), "--sensor-size", "4", "4", "--sort", "--json"]) == 0
    assert '"t_first_us": 4' in capsys.readouterr().out


def test_imu_sort_option(tmp_path):
    p = _write(tmp_path, "i.csv", "t,gx,gy,gz,ax,ay,az\n5,1,0,0,0,0,0\n4,2,0,0,0,0,0\n")
    with pytest.raises(FormatError, match=r"--sort"):
        io.read_imu(p)
    assert io.read_imu(p, sort=True).gyro[:, 0].tolist() == [2, 1]


# -- 7. centroid files by extension -------------------------------------------------------
def _centroids():
    c = np.zeros(4, evstar.extract.CENTROID_DTYPE)
    c["t"], c["x"], c["y"], c["track"], c["n_events"] = [10, 20, 30, 40], 1.25, 2.5, [0, 0, 1, -1], 5
    c["frame"], c["spread"], c["border"] = [0, 1, 2, 3], 0.5, [True, False, True, False]
    c["sigma"], c["source"] = [0.1, 0.2, 0.3, 0.4], ["measured", "coasted", "measured", "measured"]
    c["n_on"] = [2, 0, 5, 1]
    return c


@pytest.mark.parametrize("ext", ["csv", "h5", "hdf5", "npz"])
def test_centroids_round_trip_in_each_format(tmp_path, ext):
    c = _centroids()
    io.write_centroids(tmp_path / f"c.{ext}", c)
    back = io.read_centroids(tmp_path / f"c.{ext}")
    assert back.dtype == c.dtype and all(np.array_equal(back[k], c[k]) for k in c.dtype.names)
    if ext in ("h5", "hdf5"):
        assert h5py.is_hdf5(tmp_path / f"c.{ext}")


@pytest.mark.parametrize("name", ["c.txt", "c", "c.json"])
def test_centroid_extension_checked_before_any_work(tmp_path, name):
    with pytest.raises(FormatError, match=r"unknown centroid file extension .*use \.csv, \.h5, \.hdf5 or \.npz"):
        io.check_centroid_path(tmp_path / name)
    with pytest.raises(FormatError):
        io.write_centroids(tmp_path / name, _centroids())
    assert not (tmp_path / name).exists()
    assert io.check_centroid_path("a.H5") == "hdf5"


# -- 8. only evstar errors from every reader ----------------------------------------------
READERS = {"csv": io.read, "txt": io.read, "npz": io.read, "npy": io.read, "h5": io.read,
           "aedat4": io.read, "raw": io.read, "dat": io.read, "imu.csv": io.read_imu,
           "json": io.read_camera, "cent.csv": io.read_centroids, "cent.h5": io.read_centroids,
           "cent.npz": io.read_centroids}


@pytest.mark.parametrize("ext", sorted(READERS))
@pytest.mark.parametrize("content,match", [
    (None, "no such file"), ("dir", "is a folder"), (b"", "file is empty"),
    (b"\x00\xff garbage \x89HDF\r\n\x1a\n" * 7, "not a|missing|no |truncated|corrupt|non-numeric|empty"),
])
def test_every_reader_raises_format_errors_on_unreadable_input(tmp_path, ext, content, match):
    p = tmp_path / f"in.{ext}"
    if content == "dir":
        p.mkdir()
    elif content is not None:
        p.write_bytes(content)
    with pytest.raises(FormatError, match=match) as err:
        READERS[ext](p)
    assert "in." in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("name,cut", [("emlb_demo-01.aedat4", 0.5), ("expelliarmus_evt2_sample.raw", 0.37),
                                      ("expelliarmus_evt3_sample.raw", 0.73),
                                      ("expelliarmus_evt3_sample.decoded.npy", 0.5)])
def test_truncated_real_files(tmp_path, real_dir, name, cut):
    data = (real_dir / name).read_bytes()
    p = tmp_path / name
    p.write_bytes(data[:int(len(data) * cut) | 1])
    with pytest.raises(FormatError, match=name.replace(".", r"\.")):
        io.read(p, sensor_size=(1280, 720))


@pytest.mark.parametrize("arrays,match", [
    (dict(t=[0.0, np.nan], x=[0, 1], y=[0, 1], p=[0, 1]), "non-finite"),
    (dict(t=[0, 1], x=[0, np.inf], y=[0, 1], p=[0, 1]), "non-finite"),
    (dict(t=["a", "b"], x=[0, 1], y=[0, 1], p=[0, 1]), "'t' must be numeric"),
    (dict(t=[0, 1], x=[0, -1], y=[0, 1], p=[0, 1]), "'x' = -1 at index 1 is outside"),
    (dict(t=[0, 1], x=[0, 1], y=[0, 1], p=[0, 7]), "'p' must be 0/1"),
    (dict(t=[[0, 1]], x=[0, 1], y=[0, 1], p=[0, 1]), "one-dimensional"),
])
def test_npz_with_bad_arrays(tmp_path, arrays, match):
    np.savez(tmp_path / "b.npz", sensor_size=[4, 4], **arrays)
    with pytest.raises(FormatError, match=rf"b\.npz: .*{match}"):
        io.read(tmp_path / "b.npz")


@pytest.mark.parametrize("row,match", [("1,-1,1,1", "'x' = -1"), ("1,nan,1,1", "non-numeric value 'nan'"),
                                       ("1,inf,1,1", "out-of-range value inf"), ("nan,1,1,1", "column 't'")])
def test_csv_with_bad_values(tmp_path, row, match):
    with pytest.raises(FormatError, match=match):
        io.read(_write(tmp_path, "v.csv", f"t,x,y,p\n{row}\n"), sensor_size=(4, 4))


@pytest.mark.parametrize("options,match", [(dict(sensor_size=(0, 4)), "sensor_size"),
                                           (dict(sensor_size="ab"), "sensor_size"),
                                           (dict(sorted=True), "unknown option")])
def test_bad_read_options_are_parameter_errors(tmp_path, options, match):
    p = _write(tmp_path, "o.csv", "t,x,y,p\n1,1,1,1\n")
    with pytest.raises(evstar.ParameterError, match=match):
        io.read(p, **options)


def test_camera_json_with_wrong_types(tmp_path):
    with pytest.raises(FormatError, match=r"\['fx'\] must be numbers"):
        io.read_camera(_write(tmp_path, "c.json", '{"width":4,"height":4,"fx":"a","fy":1,"cx":0,"cy":0}'))
    with pytest.raises(FormatError, match="not valid JSON"):
        io.read_camera(_write(tmp_path, "d.json", "[" * 100_000))


def test_errors_are_evstar_errors():
    assert issubclass(FormatError, EvstarError) and issubclass(ParameterTypeError, TypeError)


@pytest.mark.parametrize("reader", [io.read, io.read_imu, io.read_camera, io.read_centroids])
def test_a_path_that_is_not_a_path_is_a_parameter_type_error(reader):
    with pytest.raises(ParameterTypeError, match="path must be a str or os.PathLike, got int"):
        reader(3)


@pytest.mark.parametrize("n_on", [-1, 25])
def test_centroid_on_counts_outside_their_events_name_the_row(tmp_path, n_on):
    c = _centroids()
    c["n_events"], c["n_on"] = 20, [3, 20, n_on, 0]
    pd.DataFrame({k: c[k] for k in c.dtype.names}).to_csv(tmp_path / "c.csv", index=False)
    with pytest.raises(FormatError, match=rf"c.csv.*row 2: column 'n_on' = {n_on} is not in 0..n_events \(20\)"):
        io.read_centroids(tmp_path / "c.csv")
    legacy = pd.DataFrame({k: c[k] for k in c.dtype.names if k != "n_on"})  # before n_on
    legacy.to_csv(tmp_path / "old.csv", index=False)
    assert np.all(io.read_centroids(tmp_path / "old.csv")["n_on"] == 0)


def test_times_in_the_other_unit_than_the_layout_says_are_warned(tmp_path):
    # headerless rows are seconds (RPG): whole µs read as seconds made a 99,447 s recording;
    # a header's t is µs: seconds read as µs all rounded to 0
    plain = tmp_path / "us.txt"
    plain.write_text("".join(f"{273_000_000 + 1000 * i} 5 7 1\n" for i in range(20)))
    with pytest.warns(evstar.EvstarWarning, match="whole numbers up to 273,019,000.*header line"):
        io.read(plain, sensor_size=(10, 10))
    named = tmp_path / "s.csv"
    named.write_text("t,x,y,p\n" + "".join(f"{0.000273 + 0.001 * i:.6f},5,7,1\n" for i in range(20)))
    with pytest.warns(evstar.EvstarWarning, match="fractional values all under 10⁴.*seconds"):
        io.read(named, sensor_size=(10, 10))
    for ok in ("t,x,y,p\n" + "".join(f"{1000 * i},5,7,1\n" for i in range(20)),
               "".join(f"{0.001 * i + 1.5:.6f} 5 7 1\n" for i in range(20))):
        (tmp_path / "ok.csv").write_text(ok)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            io.read(tmp_path / "ok.csv", sensor_size=(10, 10))


def test_imu_times_in_seconds_are_refused_and_fractional_us_warned(tmp_path):
    rows = "".join(f"{{t}},0.1,0,0,0,0,9.8\n".format(t=t) for t in (0.001, 0.002, 0.003))
    (tmp_path / "s.csv").write_text("t,gx,gy,gz,ax,ay,az\n" + rows)
    with pytest.raises(FormatError, match="s.csv: column 't' .*seconds, multiply them by 10⁶"):
        io.read_imu(tmp_path / "s.csv")
    whole = "".join(f"{t},0.1,0,0,0,0,9.8\n" for t in range(5))    # whole seconds
    (tmp_path / "w.csv").write_text("t,gx,gy,gz,ax,ay,az\n" + whole)
    with pytest.raises(FormatError, match="w.csv: column 't': samples lie a median 1 µs apart"):
        io.read_imu(tmp_path / "w.csv")
    (tmp_path / "us.csv").write_text("t,gx,gy,gz,ax,ay,az\n1000.7,0.1,0,0,0,0,9.8\n"
                                     "2000,0.1,0,0,0,0,9.8\n")
    with pytest.warns(EvstarWarning, match="1 value.*fractional µs, rounded"):
        imu = io.read_imu(tmp_path / "us.csv")
    assert imu.t.tolist() == [1001, 2000]
