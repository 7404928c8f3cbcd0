"""Figures a user would rather look at than read (matplotlib, written as PNG)."""
from __future__ import annotations

import pathlib

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path):
    from .io.atomic import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png")
    _plt().close(fig)
    return pathlib.Path(path)


def accumulated(events):
    """Event counts per pixel as a (height, width) image."""
    img = np.bincount(events.y.astype(np.int64) * events.width + events.x,
                      minlength=events.width * events.height)
    return img.reshape(events.height, events.width)


def _show(ax, img, title):
    ax.imshow(np.log1p(img), cmap="magma", origin="upper", interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")


def plot_denoise(path, image_before, image_after):
    """Accumulated events (per-pixel counts) before and after denoising (log colour scale)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    _show(axes[0], image_before, f"before denoising: {int(image_before.sum()):,} events")
    _show(axes[1], image_after, f"after denoising: {int(image_after.sum()):,} events kept")
    return _save(fig, path)


def plot_tracks(path, image, centroids, truth_xy=None):
    """Star tracks over an accumulated image of the kept events; truth dashed when given."""
    plt = _plt()
    height, width = image.shape
    fig, ax = plt.subplots(figsize=(8, 6))
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
    if len(np.unique(centroids["track"])) <= 12:
        ax.legend(loc="upper right", fontsize=7)
    return _save(fig, path)


def plot_errors(path, t_us, errors_px, labels=None):
    """Centroid error against ground truth over time; one curve per series."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 3.8))
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
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for name, y in curves.items():
        ax.plot(frame_t_s, y, lw=1, label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend()
    return _save(fig, path)
