"""Denoising quality metrics: SNR (as Liu et al. 2025 define it), retention, ROC, ESR.

With ground-truth labels (simulations): `denoise_scores` gives the paper's SNR before and
after filtering, the fraction of signal kept and of noise removed; `hot_pixel_scores` how
well hot pixels were silenced; `roc_from_masks` / `roc_auc_from_scores` an ROC curve and
its area over a threshold sweep. Without labels (real recordings): `esr`, E-MLB's
no-reference Event Structural Ratio (Ding et al., IEEE TMM 2023).
"""
from __future__ import annotations

import numpy as np

from .errors import DataError, ParameterError, ParameterTypeError
from .events import Events
from evstar_kernels.reference import poisson


def snr_db(n_signal, n_noise):
    """SNR = 10·lg(E_signal / E_noise) of event counts (Liu et al. 2025, §4.2).

    +inf when no noise is left but signal is, -inf when only noise is, nan when empty.
    """
    s, n = float(n_signal), float(n_noise)
    if n == 0:
        return float("inf") if s > 0 else float("nan")
    if s == 0:
        return float("-inf")
    return 10.0 * np.log10(s / n)


def _bool_pair(is_signal, keep):
    is_signal = np.asarray(is_signal, bool)
    keep = np.asarray(keep, bool)
    if is_signal.shape != keep.shape or is_signal.ndim != 1:
        raise DataError(f"is_signal and keep must be 1-D and of equal length, got "
                        f"{is_signal.shape} and {keep.shape}")
    return is_signal, keep


def denoise_scores(is_signal, keep):
    """SNR before/after (dB), its gain, signal retained and noise removed (fractions).

    is_signal: bool per event (ground truth); keep: the filter's keep mask. Noise is every
    event that is not signal (background and hot pixels alike).
    """
    is_signal, keep = _bool_pair(is_signal, keep)
    s0 = int(is_signal.sum())
    n0 = len(is_signal) - s0
    s1 = int((is_signal & keep).sum())
    n1 = int((~is_signal & keep).sum())
    before, after = snr_db(s0, n0), snr_db(s1, n1)
    return {
        "signal_before": s0, "noise_before": n0, "signal_after": s1, "noise_after": n1,
        "snr_before_db": before, "snr_after_db": after, "snr_gain_db": after - before,
        "signal_retained": s1 / s0 if s0 else float("nan"),
        "noise_removed": 1.0 - n1 / n0 if n0 else float("nan"),
    }


def find_hot_pixels(events, p_value=1e-6, n_slices=8):
    """Pixels that fire improbably often, persistently: hot pixels, not a passing target.

    The stream is cut into `n_slices` equal time slices; in each, a pixel is an outlier when
    its count's Poisson upper tail (at the slice's background rate, measured on the other
    pixels) is below p_value. Hot pixels are outliers in at least half of the slices, which
    a star crossing a pixel never is. Returns flat pixel indices y·width + x.
    """
    n_pix = events.width * events.height
    if len(events) == 0:
        return np.zeros(0, np.int64)
    pix = events.y.astype(np.int64) * events.width + events.x
    edges = np.linspace(events.t[0], events.t[-1] + 1, n_slices + 1)
    cuts = np.searchsorted(events.t, edges, side="left")
    votes = np.zeros(n_pix, np.int64)
    for a, b in zip(cuts[:-1], cuts[1:]):
        counts = np.bincount(pix[a:b], minlength=n_pix)
        inliers = counts <= poisson.isf(p_value, counts.mean())
        mean = counts[inliers].mean() if inliers.any() else counts.mean()
        votes += counts > poisson.isf(p_value, mean)
    return np.flatnonzero(2 * votes >= n_slices)


def hot_pixel_scores(events, keep, hot_pixels=None):
    """How a filter treats hot pixels: the fraction of their events removed and of them silenced.

    hot_pixels: flat pixel indices (y·width + x), e.g. a simulation's truth.hot_pixels;
    found with `find_hot_pixels` when None.
    """
    keep = np.asarray(keep, bool)
    if len(keep) != len(events):
        raise DataError(f"keep has {len(keep)} entries for {len(events)} events")
    hot = find_hot_pixels(events) if hot_pixels is None else np.unique(np.asarray(hot_pixels, np.int64))
    pix = events.y.astype(np.int64) * events.width + events.x
    on_hot = np.isin(pix, hot)
    n_hot_events = int(on_hot.sum())
    still_firing = np.unique(pix[on_hot & keep])
    return {
        "hot_pixels": len(hot), "hot_events": n_hot_events,
        "hot_events_removed": 1.0 - (on_hot & keep).sum() / n_hot_events if n_hot_events else float("nan"),
        "hot_pixels_removed": 1.0 - len(still_firing) / len(hot) if len(hot) else float("nan"),
    }


def roc_from_masks(is_signal, masks):
    """ROC of a threshold sweep: one keep mask per threshold -> (fpr, tpr, auc).

    tpr = signal retained, fpr = noise kept. The curve is closed with (0, 0) and (1, 1)
    (keep nothing / keep everything) and the area taken by the trapezoid rule.
    """
    is_signal = np.asarray(is_signal, bool)
    n_sig, n_noise = int(is_signal.sum()), int((~is_signal).sum())
    if n_sig == 0 or n_noise == 0:
        raise DataError("an ROC needs both signal and noise events")
    pts = [(0.0, 0.0), (1.0, 1.0)]
    for m in masks:
        _, m = _bool_pair(is_signal, m)
        pts.append(((m & ~is_signal).sum() / n_noise, (m & is_signal).sum() / n_sig))
    pts = np.array(sorted(pts))
    fpr, tpr = pts[:, 0], np.maximum.accumulate(pts[:, 1])
    return fpr, tpr, float(np.trapezoid(tpr, fpr))


def roc_auc_from_scores(is_signal, scores):
    """Area under the ROC of 'keep iff score >= threshold' over every threshold (sklearn)."""
    from sklearn.metrics import roc_auc_score

    try:
        scores = np.asarray(scores, np.float64)
    except (TypeError, ValueError) as exc:      # strings, ragged lists
        raise DataError(f"scores must be numbers, one per event ({exc})") from None
    is_signal = np.asarray(is_signal, bool)
    if is_signal.shape != scores.shape or is_signal.ndim != 1:
        raise DataError(f"is_signal and scores must be 1-D and of equal length, got "
                        f"{is_signal.shape} and {scores.shape}")
    if not np.all(np.isfinite(scores)):
        i = int(np.flatnonzero(~np.isfinite(scores))[0])
        raise DataError(f"scores must be finite, got {scores[i]} at index {i}")
    if is_signal.all() or not is_signal.any():  # sklearn: nan and a warning, or a ValueError
        raise DataError("an ROC needs both signal and noise events")
    return float(roc_auc_score(is_signal, scores))


def threshold_sweep(make_filter, events, is_signal, thresholds):
    """Run make_filter(th).apply(events) for every threshold; returns dict with the ROC."""
    masks = [make_filter(th).apply(events) for th in thresholds]
    fpr, tpr, auc = roc_from_masks(is_signal, masks)
    return {"thresholds": list(thresholds), "fpr": fpr, "tpr": tpr, "auc": auc,
            "masks": masks}


def esr(events, packet_events=30_000, reference_events=None):
    """E-MLB's Event Structural Ratio (no reference needed; higher = more structure).

    Per packet of N consecutive events with per-pixel counts n_i over the K sensor pixels
    (polarity ignored): NTSS = Σ n_i(n_i − 1) / (N(N − 1)), L_N = K − Σ (1 − M/N)^{n_i},
    ESR = sqrt(NTSS · L_N), with M the reference count (2N/3 as in cuke-emlb, i.e. 20 000 for
    the default 30 000-event packets). The mean over full packets is returned; a stream
    shorter than one packet is scored as one packet of all its events (nan below 2 events).
    """
    if not isinstance(events, Events):
        raise ParameterTypeError(f"expected evstar.Events, got {type(events).__name__}")
    if int(packet_events) != packet_events or packet_events < 2:
        raise ParameterError(f"packet_events must be an integer >= 2, got {packet_events!r}")
    n = len(events)
    if n < 2:
        return float("nan")
    size = int(packet_events) if n >= packet_events else n
    scores = []
    for start in range(0, n - size + 1, size):
        sl = slice(start, start + size)
        pix = events.y[sl].astype(np.int64) * events.width + events.x[sl]
        counts = np.bincount(pix).astype(np.float64)
        counts = counts[counts > 0]
        m = (2.0 * size / 3.0) if reference_events is None else float(reference_events)
        if not 0 < m <= size:
            raise ParameterError(f"reference_events must be in (0, {size}], got {reference_events!r}")
        ntss = np.sum(counts * (counts - 1)) / (size * (size - 1.0))
        l_n = np.sum(1.0 - (1.0 - m / size) ** counts)  # = K − Σ over all K pixels
        scores.append(np.sqrt(ntss * l_n))
    return float(np.mean(scores))
