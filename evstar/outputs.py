"""The output folder of a pipeline run: tables, metrics, configuration and figures.

``write_run(outdir, result, config, truth)`` writes every file into a hidden temporary
folder beside `outdir` and moves them in together once all are written, so a folder never
holds a half-written run. A rerun replaces the files of the earlier run, and removes those
of its files this run does not write (e.g. errors.png of a run with truth); other files in
the folder are never touched, and a file named as a run's output that evstar did not write
there (no line of OWNED names it) stops the run before any work (check_owned). Temporary
folders of runs killed before they finished carry the dead process's id and are removed
by the next run writing beside them.
"""
from __future__ import annotations

import json
import os
import pathlib
import shutil
import tempfile

import numpy as np

from . import report
from .errors import EvstarError, OutputError
from .io.atomic import check_output_dir
from .metrics import snr_db

#: every file a run writes (errors.png only with truth; attitude.csv only when the camera is
#: known and a frame, or the pooled events of a window, identified)
RUN_FILES = ("centroids.csv", "tracks.csv", "metrics.json", "profile.json", "config.toml",
             "denoise.png", "tracks.png", "per_frame.png", "errors.png", "attitude.csv")
_TMP_TAG = ".evstar-tmp-"  # temporary folders: .{outdir name}.evstar-tmp-{pid}-{random}
#: the names of the files evstar wrote into a folder, one a line: it replaces or removes
#: those alone (a user's centroids.csv or errors.png beside them is no earlier run's)
OWNED = ".evstar-owned"


def run_files(outdir):
    """The paths a run into `outdir` may write (to check them against the inputs)."""
    return [pathlib.Path(outdir) / name for name in RUN_FILES]


def owned(outdir):
    """The names OWNED lists in `outdir`; where it has none, a run folder of an evstar from
    before OWNED (its config.toml loads as a Config, beside a metrics.json) owns RUN_FILES;
    else none."""
    outdir = pathlib.Path(outdir)
    try:
        return set((outdir / OWNED).read_text().split("\n")) - {""}
    except OSError:
        pass
    from .config import Config

    try:
        Config.load(outdir / "config.toml")
        json.loads((outdir / "metrics.json").read_text())
    except (OSError, ValueError, EvstarError):
        return set()
    return set(RUN_FILES)


def check_owned(outdir, names):
    """OutputError where `outdir` holds one of the files `names` that evstar did not write
    there (nothing is replaced that evstar did not write)."""
    outdir = pathlib.Path(outdir)
    mine = owned(outdir)
    foreign = sorted(n for n in names if os.path.lexists(outdir / n) and n not in mine)
    if foreign:
        raise OutputError(outdir, f"holds {', '.join(foreign)}, which evstar has no record of "
                                  f"writing there ({OWNED}); evstar replaces only its own "
                                  "files: choose another folder, or move those files away")


def record_owned(outdir, written=(), removed=()):
    """OWNED in `outdir` updated: the `written` names added, the `removed` ones dropped."""
    from .io.atomic import atomic_path

    names = (owned(outdir) - set(removed)) | set(written)
    with atomic_path(pathlib.Path(outdir) / OWNED) as tmp:
        tmp.write_text("".join(f"{n}\n" for n in sorted(names)))


def write_run(outdir, result, config, truth=None, attitude=None):
    """Write a pipeline Result (with the Config used, the optional simulator Truth and
    attitude rows of evstar.attitude.estimate) into `outdir`, created if needed; returns
    its path."""
    outdir = check_output_dir(outdir)
    check_owned(outdir, RUN_FILES)
    outdir.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(outdir)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix=f".{outdir.name}{_TMP_TAG}{os.getpid()}-",
                                        dir=outdir.parent))
    try:
        _write_all(tmp, result, config, truth)
        if attitude is not None and len(attitude):
            from .attitude import write_attitude

            write_attitude(tmp / "attitude.csv", attitude)
        outdir.mkdir(exist_ok=True)
        written = {f.name for f in tmp.iterdir()}
        for name in sorted(written):
            os.replace(tmp / name, outdir / name)
        stale = (owned(outdir) & set(RUN_FILES)) - written  # an earlier run's: would mislead
        for name in stale:
            (outdir / name).unlink(missing_ok=True)
        record_owned(outdir, written, stale)
    except OSError as exc:
        if isinstance(exc, EvstarError):
            raise
        raise OutputError(outdir, f"cannot write: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return outdir


def _write_all(folder, result, config, truth):
    from . import io

    io.write_centroids(folder / "centroids.csv", result.centroids)
    track_table(result.centroids).to_csv(folder / "tracks.csv", index=False, float_format="%.4f")
    for name, doc in (("metrics.json", result.metrics), ("profile.json", result.timings_s)):
        (folder / name).write_text(json_text(doc) + "\n")
    lag = config.estimate.pixel_lag_file
    if lag is not None:   # Config.load reads a relative one beside the file: record it whole
        config = config.replace(**{"estimate.pixel_lag_file": os.path.abspath(lag)})
    (folder / "config.toml").write_text(config.to_toml())
    figures(folder, result, truth)


def remove_stale_temporaries(outdir):
    """Remove the temporary folders of earlier runs into `outdir` whose process is gone."""
    outdir = pathlib.Path(outdir)
    prefix = f".{outdir.name}{_TMP_TAG}"
    parent = outdir.absolute().parent
    if not parent.is_dir():
        return
    for path in parent.iterdir():
        if not (path.name.startswith(prefix) and path.is_dir()):
            continue
        pid = path.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(path, ignore_errors=True)


def _alive(pid):
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def figures(folder, result, truth=None):
    """denoise.png, tracks.png, per_frame.png and, with truth, errors.png."""
    folder = pathlib.Path(folder)
    report.plot_denoise(folder / "denoise.png", result.image_before, result.image_after)
    c = result.centroids
    truth_xy = None if truth is None else truth.star_position(truth.t_us).transpose(1, 0, 2)
    report.plot_tracks(folder / "tracks.png", result.image_after, c, truth_xy)
    fc = result.frame_counts
    if fc:
        if "signal_before" in fc:
            curves = {f"SNR {w} (dB)": per_frame_snr_db(fc[f"signal_{w}"], fc[f"noise_{w}"])
                      for w in ("before", "after")}
            ylabel = "SNR per frame (dB)"
        else:
            curves, ylabel = {"events before": fc["before"], "events after": fc["after"]}, "events per frame"
        report.plot_per_frame(folder / "per_frame.png", fc["t_s"], curves, ylabel)
    if truth is not None and len(c):
        from .accuracy import match

        star, err = match(c, truth.star_position)
        ok = star >= 0
        report.plot_errors(folder / "errors.png", c["t"][ok], err[ok], labels="centroid error")


def per_frame_snr_db(signal, noise):
    """metrics.snr_db of each frame's counts (inf where no noise is left, nan where empty)."""
    return np.array([snr_db(s, n) for s, n in zip(signal, noise)], dtype=np.float64)


def track_table(centroids):
    """One row per confirmed track: first/last time and position, velocity, mean events."""
    import pandas as pd

    rows = []
    for tid in np.unique(centroids["track"][centroids["track"] >= 0]):
        c = centroids[centroids["track"] == tid]
        dt = (c["t"][-1] - c["t"][0]) * 1e-6
        rows.append({"track": int(tid), "t_first": int(c["t"][0]), "t_last": int(c["t"][-1]),
                     "n_centroids": len(c), "x_first": c["x"][0], "y_first": c["y"][0],
                     "x_last": c["x"][-1], "y_last": c["y"][-1],
                     "vx_px_s": (c["x"][-1] - c["x"][0]) / dt if dt > 0 else 0.0,
                     "vy_px_s": (c["y"][-1] - c["y"][0]) / dt if dt > 0 else 0.0,
                     "mean_events": float(c["n_events"].mean())})
    cols = ["track", "t_first", "t_last", "n_centroids", "x_first", "y_first", "x_last", "y_last",
            "vx_px_s", "vy_px_s", "mean_events"]
    return pd.DataFrame(rows, columns=cols)


def summary_text(result, outdir, steady=None):
    """The few lines `evstar run` prints: counts, SNR and errors (with truth), throughput;
    with `steady` (a second run of the same input) the first call, which compiles or loads
    the kernels, and the steady state apart."""
    m = result.metrics
    lines = [f"events        {m['events']:,} ({m['events_kept']:,} kept)",
             f"centroids     {m['centroids']:,} in {m['tracks']} track(s)"]
    if "snr_before_db" in m:
        e = m["centroid_error_px"]
        lines += [f"SNR           {_num(m['snr_before_db'], '.1f')} dB -> "
                  f"{_num(m['snr_after_db'], '.1f')} dB (signal retained "
                  f"{_num(100 * m['signal_retained'], '.1f')} %)",
                  f"centroid err  mean {_num(e['mean'], '.3f')} px, max {_num(e['max'], '.3f')} px "
                  f"({e['n']} matched)"]
    if "imu_time_offset_us" in m:   # the gyro's record was moved (evstar.clock)
        lines += [f"IMU clock     {m['imu_time_offset_us']:+,.0f} µs more time offset than the "
                  "IMU was given (measured on the stars; used)"]
    lag = m.get("pixel_lag")
    if lag and lag["source"] == "not measured":   # a delay the positions do not correct
        lines += [f"pixel lag     not measured; the levels show {lag['depth_delay_ms']:.2f} ms of "
                  "delay, held in σ (`evstar calibrate` measures the lag)"]
    elif lag:   # the crossings were moved back by it
        how = ("measured from the crossings' level profiles; `evstar calibrate` measures it "
               "against a gyro" if lag["source"] == "level profiles" else "the calibration file's")
        lines += [f"pixel lag     {lag['lag_ms'][0]:.1f}–{lag['lag_ms'][1]:.1f} ms by brightness ({how})"]
    if "background_hz" in m:   # stray light: the filters followed the background
        b = m["background_hz"]
        lines += [f"background    {b['lowest']:.2f}–{b['highest']:.2f} events/pixel/s, block by "
                  f"block ({b['window']:.2f} in the calibration window; thresholds followed it)"]
    for v in m.get("vibration", ()):   # a platform's vibration the estimator followed
        whose = f"{v['tracks']} tracks" if "tracks" in v else f"track {v['track']}"
        lines += [f"vibration     {v['hz']:g} Hz, {v['amplitude_px']:g} px {v['axis']} the motion "
                  f"({whose}; followed)"]
    if steady is None:   # a process's first run: its kernels' compile or cache load in it
        lines += [f"throughput    {_throughput(result)}",
                  "              (this process's first run, kernel compiles included; "
                  "`evstar bench` measures the steady state)"]
    else:
        lines += [f"first call    {_throughput(result)}", f"steady state  {_throughput(steady)}"]
    return "\n".join(lines + [f"wrote         {outdir}/"])


def _throughput(result):
    m, total = result.metrics, sum(result.timings_s.values())
    stages = ", ".join(f"{k} {v:.2f} s" for k, v in result.timings_s.items())
    span_s = m.get("duration_s")
    real = f", {span_s / total:.1f}x real time" if span_s and total > 0 else ""
    return f"{m['events'] / max(total, 1e-9) / 1e6:.2f} M events/s{real} ({stages})"


def _num(v, fmt):
    """v formatted, or "n/a" where it is not finite (nothing kept or matched)."""
    return format(v, fmt) if np.isfinite(v) else "n/a"


def json_text(doc, default=None):
    """`doc` as JSON, a non-finite number as null (NaN and Infinity are not JSON: an SNR
    or an error where nothing was kept or matched); default: as json.dumps takes it."""
    return json.dumps(_finite(doc), indent=2, allow_nan=False, default=default)


def _finite(v):
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_finite(x) for x in v]
    if isinstance(v, (np.integer, np.bool_)):
        return v.item()
    if isinstance(v, (float, np.floating)):
        return float(v) if np.isfinite(v) else None
    return v
