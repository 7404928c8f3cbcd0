"""Fuzzing the readers: any input either reads as valid data or raises an EvstarError.

Seeds are the real recordings in shared/data/real (their heads, and now and then the whole
file) and small files evstar writes itself; each input applies a few random mutations (bit
flips, byte overwrites with awkward values, truncation, insertion, deletion, duplication).
EVSTAR_FUZZ_N sets the mutated inputs per format (default 600, about 30 s for the file; the
report's 10,000-per-format run sets EVSTAR_FUZZ_N=10000). Hypothesis adds structured CSV
rows and NPZ arrays.
"""
import os
import warnings

import faery
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import evstar
from evstar import Camera, EvstarError, Events, Imu, Recording, io
from evstar.events import T_LIMIT_US
from conftest import REAL, random_events

N = int(os.environ.get("EVSTAR_FUZZ_N", "600"))
HEAD = 24_000  # bytes of a real file kept as a quick seed (header plus the first packets)
AWKWARD = [b"\x00", b"\xff", b"\x7f", b"\x80", b"nan", b"inf", b"-1", b"-", b"e", b".", b",",
           b"\n", b"#", b"%", b"99999999999999999999999", b"-9223372036854775808", b"\xff" * 8]


def mutate(rng, data):
    """A copy of `data` with 1-4 random edits."""
    b = bytearray(data)
    for _ in range(int(rng.integers(1, 5))):
        op = int(rng.integers(0, 7))
        i = int(rng.integers(0, len(b) + 1))
        if op == 0 and b:  # flip bits
            for j in rng.integers(0, len(b), int(rng.integers(1, 9))):
                b[j] ^= 1 << int(rng.integers(0, 8))
        elif op == 1 and b:  # overwrite with an awkward value
            v = AWKWARD[int(rng.integers(0, len(AWKWARD)))]
            b[i:i + len(v)] = v
        elif op == 2:  # truncate
            del b[i:]
        elif op == 3:  # insert random bytes
            b[i:i] = rng.integers(0, 256, int(rng.integers(1, 17)), dtype=np.uint8).tobytes()
        elif op == 4:  # delete a range
            del b[i:i + int(rng.integers(1, 65))]
        elif op == 5:  # duplicate a range
            b[i:i] = b[i:i + int(rng.integers(1, 257))]
        elif op == 6 and b:  # random byte
            b[min(i, len(b) - 1)] = int(rng.integers(0, 256))
    return bytes(b)


def check_valid(result):
    """What a successful read must return: data that keep evstar's invariants."""
    ev = result.events if isinstance(result, Recording) else result
    assert isinstance(ev, Events)
    n = len(ev)
    assert all(len(getattr(ev, k)) == n for k in "txyp")
    assert [a.dtype for a in (ev.t, ev.x, ev.y, ev.p)] == [np.int64, np.uint16, np.uint16, np.int8]
    if n:
        assert np.all(np.diff(ev.t) >= 0) and np.abs(ev.t).max() <= T_LIMIT_US
        assert ev.x.max() < ev.width and ev.y.max() < ev.height
        assert set(np.unique(ev.p)) <= {0, 1}
    if isinstance(result, Recording) and result.imu is not None:
        assert isinstance(result.imu, Imu) and np.all(np.isfinite(result.imu.gyro))


def _read_events(path):
    return io.read(path)


def _read_sized(path):
    return io.read(path, sensor_size=(64, 48))


def _check_imu(imu):
    assert isinstance(imu, Imu) and np.all(np.diff(imu.t) >= 0) and np.all(np.isfinite(imu.accel))


def _check_camera(cam):
    assert isinstance(cam, Camera) and cam.fx > 0 and cam.width > 0


def _check_centroids(c):
    assert c.dtype == evstar.extract.CENTROID_DTYPE and c.ndim == 1


def read_or_evstar_error(path, reader, check):
    """Read `path`; None when it passes (valid data or an EvstarError), else the failure."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = reader(path)
    except EvstarError:
        return None
    except BaseException as exc:  # noqa: BLE001 - anything else is the bug we hunt
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            raise
        return f"{type(exc).__name__}: {str(exc)[:200]}"
    check(result)
    return None


# -- seeds --------------------------------------------------------------------------------
def _small_recording():
    ev = random_events(300, 64, 48, seed=3, duration_us=20_000)
    t = np.arange(0, 20_000, 1000)
    imu = Imu(t, np.full((len(t), 3), 0.1), np.full((len(t), 3), 9.8))
    return ev, imu, Camera(64, 48, 50, 50, 31.5, 23.5)


def _faery_seeds(tmp, ev):
    seeds = {}
    for version in ("evt2", "evt3"):
        packet = np.zeros(len(ev), [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("on", "?")])
        packet["t"], packet["x"], packet["y"], packet["on"] = ev.t, ev.x, ev.y, ev.p > 0
        path = tmp / f"{version}.raw"
        with faery.evt.Encoder(str(path), version, False, ev.sensor_size, True) as enc:
            enc.write({"events": packet})
        seeds[f"raw_{version}"] = path.read_bytes()
    packet = np.zeros(len(ev), [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("payload", "u1")])
    packet["t"], packet["x"], packet["y"], packet["payload"] = ev.t, ev.x, ev.y, ev.p
    with faery.dat.Encoder(str(tmp / "s.dat"), "dat2", "cd", False, ev.sensor_size) as enc:
        enc.write(packet)
    seeds["dat"] = (tmp / "s.dat").read_bytes()
    return seeds


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    """format -> (extension, reader, check, list of (seed bytes, weight))."""
    tmp = tmp_path_factory.mktemp("seeds")
    ev, imu, cam = _small_recording()
    own = {}
    for ext in ("csv", "npz", "h5", "aedat4"):
        io.write(tmp / f"s.{ext}", Recording(ev, imu if ext != "csv" else None,
                                             cam if ext in ("npz", "h5") else None))
        own[ext] = (tmp / f"s.{ext}").read_bytes()
    np.save(tmp / "s.npy", ev.to_structured())
    (tmp / "s.txt").write_text("".join(f"{t / 1e6:.6f} {x} {y} {p}\n" for t, x, y, p in
                                       zip(ev.t[:50], ev.x[:50], ev.y[:50], ev.p[:50])))
    io.write_imu(tmp / "i.csv", imu)
    io.write_camera(tmp / "c.json", cam)
    cents = np.zeros(5, evstar.extract.CENTROID_DTYPE)
    cents["t"], cents["x"], cents["y"], cents["track"] = np.arange(5) * 10, 1.5, 2.5, 1
    for ext in ("csv", "h5", "npz"):
        io.write_centroids(tmp / f"cent.{ext}", cents)
    real = {k: (REAL / f).read_bytes() for k, f in (
        ("aedat4", "emlb_demo-01.aedat4"), ("raw_evt2", "expelliarmus_evt2_sample.raw"),
        ("raw_evt3", "expelliarmus_evt3_sample.raw"), ("npy", "expelliarmus_evt3_sample.decoded.npy"))}
    made = _faery_seeds(tmp, ev)
    whole = lambda data: (data, 0.02)  # noqa: E731 - a whole real file now and then (slow)
    head = lambda data: (data[:HEAD], 1.0)  # noqa: E731
    own_seed = lambda data: (data, 1.0)  # noqa: E731
    return {
        "csv": ("csv", _read_events, check_valid, [own_seed(own["csv"])]),
        "txt": ("txt", _read_sized, check_valid, [own_seed((tmp / "s.txt").read_bytes())]),
        "npz": ("npz", _read_events, check_valid, [own_seed(own["npz"])]),
        "npy": ("npy", _read_sized, check_valid, [own_seed((tmp / "s.npy").read_bytes()),
                                                 head(real["npy"]), whole(real["npy"])]),
        "h5": ("h5", _read_events, check_valid, [own_seed(own["h5"])]),
        "aedat4": ("aedat4", _read_events, check_valid, [own_seed(own["aedat4"]),
                                                         head(real["aedat4"]), whole(real["aedat4"])]),
        "raw_evt2": ("raw", _read_events, check_valid, [own_seed(made["raw_evt2"]),
                                                        head(real["raw_evt2"]), whole(real["raw_evt2"])]),
        "raw_evt3": ("raw", _read_events, check_valid, [own_seed(made["raw_evt3"]),
                                                        head(real["raw_evt3"]), whole(real["raw_evt3"])]),
        "dat": ("dat", _read_events, check_valid, [own_seed(made["dat"])]),
        "imu": ("csv", io.read_imu, _check_imu, [own_seed((tmp / "i.csv").read_bytes())]),
        "camera": ("json", io.read_camera, _check_camera, [own_seed((tmp / "c.json").read_bytes())]),
        **{f"centroids_{ext}": (ext, io.read_centroids, _check_centroids,
                                [own_seed((tmp / f"cent.{ext}").read_bytes())]) for ext in ("csv", "h5", "npz")},
    }


FORMATS = ["csv", "txt", "npz", "npy", "h5", "aedat4", "raw_evt2", "raw_evt3", "dat", "imu",
           "camera", "centroids_csv", "centroids_h5", "centroids_npz"]


@pytest.mark.parametrize("fmt", FORMATS)
def test_mutated_files_read_or_raise_evstar_errors(seeds, tmp_path, fmt):
    ext, reader, check, pool = seeds[fmt]
    weights = np.array([w for _, w in pool])
    rng = np.random.default_rng(FORMATS.index(fmt))
    path = tmp_path / f"fuzz.{ext}"
    failures = []
    for k in range(N):
        seed = pool[int(rng.choice(len(pool), p=weights / weights.sum()))][0]
        data = mutate(rng, seed) if k else seed  # input 0: the seed as is must read
        path.write_bytes(data)
        problem = read_or_evstar_error(path, reader, check)
        if problem:
            failures.append((k, problem))
    assert not failures, f"{len(failures)} of {N} {fmt} inputs raised non-evstar errors: {failures[:5]}"


# -- structured content -------------------------------------------------------------------
CELL = st.one_of(st.integers(-2 ** 70, 2 ** 70).map(str), st.floats(allow_nan=True).map(repr),
                 st.sampled_from(["", "nan", "-inf", "1e400", "0x10", " 1", "True", "1.5", "-0"]),
                 st.text("0123456789-+.eE ", max_size=8))
HEADER = st.lists(st.sampled_from(["t", "x", "y", "p", "timestamp", "polarity", "X", "extra", ""]),
                  min_size=0, max_size=6)


@settings(max_examples=max(50, N // 3), deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(header=st.one_of(st.none(), HEADER), rows=st.lists(st.lists(CELL, min_size=1, max_size=6), max_size=6),
       sep=st.sampled_from([",", ";", " ", "\t"]))
def test_generated_csv_rows(tmp_path, header, rows, sep):
    lines = ([sep.join(header)] if header is not None else []) + [sep.join(r) for r in rows]
    path = tmp_path / "gen.csv"
    path.write_text("\n".join(lines) + "\n")
    assert read_or_evstar_error(path, _read_events, check_valid) is None


ARRAY = st.one_of(
    st.lists(st.integers(-2 ** 63, 2 ** 63 - 1), max_size=5).map(lambda v: np.array(v, np.int64)),
    st.lists(st.integers(0, 2 ** 64 - 1), max_size=5).map(lambda v: np.array(v, np.uint64)),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=5).map(np.array),
    st.lists(st.booleans(), max_size=5).map(np.array),
    st.lists(st.text(max_size=3), max_size=5).map(lambda v: np.array(v, dtype=str)),
    st.just(np.zeros((2, 2))), st.just(np.array(3)),
)


@settings(max_examples=max(50, N // 3), deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(arrays=st.dictionaries(st.sampled_from(["t", "x", "y", "p", "sensor_size", "imu_t", "imu_gyro",
                                               "imu_accel", "imu_R_cam_imu", "imu_time_offset_us",
                                               "camera", "events"]), ARRAY, max_size=12))
def test_generated_npz_arrays(tmp_path, arrays):
    path = tmp_path / "gen.npz"
    np.savez(path, **arrays)
    assert read_or_evstar_error(path, _read_events, check_valid) is None
