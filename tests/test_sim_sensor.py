"""The vectorised change detection against a plain per-pixel loop over the same samples,
its two processing orders against each other, and the adaptive time grid."""
import copy
import math

import numpy as np
import pytest

from evstar import sim
from evstar.sim.psf import window_half_width
from evstar.sim.render import render_chunks, time_grid
from evstar.sim.sensor import PixelState, star_events


def reference_events(state, samples, grid, refractory_s):
    """Per pixel, sample by sample, crossing by crossing — the rules of evstar.sim.sensor
    written as a loop: (pixel, t, polarity, star) sorted by pixel then time."""
    out = []
    for pix, seq in samples.items():
        ref, last, held = state.ref[pix], state.last_L[pix], None
        con, coff = state.c_on[pix], state.c_off[pix]
        for k, L, star in seq:
            if k == 0:
                ref, last = ref + L - last, L
                continue
            t0, t1, L0 = grid[k - 1], grid[k], last

            def line(t):
                return L0 + (t - t0) / (t1 - t0) * (L - L0)

            t = t0
            if held is not None:
                if held >= t1:
                    last = L
                    continue
                t = max(held, t0)
                ref, held = line(t), None
            while True:
                if L - ref >= con:
                    level, pol = ref + con, 1
                elif ref - L >= coff:
                    level, pol = ref - coff, 0
                else:
                    break
                tc = min(max(t0 + (level - L0) / (L - L0) * (t1 - t0), t), t1)
                out.append((pix, tc, pol, star))
                if refractory_s > 0:
                    tb = tc + refractory_s
                    if tb >= t1:
                        held = tb
                        break
                    ref, t = line(tb), tb
                else:
                    ref, t = level, tc
            last = L
    out.sort(key=lambda e: (e[0], e[1]))
    return np.array(out).reshape(-1, 4)


def setup(spec, rate_dps=16.0, duration_s=0.1, stars=None, seed=3):
    scn = sim.paper_preset(rate_dps, duration_s=duration_s, sensor=spec)
    if stars is not None:
        scn = scn.replace(stars=stars)
    flux = scn.stars.flux(scn.flux_mag3)
    grid = time_grid(scn.trajectory, scn.camera, scn.duration_s, scn.grid_step_px)
    state = PixelState(scn.camera.width * scn.camera.height, spec, np.random.default_rng(seed))
    return scn, flux, grid, state


def samples_of(scn, flux, grid, spec):
    half = np.array([window_half_width(f, scn.psf_sigma_px, spec.min_log_change) for f in flux])
    samples = {}
    for ch in render_chunks(scn.camera, scn.stars.directions, flux, half, scn.psf_sigma_px,
                            spec.min_log_change, scn.trajectory, grid):
        for p, c, s, k in zip(ch.pix, ch.contrib, ch.star, ch.step):
            samples.setdefault(int(p), []).append((int(k), math.log1p(c), int(s)))
    return samples


def run_star_events(scn, flux, grid, spec, state, layout="auto"):
    t, pix, pol, star = star_events(scn.camera, scn.stars, flux, scn.trajectory, grid, spec,
                                    scn.psf_sigma_px, state, layout=layout)
    order = np.lexsort((t, pix))
    return np.column_stack([pix[order], t[order], pol[order], star[order]])


@pytest.mark.parametrize("refractory_us", [0.0, 300.0])
def test_change_detection_matches_a_per_pixel_loop(refractory_us):
    spec = sim.SensorSpec.ideal(threshold_on=0.15, threshold_off=0.25, threshold_mismatch=0.03,
                                refractory_us=refractory_us)
    scn, flux, grid, state = setup(spec)
    expected = reference_events(copy.deepcopy(state), samples_of(scn, flux, grid, spec), grid,
                                refractory_us * 1e-6)
    got = run_star_events(scn, flux, grid, spec, state)
    assert len(got) == len(expected) > 500
    assert np.array_equal(got[:, [0, 2, 3]], expected[:, [0, 2, 3]])
    assert np.abs(got[:, 1] - expected[:, 1]).max() < 1e-9


def test_two_overlapping_stars_match_the_loop_too():
    spec = sim.SensorSpec.ideal(threshold_mismatch=0.03, refractory_us=200.0)
    base = sim.paper_preset(12.0, duration_s=0.1)
    R = base.trajectory.rotation([0.05])[0]
    cam = base.camera
    stars = sim.StarField(np.stack([R.T @ cam.unproject([[cam.cx + dx, cam.cy + dy]])[0]
                                    for dx, dy in ((0, 0), (2.5, 1.5))]), [3.0, 4.0], [-1, -1])
    scn, flux, grid, state = setup(spec, 12.0, stars=stars)
    samples = samples_of(scn, flux, grid, spec)
    assert all(len({k for k, _, _ in seq}) == len(seq) for seq in samples.values())  # merged
    expected = reference_events(copy.deepcopy(state), samples, grid, 200e-6)
    got = run_star_events(scn, flux, grid, spec, state)
    assert len(got) == len(expected) and set(np.unique(got[:, 3])) == {0, 1}
    assert np.array_equal(got[:, [0, 2, 3]], expected[:, [0, 2, 3]])
    assert np.abs(got[:, 1] - expected[:, 1]).max() < 1e-9


def test_step_and_column_orders_give_identical_events():
    spec = sim.SensorSpec(jitter_us=0.0, noise_hz=0.0, hot_pixels=0)
    scn, flux, grid, state = setup(spec, 20.0, duration_s=0.2)
    a = run_star_events(scn, flux, grid, spec, copy.deepcopy(state), layout="steps")
    b = run_star_events(scn, flux, grid, spec, state, layout="columns")
    assert len(a) > 1000 and np.array_equal(a, b)


@pytest.mark.parametrize("motion", [sim.ConstantRate(20.0), sim.Sinusoid(10.0, 1.0)])
def test_time_grid_keeps_every_step_below_step_px(motion):
    cam = sim.camera_preset("dvxplorer-lite")
    grid = time_grid(motion, cam, 1.0, 0.2)
    assert grid[0] == 0 and grid[-1] >= 1.0 and np.all(np.diff(grid) > 0)
    assert np.diff(grid).max() <= 1e-3 + 1e-12
    points = cam.unproject(np.array([[0.0, 0.0], [319.0, 239.0], [159.5, 119.5], [0.0, 239.0]]))
    xy = np.stack([cam.project(points @ R.T) for R in motion.rotation(grid)])   # (steps, points, 2)
    inside = np.all((xy > -0.5) & (xy < [319.5, 239.5]), axis=2)
    moved = np.linalg.norm(np.diff(xy, axis=0), axis=2)[inside[1:] & inside[:-1]]
    assert 0.1 < moved.max() <= 0.2                               # on the sensor, where it matters


def test_default_grid_step_is_fine_enough():
    """Half-sigma steps against ten times finer ones: same streak, to 0.5 % and 0.05 px."""
    def streak(step_px):
        run = sim.simulate(sim.paper_preset(20.0, sensor=sim.SensorSpec.ideal(), step_px=step_px), seed=0)
        ev = run.events[run.truth.labels >= 0]
        frame = ev.t // 10_000
        n = np.bincount(frame)
        return len(ev), np.bincount(frame, ev.x) / n, np.bincount(frame, ev.y) / n
    (n0, x0, y0), (n1, x1, y1) = streak(0.05), streak(None)
    assert abs(n1 / n0 - 1) < 0.005
    assert np.abs(x1 - x0).max() < 0.05 and np.abs(y1 - y0).max() < 0.05
