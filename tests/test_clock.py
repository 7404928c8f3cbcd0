"""The IMU clock's offset against the camera's, measured on the stars' crossings
(evstar.clock), and the pipeline's gyro prior moved by it."""
import dataclasses
import pathlib
import sys

import numpy as np
import pytest

from evstar import Config, Pipeline, accuracy, sim
from evstar.imu import Imu

OFFSET_US = 4000   # the gyro's clock behind the camera's (t_camera = t_imu + 4 ms)


def untold(run):
    """The run with its IMU given as if its clock were the camera's."""
    return dataclasses.replace(run, imu=Imu(run.imu.t, run.imu.gyro, run.imu.accel))


@pytest.fixture(scope="module")
def sinusoid():
    """The paper's 10°/1 Hz sinusoid, a magnitude-3 star, its gyro 4 ms behind."""
    scene = sim.paper_sinusoid(10.0, duration_s=1.0, magnitude=3.0,
                               imu=sim.ImuSpec(time_offset_us=OFFSET_US))
    return sim.simulate(scene, seed=3)


def run_imu(run, **settings):
    cfg = Config().replace(**{"motion.compensate": "imu", **settings})
    res = Pipeline(cfg).run(run.events, run.imu, run.camera)
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    return res, err[star >= 0].mean()


def test_an_untold_clock_offset_is_measured_and_the_positions_hold(sinusoid, tmp_path):
    from evstar.outputs import summary_text

    res, err = run_imu(untold(sinusoid))
    assert res.metrics["imu_time_offset_us"] == pytest.approx(OFFSET_US, abs=200)
    line = [s for s in summary_text(res, tmp_path).splitlines() if s.startswith("IMU clock")]
    assert len(line) == 1 and f"{res.metrics['imu_time_offset_us']:+,.0f} µs" in line[0]
    # 0.43 px per ms of the offset left here: 70 µs off, 0.052 px against the told 0.023
    _, told = run_imu(sinusoid)
    assert err < 0.08 and err < told + 0.05
    off, err_off = run_imu(untold(sinusoid), **{"motion.measure_clock": False})
    assert "imu_time_offset_us" not in off.metrics and err_off > 0.5   # what it had been


def test_a_told_clock_is_left_as_it_is(sinusoid):
    """The IMU's own time_offset_us applied: no offset stands out, the rows are those of a
    run that measures none."""
    res, _ = run_imu(sinusoid)
    assert "imu_time_offset_us" not in res.metrics
    plain, _ = run_imu(sinusoid, **{"motion.measure_clock": False})
    assert res.centroids.tobytes() == plain.centroids.tobytes()   # (spread holds NaNs)


def test_a_constant_rate_tells_no_offset():
    """At a constant rate the gyro's clock does not matter and cannot be read: nothing is
    measured, whatever its noise."""
    from evstar.clock import measured_offset_us
    from evstar.estimation import chunk_crossings

    scene = sim.paper_preset(8.0, duration_s=0.6, magnitude=3.0,
                             imu=sim.ImuSpec(time_offset_us=OFFSET_US, gyro_noise_density=1.2e-3))
    run = untold(sim.simulate(scene, seed=4))
    res, _ = run_imu(run)
    crossings = chunk_crossings(run.events, res.keep, 2.5)
    assert measured_offset_us(crossings, res.centroids, run.imu, run.camera) is None
    assert "imu_time_offset_us" not in res.metrics


def test_corrected_moves_the_gyro_to_the_camera_clock():
    from evstar.clock import corrected

    imu = Imu(np.arange(0, 10_000, 1000), np.zeros((10, 3)), time_offset_us=500)
    moved = corrected(imu, -3000.0)
    assert np.array_equal(moved.t_cam, imu.t_cam + 3000) and np.array_equal(moved.gyro, imu.gyro)


def test_measure_clock_must_be_a_bool():
    with pytest.raises(ValueError, match="'motion.measure_clock'"):
        Config.from_dict({"motion": {"measure_clock": "maybe"}})


def test_the_attitude_reads_the_gyro_on_the_measured_clock():
    """evstar run hands the attitude filter the IMU moved by the offset it measured, its ends
    held over the run's rows; an IMU of a run that measured none as it is."""
    from evstar.clock import as_measured
    from evstar.extract import CENTROID_DTYPE
    from evstar.pipeline import Result

    imu = Imu(np.arange(0, 100_001, 1000), np.ones((101, 3)))
    rows = np.zeros(2, CENTROID_DTYPE)
    rows["t"] = [0, 100_000]
    moved = as_measured(imu, Result(rows, {"imu_time_offset_us": 3000.0}, {}), 5000)
    # 3 ms later, the first sample held back to the first row
    assert moved.t_cam[0] == 0 and np.array_equal(moved.t_cam[1:], imu.t_cam + 3000)
    assert as_measured(imu, Result(rows, {}, {}), 5000) is imu


def test_behind_a_pixel_lag_only_an_offset_beyond_the_lag_is_taken():
    """A dark sky's 30 Hz pixels: the profiles' lag of bright crossings errs by up to 43 %
    of itself (~2 ms here), which reads as an offset; told its clock, a run takes none, and
    5 ms ahead, untold, is measured on the least-lagged third of the pairs (all of them read
    4556 µs, 0.213 px; that third 5057, 0.031)."""
    scene = sim.paper_sinusoid(10.0, duration_s=1.0, magnitude=3.5,
                               sensor=sim.sensor_model("dark-sky"),
                               imu=sim.ImuSpec(time_offset_us=-5000))
    run = sim.simulate(scene, seed=21)
    told, told_err = run_imu(run)
    assert "imu_time_offset_us" not in told.metrics and told_err < 0.1
    res, err = run_imu(untold(run))
    assert res.metrics["imu_time_offset_us"] == pytest.approx(-5000, abs=300)
    _, before = run_imu(untold(run), **{"motion.measure_clock": False})
    assert err < 0.1 and before > 10 * err   # 0.031 against 1.656 px on this seed


@pytest.fixture(scope="module")
def hd_dark_sinusoid():
    """The independent simulator's HD sensor on its asymmetric dark sky (a saturating
    cutoff law, not evstar's), two stars on a 4°/1.5 Hz sinusoid with the gyro
    (perf/study_indep.py --fresh4 K7), 1 s."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "perf"))
    import study_indep as si

    i, spec = si.held_out_scene("K7")
    scene, sensor = si.scene_of(i, spec)
    return si.S.simulate(scene, sensor, seed=i, imu=True)


def test_behind_a_pixel_lag_the_least_lagged_pairs_must_tell_the_offset(hd_dark_sinusoid):
    """The faint crossings' lag errs by ms there, which all the pairs together read as a
    0.5 ms offset of a gyro told its clock (taken before, 0.012 -> 0.253 px); the
    least-lagged third does not confirm it, so none is taken. An untold 3 ms is confirmed
    and that third's offset taken (2752 µs; all the pairs read 2501)."""
    from evstar.clock import LEAST_LAGGED, _least_lagged

    run = hd_dark_sinusoid
    pipe = Pipeline(Config().replace(**{"motion.compensate": "imu"}))
    assert "imu_time_offset_us" not in pipe.run(run.events, run.imu, run.camera).metrics
    late = Imu(run.imu.t - 3000, run.imu.gyro)
    res = pipe.run(run.events, late, run.camera)
    assert res.metrics["imu_time_offset_us"] == pytest.approx(3000, abs=400)
    lag = np.array([5.0, 1.0, 3.0, 2.0, 4.0, 6.0])
    assert _least_lagged(lag).sum() == round(LEAST_LAGGED * len(lag))
    assert np.all(lag[_least_lagged(lag)] <= 2.0)


def test_a_known_offset_is_added_to_the_imu_whichever_file_holds_it(tmp_path):
    """--imu-offset-us / imu_offset_us: the offset `evstar run` printed, given back, moves the
    IMU of an --imu CSV or of the recording itself; a fraction or a huge value is refused."""
    from evstar import io
    from evstar.errors import ParameterError
    from evstar.runs import offset_imu, read_recording

    from conftest import random_events

    imu = Imu(np.arange(0, 10_000, 1000), np.zeros((10, 3)), time_offset_us=200)
    io.write(tmp_path / "ev.npz", random_events(), imu=imu)
    io.write_imu(tmp_path / "imu.csv", Imu(imu.t, imu.gyro))
    from_file = read_recording(tmp_path / "ev.npz", imu_offset_us=3000).imu
    from_csv = read_recording(tmp_path / "ev.npz", imu=tmp_path / "imu.csv", imu_offset_us=3000).imu
    assert from_file.time_offset_us == 3200 and from_csv.time_offset_us == 3000
    assert np.array_equal(from_csv.t_cam, imu.t + 3000)
    assert offset_imu(None, 3000) is None and offset_imu(imu, 0) is imu
    for bad in (1.5, 10**9, "3000"):
        with pytest.raises(ParameterError, match="imu_offset_us"):
            offset_imu(imu, bad)


def test_an_imu_offset_without_an_imu_is_refused_naming_the_recording(capsys, tmp_path):
    """An offset with no IMU to move would do nothing: in memory, streamed (the recording
    above stream_above_mb) and on the command line, one line naming the input and value."""
    from evstar import io
    from evstar.errors import ParameterError
    from evstar.runs import read_recording, run_recording

    from conftest import cli_fails, random_events

    path = tmp_path / "ev.npz"
    io.write(path, random_events())
    assert read_recording(path, imu_offset_us=0).imu is None
    with pytest.raises(ParameterError, match=r"ev\.npz: imu_offset_us = 3000 .* no IMU"):
        read_recording(path, imu_offset_us=3000)
    with pytest.raises(ParameterError, match=r"ev\.npz: imu_offset_us = -20 .* no IMU"):
        run_recording(str(path), str(tmp_path / "streamed"), Config(), stream_above_mb=0,
                      imu_offset_us=-20)
    assert not (tmp_path / "streamed" / "metrics.json").exists()
    cli_fails(capsys, ["run", path, "--imu-offset-us", "3000", "-o", tmp_path / "o"], 2,
              "ev.npz", "3000", "--imu FILE")


def test_the_command_line_refuses_a_fractional_imu_offset(capsys, tmp_path):
    from conftest import cli_fails

    cli_fails(capsys, ["run", tmp_path / "ev.npz", "--imu-offset-us", "1.5", "-o", tmp_path / "o"],
              2, "--imu-offset-us", "integer")


def test_batch_checks_the_imu_offset_before_any_work(tmp_path):
    from evstar.batch import run_many
    from evstar.errors import ParameterError

    with pytest.raises(ParameterError, match=r"options\['imu_offset_us'\] must be a whole number"):
        run_many([str(tmp_path / "a.npz")], Config(), tmp_path / "out",
                 options={"imu_offset_us": 2.5})


def test_levels_passing_apart_keep_an_unmeasured_lag_from_reading_as_an_offset(sinusoid):
    """A clock delays every level of a crossing alike, a pixel low-pass a dimmer one more.
    Where no lag was measured, an offset the crossings' deepest levels trail their top by
    more than DELAY_SHARE of is taken for the lag it is: none. The magnitude-3 star's
    untold 4 ms, its levels passing together, is still taken."""
    from evstar.clock import DELAY_SHARE, measured_offset_us

    run = untold(sinusoid)
    res, _ = run_imu(run)
    assert res.metrics["imu_time_offset_us"] == pytest.approx(OFFSET_US, abs=200)
    from evstar.estimation import chunk_crossings

    crossings = chunk_crossings(run.events, res.keep, 3.0)
    args = (crossings, res.centroids, run.imu, run.camera, None)
    assert abs(measured_offset_us(*args)) == pytest.approx(OFFSET_US, abs=200)
    assert measured_offset_us(*args, 0.9 * DELAY_SHARE * OFFSET_US) is not None
    assert measured_offset_us(*args, 1.1 * DELAY_SHARE * OFFSET_US) is None


def test_a_faint_stars_unmeasured_lag_on_a_dark_sky_is_not_taken_for_a_clock_offset():
    """Magnitude 6 on the paper's 10°/1 Hz sinusoid, a dark sky, the gyro on the camera's
    clock: too few multi-level crossings for a lag from the level profiles, and its 2.8-3.7
    ms lag read as a 2.7 ms offset (1.17 px behind the star). Its levels pass 1.4 ms
    apart: no offset is taken, and the lag fitted against the gyro's speed changes holds."""
    run = sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.5, magnitude=6.0,
                                          sensor=sim.sensor_model("dark-sky")), seed=3)
    res, err = run_imu(run)
    assert "imu_time_offset_us" not in res.metrics and err < 0.15


def test_a_vibration_along_the_motion_is_not_read_as_a_clock_offset(monkeypatch):
    """fresh-56: a 30 Hz, 0.03° vibration along a 9 °/s pan, the gyro told its clock. The
    crossings, each timed over a ~20 ms passage, see the vibration reversed (gain
    cos(π f T) < 0), which the search reads as half its period; the gyro's prior was then
    rejected (0.22 px). The gyro's slow turns (ALIAS_PERIODS) are a constant rate and tell
    no offset: none is taken, and the gyro carries the vibration. Without that guard the
    centroids, which the prior moved by half a period explains worse, refuse the offset."""
    from evstar.clock import measured_offset_us
    from evstar.estimation import chunk_crossings
    from evstar import clock
    from evstar.sim.scene import Scenario
    from evstar.sim.targets import star_at_pixel

    cam = sim.camera_preset("dvxplorer-lite")
    motion = sim.Jitter(sim.ConstantRate(9.0), 0.03, 30.0, (0.0, -1.0, 0.0))
    stars = star_at_pixel(cam, motion.rotation(0.4)[0], (cam.cx, cam.cy), 4.0)
    run = sim.simulate(Scenario(cam, stars, motion, 0.8), seed=56)
    res, err = run_imu(run)
    assert "imu_time_offset_us" not in res.metrics and err < 0.06
    # fast turns alone: the half-period offset, which the centroids refuse
    monkeypatch.setattr(clock, "ALIAS_PERIODS", 0.0)
    crossings = chunk_crossings(run.events, res.keep, 2.5)
    aliased = measured_offset_us(crossings, res.centroids, run.imu, run.camera)
    assert abs(abs(aliased) - 1e6 / 60) < 3000
    refused, err_refused = run_imu(run, **{"estimate.vibration": False})
    assert "imu_time_offset_us" not in refused.metrics and err_refused < 0.06


def test_a_faint_stars_lag_behind_unequal_thresholds_is_not_taken_for_a_clock_offset():
    """faint-dark of perf/study_accuracy.py: magnitude 6 on the paper's sinusoid behind a dark
    sky whose OFF threshold (0.2) is below ON (0.28), the gyro on the camera's clock. Its
    crossings hold one or two levels, which show no depth delay, and its 2.7 ms lag read as a
    −2.4 ms offset (1.24 px behind the star). Its pixels relax slower than they rise
    (LevelProfiles.slow_decay): no offset is taken, and the lag fitted against the gyro's
    speed changes holds."""
    dark = sim.sensor_model("dark-sky", threshold_on=0.28, threshold_off=0.2)
    run = sim.simulate(sim.paper_sinusoid(10.0, 1.0, duration_s=1.5, magnitude=6.0, sensor=dark),
                       seed=3)
    res, err = run_imu(run)
    assert "imu_time_offset_us" not in res.metrics and err < 0.2


def test_slow_decay_is_the_passages_off_span_over_their_on_span(monkeypatch):
    """Passages of two ON then two OFF events (a pixel each): OFF spans three times their ON
    spans tell a slow decay, equal ones do not; too few passages tell nothing; a passage the
    event cut may have shortened is left out; passages end at gaps of PASSAGE_GAP_US."""
    from evstar.level_lag import MIN_PASSAGES, PASSAGE_GAP_US, LevelProfiles

    def passages(n, off_span_us, pixels=True):
        t = np.concatenate([[0, 1000, 2000, 2000 + off_span_us] for _ in range(n)])
        t = t + (0 if pixels else np.repeat(np.arange(n) * (PASSAGE_GAP_US + 10_000), 4))
        key = np.repeat(np.arange(n) if pixels else np.zeros(n, np.int64), 4)
        return t, key, np.tile([1, 1, 0, 0], n)

    slow, even, few = LevelProfiles(), LevelProfiles(), LevelProfiles()
    slow.add_passages(*passages(MIN_PASSAGES, 3000))
    even.add_passages(*passages(MIN_PASSAGES, 1000))
    few.add_passages(*passages(MIN_PASSAGES - 1, 3000))
    assert slow.slow_decay() and not even.slow_decay() and not few.slow_decay()
    one_pixel = LevelProfiles()
    one_pixel.add_passages(*passages(MIN_PASSAGES, 3000, pixels=False))
    assert one_pixel.slow_decay()
    from evstar import level_lag

    monkeypatch.setattr(level_lag, "PASSAGE_EVENTS", 10)   # the third passage cut at 2 of 4
    cut = LevelProfiles()
    cut.add_passages(*passages(3, 3000))
    np.testing.assert_array_equal(np.concatenate(cut._spans), [3.0, 3.0])


def test_the_centroids_refuse_an_offset_that_explains_them_worse():
    """Tracks of a pan swinging 0.2 px across at 12 Hz and of a 1 Hz sinusoid, their
    centroids on the camera's clock: a prior moved 14 ms off the swing (the independent
    simulator's C8 read such an offset off its crossings) explains them worse than the
    gyro as given, and is refused; a gyro 3 ms late on the sinusoid, moved back, explains
    them better, and is taken."""
    from evstar.clock import _centroids_gain

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
    from test_smoothing import centroids

    def swing(t):   # px: a 40 px/s pan, 0.2 px across at 12 Hz
        return np.column_stack([50 + 40.0 * t, 80 + 0.2 * np.sin(2 * np.pi * 12.0 * t)])

    def sine(t):    # px: ±60 px at 1 Hz
        return np.column_stack([100 + 60.0 * np.sin(2 * np.pi * t), 40 + 0.0 * t])

    def prior_of(path, late_us):   # the path's velocity, read late_us late
        def prior(t_us, x, y):
            t = (np.asarray(t_us, float) - late_us) * 1e-6
            return (path(t + 1e-5) - path(t - 1e-5)) / 2e-5
        return prior

    rng = np.random.default_rng(12)
    config = Config()
    for path, given, moved, agree in ((swing, 0, 14_000, False), (sine, 3000, 0, True)):
        cents = np.concatenate([centroids(np.arange(100), lambda t, j=j: path(t) + [0.0, 30.0 * j],
                                          0.1, rng, track=j) for j in range(2)])
        gain, tracks = _centroids_gain(config, cents, prior_of(path, given), prior_of(path, moved))
        assert tracks == 2 and (gain >= 0) is agree


def test_an_offset_few_standard_errors_tell_is_taken_on_the_centroids_strong_evidence():
    """The independent simulator's 5°/1 Hz DAVIS346 sinusoid (perf/study_indep.py's scene
    14, two stars, 1 s), its gyro 3 ms late, untold: the crossings read 2.35 ms at 3.7
    standard errors, under MIN_Z (0.326 px before); the centroids take it by strong
    evidence (0.073 px). Told its clock, nothing is taken."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "perf"))
    import study_indep as si

    scene, sensor = si.scene_of(13, si.GRID[13])
    run = si.S.simulate(scene, sensor, seed=13, imu=True)
    pipe = Pipeline(Config().replace(**{"motion.compensate": "imu"}))
    res = pipe.run(run.events, Imu(run.imu.t - 3000, run.imu.gyro), run.camera)
    star, err = accuracy.match(res.centroids, run.truth)
    assert res.metrics["imu_time_offset_us"] == pytest.approx(3000, abs=1000)
    assert err[star >= 0].mean() < 0.12
    assert "imu_time_offset_us" not in pipe.run(run.events, run.imu, run.camera).metrics
