"""The robust scale the estimators clip and weigh with."""
import numpy as np

#: a normal distribution's σ per median absolute deviation (1 / Φ⁻¹(3/4))
MAD_TO_SIGMA = 1.4826


def robust_sigma(x, center=None, axis=None):
    """MAD_TO_SIGMA × the median absolute deviation of `x` from `center` (its median when
    None; along `axis` when given): a normal σ that a few outliers do not move.
    scipy.stats.median_abs_deviation(scale="normal") computes the same at ~9x the cost a
    call on the short arrays of a track (210 against 24 µs on 200 values), which the
    estimators call per track and per pass."""
    if center is None:
        center = np.median(x, axis=axis, keepdims=axis is not None)
    return MAD_TO_SIGMA * np.median(np.abs(x - center), axis=axis)
