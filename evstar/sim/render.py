"""Star windows on the simulation time grid: which pixels each star lights, and how much.

At each grid time every star is projected through the camera and gets a window of pixels
around its nearest pixel, clipped to a disk-like footprint outside which its light changes
the log intensity by less than `min_log_change`. A pixel's intensity is the sky background
(1) plus the star's flux times the pixel-integrated PSF; where two stars' windows meet at a
grid time their fluxes add up and the brighter contribution names the star.

The grid adapts to the motion: uniform within 10 ms spans, each fine enough that no star
moves more than `step_px` per step, and never coarser than 1 ms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from .psf import pixel_profile

#: largest number of window samples held for one chunk of grid steps (memory bound)
CHUNK_ENTRIES = 2_000_000


def time_grid(trajectory, camera, duration_s, step_px, max_step_s=1e-3, span_s=0.01):
    """Grid times (s) from 0 to >= duration_s: uniform within spans of `span_s`, each fine
    enough that no star moves more than step_px per step (rate probed at 5 points per span),
    and no step longer than max_step_s."""
    n_span = max(1, int(math.ceil(duration_s / span_s)))
    edges = np.arange(n_span + 1) * span_s
    f = max(camera.fx, camera.fy)
    widen = 1 + (math.hypot(camera.width, camera.height) / 2 / f) ** 2  # off-axis stars move faster
    probe = edges[:-1, None] + np.linspace(0, span_s, 5)[None, :]
    peak = np.linalg.norm(trajectory.omega(probe.ravel()), axis=1).reshape(n_span, 5).max(axis=1)
    n = np.maximum(math.ceil(span_s / max_step_s - 1e-9),
                   np.ceil(peak * f * widen * span_s / step_px)).astype(np.int64)
    first = np.cumsum(n) - n
    within = np.arange(int(n.sum())) - np.repeat(first, n)
    return np.append(np.repeat(edges[:-1], n) + within * np.repeat(span_s / n, n), edges[-1])


def footprint(flux, h, sigma, min_log_change):
    """Offsets (dy, dx) of the (2h+1)² window whose pixel can change by >= min_log_change
    for a star anywhere within half a pixel of the window centre: a disk-like mask."""
    a = np.abs(np.arange(-h, h + 1)).astype(np.float64)
    # the most flux a pixel at offset a can get: star centred (a = 0), else 0.5 px towards it
    lo, hi = np.where(a == 0, -0.5, a - 1.0), np.where(a == 0, 0.5, a)
    best = ndtr(hi / sigma) - ndtr(lo / sigma)
    dy, dx = np.nonzero(flux * best[:, None] * best[None, :] >= math.expm1(min_log_change))
    return dy - h, dx - h


@dataclass
class Chunk:
    """Window samples of grid steps span[0] .. span[1], step-major: pixel index, flux over
    the background, star index and grid step of each."""

    pix: np.ndarray
    contrib: np.ndarray
    star: np.ndarray
    step: np.ndarray
    span: tuple = (0, -1)


def _samples_per_step(camera, dirs, flux, half, sigma, min_log_change, trajectory, grid):
    """Most window samples at one grid step, from the stars in view at 64 probe times."""
    R = trajectory.rotation(np.linspace(grid[0], grid[-1], 64))
    cam = np.matmul(dirs[None], R.transpose(0, 2, 1))
    ahead = cam[..., 2] > 1e-9
    uv = camera.project(np.where(ahead[..., None], cam, [0, 0, 1]).reshape(-1, 3)).reshape(cam.shape[:2] + (2,))
    pad = half + 1
    seen = (ahead & (uv[..., 0] > -pad) & (uv[..., 0] < camera.width + pad)
            & (uv[..., 1] > -pad) & (uv[..., 1] < camera.height + pad))
    size = np.array([len(footprint(f, h, sigma, min_log_change)[0]) for f, h in zip(flux, half)])
    return int((seen * size).sum(axis=1).max())


def render_chunks(camera, dirs, flux, half, sigma, min_log_change, trajectory, grid):
    """Yield the Chunks covering every grid step (memory-bounded), empty ones included."""
    per_step = _samples_per_step(camera, dirs, flux, half, sigma, min_log_change, trajectory, grid)
    size = max(2, CHUNK_ENTRIES // max(per_step, 1))
    for k0 in range(0, len(grid), size):
        ks = np.arange(k0, min(len(grid), k0 + size))
        chunk = _render(camera, dirs, flux, half, sigma, min_log_change, trajectory.rotation(grid[ks]), ks)
        if chunk is None:  # no star in view: an empty chunk still marks the steps' passing
            empty = np.zeros(0, np.int64)
            chunk = Chunk(empty, np.zeros(0), empty, empty)
        chunk.span = (int(ks[0]), int(ks[-1]))
        yield chunk


def _render(camera, dirs, flux, half, sigma, min_log_change, R, ks):
    """The Chunk of grid steps ks (attitudes R): window samples of the stars in view."""
    K = len(R)
    cam = np.matmul(dirs[None], R.transpose(0, 2, 1))              # (K, S, 3) = R @ direction
    ahead = cam[..., 2] > 1e-9
    uv = camera.project(np.where(ahead[..., None], cam, [0, 0, 1]).reshape(-1, 3)).reshape(K, -1, 2)
    # int32 halves the memory traffic of the window arithmetic; far-off stars are clipped
    cx, cy = (np.rint(np.clip(uv[..., i], -1e6, 1e6)).astype(np.int32) for i in (0, 1))
    vis = (ahead & (cx + half > -1) & (cx - half < camera.width)
           & (cy + half > -1) & (cy - half < camera.height))
    used = np.flatnonzero(vis.any(axis=0))
    if len(used) == 0:
        return None
    box = np.zeros((K, len(dirs), 4), np.int32)
    box[:, used] = _overlap_boxes(cx[:, used], cy[:, used], half[used], vis[:, used])
    blocks = []
    for h in np.unique(half[used]):
        sel = used[half[used] == h]
        foot = footprint(flux[sel].max(), int(h), sigma, min_log_change)
        blocks.append(_block(camera, uv[:, sel], cx[:, sel], cy[:, sel], vis[:, sel], box[:, sel],
                             flux[sel], sel, int(h), foot, sigma))
    return _combine(blocks, ks, camera.width * camera.height)


def _block(camera, uv, cx, cy, vis, box, flux, sel, h, foot, sigma):
    """Samples of stars sel sharing the half-width h: (ok, pixel, flux, star per column,
    shared-with-another-star or None), each (K, stars × footprint) but the star column."""
    K = len(uv)
    px = pixel_profile(uv[..., 0], cx - h, 2 * h + 1, sigma)        # (K, s, W)
    py = pixel_profile(uv[..., 1], cy - h, 2 * h + 1, sigma)
    dy, dx = foot
    c = flux[None, :, None] * py[..., dy + h] * px[..., dx + h]      # (K, s, n)
    X, Y = cx[..., None] + dx.astype(np.int32), cy[..., None] + dy.astype(np.int32)
    ok = vis[..., None] & (X >= 0) & (X < camera.width) & (Y >= 0) & (Y < camera.height)
    b = box[:, :, None, :]
    shared = None
    if np.any(b[..., 0] <= b[..., 1]):
        shared = (ok & (X >= b[..., 0]) & (X <= b[..., 1]) & (Y >= b[..., 2]) & (Y <= b[..., 3])).reshape(K, -1)
    return (ok.reshape(K, -1), (Y * camera.width + X).reshape(K, -1), c.reshape(K, -1),
            np.repeat(sel, len(dx)), shared)


def _combine(blocks, ks, n_pixels):
    """Compact the blocks' valid samples step-major into a Chunk, merging shared pixels."""
    def join(arrays):
        return arrays[0] if len(arrays) == 1 else np.concatenate(arrays, axis=1)

    ok, pix, c = (join([bl[i] for bl in blocks]) for i in range(3))
    star_of_col = np.concatenate([bl[3] for bl in blocks])
    step = np.repeat(ks, ok.sum(axis=1))
    pix, c, star = pix[ok], c[ok], np.broadcast_to(star_of_col, ok.shape)[ok]
    if any(bl[4] is not None for bl in blocks):
        shared = join([np.zeros_like(bl[0]) if bl[4] is None else bl[4] for bl in blocks])[ok]
        if shared.any():
            keep, c = _merge_shared(np.flatnonzero(shared), pix, c, step, n_pixels)
            pix, c, star, step = pix[keep], c[keep], star[keep], step[keep]
    return Chunk(pix, c, star, step)


def _overlap_boxes(cx, cy, half, vis):
    """(K, S, 4) box x0, x1, y0, y1 (inclusive) of the pixels star s shares with other stars'
    windows at step k; empty boxes have x0 > x1.

    Candidate pairs come from bounding boxes over the chunk, then each is checked per step.
    """
    K, S = cx.shape
    big = 2 ** 30
    box = np.empty((K, S, 4), np.int32)
    box[..., 0::2], box[..., 1::2] = big, -big
    if S < 2:
        return box
    x0, x1 = np.where(vis, cx, big).min(0) - half, np.where(vis, cx, -big).max(0) + half
    y0, y1 = np.where(vis, cy, big).min(0) - half, np.where(vis, cy, -big).max(0) + half
    i, j = np.nonzero(np.triu((x0[:, None] <= x1[None, :]) & (x0[None, :] <= x1[:, None])
                              & (y0[:, None] <= y1[None, :]) & (y0[None, :] <= y1[:, None]), 1))
    if len(i) == 0:
        return box
    reach = half[i] + half[j]
    kk, pp = np.nonzero(vis[:, i] & vis[:, j] & (np.abs(cx[:, i] - cx[:, j]) <= reach)
                        & (np.abs(cy[:, i] - cy[:, j]) <= reach))
    if len(kk) == 0:
        return box
    i, j = i[pp], j[pp]
    hi_, hj = half[i], half[j]
    xi, xj, yi, yj = cx[kk, i], cx[kk, j], cy[kk, i], cy[kk, j]
    inter = np.stack([np.maximum(xi - hi_, xj - hj), np.minimum(xi + hi_, xj + hj),
                      np.maximum(yi - hi_, yj - hj), np.minimum(yi + hi_, yj + hj)], 1)
    for star in (i, j):
        for c, op in ((0, np.minimum), (1, np.maximum), (2, np.minimum), (3, np.maximum)):
            op.at(box[..., c], (kk, star), inter[:, c])
    return box


def _merge_shared(idx, pix, c, step, n_pixels):
    """Among samples idx, those of one pixel at one step become one: fluxes summed, kept
    at the sample with the largest contribution. Returns (keep mask, new contributions)."""
    key = step[idx] * n_pixels + pix[idx]
    order = np.argsort(key, kind="stable")
    key_s, idx_s = key[order], idx[order]
    new = np.insert(key_s[1:] != key_s[:-1], 0, True)
    starts = np.flatnonzero(new)
    group = np.cumsum(new) - 1
    cs = c[idx_s]
    top = cs == np.maximum.reduceat(cs, starts)[group]
    # the first sample reaching its group's maximum represents the group
    rank = np.where(top, np.arange(len(cs)), len(cs))
    rep = np.minimum.reduceat(rank, starts)
    c = c.copy()
    c[idx_s[rep]] = np.add.reduceat(cs, starts)
    keep = np.ones(len(pix), bool)
    keep[idx_s] = False
    keep[idx_s[rep]] = True
    return keep, c
