"""Prophesee RAW (EVT2, EVT2.1, EVT3) and DAT through faery.

Time origin: timestamps are returned as the file encodes them (faery keeps the RAW
header's start time), so they need not start at 0; compare streams after subtracting
the first timestamp. RAW headers often omit the sensor size: it is then taken from the
`sensor_size` option, else from the camera plugin named in the header.
"""
from __future__ import annotations

import re

import faery
import numpy as np

from ..errors import DataError, FormatError
from ..events import Events
from ..recording import Recording
from .guard import decoder_errors, int64_times, is_rust_panic, one_line, stored_size

# sensor generation (from the header's plugin_name) -> size
PLUGIN_SIZES = {"gen3": (640, 480), "gen31": (640, 480), "gen4": (1280, 720),
                "gen41": (1280, 720), "imx636": (1280, 720), "imx646": (1280, 720),
                "imx8": (320, 320), "genx320": (320, 320)}


def _header_size(path):
    """(the size the header states, the size its camera plugin implies), each or None."""
    with open(path, "rb") as f:
        head = f.read(4096)
    text = head.split(b"\n% end", 1)[0].decode("latin-1")
    m = re.search(r"% geometry (\d+)x(\d+)", text) or re.search(r"width (\d+).*height (\d+)", text, re.S)
    stated = (int(m.group(1)), int(m.group(2))) if m else None
    m = re.search(r"plugin_name \S*?(gen\d+|imx\d+|genx320)", text)
    return stated, PLUGIN_SIZES.get(m.group(1)) if m else None


def _check_whole_words(path, dec, kind):
    """RAW data are 16-bit (EVT3) or 32-bit (EVT2) words: a partial word means truncation."""
    if kind != "evt":
        return
    with open(path, "rb") as f:
        data = f.read()
    i = 0
    while data[i:i + 1] == b"%":
        i = data.index(b"\n", i) + 1 if b"\n" in data[i:] else len(data)
    word = 2 if dec.version == "evt3" else 4
    if (len(data) - i) % word:
        raise FormatError(path, f"truncated: {(len(data) - i) % word} trailing byte(s) of a "
                                f"{8 * word}-bit {dec.version.upper()} word")


def _decoder(path, sensor_size):
    kind = "dat" if str(path).lower().endswith(".dat") else "evt"
    stated, plugin = _header_size(path)
    # a stated size must agree with the option; a plugin's is a guess the option overrides
    size = stored_size(path, stated, sensor_size) or plugin
    mod = faery.dat if kind == "dat" else faery.evt
    try:
        dec = mod.Decoder(str(path), size, None)
    except BaseException as exc:  # faery raises plain exceptions, or panics (BaseException)
        if not (isinstance(exc, Exception) or is_rust_panic(exc)):
            raise
        hint = "; pass sensor_size=(W, H)" if "size" in str(exc) or "dimension" in str(exc) else ""
        raise FormatError(path, f"cannot decode Prophesee {kind.upper()} file ({one_line(exc)}){hint}") from None
    _check_whole_words(path, dec, kind)
    return dec


#: faery's error for an event beyond the sensor size it decodes with
_OVERFLOW = re.compile(r"([xy]) overflow \(\1=(\d+) must be strictly smaller than (?:width|height)=(\d+)\)")


def _outside(path, exc, size, sensor_size):
    """FormatError for an event beyond the sensor (a sensor_size smaller than the camera's,
    or a header's camera plugin guessing wrong) instead of "truncated or corrupt", else None."""
    m = _OVERFLOW.search(str(exc))
    if m is None:
        return None
    stated, plugin = _header_size(path)
    if stated is not None:
        source = "that the header states"
    elif sensor_size is not None:
        source = ("given as sensor_size (command line: --sensor-size, or the --camera's width and "
                  "height)" + (f"; the header's camera plugin implies {plugin[0]}x{plugin[1]}"
                               if plugin else ""))
    else:
        source = "that the header's camera plugin implies; pass sensor_size=(W, H)"
    return FormatError(path, f"an event has {m.group(1)} = {m.group(2)}, outside the "
                             f"{size[0]}x{size[1]} sensor {source}")


def packets(path, sensor_size=None, **_):
    dec = _decoder(path, sensor_size)
    if dec.dimensions is None:
        raise FormatError(path, "the file does not give the sensor size; pass sensor_size=(W, H)")
    w, h = dec.dimensions

    def gen():
        try:
            yield from _decoded(path, dec)
        except FormatError as exc:
            raise _outside(path, exc, (w, h), sensor_size) or exc from None
    return w, h, gen()


def _decoded(path, dec):
    """(t, x, y, p) per packet of the decoder; its errors as FormatError."""
    with decoder_errors(path, "Prophesee file: truncated or corrupt data", (Exception,)):
        for packet in dec:
            ev = packet.get("events") if isinstance(packet, dict) else packet
            if ev is not None and len(ev):
                p = ev["on"] if "on" in ev.dtype.names else ev["payload"]
                yield int64_times(path, ev["t"]), ev["x"], ev["y"], p.astype(np.int8)


def read(path, sensor_size=None, sort=False):
    w, h, gen = packets(path, sensor_size)
    parts = list(gen)
    try:
        cols = [np.concatenate(c) for c in zip(*parts)] if parts else [np.zeros(0, np.int64)] * 4
        return Recording(Events(*cols, w, h, sort=sort))
    except DataError as exc:
        raise FormatError(path, str(exc)) from None
