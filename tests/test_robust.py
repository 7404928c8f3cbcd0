"""The robust scale (evstar.robust): scipy's normal-scaled median absolute deviation, a few
outliers ignored."""
import numpy as np
import pytest
from scipy.stats import median_abs_deviation

from evstar.robust import robust_sigma


def test_robust_sigma_is_scipy_s_normal_scaled_mad():
    x = np.random.default_rng(0).normal(3.0, 2.0, (500, 3))
    assert robust_sigma(x[:, 0]) == pytest.approx(median_abs_deviation(x[:, 0], scale="normal"),
                                                  rel=1e-5)
    assert np.allclose(robust_sigma(x, axis=0), median_abs_deviation(x, axis=0, scale="normal"),
                       rtol=1e-5)
    # about a given centre: scipy's about that centre
    assert robust_sigma(x[:, 1], 0.0) == pytest.approx(
        median_abs_deviation(x[:, 1], center=lambda a, axis: 0.0, scale="normal"), rel=1e-5)


def test_a_few_outliers_do_not_move_it():
    x = np.random.default_rng(1).normal(0.0, 1.0, 2000)
    wild = x.copy()
    wild[:40] = 1e6
    assert robust_sigma(x) == pytest.approx(1.0, rel=0.06)
    assert robust_sigma(wild) == pytest.approx(robust_sigma(x), rel=0.05)
    assert np.std(wild) > 1e4
