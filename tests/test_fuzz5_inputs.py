"""Fifth fuzz round: a distorted camera's inversion, hand-made centroid tables for the
attitude, ROC areas of degenerate inputs, streamed files whose time goes back, and
outputs evstar cannot write, named before any work."""
import subprocess
import sys

import numpy as np
import pytest

import evstar
from evstar import Camera, DataError, FormatError, attitude, io, metrics
from evstar.camera import fold_radius, radial
from evstar.extract import CENTROID_DTYPE
from evstar.io.chunks import windows as packet_windows

CAM = Camera(346, 260, 300, 300, 173, 130)


# -- Camera: distortion ------------------------------------------------------------------
def _grid(cam, n=60):
    u, v = np.meshgrid(np.linspace(-0.5, cam.width - 0.5, n), np.linspace(-0.5, cam.height - 0.5, n))
    return np.stack([u.ravel(), v.ravel()], 1)


@pytest.mark.parametrize("k1, k2, f", [(-0.3, 0.1, 300), (0.1, 0.05, 150), (-0.2, 0.05, 200),
                                       (-0.58, 0.188, 250), (0.2, -0.1, 300), (-0.05, 0.0, 300)])
def test_unproject_inverts_project_over_the_whole_sensor(k1, k2, f):
    cam = Camera(346, 260, f, f, 173, 130, k1, k2)
    uv = _grid(cam)
    rays = cam.unproject(uv)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(cam.project(rays), uv, atol=1e-8)
    # the columns form gives the same bits
    cols = np.stack(cam.unproject_columns(uv[:, 0], uv[:, 1]), 1)
    assert cols.tobytes() == rays.tobytes()


def test_five_fixed_point_steps_stay_available_and_are_what_they_were():
    # a fixed number of fixed-point steps (the motion kernels': 10) gives exactly those
    cam = Camera(346, 260, 300, 300, 173, 130, -0.3, 0.1)
    uv = _grid(cam)
    xd, yd = (uv[:, 0] - cam.cx) / cam.fx, (uv[:, 1] - cam.cy) / cam.fy
    xn, yn = xd, yd
    for _ in range(5):
        s = 1 + cam.k1 * (xn * xn + yn * yn) + cam.k2 * (xn * xn + yn * yn) ** 2
        xn, yn = xd / s, yd / s
    want = np.stack([xn, yn, np.ones_like(xn)], 1)
    want /= np.linalg.norm(want, axis=1, keepdims=True)
    np.testing.assert_allclose(cam.unproject(uv, iterations=5), want, atol=1e-15)
    off = np.abs(cam.project(cam.unproject(uv, iterations=5)) - uv).max()
    assert off > 0.01          # why the default no longer uses them


def test_one_ray_and_the_centre():
    cam = Camera(346, 260, 300, 300, 173, 130, -0.3, 0.1)
    assert cam.unproject([173.0, 130.0]).tolist() == [0.0, 0.0, 1.0]
    np.testing.assert_allclose(cam.project(cam.unproject([10.0, 250.0])), [10.0, 250.0], atol=1e-9)


@pytest.mark.parametrize("k1, k2, f", [(-0.3, 0.0, 150), (-0.5, 0.0, 100), (0.0, -0.2, 120)])
def test_distortion_folding_inside_the_sensor_is_refused(k1, k2, f):
    with pytest.raises(DataError, match=r"k1=.*folds back inside the 346x260 sensor"):
        Camera(346, 260, f, f, 173, 130, k1, k2)


def test_fold_radius_is_where_the_distortion_stops_growing():
    assert fold_radius(0.1, 0.05) == np.inf and fold_radius(0.0, 0.0) == np.inf
    rf = fold_radius(-0.3, 0.0)
    assert rf == pytest.approx(np.sqrt(1 / 0.9))
    r = np.array([rf * 0.999, rf, rf * 1.001])
    assert radial(r[1], -0.3, 0.0) > radial(r[0], -0.3, 0.0)
    assert radial(r[1], -0.3, 0.0) > radial(r[2], -0.3, 0.0)


def test_camera_json_with_folding_distortion_is_one_error(tmp_path):
    p = tmp_path / "cam.json"
    p.write_text('{"width": 346, "height": 260, "fx": 100, "fy": 100, "cx": 173, "cy": 130, "k1": -0.5}')
    with pytest.raises(evstar.EvstarError, match="folds back"):
        io.read_camera(p)


# -- attitude.estimate on hand-made tables -------------------------------------------------
def _table(**cols):
    dt = [(k, np.asarray(v).dtype) for k, v in cols.items()]
    out = np.zeros(len(next(iter(cols.values()))), dt)
    for k, v in cols.items():
        out[k] = v
    return out


@pytest.mark.parametrize("field, value, match", [
    ("t", [0.0, np.nan, 2e4], r"field 't' = nan at row 1"),
    ("t", [0.0, 1e4, 1e30], r"field 't' = 1e\+30 at row 2 is outside"),
    ("t", np.array(["0", "1", "2"]), r"field 't' must hold numbers"),
    ("track", [0.0, np.nan, 1.0], r"field 'track' = nan at row 1"),
    ("track", [0.0, 0.5, 1.0], r"field 'track' = 0.5 at row 1"),
])
def test_estimate_names_a_bad_field(field, value, match):
    cols = {"t": [0, 10_000, 20_000], "x": [100.0, 101.0, 102.0], "y": [50.0] * 3, "track": [0, 0, 0]}
    cols[field] = value
    with pytest.raises(DataError, match=match):
        attitude.estimate(_table(**cols), CAM)


def test_estimate_sigma_of_strings_is_named():
    c = _table(t=[0, 1], x=[1.0, 2.0], y=[1.0, 2.0], track=[0, 0], sigma=np.array(["a", "b"]))
    with pytest.raises(DataError, match="field 'sigma' must hold numbers"):
        attitude.estimate(c, CAM)


def test_estimate_takes_whole_float_times_and_a_table_without_optional_fields():
    c = _table(t=[0.0, 10_000.0, 20_000.0], x=[100.0, 101.0, 102.0], y=[50.0] * 3, track=[0.0, 0.0, 0.0])
    rows = attitude.estimate(c, CAM)          # three centroids of one star: no fix, no rows
    assert len(rows) == 0 and rows.dtype == attitude.ATTITUDE_DTYPE
    c = np.zeros(0, CENTROID_DTYPE)
    assert len(attitude.estimate(c, CAM)) == 0


def test_estimate_reads_centroids_as_pandas_gives_them(tmp_path):
    pd = pytest.importorskip("pandas")
    c = np.zeros(4, CENTROID_DTYPE)
    c["t"] = [0, 10_000, 20_000, 30_000]
    c["x"], c["y"], c["sigma"], c["track"] = 100.0, 50.0, 0.1, 0
    c["source"] = "measured"
    path = tmp_path / "c.csv"
    io.write_centroids(path, c)
    rec = pd.read_csv(path).to_records(index=False)   # source as objects, t int64
    assert len(attitude.estimate(rec, CAM)) == len(attitude.estimate(c, CAM)) == 0


# -- metrics: ROC of degenerate inputs -----------------------------------------------------
@pytest.mark.parametrize("is_signal, scores", [([], []), ([True, True], [0.1, 0.2]),
                                               ([False], [0.3])])
def test_roc_auc_needs_both_classes(is_signal, scores):
    with pytest.raises(DataError, match="both signal and noise"):
        metrics.roc_auc_from_scores(is_signal, scores)


def test_roc_auc_checks_lengths_and_values():
    with pytest.raises(DataError, match="equal length"):
        metrics.roc_auc_from_scores([True, False], [0.1])
    with pytest.raises(DataError, match="finite, got nan at index 1"):
        metrics.roc_auc_from_scores([True, False], [0.1, np.nan])
    with pytest.raises(DataError, match="must be numbers"):
        metrics.roc_auc_from_scores([True, False], ["a", "b"])
    assert metrics.roc_auc_from_scores([True, False, True, False], [0.9, 0.1, 0.8, 0.2]) == 1.0


# -- streamed files whose time goes back -------------------------------------------------
def _write_csv(path, t, n_pix=(64, 48), seed=0):
    rng = np.random.default_rng(seed)
    n = len(t)
    rows = np.c_[t, rng.integers(0, n_pix[0], n), rng.integers(0, n_pix[1], n), rng.integers(0, 2, n)]
    np.savetxt(path, rows, fmt="%d", delimiter=",", header="t,x,y,p", comments="")


def test_windows_name_the_file_and_the_stream_index(tmp_path):
    t = np.arange(20_000) * 50
    t[12_345] = t[12_344] - 5
    path = tmp_path / "back.csv"
    _write_csv(path, t)
    with pytest.raises(FormatError, match=r"back\.csv: event timestamps decrease at index 12345 "
                                          r"\(617200 -> 617195 µs\)"):
        list(io.windows(path, 1000, sensor_size=(64, 48)))
    # in memory the same event is named
    with pytest.raises(FormatError, match="index 12345"):
        io.read(path, sensor_size=(64, 48))


def test_pipeline_run_file_names_the_file(tmp_path):
    t = np.sort(np.random.default_rng(1).integers(0, 2_000_000, 8000))
    t[4000:] -= 1_500_000
    path = tmp_path / "jump.csv"
    _write_csv(path, t)
    cfg = evstar.Config().replace(chunk_frames=5)
    with pytest.raises(FormatError, match=r"jump\.csv: event timestamps decrease at index 4000"):
        evstar.Pipeline(cfg).run_file(path, sensor_size=(64, 48), progress=False)


def test_packet_windows_count_events_across_packets():
    def packets():
        z = np.zeros(3, np.int64)
        yield np.array([0, 10, 20]), z, z, z
        yield np.array([30, 40, 50]), z, z, z
        yield np.array([45, 60, 70]), z, z, z      # back from 50 to 45: stream index 6
    with pytest.raises(DataError, match=r"decrease at index 6 \(50 -> 45 µs\)"):
        list(packet_windows(packets(), 4, 4, 1000))

    def inside():
        z = np.zeros(4, np.int64)
        yield np.array([0, 10, 20, 30]), z, z, z
        yield np.array([40, 50, 49, 60]), z, z, z  # within the second packet: index 6
    with pytest.raises(DataError, match=r"decrease at index 6 \(50 -> 49 µs\)"):
        list(packet_windows(inside(), 4, 4, 1000))

    def fine():
        z = np.zeros(3, np.int64)
        yield np.array([0, 10, 10]), z, z, z
        yield np.array([10, 2500, 2600]), z, z, z
    got = [(k, e.t.tolist()) for k, e in packet_windows(fine(), 4, 4, 1000)]
    assert got == [(0, [0, 10, 10, 10]), (2, [2500, 2600])]


# -- command line ----------------------------------------------------------------------------
def _evstar(*args, cwd):
    return subprocess.run([sys.executable, "-m", "evstar", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def test_convert_to_npy_is_a_usage_error_before_reading(tmp_path):
    # the input does not even exist: the output name is checked first
    r = _evstar("convert", tmp_path / "missing.h5", tmp_path / "out.npy", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().count("\n") == 0
    assert "out.npy: a .npy file holds one array, not a recording; give a .npz name" in r.stderr
    assert not (tmp_path / "out.npy").exists()


def test_convert_says_one_event(tmp_path):
    src = tmp_path / "one.csv"
    src.write_text("t,x,y,p\n5,1,1,1\n")
    r = _evstar("convert", src, tmp_path / "one.h5", "--sensor-size", 8, 8, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"wrote 1 event to {tmp_path / 'one.h5'}"
    assert len(io.read(tmp_path / "one.h5").events) == 1


def test_info_gap_floor_of_repeated_times_is_no_refractory_hint(tmp_path):
    rng = np.random.default_rng(0)
    n = 3000
    path = tmp_path / "same.csv"
    rows = np.c_[np.zeros(n, int), rng.integers(0, 8, n), rng.integers(0, 8, n), rng.integers(0, 2, n)]
    np.savetxt(path, rows, fmt="%d", delimiter=",", header="t,x,y,p", comments="")
    r = _evstar("info", path, "--sensor-size", 8, 8, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    line = next(s for s in r.stdout.splitlines() if s.startswith("gap floor"))
    assert "duplicate timestamps" in line and "--refractory-us" not in line
