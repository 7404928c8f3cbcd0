"""The `evstar info` and `evstar convert` commands, run in-process as a user would."""
import json
import re

import numpy as np

import evstar

from evstar import io
from evstar.cli import main


def test_info_json_on_real_aedat4(real_dir, capsys):
    assert main(["info", str(real_dir / "emlb_demo-01.aedat4"), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["events"] == 319_512 and s["sensor_size"] == [346, 260]
    assert s["imu"] and s["imu_samples"] == 510 and 900 < s["imu_rate_hz"] < 1100
    assert 0.5 < s["duration_s"] < 0.52 and 0 < s["on_fraction"] < 1
    assert 700 < s["gap_floor_us"] < 900          # this DAVIS346 fires no pixel twice within ~0.8 ms
    assert 0.9 < s["threshold_ratio"] < 1.1        # its runs: OFF and ON thresholds alike


def test_convert_raw_to_hdf5_and_back_to_csv(real_dir, tmp_path, capsys):
    out = tmp_path / "a.h5"
    assert main(["convert", str(real_dir / "expelliarmus_evt2_sample.raw"), str(out)]) == 0
    assert "539,481 events" in capsys.readouterr().out
    assert main(["convert", str(out), str(tmp_path / "a.csv")]) == 0
    assert io.read(tmp_path / "a.csv", sensor_size=(640, 480)).events == io.read(out).events


def test_input_errors_exit_3_with_message(tmp_path, capsys):
    assert main(["info", str(tmp_path / "missing.aedat4")]) == 3
    err = capsys.readouterr().err
    assert "evstar info: error:" in err and "missing.aedat4: no such file" in err


def test_info_polarity_shares_sum_to_100(tmp_path, capsys):
    # 989 of 2000 events ON: 49.45 % and 50.55 % each round up (49.5 + 50.6 = 100.1)
    p = np.zeros(2000, np.uint8)
    p[:989] = 1
    ev = evstar.Events(np.arange(2000), np.zeros(2000, int), np.zeros(2000, int), p, 4, 4)
    io.write(tmp_path / "e.csv", ev)
    assert main(["info", str(tmp_path / "e.csv")]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("polarity"))
    on, off = (float(v) for v in re.findall(r"([\d.]+) %", line))
    assert on + off == 100.0, line
