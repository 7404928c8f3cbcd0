"""AEDAT4 (iniVation DV) events and IMU through faery; gyro °/s and acceleration g become SI."""
from __future__ import annotations

import faery
import numpy as np

from ..errors import DataError, FormatError
from ..events import Events
from ..imu import Imu
from ..recording import Recording
from .atomic import atomic_path
from .guard import decoder_errors, int64_times, stored_size

G = 9.80665  # standard gravity, m/s² per g
AEDAT4_MAX_SIDE = 32768  # sizeX / sizeY are 16-bit signed in the format
D = faery.aedat


def _decoder(path):
    _header_description(path)
    with decoder_errors(path, "AEDAT4 file", (Exception,)):  # faery raises plain exceptions
        return D.Decoder(str(path))


def _event_track(path, dec):
    tracks = [t for t in dec.tracks() if t.data_type == "events"]
    if not tracks:
        raise FormatError(path, "no event stream in this AEDAT4 file")
    return tracks[0]


def _iterate(path, dec):
    with decoder_errors(path, "AEDAT4 file: truncated or corrupt data", (Exception,)):
        yield from dec


def _imu_from(packets):
    if not packets:
        return None
    a = np.concatenate(packets)
    gyro = np.radians(np.stack([a[f"gyroscope_{c}"] for c in "xyz"], 1).astype(np.float64))
    accel = G * np.stack([a[f"accelerometer_{c}"] for c in "xyz"], 1).astype(np.float64)
    return Imu(a["t"], gyro, accel)  # Imu range-checks the unsigned times before its cast


def extras(path):
    """(Imu or None, None): the IMU stream, in one pass that drops the event packets."""
    dec = _decoder(path)
    imu = [packet for tr, packet in _iterate(path, dec) if tr.data_type == "imus"]
    try:
        return _imu_from(imu), None
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def read(path, sensor_size=None, sort=False):
    dec = _decoder(path)
    track = _event_track(path, dec)
    w, h = stored_size(path, track.dimensions, sensor_size)  # the event stream states its size
    ev, imu = [], []
    for tr, packet in _iterate(path, dec):
        if tr.id == track.id:
            ev.append(packet)
        elif tr.data_type == "imus":
            imu.append(packet)
    try:
        a = np.concatenate(ev) if ev else np.zeros(0, ev_dtype())
        events = Events(a["t"], a["x"], a["y"], a["on"], w, h, sort=sort)
        return Recording(events, _imu_from(imu))
    except DataError as exc:
        raise FormatError(path, str(exc)) from None


def ev_dtype():
    return np.dtype([("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("on", "?")])


def packets(path, sensor_size=None):
    dec = _decoder(path)
    track = _event_track(path, dec)
    w, h = stored_size(path, track.dimensions, sensor_size)

    def gen():
        for tr, packet in _iterate(path, dec):
            if tr.id == track.id and len(packet):
                yield (int64_times(path, packet["t"]), packet["x"], packet["y"],
                       packet["on"].astype(np.int8))
    return w, h, gen()


def _node(name, path, attrs, nodes=()):
    return D.DescriptionNode(name=name, path=path, attributes=attrs, nodes=list(nodes))


def _stream(i, type_id, name, info):
    s = lambda v: D.DescriptionAttribute(attribute_type="string", value=v)  # noqa: E731
    base = f"/mainloop/Recorder/outInfo/{i}/"
    return _node(str(i), base, {"compression": s("LZ4"), "originalOutputName": s(name),
                                "typeIdentifier": s(type_id)},
                 [_node("info", base + "info/", dict(info, source=s("evstar")))])


def write(path, events, imu=None, camera=None, packet_events=20_000):
    """Events as track 0 and IMU (°/s, g) as track 1, packets interleaved by time."""
    if max(events.width, events.height) >= AEDAT4_MAX_SIDE:   # the format's int16 sizes
        raise FormatError(path, f"AEDAT4 holds sensors below {AEDAT4_MAX_SIDE} px a side, got "
                                f"{events.width}x{events.height}: write hdf5 or npz")
    i = lambda v: D.DescriptionAttribute(attribute_type="int", value=v)  # noqa: E731
    streams = [_stream(0, "EVTS", "events", {"sizeX": i(events.width), "sizeY": i(events.height)})]
    if imu is not None:
        streams.append(_stream(1, "IMUS", "imu", {}))
    desc = [_node("outInfo", "/mainloop/Recorder/outInfo/", {}, streams)]
    if len(events) and events.t[0] < 0:
        raise FormatError(path, "AEDAT4 stores unsigned timestamps; events start before t=0")
    with atomic_path(path) as tmp:
        with D.Encoder(str(tmp), desc, D.LZ4_DEFAULT) as enc:
            for track, packet in _interleave(events, imu, packet_events):
                enc.write(track, packet)


def _imu_packet(imu):
    names = ["t", "temperature"] + [f"accelerometer_{c}" for c in "xyz"] + \
            [f"gyroscope_{c}" for c in "xyz"] + [f"magnetometer_{c}" for c in "xyz"]
    out = np.zeros(len(imu), np.dtype([(n, "<u8" if n == "t" else "<f4") for n in names]))
    out["t"] = imu.t
    for k, c in enumerate("xyz"):
        out[f"accelerometer_{c}"] = imu.accel[:, k] / G
        out[f"gyroscope_{c}"] = np.degrees(imu.gyro[:, k])
    return out


def _interleave(events, imu, packet_events):
    """Yield (track, packet) in time order so readers see a causal stream."""
    ev = np.zeros(len(events), ev_dtype())
    ev["t"], ev["x"], ev["y"], ev["on"] = events.t, events.x, events.y, events.p > 0
    items = [(int(ev["t"][k]), 0, ev[k:k + packet_events]) for k in range(0, len(ev), packet_events)]
    if imu is not None and len(imu):
        ip = _imu_packet(imu)
        items += [(int(ip["t"][k]), 1, ip[k:k + 1000]) for k in range(0, len(ip), 1000)]
    for _, track, packet in sorted(items, key=lambda it: (it[0], it[1])):
        yield track, packet


MAGIC = b"#!AER-DAT4.0\r\n"


def _header_description(path):
    """The description (XML) of an AEDAT4 header, parsed from its flatbuffer IOHeader (fields
    compression, dataTablePosition, infoNode). Checked before faery sees the file: faery
    aborts the whole process when this text is not UTF-8."""
    with open(path, "rb") as f:
        head = f.read(len(MAGIC) + 4)
        if len(head) < len(MAGIC) + 4 or not head.startswith(MAGIC):
            raise FormatError(path, "not an AEDAT4 file (no '#!AER-DAT4.0' header)")
        size = int.from_bytes(head[-4:], "little")
        buf = f.read(size)
    if len(buf) < size:
        raise FormatError(path, f"truncated AEDAT4 header ({len(buf)} of {size} bytes)")

    def u(pos, n, signed=False):
        if pos < 0 or pos + n > len(buf):
            raise FormatError(path, "corrupt AEDAT4 header (offset outside the header)")
        return int.from_bytes(buf[pos:pos + n], "little", signed=signed)

    table = u(0, 4)
    vtable = table - u(table, 4, signed=True)
    field = u(vtable + 8, 2) if u(vtable, 2) > 8 else 0  # vtable: size, table size, 3 fields
    if not field:
        raise FormatError(path, "AEDAT4 header has no description")
    text = table + field + u(table + field, 4)
    n = u(text, 4)
    if text + 4 + n > len(buf):
        raise FormatError(path, "corrupt AEDAT4 header (description runs past the header)")
    try:
        return buf[text + 4:text + 4 + n].decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FormatError(path, f"corrupt AEDAT4 header (description is not UTF-8: {exc.reason} "
                                f"at byte {exc.start})") from None
