"""One recording through the whole pipeline into a result folder: what `evstar run` does,
as a library function that `evstar run` and `evstar batch` (evstar.batch) share.

    from evstar import Config, runs
    result = runs.run_recording("night.h5", "out/night", Config())
"""
from __future__ import annotations

import math
import numbers
import os

from .errors import ParameterError


def run_recording(input, outdir, config, *, truth=None, imu=None, camera=None, format=None,
                  sensor_size=None, sort=False, stream_above_mb=1024.0, progress=False,
                  imu_offset_us=0):
    """Run `config`'s pipeline on the recording at `input` and write the result folder
    `outdir` (evstar.outputs.write_run); returns the pipeline Result.

    truth, imu and camera are paths (simulator truth.npz, IMU CSV, camera JSON);
    imu_offset_us is added to the IMU's time offset, whether the CSV's or the file's. Inputs
    larger than `stream_above_mb` MB are processed in chunks with bounded memory. Output
    paths are checked before any work: an output that is one of the inputs is an OutputError.
    """
    from . import backends, outputs
    from .clock import as_measured
    from .io.atomic import check_output_dir, check_outputs
    from .pipeline import Pipeline
    from .sim import load_truth

    if not valid_stream_above_mb(stream_above_mb):
        raise ParameterError(f"stream_above_mb must be a finite number >= 0, got {stream_above_mb!r}")
    check_output_dir(outdir)
    check_outputs(outputs.run_files(outdir),
                  [input, imu, camera, truth, *config.input_files()])
    outputs.check_owned(outdir, outputs.RUN_FILES)
    truth = load_truth(truth) if truth else None
    backends.require(config.device)    # a missing GPU before the recording is read
    pipe = Pipeline(config)
    big = os.path.isfile(input) and os.path.getsize(input) > stream_above_mb * 1e6
    if big:
        if sort:   # a streamed run sees one chunk at a time: it cannot reorder the file
            raise ParameterError(f"{input}: --sort (sort=True) orders a recording in memory, but "
                                 f"it is {os.path.getsize(input) / 1e6:,.0f} MB, above "
                                 f"stream_above_mb = {stream_above_mb:g}: raise --stream-above-mb "
                                 "above its size, or sort it once (evstar convert --sort)")
        cam, imu_data = read_aux(camera, imu, imu_offset_us=imu_offset_us)
        if cam is None or imu_data is None:   # the file's own, as an in-memory run reads them
            from . import io

            held_imu, held_cam = io.extras(input, format)
            cam, imu_data = cam or held_cam, imu_data or offset_imu(held_imu, imu_offset_us)
        require_imu(imu_data, imu_offset_us, input)
        result = pipe.run_file(input, imu_data, cam, truth=truth, format=format,
                               sensor_size=sensor_size, progress=progress)
        events = None                          # streamed: no pooled-window fallback
    else:
        rec = read_recording(input, format=format, sensor_size=sensor_size, camera=camera,
                             imu=imu, sort=sort, imu_offset_us=imu_offset_us)
        if rec.imu is not None and rec.camera is not None and len(rec.events):
            _check_imu_span(rec.imu, rec.events, config, imu or input)
        result = pipe.run(rec.events, rec.imu, rec.camera, truth=truth)
        cam, imu_data, events = rec.camera, rec.imu, rec.events
    # the attitude filter reads the gyro on the clock the run measured (evstar.clock), and
    # repaired as the run read it
    imu_data = as_measured(_repaired_once(imu_data, config), result, config.motion.extrapolate_us)
    outputs.write_run(outdir, result, config, truth,
                      attitude=attitude_rows(result, cam, imu_data, events, config))
    return result


def _repaired_once(imu, config):
    """The gyro record the attitude after a run reads: repaired (evstar.gyro_repair, where
    motion.repair_gyro) and warned of once — silently where the pipeline compensated with
    it, which repaired its own copy and warned already."""
    from .gyro_repair import repair_of, repaired

    if imu is None or not config.motion.repair_gyro:
        return imu
    return repaired(imu) if config.motion.compensate == "none" else repair_of(imu)[0]


def valid_stream_above_mb(value):
    """Whether `value` is a stream_above_mb run_recording takes: a finite number >= 0 (not a
    bool; evstar batch checks its options with this before any work)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) \
        and math.isfinite(value) and value >= 0


def _check_imu_span(imu, events, config, source):
    """DataError before any work where the IMU (from `source`) does not reach the events
    within motion.extrapolate_us: compensation or the attitude after the run would refuse
    it, minutes later."""
    from .errors import DataError
    from .motion import hold_ends

    try:
        hold_ends(imu, int(events.t[0]), int(events.t[-1]), config.motion.extrapolate_us)
    except DataError as exc:
        raise DataError(f"{source}: {exc}") from None


def attitude_rows(result, camera, imu=None, events=None, config=None):
    """The attitude of a run's centroids (evstar.attitude.estimate with `config`'s
    [attitude_filter], default Config(); with the run's events, its pooled-window fallback
    too) when the camera is known, else None; empty when nothing could be identified."""
    if camera is None:
        return None
    import warnings

    from .attitude import estimate
    from .attitude.solver import FieldOfViewError
    from .config import Config
    from .errors import EvstarWarning

    try:
        return estimate(result.centroids, camera, imu, events=events,
                        **(config or Config()).attitude_options())
    except FieldOfViewError as exc:   # the run's own outputs are still written
        warnings.warn(EvstarWarning(f"no attitude: {exc}"), stacklevel=2)
        return None


def read_recording(input, *, format=None, sensor_size=None, camera=None, imu=None, sort=False,
                   imu_offset_us=0):
    """The recording at `input` with the camera / IMU files given (paths; they win over what
    the file carries); the camera also gives the sensor size when `sensor_size` is None;
    imu_offset_us is added to the IMU's time offset, whichever IMU it is."""
    from . import io

    cam, imu_data = read_aux(camera, imu, sort, imu_offset_us)
    size = sensor_size or (cam and (cam.width, cam.height)) or None
    rec = io.read(input, format=format, sensor_size=size, sort=sort)
    if cam is not None:
        rec.camera = cam
    rec.imu = imu_data if imu_data is not None else offset_imu(rec.imu, imu_offset_us)
    require_imu(rec.imu, imu_offset_us, input)
    return rec


def read_aux(camera=None, imu=None, sort=False, imu_offset_us=0):
    """(Camera or None, Imu or None) read from their own files, imu_offset_us added to the
    IMU's time offset. An IMU file of fewer than 2 samples is a FormatError naming it
    (every use of a gyro needs 2; found only after the pipeline had run, the attitude
    filter's message named no file)."""
    from . import io
    from .errors import FormatError

    cam = io.read_camera(camera) if camera else None
    imu_data = io.read_imu(imu, sort=sort) if imu else None
    if imu_data is not None and len(imu_data) < 2:
        raise FormatError(imu, f"holds {len(imu_data)} IMU sample(s); a gyro's rotation needs "
                               "at least 2")
    return cam, offset_imu(imu_data, imu_offset_us)


#: the most a known IMU clock offset may be (µs each way): a minute
MAX_IMU_OFFSET_US = 60_000_000


def valid_imu_offset_us(value):
    """Whether `value` is an imu_offset_us run_recording takes: an int (not a bool) within
    ±MAX_IMU_OFFSET_US (evstar batch checks its options with this before any work)."""
    return (isinstance(value, numbers.Integral) and not isinstance(value, bool)
            and abs(value) <= MAX_IMU_OFFSET_US)


def require_imu(imu, offset_us, source):
    """ParameterError naming `source` where an IMU clock offset is given but there is no IMU
    to move: the offset would have done nothing, silently."""
    if offset_us and imu is None:
        raise ParameterError(f"{source}: imu_offset_us = {offset_us} (--imu-offset-us) moves an "
                             "IMU's clock, but this run has no IMU: give --imu FILE, or a "
                             "recording that holds one")


def offset_imu(imu, offset_us):
    """`imu` (or None) with offset_us µs added to its time offset (t_camera = t_imu +
    offset): a clock the user knows, e.g. the one `evstar run` measured and printed."""
    if not valid_imu_offset_us(offset_us):
        raise ParameterError(f"imu_offset_us must be a whole number of µs within "
                             f"±{MAX_IMU_OFFSET_US:,}, got {offset_us!r}")
    if imu is None or not offset_us:
        return imu
    from .clock import corrected

    return corrected(imu, -int(offset_us))
