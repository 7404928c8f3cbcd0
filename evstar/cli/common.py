"""Options and helpers shared by several sub-commands."""
from __future__ import annotations


def add_input_options(p):
    p.add_argument("--format", help="input format, overriding the extension (csv, npz, hdf5, aedat4, raw, dat)")
    p.add_argument("--sensor-size", nargs=2, type=int, metavar=("W", "H"),
                   help="sensor size when the file does not say")
    p.add_argument("--camera", help="camera JSON (width, height, fx, fy, cx, cy)")
    p.add_argument("--imu", help="IMU CSV t,gx,gy,gz,ax,ay,az (µs, rad/s, m/s²)")
    p.add_argument("--sort", action="store_true",
                   help="order unsorted timestamps by time (otherwise they are an error)")


def load(args):
    """Read the input recording with the camera / IMU files the user passed."""
    from ..runs import read_recording

    return read_recording(args.input, format=args.format, sensor_size=args.sensor_size,
                          camera=getattr(args, "camera", None), imu=getattr(args, "imu", None),
                          sort=bool(getattr(args, "sort", False)))
