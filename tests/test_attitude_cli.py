"""`evstar attitude` and the attitude.csv of `evstar run`: header, rates, inputs, errors.

Centroids come from the simulator's truth (evstar.attitude.oracle.synthetic_run) and are
identified by the real plate solver (evstar.attitude.identify) from the CSV file.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from evstar import io, sim
from evstar.attitude import COLUMNS, read_attitude, rotation
from conftest import write_orion_pan
from evstar.cli import main

HEADER = "t,qw,qx,qy,qz,ra_deg,dec_deg,roll_deg,wx,wy,wz,n_stars,status"
CAM = sim.camera_preset("davis346", 16.0)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("attitude")
    truth, imu = write_orion_pan(d, CAM)
    io.write_imu(d / "imu.csv", imu)
    return d, truth


def cross_px(rows, truth):
    R = rotation(np.stack([rows[k] for k in ("qw", "qx", "qy", "qz")], 1))
    rv = Rotation.from_matrix(truth.rotation_at(rows["t"]) @ R).as_rotvec()
    return np.hypot(rv[:, 0], rv[:, 1]) * CAM.fx


def test_header_exactly_and_the_attitude_of_the_truth(files, capsys):
    d, truth = files
    assert main(["attitude", str(d / "cents.csv"), "-o", str(d / "a.csv"), "--camera",
                 str(d / "camera.json"), "--epoch", "1991.25"]) == 0
    assert "wrote" in capsys.readouterr().out
    assert (d / "a.csv").read_text().splitlines()[0] == HEADER == ",".join(COLUMNS)
    rows = read_attitude(d / "a.csv")
    assert len(rows) >= 25 and np.all(np.diff(rows["t"]) == 10_000)
    q = np.stack([rows[k] for k in ("qw", "qx", "qy", "qz")], 1)
    assert np.allclose(np.linalg.norm(q, axis=1), 1) and np.all(q[:, 0] >= 0)
    assert np.sqrt(np.mean(cross_px(rows, truth)[5:] ** 2)) < 0.1
    assert set(rows["status"]) <= {"fix", "tracking", "coasting"}
    ra, dec, roll = rows["ra_deg"][0], rows["dec_deg"][0], rows["roll_deg"][0]
    assert abs(dec + 5.4) < 1 and math.isfinite(ra + roll)


def test_rate_hz_1000_gives_1khz_rows_with_and_without_imu(files):
    d, truth = files
    for extra in ([], ["--imu", str(d / "imu.csv")]):
        out = d / f"k{len(extra)}.csv"
        assert main(["attitude", str(d / "cents.csv"), "-o", str(out), "--camera",
                     str(d / "camera.json"), "--rate-hz", "1000", *extra]) == 0
        rows = read_attitude(out)
        assert len(rows) > 250 and np.all(np.diff(rows["t"]) == 1000)
        assert np.sqrt(np.mean(cross_px(rows, truth)[50:] ** 2)) < 0.1


def one_line_error(capsys):
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and err.startswith("evstar attitude: error:")
    return err


def test_no_camera_is_a_one_line_error(files, capsys):
    d, _ = files
    assert main(["attitude", str(d / "cents.csv"), "-o", str(d / "x.csv")]) == 2
    assert "--camera" in one_line_error(capsys)
    assert not (d / "x.csv").exists()


def test_no_identifiable_stars_is_a_one_line_error(files, tmp_path, capsys):
    d, _ = files
    c = io.read_centroids(d / "cents.csv")
    rng = np.random.default_rng(0)
    c = c[c["track"] < 3]                                    # three stars: too few to identify
    io.write_centroids(tmp_path / "few.csv", c)
    assert main(["attitude", str(tmp_path / "few.csv"), "-o", str(tmp_path / "x.csv"),
                 "--camera", str(d / "camera.json")]) == 3
    assert "no attitude: identification:" in one_line_error(capsys)
    c = io.read_centroids(d / "cents.csv")
    c = c[c["t"] < c["t"][0] + 20_000]                        # two frames: each a full search
    c["x"], c["y"] = rng.uniform(0, CAM.width, len(c)), rng.uniform(0, CAM.height, len(c))
    io.write_centroids(tmp_path / "noise.csv", c)             # no star pattern at all
    assert main(["attitude", str(tmp_path / "noise.csv"), "-o", str(tmp_path / "x.csv"),
                 "--camera", str(d / "camera.json")]) == 3
    assert "no attitude" in one_line_error(capsys) and not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("argv,code,message", [
    (["--rate-hz", "0"], 2, "rate_hz"),
    (["--rate-hz", "2000"], 2, "rate_hz"),
    (["--epoch", "x"], 2, "epoch"),
])
def test_bad_options_are_usage_errors(files, capsys, argv, code, message):
    d, _ = files
    assert main(["attitude", str(d / "cents.csv"), "-o", str(d / "y.csv"), "--camera",
                 str(d / "camera.json"), *argv]) == code
    assert message in capsys.readouterr().err


def test_never_overwrites_an_input_and_wants_csv(files, capsys):
    d, _ = files
    before = (d / "cents.csv").read_bytes()
    assert main(["attitude", str(d / "cents.csv"), "-o", str(d / "cents.csv"), "--camera",
                 str(d / "camera.json")]) == 4
    assert "never overwrites" in one_line_error(capsys)
    assert (d / "cents.csv").read_bytes() == before
    assert main(["attitude", str(d / "cents.csv"), "-o", str(d / "a.json"), "--camera",
                 str(d / "camera.json")]) == 2            # a usage error, as convert's
    assert "-o/--output" in (err := one_line_error(capsys)) and ".csv" in err


def test_run_writes_attitude_csv_when_the_camera_is_known(tmp_path, capsys):
    traj = sim.ConstantRate(20.0, R0=sim.attitude_from_radec(83.8, -5.4))
    stars = sim.hipparcos_field_along(CAM, traj, 0.15, mag_limit=5.0)
    run = sim.simulate(sim.Scenario(CAM, stars, traj, 0.15), seed=2)
    io.write(tmp_path / "ev.h5", run.events, camera=CAM)
    assert main(["run", str(tmp_path / "ev.h5"), "-o", str(tmp_path / "out"), "--no-progress"]) == 0
    text = (tmp_path / "out" / "attitude.csv").read_text().splitlines()
    assert text[0] == HEADER and len(text) > 5
    rows = read_attitude(tmp_path / "out" / "attitude.csv")
    assert np.sqrt(np.mean(cross_px(rows, run.truth) ** 2)) < 0.5
    # a recording as `evstar attitude`'s input: the pipeline runs first, same attitude
    assert main(["attitude", str(tmp_path / "ev.h5"), "-o", str(tmp_path / "a.csv")]) == 0
    again = read_attitude(tmp_path / "a.csv")
    np.testing.assert_allclose(again["qw"], rows["qw"], atol=1e-9)
