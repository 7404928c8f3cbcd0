"""evstar_kernels.reference.poisson equals scipy.stats.poisson (the thresholds of the
density filters, the hot-pixel map and the metrics come from it)."""
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import poisson as scipy_poisson

from evstar_kernels.reference import poisson


def test_isf_and_sf_equal_scipy_stats():
    rng = np.random.default_rng(0)
    mu = np.r_[10 ** rng.uniform(-4, 4, 20_000), 1e-3, 0.5, 1.0, 2.0, 100.0]
    q = np.r_[10 ** rng.uniform(-12, -0.01, 20_000), 0.5, 1e-6, 1e-3, 0.05, 0.1]
    k = np.floor(rng.uniform(-2, 500, len(mu)))
    assert np.array_equal(poisson.isf(q, mu), scipy_poisson.isf(q, mu))
    assert np.array_equal(poisson.sf(k, mu), scipy_poisson.sf(k, mu))
    assert poisson.isf(0.01, 3.0) == scipy_poisson.isf(0.01, 3.0) and np.ndim(poisson.isf(0.01, 3.0)) == 0


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_the_edges_equal_scipy_stats():
    """q 0 and 1, outside [0, 1], mu 0, tiny, huge, negative, nan; k below the support, inf."""
    qs = np.array([0.0, 1.0, 0.5, 1e-300, 1 - 1e-16, -0.1, 1.1, np.nan])
    mus = np.array([0.0, 1e-300, 2.0, 1e6, -1.0, np.nan])
    q, mu = (a.ravel() for a in np.meshgrid(qs, mus))
    np.testing.assert_array_equal(poisson.isf(q, mu), scipy_poisson.isf(q, mu))
    k, mu = (a.ravel() for a in np.meshgrid([-1.0, 0.0, 3.0, np.inf, np.nan], mus))
    np.testing.assert_array_equal(poisson.sf(k, mu), scipy_poisson.sf(k, mu))


def test_a_pipeline_run_imports_neither_scipy_stats_nor_scikit_learn():
    """Each costs ~1-2 s of a process's start (scikit-learn is the DBSCAN reference only)."""
    code = ("import sys, evstar; from evstar import sim; "
            "run = sim.simulate(sim.paper_preset(20.0, duration_s=0.05), seed=1); "
            "evstar.Pipeline().run(run.events); "
            "print(sorted(m for m in ('scipy.stats', 'sklearn') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"
