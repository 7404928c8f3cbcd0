"""Poisson tail quantiles without scipy.stats: its import costs ~1 s of every process that
denoises (scipy.special, ~0.3 s, holds the functions scipy.stats calls for these).

Same values as scipy.stats.poisson.isf and .sf, edges included (its algorithm; tests compare
the two on a grid and at the edges).
"""
from __future__ import annotations

import numpy as np
from scipy import special


def isf(q, mu):
    """The least k with P(X > k) <= q, X ~ Poisson(mu); -1 at q = 1, inf at q = 0, nan for
    q outside [0, 1] or mu < 0."""
    q, mu = np.asarray(q, float), np.asarray(mu, float)
    p = 1.0 - q
    with np.errstate(invalid="ignore"):
        vals = np.ceil(special.pdtrik(p, mu))
        vals1 = np.maximum(vals - 1, 0)
        out = np.where(special.pdtr(vals1, mu) >= p, vals1, vals)
    out = np.where(q == 1, -1.0, np.where(q == 0, np.inf, out))
    return np.where((q >= 0) & (q <= 1) & (mu >= 0), out, np.nan)[()]


def sf(k, mu):
    """P(X > k), X ~ Poisson(mu): 1 below the support (k < 0); nan for mu < 0 or nan k."""
    k, mu = np.floor(np.asarray(k, float)), np.asarray(mu, float)
    with np.errstate(invalid="ignore"):
        out = np.where(k < 0, 1.0, special.pdtrc(np.maximum(k, 0), mu))
    return np.where((mu >= 0) & ~np.isnan(k), out, np.nan)[()]
