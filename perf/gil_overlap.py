"""Does Python run while a Taichi kernel runs? (It does not: Taichi 1.7 holds the GIL.)

A CPU Taichi kernel of ~0.5 s and a pure-Python loop of ~0.1 s run alone, then together
(the loop in a second thread, started just before the kernel). If the launch released
the GIL, the loop would finish within ~its own time while the kernel runs; it finishes
only after the kernel. So evstar's Python stages and its kernels cannot overlap in
threads, and the pipeline's wall time is at least its CPU time over the cores
(perf/bench_pipeline.py --fields reports both).

    python perf/gil_overlap.py

Writes perf/results/gil_overlap.json and .md; prints the table.
"""
import pathlib
import threading
import time

import numpy as np

from evstar import backends, profiling

RESULTS = pathlib.Path(__file__).parent / "results"
COLUMNS = [("case", "case", ""), ("kernel_s", "kernel s", ".3f"), ("python_s", "Python loop s", ".3f")]


def main():
    ti = backends.taichi("cpu")

    @ti.kernel
    def busy(a: ti.types.ndarray(), n: ti.i32):
        for i in range(a.shape[0]):
            s = 0.0
            for j in range(n):
                s += ti.sin(s + j)
            a[i] = s

    def loop():
        t = time.perf_counter()
        s = 0
        for i in range(3_000_000):
            s += i
        return time.perf_counter() - t

    a = np.zeros(2, np.float32)
    busy(a, 10)                       # compile
    py_alone = loop()
    t = time.perf_counter()
    busy(a, 20_000_000)
    kernel_alone = time.perf_counter() - t
    out = {}
    th = threading.Thread(target=lambda: out.setdefault("py", loop()))
    t = time.perf_counter()
    th.start()
    busy(a, 20_000_000)
    kernel_both = time.perf_counter() - t
    th.join()
    rows = [{"case": "alone", "kernel_s": kernel_alone, "python_s": py_alone},
            {"case": "together (loop in a thread)", "kernel_s": kernel_both, "python_s": out["py"]}]
    text = profiling.table(rows, COLUMNS)
    profiling.write_report(RESULTS, "gil_overlap", rows, "A Python thread during a Taichi kernel",
                           text, {})
    print(text)


if __name__ == "__main__":
    main()
