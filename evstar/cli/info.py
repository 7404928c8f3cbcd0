"""`evstar info FILE`: what a recording holds."""
from __future__ import annotations

import json

from .common import add_input_options, load


def add_arguments(p):
    p.add_argument("input", metavar="FILE")
    add_input_options(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")


def summary(rec):
    import numpy as np

    ev = rec.events
    dur_s = ev.duration_us * 1e-6
    on = int(np.count_nonzero(ev.p))
    out = {"events": len(ev), "sensor_size": [ev.width, ev.height],
           "t_first_us": int(ev.t[0]) if len(ev) else None,
           "t_last_us": int(ev.t[-1]) if len(ev) else None, "duration_s": dur_s,
           "event_rate_hz": len(ev) / dur_s if dur_s > 0 else None,
           "on_fraction": on / len(ev) if len(ev) else None, "imu": rec.imu is not None}
    if len(ev):
        from ..crossings import sensor_hints

        out["gap_floor_us"], out["threshold_ratio"] = sensor_hints(ev)
    if rec.imu is not None:
        out.update(imu_samples=len(rec.imu), imu_rate_hz=rec.imu.rate_hz)
    if rec.camera is not None:
        out["camera"] = rec.camera.to_dict()
    return out


def run(args):
    s = summary(load(args))
    if args.json:
        print(json.dumps(s, indent=2))
        return
    print(f"file         {args.input}")
    print(f"events       {s['events']:,}")
    print(f"sensor       {s['sensor_size'][0]} x {s['sensor_size'][1]}")
    print(f"duration     {s['duration_s']:.6f} s")
    if s["event_rate_hz"]:
        print(f"event rate   {s['event_rate_hz'] / 1e6:.3f} M events/s")
    if s["on_fraction"] is not None:
        on = round(100 * s['on_fraction'], 1)   # OFF from the rounded ON: the two sum to 100
        print(f"polarity     {on:.1f} % ON / {100 - on:.1f} % OFF")
    if s.get("gap_floor_us") == 0:     # no refractory period shows through repeated times
        print("gap floor    0 µs (a pixel's same-polarity events repeat within one µs: "
              "duplicate timestamps, no refractory period to read)")
    elif s.get("gap_floor_us") is not None:
        print(f"gap floor    {s['gap_floor_us']:.0f} µs (0.1 % of a pixel's same-polarity gaps are "
              "shorter: a hint for --refractory-us, near the period where bright stars cross "
              "pixels fast on a quiet background; background and slow stars move it)")
    if s.get("threshold_ratio") is not None:
        print(f"OFF/ON ratio {s['threshold_ratio']:.3f} (from the pixels' ON and OFF runs, as "
              "--threshold-ratio auto measures it; meaningful for stars passing pixels)")
    imu = f"{s['imu_samples']:,} samples at {s['imu_rate_hz']:.1f} Hz" if s["imu"] else "none"
    print(f"IMU          {imu}")
