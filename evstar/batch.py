"""Many recordings at once on Dask distributed: one task per recording, each doing what
`evstar run` does (evstar.runs.run_recording) into OUTDIR/<file stem>/.

    from evstar import Config, batch
    summary = batch.run_many(["night/*.h5"], Config(), "out")   # a pandas DataFrame

The summary (OUTDIR/summary.csv and summary.parquet) has one row per input: a recording
that fails (corrupt, unreadable) is a row with status "failed" and its one-line error, and
never stops the others. Reruns are resumable: a folder whose completion marker
(.evstar-batch.json, written last) matches the fingerprints of the input and of every other
file the run reads (IMU, camera, truth, pixel-lag file, by resolved path) and the
configuration is skipped (status ok, skipped true); force=True redoes it.
"""
from __future__ import annotations

import collections.abc
import contextlib
import glob
import hashlib
import json
import numbers
import os
import pathlib
import time
import uuid

from .errors import BackendError, EvstarError, ParameterError, ParameterTypeError

#: summary columns of counts (integers; empty in a failed row)
_COUNTS = ("events", "events_kept", "centroids", "tracks")
MARKER = ".evstar-batch.json"  # in each output folder; written once the run is complete
SUMMARY = ("summary.csv", "summary.parquet")
CONNECT_TIMEOUT_S = 5
_HEAD_BYTES = 1 << 20  # the fingerprint hashes the first MiB (with size and mtime)
OPTIONS = ("truth", "imu", "camera", "format", "sensor_size", "sort", "stream_above_mb",
           "imu_offset_us")
_FILES = ("truth", "imu", "camera")  # the options that name input files
#: the Dask comm schemes a scheduler address may name (distributed.comm.registry less inproc,
#: which only a client in the scheduler's own process reaches: pass client= there; ucx needs
#: its package)
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
_FIRST = ["input", "output", "status", "error", "skipped", "events", "centroids", "tracks",
          "seconds"]


def run_many(paths, config, outdir, client=None, force=False, *, workers=None, scheduler=None,
             options=None, progress=False):
    """Run every recording of `paths` (files or glob patterns) with `config` into
    `outdir`/<stem>/ and return the summary DataFrame (also written to `outdir`).

    `client` is a distributed.Client to run on; without one, `scheduler` (an address such
    as tcp://host:8786) is connected to, or else a LocalCluster of `workers` processes (the
    CPU count by default; one per recording at most) is started for the call. `options`
    are run_recording keywords shared by all recordings (format, sensor_size, camera, imu,
    sort, stream_above_mb, imu_offset_us).
    """
    import pandas as pd

    from . import backends
    from .io.atomic import check_output_dir, check_outputs
    from .outputs import check_owned

    paths, options = check_arguments(paths, config, outdir, client, workers, scheduler, options)
    inputs = expand_inputs(paths)
    if not inputs:
        raise ParameterError("no recordings given")
    backends.require(config.device)   # once, not one failed row per recording
    outdir = check_output_dir(outdir).absolute()  # workers may run in other folders
    check_outputs([outdir / name for name in SUMMARY], inputs + config.input_files())
    check_owned(outdir, SUMMARY)
    # input files by their resolved paths: another spelling of a file is the same file
    options = {k: _resolved(v) if k in _FILES and v else v for k, v in options.items()}
    lag = config.estimate.pixel_lag_file
    if lag is not None:
        config = config.replace(**{"estimate.pixel_lag_file": _resolved(lag)})
    files = {k: v for k, v in {**options, "pixel_lag_file": config.estimate.pixel_lag_file}.items()
             if k in (*_FILES, "pixel_lag_file") and v is not None}
    spec = config.to_dict()
    key = config_key(config, options)
    names = output_names(inputs, earlier_names(outdir))
    call = uuid.uuid4().hex[:8]  # fresh task keys: Dask would hand back an earlier call's result
    settings = backends.settings()
    if client is None and not scheduler and settings["cpu_threads"] is None:
        settings["cpu_threads"] = 1  # also for local workers restarted after a crash
    # a local worker per recording at most: more only start processes (1000 did not start
    # within 2 minutes on 2 cores)
    local = min(workers or os.cpu_count() or 1, len(inputs))
    with _client(client, local, scheduler) as c:
        futures = [c.submit(process, str(p.absolute()), str(outdir / n), spec, key, options,
                            force, settings, files, key=f"evstar-run-{n}-{call}-{i}",
                            pure=False)
                   for i, (p, n) in enumerate(zip(inputs, names))]
        rows = _gather(futures, [outdir / n for n in names], progress)
    table = pd.DataFrame([{**row, "input": str(p)} for row, p in zip(rows, inputs)])
    table = table[[c for c in _FIRST if c in table] + [c for c in table if c not in _FIRST]]
    for c in _COUNTS:   # counts stay integers where a failed row has none (pandas: NaN, float)
        if c in table:
            table[c] = table[c].astype("Int64")
    write_summary(outdir, table)
    return table


def check_arguments(paths, config, outdir, client, workers, scheduler, options):
    """ParameterTypeError / ParameterError for run_many's arguments before any work;
    returns the paths as a list and the options as a dict."""
    from distributed import Client

    from .config import Config

    path = (str, os.PathLike)
    if isinstance(paths, path):
        paths = [paths]
    elif isinstance(paths, collections.abc.Iterable) and not isinstance(paths, (bytes, dict)):
        paths = list(paths)
    if not isinstance(paths, list) or not all(isinstance(p, path) for p in paths):
        raise ParameterTypeError(f"run_many: paths must be a path or a list of paths, got {paths!r}")
    for p in paths:
        if not str(p).strip():   # Path("") is the current folder: never meant as a recording
            raise ParameterError(f"run_many: paths must name recordings, got an empty name {str(p)!r}")
    checks = (("config", config, Config, "an evstar.Config"),
              ("outdir", outdir, path, "a str or os.PathLike"),
              ("client", client, (Client, type(None)), "a distributed.Client or None"),
              ("scheduler", scheduler, (str, type(None)), "an address string or None"),
              ("options", options, (dict, type(None)), "a dict or None"))
    for name, value, types, want in checks:
        if not isinstance(value, types):
            raise ParameterTypeError(f"run_many: {name} must be {want}, got {value!r}")
    why = scheduler_address_error(scheduler) if isinstance(scheduler, str) else None
    if why:
        raise ParameterError(f"run_many: scheduler {why}")
    if workers is not None and (not isinstance(workers, numbers.Integral)
                                or isinstance(workers, bool)):
        raise ParameterTypeError(f"run_many: workers must be an int or None, got {workers!r}")
    if workers is not None and workers < 1:
        raise ParameterError(f"run_many: workers must be >= 1, got {workers!r}")
    options = dict(options or {})
    for k, v in options.items():
        if k not in OPTIONS:
            raise ParameterError(f"run_many: unknown option {k!r}; known: {', '.join(OPTIONS)}")
        want = _bad_option(k, v)
        if want:
            raise ParameterError(f"run_many: options[{k!r}] must be {want}, got {v!r}")
    return paths, options


def scheduler_address_error(address):
    """Why `address` is no Dask scheduler address ([SCHEME://]HOST:PORT, SCHEME one of
    SCHEMES, default tcp; HOST may be [IPv6]), or None for a well-formed one (reachable or not)."""
    scheme, sep, loc = address.strip().partition("://")
    if not sep:
        scheme, loc = "tcp", address.strip()
    want = (f"must be a Dask scheduler address [SCHEME://]HOST:PORT with SCHEME one of "
            f"{', '.join(SCHEMES)} (default tcp), e.g. tcp://host:8786, got {address!r}")
    if scheme not in SCHEMES:
        return want
    if loc.startswith("["):                         # [IPv6]:PORT
        host, _, rest = loc[1:].partition("]")
        port = rest[1:] if rest.startswith(":") else ""
    else:
        host, _, port = loc.rpartition(":")
        if ":" in host:                             # an IPv6 address needs its brackets
            return want
    ok = host.strip() and "/" not in host + port and port.isdigit() and 0 < int(port) < 65536
    return None if ok else want


def _bad_option(key, value):
    """What option `key` must be where `value` is not that, else None."""
    def count(n):
        return isinstance(n, numbers.Integral) and not isinstance(n, bool) and n > 0

    if key == "sort":
        return None if isinstance(value, bool) else "True or False"
    if key == "stream_above_mb":
        from .runs import valid_stream_above_mb

        return None if valid_stream_above_mb(value) else "a finite number >= 0"
    if key == "imu_offset_us":
        from .runs import MAX_IMU_OFFSET_US, valid_imu_offset_us

        return None if valid_imu_offset_us(value) else \
            f"a whole number of µs within ±{MAX_IMU_OFFSET_US:,}"
    if value is None:
        return None
    if key == "format":
        from .io import FORMATS

        return None if isinstance(value, str) and value in FORMATS else \
            f"one of {', '.join(FORMATS)} or None"
    if key == "sensor_size":
        ok = isinstance(value, (list, tuple)) and len(value) == 2 and all(map(count, value))
        return None if ok else "two positive integers (W, H) or None"
    ok = isinstance(value, (str, os.PathLike)) and str(value).strip()  # truth, imu, camera
    return None if ok else "a file path or None"


def expand_inputs(paths):
    """Files and glob patterns -> paths in order, each once. A pattern that matches nothing
    is a ParameterError; a plain path is kept even when missing (it becomes a failed row)."""
    out = []
    for p in [paths] if isinstance(paths, (str, os.PathLike)) else paths:
        p = str(p)
        if glob.has_magic(p):
            found = sorted(glob.glob(p, recursive=True))
            if not found:
                raise ParameterError(f"{p}: no file matches this pattern")
            out += found
        else:
            out.append(p)
    return [pathlib.Path(p) for p in dict.fromkeys(out)]


def output_names(paths, earlier=None):
    """A folder name per input: the folder an earlier call gave it (`earlier`: absolute
    input path -> name, earlier_names; a rerun with more or fewer inputs must find its
    results, not rename them), else its stem, prefixed by its parent folder's name where
    stems repeat (and numbered if that still repeats or another input of the call keeps
    the name). A new input may take an earlier one's folder, as a rerun does: its run
    there is skipped if it is the same file, else redone."""
    earlier = earlier or {}
    kept = [earlier.get(str(p.absolute())) for p in paths]
    stems = [p.stem for p in paths]
    names = [k or (f"{p.absolute().parent.name}_{s}" if stems.count(s) > 1 else s)
             for p, s, k in zip(paths, stems, kept)]
    taken = {k for k in kept if k}    # kept by another input of this call
    seen = {}
    for i, n in enumerate(names):
        if kept[i]:
            continue
        seen[n] = seen.get(n, 0) + 1
        if names.count(n) > 1 or n in taken:
            k = seen[n]
            while f"{n}-{k}" in names or f"{n}-{k}" in taken:
                k += 1
            names[i] = f"{n}-{k}"
            seen[n] = k
    return names


def earlier_names(outdir):
    """Absolute input path -> output folder name, from the completion markers an earlier
    call left in `outdir`'s folders."""
    out = {}
    for marker in pathlib.Path(outdir).glob(f"*/{MARKER}"):
        try:
            out[json.loads(marker.read_text())["row"]["input"]] = marker.parent.name
        except (OSError, ValueError, KeyError, TypeError):  # damaged: that run is redone anyway
            continue
    return out


def config_key(config, options):
    """What besides the input decides a run's outputs: the configuration and shared options."""
    text = config.to_toml() + json.dumps(options, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _resolved(path):
    return str(pathlib.Path(path).expanduser().resolve())


def fingerprint(path):
    """Size, mtime and the sha256 of the first MiB: cheap, and changes with any rewrite."""
    st = os.stat(path)
    with open(path, "rb") as f:
        head = hashlib.sha256(f.read(_HEAD_BYTES)).hexdigest()
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns, "head_sha256": head}


def process(input, outdir, spec, key, options, force=False, settings=None, files=None):
    """One recording (the task run on a worker): its summary row; errors become the row's.
    `files` are the other input files by role (imu, camera, truth, pixel_lag_file): the
    result is up to date only while they are unchanged too."""
    from .config import Config

    t = time.perf_counter()
    row = {"input": input, "output": outdir, "status": "ok", "error": "", "skipped": False}
    try:
        from .io import check_readable
        from .runs import run_recording

        check_readable(input)
        stamp = {"input": fingerprint(input), "config": key,
                 "inputs": {k: fingerprint(p) if os.path.isfile(p) else None  # missing: the run says
                           for k, p in sorted((files or {}).items())}}
        done = None if force else completed(outdir, stamp)
        if done is not None:
            return {**done, "input": input, "output": outdir, "skipped": True}
        pathlib.Path(outdir, MARKER).unlink(missing_ok=True)  # a run killed now stays undone
        _configure_backends(settings)
        result = run_recording(input, outdir, Config.from_dict(spec), **options)
        row.update(metric_columns(result.metrics), seconds=time.perf_counter() - t)
        _write_marker(outdir, {**stamp, "row": row})
    except Exception as exc:  # any failure is this recording's, reported in its row
        row.update(status="failed", error=_one_line(exc), seconds=time.perf_counter() - t)
    return row


def completed(outdir, stamp):
    """The stored row when `outdir` holds a complete run of the same input and config."""
    try:
        saved = json.loads(pathlib.Path(outdir, MARKER).read_text())
        same = all(saved[k] == v for k, v in stamp.items())
        files = all(pathlib.Path(outdir, f).is_file() for f in saved["files"])
        return saved["row"] if same and files else None
    except (OSError, ValueError, KeyError, TypeError):  # no marker, or a damaged one: redo
        return None


def metric_columns(metrics):
    """The scalar metrics (events, centroids, tracks, SNR, ...) as summary columns."""
    return {k: v for k, v in metrics.items() if isinstance(v, numbers.Real)}


def write_summary(outdir, table):
    """summary.csv and summary.parquet, each written atomically."""
    from .io.atomic import atomic_path
    from .outputs import record_owned

    with atomic_path(pathlib.Path(outdir, SUMMARY[0])) as tmp:
        table.to_csv(tmp, index=False)
    with atomic_path(pathlib.Path(outdir, SUMMARY[1])) as tmp:
        table.to_parquet(tmp, index=False)
    record_owned(outdir, SUMMARY)


def _write_marker(outdir, data):
    from .io.atomic import atomic_path

    from .outputs import RUN_FILES, json_text

    files = [name for name in RUN_FILES if pathlib.Path(outdir, name).is_file()]
    with atomic_path(pathlib.Path(outdir, MARKER)) as tmp:   # NaN metrics as null (JSON)
        tmp.write_text(json_text({**data, "files": files}, default=_json) + "\n")


def _one_line(exc):
    text = str(exc).strip().splitlines()
    text = text[0] if text else ""
    return text if isinstance(exc, EvstarError) else f"{type(exc).__name__}: {text}"


def _json(v):
    return v.item() if hasattr(v, "item") else str(v)


@contextlib.contextmanager
def _client(client, workers, scheduler):
    """The given client; or one connected to `scheduler`; or a LocalCluster for the call."""
    if client is not None:
        yield client
        return
    if not scheduler:
        with local_client(workers) as c:
            yield c
        return
    from distributed import Client

    try:
        c = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise BackendError(f"cannot reach the Dask scheduler at {scheduler} within "
                           f"{CONNECT_TIMEOUT_S} s ({_one_line(exc)})") from None
    with c:
        yield c


#: worker self-monitoring that costs a few tenths of a core per worker: with one worker per
#: core it slowed the tasks by about a quarter (perf/bench_batch.py)
QUIET = {"distributed.worker.profile.enabled": False,
         "distributed.admin.system-monitor.gil.enabled": False}


@contextlib.contextmanager
def local_client(workers=None):
    """A distributed.Client of a LocalCluster of `workers` processes (the CPU count by
    default) with one thread each, whose kernels use one thread too (the processes already
    use every core)."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    n = workers or os.cpu_count() or 1
    with dask.config.set(QUIET), \
            LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                         dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as c:
        c.run(_configure_backends, {"cpu_threads": 1})
        yield c


def _gather(futures, outputs, progress):
    """Rows in input order, with a progress bar over recordings as they finish. A task that
    Dask itself lost (its worker killed again and again, e.g. out of memory) is a failed row."""
    from distributed import as_completed
    from tqdm import tqdm

    # disable=None: no bar where stderr is no terminal (a log)
    with tqdm(total=len(futures), unit="recording", disable=None if progress else True) as bar:
        for _ in as_completed(futures):
            bar.update()
    return [f.result() if f.status == "finished" else
            {"output": str(out), "status": "failed", "skipped": False,
             "error": _one_line(f.exception())} for f, out in zip(futures, outputs)]


def _configure_backends(settings):
    """Apply the settings given (a kernel cache folder set where run_many was called: one
    compile for all workers on a machine) to this worker before its first kernel."""
    from . import backends

    given = {k: v for k, v in (settings or {}).items() if v is not None}
    if given and not backends.initialised():
        backends.configure(**{**backends.settings(), **given})
