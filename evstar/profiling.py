"""Throughput measurement shared by `evstar bench` and the perf/ scripts.

Medians of several runs after warm-up; compile time (the first call) reported apart.
Results are written as JSON and printed as a table.
"""
from __future__ import annotations

import json
import pathlib
import platform
import time

import numpy as np


def time_call(fn, repeats=5, warmup=1):
    """Run fn() warmup + repeats times: {'first_s', 'median_s', 'runs_s', 'cpu_median_s'};
    the first call (kernel compilation included) is timed separately. cpu_median_s: the
    process's CPU time per run (every thread), whose ratio to the wall time is the cores
    the call kept busy."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    for _ in range(max(warmup - 1, 0)):
        fn()
    runs, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        runs.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {"first_s": first, "median_s": float(np.median(runs)), "runs_s": runs,
            "cpu_median_s": float(np.median(cpu))}


def machine():
    import os

    return {"python": platform.python_version(), "machine": platform.machine(),
            "cpus": os.cpu_count(), "processor": platform.processor() or platform.machine()}


def write_results(path, rows, meta=None):
    """Write {'machine', 'meta', 'rows'} as JSON (atomically)."""
    from .io.atomic import atomic_path

    doc = {"machine": machine(), "meta": meta or {}, "rows": rows}
    with atomic_path(path) as tmp:
        pathlib.Path(tmp).write_text(json.dumps(doc, indent=2, default=float))
    return path


def write_report(results_dir, name, rows, title, text, meta=None):
    """A study's results: results_dir/name.json (write_results) and name.md, a Markdown
    page of `title` over `text` (its table)."""
    results_dir = pathlib.Path(results_dir)
    results_dir.mkdir(exist_ok=True)
    write_results(results_dir / f"{name}.json", rows, meta)
    (results_dir / f"{name}.md").write_text(f"# {title}\n\n{text}\n")


def table(rows, columns):
    """A Markdown table of `rows` (dicts) with `columns` = [(key, header, format)]."""
    head = "| " + " | ".join(h for _, h, _ in columns) + " |"
    sep = "|" + "|".join("---" for _ in columns) + "|"
    body = ["| " + " | ".join(_fmt(r.get(k), f) for k, _, f in columns) + " |" for r in rows]
    return "\n".join([head, sep, *body])


def _fmt(v, f):
    if v is None:
        return "—"
    if isinstance(v, float) and not np.isfinite(v):
        return "—"
    return format(v, f) if f else str(v)
