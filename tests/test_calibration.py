"""Pixel-lag calibration: a known lag is recovered, files round-trip, bad files are refused,
and a calibrated lag removes most of a dark sky's constant-rate trail."""
import json

import numpy as np
import pytest

import evstar
from evstar import DataError, FormatError, sim
from evstar.calibration import PixelLag, fit_pixel_lag
from evstar.cli import main
from evstar.crossings import CROSSING_DTYPE


def _lag_truth(k, speed):
    """A made-up sensor: dim pixels slow, and slower for long pulses (slow stars)."""
    return 2500.0 * np.exp(-0.15 * (k - 1)) * (1 + 100.0 / (speed + 100.0))


def _synthetic(amplitude_px=60.0, freq_hz=0.5, duration_s=4.0, n_tracks=3, seed=0):
    """Tracks moving along x as x0 + A sin(2π f t), crossing every pixel they pass; each
    crossing reported late by _lag_truth at a random brightness k."""
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * freq_hz
    t_fine = np.arange(0, duration_s, 1e-5)
    rows, tracks = [], []
    for tid in range(n_tracks):
        x0, y0 = 100.0 + 150 * tid, 50.0 + 40 * tid
        x = x0 + amplitude_px * np.sin(w * t_fine)
        v = amplitude_px * w * np.cos(w * t_fine)
        cross = np.flatnonzero(np.floor(x[1:]) != np.floor(x[:-1]))   # passes pixel boundaries
        q = np.round(x[cross + 1]).astype(int)
        speed = np.abs(v[cross])
        k = rng.integers(1, 11, len(cross))
        t_rep = t_fine[cross] * 1e6 + _lag_truth(k, speed) + rng.normal(0, 50, len(cross))
        for dy in (-1, 0, 1):                                            # three rows of pixels
            r = np.zeros(len(cross), CROSSING_DTYPE)
            r["x"], r["y"], r["t"], r["pairs"] = q, int(y0) + dy, t_rep, k
            rows.append(r)
        t_tr = np.arange(0, duration_s, 0.01)
        tr = np.zeros(len(t_tr), [("t", "<f8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
                                  ("vx", "<f8"), ("vy", "<f8")])
        tr["t"], tr["track"], tr["y"] = t_tr * 1e6, tid, y0
        tr["x"], tr["vx"] = x0 + amplitude_px * np.sin(w * t_tr), amplitude_px * w * np.cos(w * t_tr)
        tracks.append(tr)
    cr = np.concatenate(rows)
    cr = cr[np.argsort(cr["t"], kind="stable")]

    def prior(t_us, x, y):
        return np.column_stack([amplitude_px * w * np.cos(w * np.asarray(t_us) * 1e-6), 0 * x])

    return cr, np.concatenate(tracks), prior


def test_fit_recovers_a_known_lag_by_brightness_and_speed():
    cr, tracks, prior = _synthetic()
    lag = fit_pixel_lag(cr, tracks, prior)
    k = np.arange(1, 11)
    for speed in (60.0, 120.0):
        got, want = lag.lag_at(k, np.full(len(k), speed)), _lag_truth(k, speed)
        assert np.max(np.abs(got - want)) < 0.12 * want.max(), (speed, got, want)


def test_crossings_a_lag_puts_behind_a_fast_track_are_its_own():
    """A track moving +x at 1000 px/s: a faint flank crossing 2.5 px across it and 2.4 px
    behind (a 2.4 ms lag) lies 3.5 px from its position and was left out; it is within the
    reach of a point behind it. Ahead of the track, or further behind than BEHIND_PX, the
    reach alone holds; with behind_px 0 it is evstar.crossings.along_track's rule."""
    from evstar.calibration import BEHIND_PX, _assigned
    from evstar.crossings import along_track

    t = np.arange(0, 21) * 1000.0
    tracks = np.zeros(len(t), [("t", "<f8"), ("track", "<i8"), ("x", "<f8"), ("y", "<f8"),
                               ("vx", "<f8"), ("vy", "<f8")])
    tracks["t"], tracks["x"], tracks["y"], tracks["vx"] = t, 10 + t * 1e-3, 50.0, 1000.0
    at = {"behind": (-2.4, 2.5), "near": (-1.0, 1.0), "ahead": (3.5, 0.0),
          "too far behind": (-BEHIND_PX - 3.2, 0.0), "far across": (-2.0, 3.2)}
    cr = np.zeros(len(at), CROSSING_DTYPE)
    cr["t"] = 10_000.0
    cr["x"] = [20 + a for a, _ in at.values()]
    cr["y"] = [50 + c for _, c in at.values()]
    got, owner, u = _assigned(cr, tracks, BEHIND_PX)
    assert sorted(np.array(list(at))[got]) == ["behind", "near"]
    assert np.all(owner == 0) and np.allclose(u, [1.0, 0.0])
    plain, _, _ = _assigned(cr, tracks, 0.0)
    np.testing.assert_array_equal(plain, along_track(cr, tracks)[0])
    assert list(np.array(list(at))[plain]) == ["near"]


def test_a_constant_rate_cannot_be_calibrated():
    cr, tracks, _ = _synthetic()
    with pytest.raises(DataError, match="rate changes"):
        fit_pixel_lag(cr, tracks, lambda t, x, y: np.column_stack([np.full(len(t), 50.0), 0 * x]))


def test_width_terms_add_to_the_table_and_files_hold_none(tmp_path):
    table = dict(pairs=[2, 6], speed_px_s=[1.0], lag_us=[[3000.0], [1000.0]], se_us=[[0.0], [0.0]])
    # references 1000 µs + 0.9 px and 1500 µs + 1.35 px: 4000 and 6000 µs at 300 px/s
    lag = PixelLag(**table, width_slope=np.array([0.5, 0.5]),
                   width_ref_us=np.array([1000.0, 1500.0]), width_ref_px=np.array([0.9, 1.35]))
    k, w = np.array([2, 4, 6, 2]), np.array([5000.0, 5000.0, 2000.0, np.nan])
    # k = 4 lies halfway: τ 2000, reference 5000; a crossing far narrower than its k's
    # reference lags no less than nothing; one without a width lags its k's τ
    np.testing.assert_allclose(lag.lag_at(k, 300.0, w), [3500.0, 2000.0, 0.0, 3000.0])
    np.testing.assert_allclose(lag.width_at(k[:3], 150.0), [7000.0, 8750.0, 10500.0])
    np.testing.assert_allclose(lag.lag_at(k, 300.0), [3000.0, 2000.0, 1000.0, 3000.0])
    lag.save(tmp_path / "lag.json")
    again = PixelLag.load(tmp_path / "lag.json")
    np.testing.assert_allclose(again.lag_at(k, 300.0, w), lag.lag_at(k, 300.0))


def test_file_round_trip_and_bad_files(tmp_path):
    lag = PixelLag([1, 2, 4], [50.0, 200.0], [[3000, 2000], [2000, 1500], [900, 800]],
                   [[10, 20], [10, 20], [10, 20]], {"note": "x"})
    path = lag.save(tmp_path / "lag.json")
    back = PixelLag.load(path)
    np.testing.assert_allclose(back.lag_us, lag.lag_us)
    # between entries: linear in k and in log speed; beyond them the nearest entry
    assert back.lag_at([3], [100.0])[0] == pytest.approx((2000 + 1500 + 900 + 800) / 4)
    assert back.lag_at([9], [1e4])[0] == pytest.approx(800)
    doc = json.loads(path.read_text())
    for key, value, match in [("format", "other", "format must be"),
                              ("lag_us", [[1, 2]], "rows"),
                              ("pairs", "abc", "field 'pairs'"),
                              ("speed_px_s", [200.0, 50.0], "must increase")]:
        bad = tmp_path / f"bad_{key}.json"
        bad.write_text(json.dumps({**doc, key: value}))
        with pytest.raises(FormatError, match=match) as e:
            PixelLag.load(bad)
        assert str(bad) in str(e.value)
    bad = tmp_path / "bad_ratio.json"
    bad.write_text(json.dumps({**doc, "meta": {"threshold_ratio": 9}}))
    with pytest.raises(FormatError, match="meta.threshold_ratio must be a number in"):
        PixelLag.load(bad)
    with pytest.raises(FormatError, match="cannot read"):
        evstar.Pipeline(evstar.Config().replace(**{"estimate.pixel_lag_file": str(tmp_path / "no")}))


def test_calibrated_lag_removes_the_dark_sky_trail(tmp_path):
    """Calibrate on a dark-sky sinusoid (a star field, IMU), then correct a single star at a
    constant rate, magnitude and camera the calibration did not see."""
    dark = sim.SensorSpec.dark_sky()
    cal_dir = tmp_path / "cal"
    assert main(["simulate", str(cal_dir), "--preset", "davis346", "--stars", "12", "--sine", "10",
                 "1", "--sensor", "dark-sky", "--duration", "1.5", "--seed", "5"]) == 0
    out = tmp_path / "lag.json"
    assert main(["calibrate", str(cal_dir / "events.h5"), "--imu", str(cal_dir / "imu.csv"),
                 "--camera", str(cal_dir / "camera.json"), "-o", str(out)]) == 0
    run = sim.simulate(sim.paper_preset(12.0, magnitude=4.0, sensor=dark, duration_s=0.3), seed=9)
    err = {}
    for name, lag_file in (("raw", None), ("calibrated", str(out))):
        cfg = evstar.Config().replace(**{"estimate.pixel_lag_file": lag_file,
                                         "estimate.measure_lag": False})
        r = evstar.Pipeline(cfg).run(run.events, run.imu, run.camera, truth=run.truth)
        err[name] = r.metrics["centroid_error_px"]["mean"]
    assert err["raw"] > 0.25 and err["calibrated"] < err["raw"] / 2.5, err
    table = PixelLag.load(str(out))
    assert r.metrics["pixel_lag"] == {"source": "file", "lag_ms": [
        round(float(table.lag_us.min()) / 1e3, 2), round(float(table.lag_us.max()) / 1e3, 2)]}


def test_the_calibration_files_threshold_ratio_pairs_a_faint_stars_levels(tmp_path):
    """A bright field on a sensor with ON 0.25 / OFF 0.15 measures the ratio; a slow faint
    star's few runs (under 20 changes with >= 3 levels on both flanks) cannot, were paired
    at 1 and led the star along its motion. With the file's ratio they are not."""
    from evstar.calibration import calibrate

    sensor = sim.sensor_model("default", threshold_on=0.25, threshold_off=0.15)
    cam = sim.camera_preset("davis346", 16.0)
    motion = sim.Sinusoid(10.0, 1.0, R0=sim.attitude_from_radec(83.8, -5.4, 0.0))
    field = sim.hipparcos_field_along(cam, motion, 0.6, mag_limit=4.5)
    cal = sim.simulate(sim.Scenario(cam, field, motion, 0.6, sensor=sensor), seed=3)
    told = evstar.Config().replace(**{"estimate.refractory_us": sensor.refractory_us})
    lag = calibrate(cal.events, cal.imu, cal.camera, told)
    assert lag.threshold_ratio == pytest.approx(0.6, abs=0.03)
    path = lag.save(tmp_path / "lag.json")
    assert PixelLag.load(path).threshold_ratio == lag.threshold_ratio

    faint = sim.simulate(sim.paper_preset(1.0, magnitude=4.0, psf_sigma_px=1.2, sensor=sensor),
                         seed=22)
    err = {}
    for name, extra in (("auto", {}), ("file", {"estimate.pixel_lag_file": str(path)})):
        r = evstar.Pipeline(evstar.Config().replace(**extra)).run(
            faint.events, faint.imu, faint.camera, truth=faint.truth)
        err[name] = r.metrics["centroid_error_px"]["mean"]
    assert err["auto"] > 0.2 and err["file"] < err["auto"] / 2, err
