"""Readers on real recordings from real sensors (shared/data/real)."""
import numpy as np

from evstar import io


def test_davis346_aedat4_events_and_imu(real_dir):
    rec = io.read(real_dir / "emlb_demo-01.aedat4")
    assert len(rec.events) == 319_512
    assert rec.events.sensor_size == (346, 260)
    assert len(rec.imu) == 510
    # the file stores °/s: a hand-held DAVIS turns at well under 10 rad/s, i.e. small values in rad/s
    assert np.abs(rec.imu.gyro).max() < 10
    assert 900 < rec.imu.rate_hz < 1100
    assert np.all(rec.imu.accel == 0)  # this file's accelerometer fields are 0


def test_davis346_gyro_is_converted_from_degrees(real_dir):
    import faery

    raw = np.concatenate([p for tr, p in faery.aedat.Decoder(str(real_dir / "emlb_demo-01.aedat4"))
                          if tr.data_type == "imus"])
    rec = io.read(real_dir / "emlb_demo-01.aedat4")
    np.testing.assert_allclose(rec.imu.gyro[:, 0], np.radians(raw["gyroscope_x"].astype(float)))


def _evt3_time_high_span_us(path):
    """Upper bound of the file's time span from its EVT3 TIME_HIGH words (4096 µs each)."""
    data = open(path, "rb").read()
    i = 0
    while data[i:i + 1] == b"%":
        i = data.index(b"\n", i) + 1
    words = np.frombuffer(data[i:i + (len(data) - i) // 2 * 2], "<u2")
    high = words[(words >> 12) == 0x8] & 0xFFF
    return (int(high.max()) - int(high.min()) + 1) * 4096


def test_evt3_matches_reference_decode(real_dir):
    ev = io.read(real_dir / "expelliarmus_evt3_sample.raw").events
    ref = np.load(real_dir / "expelliarmus_evt3_sample.decoded.npy")
    assert len(ev) == len(ref) == 219_596
    assert ev.sensor_size == (1280, 720)
    np.testing.assert_array_equal(ev.x, ref["x"])
    np.testing.assert_array_equal(ev.y, ref["y"])
    np.testing.assert_array_equal(ev.p, ref["p"])
    # Time: identical to the reference up to its first +4097 µs step. The reference decoder
    # then adds 4096 µs at eleven places where the TIME_HIGH word does not change, which the
    # file's own words rule out: its whole span is bounded by the TIME_HIGH range.
    t, rt = ev.t - ev.t[0], ref["t"] - ref["t"][0]
    first_jump = int(np.flatnonzero(np.diff(ref["t"]) == 4097)[0]) + 1
    np.testing.assert_array_equal(t[:first_jump], rt[:first_jump])
    assert ev.t[0] == ref["t"][0]  # same time origin: faery keeps the RAW start time
    assert ev.duration_us <= _evt3_time_high_span_us(real_dir / "expelliarmus_evt3_sample.raw")
    assert rt[-1] > _evt3_time_high_span_us(real_dir / "expelliarmus_evt3_sample.raw")


def test_evt2_event_count_and_size(real_dir):
    ev = io.read(real_dir / "expelliarmus_evt2_sample.raw").events
    assert len(ev) == 539_481 and ev.sensor_size == (640, 480)
    assert np.all(np.diff(ev.t) >= 0)


def test_windows_stream_the_whole_file_in_order(real_dir):
    full = io.read(real_dir / "emlb_demo-01.aedat4").events
    parts = list(io.windows(real_dir / "emlb_demo-01.aedat4", 50_000))
    ks = [k for k, _ in parts]
    assert ks == sorted(ks) and len(ks) == len(set(ks))
    for k, w in parts:
        assert np.all((w.t - full.t[0]) // 50_000 == k)
    from evstar import Events
    assert Events.concatenate([w for _, w in parts]) == full
