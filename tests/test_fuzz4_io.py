"""Fourth fuzz round, files: `evstar convert` between every pair of writable formats keeps
the events exactly (zero, one, same-time, offset, negative and near-limit timestamps, 1x1
sensors, one polarity, events on the sensor's edges), and files with impossible coordinates
or polarities are one error naming the value, without a warning about a size inferred from
them first."""
import contextlib
import io as pyio
import itertools
import warnings

import numpy as np
import pytest

from evstar import EvstarWarning, Events, FormatError, io
from evstar.cli import main
from evstar.events import T_LIMIT_US

REAL = "/work/shared/data/real"
EXT = {"csv": ".csv", "npz": ".npz", "hdf5": ".h5", "aedat4": ".aedat4"}
PAIRS = list(itertools.product(EXT, EXT))


def ev(t, x, y, p, w, h):
    return Events(np.asarray(t, np.int64), np.asarray(x), np.asarray(y), np.asarray(p), w, h)


rng = np.random.default_rng(0)
CASES = {
    "zero": Events.empty(10, 8),
    "one": ev([5], [1], [2], [1], 10, 8),
    "same_t": ev([7] * 50, rng.integers(0, 10, 50), rng.integers(0, 8, 50), rng.integers(0, 2, 50), 10, 8),
    "offset": ev(np.sort(rng.integers(10**12, 10**12 + 10**6, 300)), rng.integers(0, 10, 300),
                 rng.integers(0, 8, 300), rng.integers(0, 2, 300), 10, 8),
    "near_limit": ev([T_LIMIT_US - 5, T_LIMIT_US - 1, T_LIMIT_US], [0, 1, 2], [0, 0, 0], [1, 0, 1], 3, 1),
    "one_pixel": ev(np.arange(20), np.zeros(20, int), np.zeros(20, int), np.arange(20) % 2, 1, 1),
    "all_on": ev(np.arange(20), np.arange(20) % 5, np.arange(20) % 3, np.ones(20, int), 5, 3),
    "all_off": ev(np.arange(20), np.arange(20) % 5, np.arange(20) % 3, np.zeros(20, int), 5, 3),
    "edges": ev(np.arange(4), [0, 639, 0, 639], [0, 0, 479, 479], [1, 0, 1, 0], 640, 480),
}
#: AEDAT4 stores unsigned timestamps: negative ones are for the other formats
SIGNED = {"negative": ev(np.sort(rng.integers(-10**6, 10**6, 300)), rng.integers(0, 10, 300),
                         rng.integers(0, 8, 300), rng.integers(0, 2, 300), 10, 8),
          "most_negative": ev([-T_LIMIT_US, -T_LIMIT_US + 1, 0], [0, 1, 2], [0, 0, 0], [1, 0, 1], 3, 1)}


def convert(*argv):
    out, err = pyio.StringIO(), pyio.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["convert", *map(str, argv)])
    return code, err.getvalue()


@pytest.mark.parametrize("name", list(CASES) + list(SIGNED))
def test_convert_round_trips_every_pair_exactly(tmp_path, name):
    events = {**CASES, **SIGNED}[name]
    formats = [f for f in EXT if f != "aedat4" or name not in SIGNED]
    for f in formats:
        io.write(tmp_path / f"src{EXT[f]}", events)
    for a, b in itertools.product(formats, formats):
        out = tmp_path / f"{a}_to_{b}{EXT[b]}"
        code, err = convert(tmp_path / f"src{EXT[a]}", out)
        assert code == 0, (a, b, err)
        back = io.read(out).events
        assert back == events and back.sensor_size == events.sensor_size, (a, b, back)


@pytest.mark.parametrize("name", list(SIGNED))
def test_negative_times_to_aedat4_are_one_line_and_leave_no_file(tmp_path, name):
    io.write(tmp_path / "src.h5", SIGNED[name])
    code, err = convert(tmp_path / "src.h5", tmp_path / "out.aedat4")
    assert code == 3 and err.count("\n") == 1 and "unsigned timestamps" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src.h5"]


@pytest.mark.parametrize("fmt", ["npz", "hdf5", "aedat4", "csv"])
def test_a_real_recording_converts_exactly(tmp_path, fmt):
    src = io.read(f"{REAL}/emlb_demo-01.aedat4")
    out = tmp_path / f"o{EXT[fmt]}"
    code, err = convert(f"{REAL}/emlb_demo-01.aedat4", out)
    assert code == 0, err
    back = io.read(out)
    assert back.events == src.events
    if fmt != "csv":   # CSV holds no IMU (convert says so)
        for k in ("t", "gyro", "accel"):
            assert np.array_equal(getattr(back.imu, k), getattr(src.imu, k)), k
    else:
        assert "holds no IMU" in err


# -- coordinates and polarities no sensor has: one error naming the value -------------------------
@pytest.mark.parametrize("row,message", [
    ("5,-1,1,1", "line 2: column 'x' = -1 is not a pixel index (0..65535)"),
    ("5,65536,1,1", "line 2: column 'x' = 65536 is not a pixel index"),
    ("5,1,-3,1", "line 2: column 'y' = -3 is not a pixel index"),
    ("5,1,1,2", "line 2: column 'p' = 2 is not a polarity (0, 1 or -1)"),
])
def test_csv_values_no_sensor_has_are_named_by_line(tmp_path, capsys, row, message):
    path = tmp_path / "e.csv"
    path.write_text(f"t,x,y,p\n{row}\n")
    assert main(["info", str(path)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "inferred" not in err, err


@pytest.mark.parametrize("fmt", ["npz", "hdf5"])
@pytest.mark.parametrize("x,message", [(-1, "'x' = -1 at index 0 is not a pixel index"),
                                       (70000, "'x' = 70000 at index 0 is not a pixel index")])
def test_npz_and_hdf5_coordinates_no_sensor_has(tmp_path, fmt, x, message):
    import h5py

    cols = {k: np.array([v], np.int64) for k, v in zip("txyp", (1, x, 0, 1))}
    path = tmp_path / f"e{EXT[fmt]}"
    if fmt == "npz":
        np.savez(path, **cols)
    else:
        with h5py.File(path, "w") as f:
            for k, v in cols.items():
                f[f"events/{k}"] = v
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no "inferred 0x1" warning before the error
        with pytest.raises(FormatError, match=message):
            io.read(path)


def test_a_failing_read_warns_nothing_and_a_good_one_still_warns(tmp_path):
    (tmp_path / "bad.csv").write_text("t,x,y,p\n5,1,1,1\n4,1,1,1\n")     # unsorted
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(FormatError, match="decrease"):
            io.read(tmp_path / "bad.csv")
    (tmp_path / "ok.csv").write_text("t,x,y,p\n5.5,1,1,1\n")
    with pytest.warns(EvstarWarning) as caught:
        io.read(tmp_path / "ok.csv")
    texts = [str(w.message) for w in caught]
    assert any("fractional" in t for t in texts) and any("inferred 2x2" in t for t in texts), texts
