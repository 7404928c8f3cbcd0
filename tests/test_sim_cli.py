"""`evstar simulate OUT_DIR ...` end to end, in-process, reading back every file it writes."""
import numpy as np
import pytest

from evstar import io, sim
from evstar.cli import main


def test_simulate_writes_events_imu_camera_and_truth(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", str(out), "--rate", "16", "--duration", "0.2", "--seed", "4"]) == 0
    assert "events" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["camera.json", "events.h5", "imu.csv", "truth.npz"]
    rec = io.read(out / "events.h5")
    truth = sim.load_truth(out / "truth.npz")
    camera = io.read_camera(out / "camera.json")
    imu = io.read_imu(out / "imu.csv")
    assert camera == sim.camera_preset("dvxplorer-lite") == truth.camera
    assert len(truth.labels) == len(rec.events) and (truth.labels >= 0).sum() > 1000
    assert np.array_equal(imu.t, rec.imu.t) and np.allclose(imu.gyro, rec.imu.gyro)
    # the same options in the library give the same run
    again = sim.simulate(sim.paper_preset(16.0, duration_s=0.2), seed=4)
    assert again.events == rec.events and np.array_equal(again.truth.labels, truth.labels)
    # the star streaks through the centre mid-run
    assert truth.star_position([100_000], star=0)[0] == pytest.approx([camera.cx, camera.cy], abs=1e-6)


def test_simulate_sine_with_star_field_to_npz(tmp_path):
    out = tmp_path / "field"
    args = ["simulate", str(out), "--sine", "5", "2", "--stars", "4", "--preset", "davis346",
            "--duration", "0.1", "--noise-hz", "0.5", "--events-name", "ev.npz", "--ideal-imu"]
    assert main(args) == 0
    rec = io.read(out / "ev.npz")
    truth = sim.load_truth(out / "truth.npz")
    assert rec.events.sensor_size == (346, 260) and truth.n_stars == 4
    assert np.all(truth.stars.hip > 0)
    assert "Sinusoid(amplitude_deg=5.0, freq_hz=2.0" in truth.meta["trajectory"]
    w = np.linalg.norm(truth.omega_cam, axis=1).max()
    assert w == pytest.approx(np.radians(5.0) * 2 * np.pi * 2.0, rel=1e-6)
    assert np.abs(rec.imu.gyro).max() == pytest.approx(w, rel=1e-6)   # ideal IMU reads the truth


def test_simulate_user_errors_exit_2(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "a"), "--preset", "nosuch"]) == 2
    assert "unknown camera preset" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "b"), "--events-name", "ev.xyz"]) == 2
    assert "unknown extension" in capsys.readouterr().err
    (tmp_path / "file").write_text("x")
    assert main(["simulate", str(tmp_path / "file")]) == 4
    assert "not a folder" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "c"), "--rate", "4", "--sine", "10", "1"]) == 2
    assert "not allowed with argument" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "d"), "--duration", "0"]) == 2
    assert "argument --duration: must be a number in (0, 3600]" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


def test_simulate_a_star_too_faint_for_the_sensor_gives_noise_only(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "a"), "--magnitude", "30", "--duration", "0.05"]) == 0
    assert "gave no events" in capsys.readouterr().out
    assert (sim.load_truth(tmp_path / "a" / "truth.npz").labels < 0).all()


def test_simulate_notes_say_what_can_leave_a_recording_without_star_events(tmp_path, capsys):
    # a still camera: no pixel changes (the note once blamed the magnitude alone)
    assert main(["simulate", str(tmp_path / "still"), "--rate", "0", "--duration", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "does not move" in out and "--rate" in out
    # a field whose magnitude limit leaves no star
    assert main(["simulate", str(tmp_path / "none"), "--stars", "5", "--mag-limit", "-5",
                 "--duration", "0.05"]) == 0
    assert "no star lies in view" in capsys.readouterr().out


def test_simulate_a_vibrating_platform(tmp_path, capsys):
    """--jitter AMP_DEG FREQ_HZ: the star, panned along x, swings across it (in y) by the
    amplitude's pixels at that frequency; a peak rate beyond --rate's bound is refused."""
    out = tmp_path / "jitter"
    assert main(["simulate", str(out), "--rate", "8", "--jitter", "0.1", "20", "--duration", "0.2",
                 "--seed", "3"]) == 0
    truth = sim.load_truth(out / "truth.npz")
    t = np.arange(0, 200_000, 1000)
    y = truth.star_position(t, star=0)[:, 1]
    amp_px = truth.camera.fy * np.tan(np.radians(0.1))
    assert np.ptp(y) == pytest.approx(2 * amp_px, rel=0.05)
    spectrum = np.abs(np.fft.rfft(y - y.mean()))
    assert np.fft.rfftfreq(len(y), 1e-3)[np.argmax(spectrum)] == pytest.approx(20.0, abs=5.0)
    capsys.readouterr()
    assert main(["simulate", str(tmp_path / "fast"), "--jitter", "10", "100"]) == 2
    assert "--jitter 10 100" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "neg"), "--jitter", "-1", "20"]) == 2


def test_simulate_stray_light(tmp_path, capsys):
    """--noise-growth: the background changes linearly to that multiple by the end."""
    from evstar_kernels.reference.denoise import background_rate

    out = tmp_path / "stray"
    assert main(["simulate", str(out), "--rate", "8", "--duration", "0.5", "--noise-hz", "2",
                 "--noise-growth", "5", "--hot-pixels", "0", "--seed", "2"]) == 0
    ev = io.read(out / "events.h5").events
    t0, t1 = int(ev.t[0]), int(ev.t[-1])

    def rate(a, b):
        w = ev.time_window(t0 + int(a * (t1 - t0)), t0 + int(b * (t1 - t0)))
        return background_rate(w.t, w.x, w.y, w.width, w.height)

    # 2 -> 10 events/pixel/s: 2.4 over the first tenth, 9.6 over the last
    assert rate(0, 0.1) == pytest.approx(2.4, rel=0.1)
    assert rate(0.9, 1.0) == pytest.approx(9.6, rel=0.1)
    assert main(["simulate", str(tmp_path / "bad"), "--noise-growth", "0"]) == 2
    assert "--noise-growth" in capsys.readouterr().err
