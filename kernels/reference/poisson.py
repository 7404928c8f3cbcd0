"""Poisson tail quantiles without scipy.stats: its import costs ~1 s of every process that
denoises (scipy.special, ~0.3 s, holds the functions scipy.stats calls for these).

Same values as scipy.stats.poisson.isf and .sf (its algorithm, for 0 < q < 1 and mu > 0:
tests compare the two on a grid).
"""
from __future__ import annotations

import numpy as np
from scipy import special


def isf(q, mu):
    """The least k with P(X > k) <= q, X ~ Poisson(mu) (mu > 0, 0 < q < 1)."""
    p = 1.0 - np.asarray(q, float)
    vals = np.ceil(special.pdtrik(p, mu))
    vals1 = np.maximum(vals - 1, 0)
    return np.where(special.pdtr(vals1, mu) >= p, vals1, vals)[()]


def sf(k, mu):
    """P(X > k), X ~ Poisson(mu): 1 below the support (k < 0)."""
    k = np.floor(np.asarray(k, float))
    return np.where(k < 0, 1.0, special.pdtrc(np.maximum(k, 0), mu))[()]
