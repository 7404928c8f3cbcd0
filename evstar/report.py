"""Figures a user would rather look at than read (matplotlib, written as PNG).

Each figure is a matplotlib Figure of its own, so plotting leaves pyplot's state alone."""
from __future__ import annotations

import pathlib

import numpy as np


def _figure(figsize):
    """A Figure of its own (no pyplot): plotting never switches the user's backend nor adds
    to pyplot's open figures."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path):
    from .io.atomic import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png")
    return pathlib.Path(path)


def _show(ax, img, title):
    ax.imshow(np.log1p(img), cmap="magma", origin="upper", interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")


def plot_denoise(path, image_before, image_after):
    """Accumulated events (per-pixel counts) before and after denoising (log colour scale)."""
    fig = _figure((12, 4.8))
    axes = fig.subplots(1, 2)
    _show(axes[0], image_before, f"before denoising: {int(image_before.sum()):,} events")
    _show(axes[1], image_after, f"after denoising: {int(image_after.sum()):,} events kept")
    return _save(fig, path)


def plot_tracks(path, image, centroids, truth_xy=None):
    """Star tracks over an accumulated image of the kept events; truth dashed when given."""
    height, width = image.shape
    fig = _figure((8, 6))
    ax = fig.subplots()
    _show(ax, image, "star tracks")
    for tid in np.unique(centroids["track"]):
        if tid < 0:
            continue
        c = centroids[centroids["track"] == tid]
        ax.plot(c["x"], c["y"], ".-", ms=3, lw=1, label=f"track {tid}")
    if truth_xy is not None:
        for k, xy in enumerate(truth_xy):
            ax.plot(xy[:, 0], xy[:, 1], "--", color="cyan", lw=0.8, label="truth" if k == 0 else None)
    ax.set_xlim(-0.5, width - 0.5)
    ax.set_ylim(height - 0.5, -0.5)
    if ax.get_legend_handles_labels()[0] and len(np.unique(centroids["track"])) <= 12:
        ax.legend(loc="upper right", fontsize=7)   # none without a track: matplotlib warns
    return _save(fig, path)


def plot_errors(path, t_us, errors_px, labels=None):
    """Centroid error against ground truth over time; one curve per series."""
    fig = _figure((8, 3.8))
    ax = fig.subplots()
    series = errors_px if isinstance(errors_px, dict) else {labels or "error": errors_px}
    times = t_us if isinstance(t_us, dict) else {k: t_us for k in series}
    for name, err in series.items():
        ax.plot((times[name] - times[name][0]) * 1e-6 if len(err) else [], err, ".-", ms=3, lw=0.8,
                label=f"{name}: mean {np.mean(err):.2f} px" if len(err) else name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("centroid error (px)")
    ax.grid(alpha=0.3)
    ax.legend()
    return _save(fig, path)


def plot_per_frame(path, frame_t_s, curves, ylabel):
    """Per-frame curves (e.g. SNR before/after, or events before/after) against time."""
    fig = _figure((8, 3.8))
    ax = fig.subplots()
    for name, y in curves.items():
        ax.plot(frame_t_s, y, lw=1, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend()
    return _save(fig, path)
