"""Rigid-field refinement (evstar.field): stars share the camera's rotation.

Rows are synthetic: stars' true pixels along a known rotation, plus a wander per track
(AR(1) noise, as a smoothed track's errors are), with the estimator's columns.
"""
import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from evstar import Config, Pipeline, field, sim
from evstar.errors import ParameterError
from evstar.extract import CENTROID_DTYPE

CAM = sim.camera_preset("davis346", 16.0)
FRAMES = 60


def rotations(t_s, rate_dps=8.0, wobble_deg=0.3):
    """Camera rotations at times t_s: a pan about y with a wobble about the other axes."""
    rv = np.stack([wobble_deg * np.sin(9 * t_s), rate_dps * t_s, wobble_deg * np.cos(7 * t_s)], 1)
    return Rotation.from_rotvec(np.radians(rv)).as_matrix()


def star_dirs(n, rng, cam=CAM):
    """Unit directions of stars in view across the pan."""
    uv = np.stack([rng.uniform(60, cam.width - 60, n), rng.uniform(20, cam.height - 20, n)], 1)
    return cam.unproject(uv)


def sine_rotations(t_s, amplitude_deg=3.0, freq_hz=2.0):
    """A 2 Hz sinusoid about y (peak 38 °/s, ~0.6 px/ms on the DAVIS346 at 16 mm): the speed
    varies, as a star tracker's turn makes it."""
    rv = np.stack([0 * t_s, amplitude_deg * np.sin(2 * np.pi * freq_hz * t_s), 0 * t_s], 1)
    return Rotation.from_rotvec(np.radians(rv)).as_matrix()


def rows_of(dirs, rng, sigma=0.2, rho=0.8, spread_us=3000, cam=CAM, rot=rotations, lag_us=None):
    """Rows of every star in every frame where it is in view: truth + AR(1) wander; and truth.
    A row's time is its frame's middle ± up to spread_us (its events' mean time). lag_us: per
    star, how long its rows trail it (where the star was that long before)."""
    rows, truth = [], []
    lag_us = np.zeros(len(dirs)) if lag_us is None else lag_us
    for i, d in enumerate(dirs):
        t = np.arange(FRAMES) * 10_000 + 5_000 + rng.integers(-spread_us, spread_us + 1, FRAMES)
        uv = cam.project(np.einsum("fij,j->fi", rot(t / 1e6), d))
        late = cam.project(np.einsum("fij,j->fi", rot((t - lag_us[i]) / 1e6), d))
        e = np.zeros((FRAMES, 2))
        e[0] = rng.normal(0, sigma, 2)
        for f in range(1, FRAMES):
            e[f] = rho * e[f - 1] + np.sqrt(1 - rho ** 2) * rng.normal(0, sigma, 2)
        inside = (uv[:, 0] > 0) & (uv[:, 0] < cam.width - 1) & (uv[:, 1] > 0) & (uv[:, 1] < cam.height - 1)
        r = np.zeros(inside.sum(), CENTROID_DTYPE)
        r["frame"], r["t"] = np.flatnonzero(inside), t[inside]
        r["track"], r["sigma"], r["source"] = i, sigma, "measured"
        r["x"], r["y"] = (late + e)[inside].T
        rows.append(r)
        truth.append(uv[inside])
    order = np.argsort(np.concatenate(rows)["frame"], kind="stable")
    return np.concatenate(rows)[order], np.concatenate(truth)[order]


def err(rows, truth):
    return np.hypot(rows["x"] - truth[:, 0], rows["y"] - truth[:, 1])


def test_noise_free_rows_are_a_fixed_point():
    rng = np.random.default_rng(0)
    dirs = star_dirs(12, rng)
    for spread_us, atol in ((0, 1e-6), (3000, 1e-2)):
        rows, truth = rows_of(dirs, rng, rho=0.0, spread_us=spread_us)
        rows["x"], rows["y"] = truth.T
        out = field.refine(rows, CAM, 4)
        # rows of one frame at different times move to one along straight lines: <= 5e-3 px
        # off where the wobble bends their paths
        np.testing.assert_allclose(out["x"], truth[:, 0], atol=atol)
        np.testing.assert_allclose(out["y"], truth[:, 1], atol=atol)


def test_a_distorted_lens_keeps_the_fixed_point_and_the_gain():
    cam = dataclasses.replace(CAM, k1=-0.2, k2=0.05)           # barrel, ~2 px at the corners
    rng = np.random.default_rng(9)
    dirs = star_dirs(12, rng, cam)
    rows, truth = rows_of(dirs, rng, rho=0.0, spread_us=0, cam=cam)
    rows["x"], rows["y"] = truth.T
    out = field.refine(rows, cam, 4)
    np.testing.assert_allclose(np.column_stack([out["x"], out["y"]]), truth, atol=1e-5)
    rows, truth = rows_of(dirs, rng, cam=cam)
    assert err(field.refine(rows, cam, 4), truth).mean() < 0.6 * err(rows, truth).mean()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_wandering_tracks_are_pulled_onto_the_field(seed):
    rng = np.random.default_rng(seed)
    rows, truth = rows_of(star_dirs(15, rng), rng)
    out = field.refine(rows, CAM, 4)
    before, after = err(rows, truth).mean(), err(out, truth).mean()
    # the wander of 60 frames at ρ 0.8 averages like ~7 independent rows (≈ 0.4 of a row's)
    assert after < 0.6 * before
    np.testing.assert_array_equal(out["sigma"], rows["sigma"])
    for f in ("t", "track", "frame", "source"):
        np.testing.assert_array_equal(out[f], rows[f])


def test_a_track_trailing_the_field_by_a_time_moves_onto_it_where_its_speed_varies():
    rng = np.random.default_rng(6)
    lag = np.zeros(12)
    lag[[2, 7]] = 3000.0                 # two faint stars whose pixels lag 3 ms more
    rows, truth = rows_of(star_dirs(12, rng), rng, sigma=0.1, rot=sine_rotations, lag_us=lag)
    out = field.refine(rows, CAM, 4, max_lag_us=4000.0)
    slow = np.isin(rows["track"], [2, 7])
    assert err(rows[slow], truth[slow]).max() > 1.0          # ~0.6 px/ms x 3 ms at the peak
    assert err(out[slow], truth[slow]).mean() < 0.1
    assert err(out[~slow], truth[~slow]).mean() < 0.6 * err(rows[~slow], truth[~slow]).mean()
    # a lag beyond the largest the estimator corrected, or none corrected: nothing moves
    for bound in (2000.0, 0.0):
        kept = field.refine(rows, CAM, 4, max_lag_us=bound)
        assert err(kept[slow], truth[slow]).mean() > 0.5
        # the moved tracks refit their own directions: the rotations, and every other
        # star's rows, stay
        np.testing.assert_array_equal(kept[~slow], out[~slow])


def test_a_close_pair_is_not_moved_by_a_lag():
    rng = np.random.default_rng(9)
    dirs = star_dirs(12, rng)
    dirs[7] = CAM.unproject(CAM.project(dirs[2][None])[0][None] + [[5.0, 3.0]])[0]   # 6 px off
    lag = np.zeros(12)
    lag[[2, 7]] = 3000.0
    rows, truth = rows_of(dirs, rng, sigma=0.1, rot=sine_rotations, lag_us=lag)
    out = field.refine(rows, CAM, 4, max_lag_us=4000.0)
    pair = np.isin(rows["track"], [2, 7])
    assert err(out[pair], truth[pair]).mean() > 0.5


def test_on_a_pan_a_lag_is_no_offset_and_nothing_moves():
    rng = np.random.default_rng(7)
    lag = np.zeros(12)
    lag[[2, 7]] = 10_000.0
    pan = lambda t_s: rotations(t_s, wobble_deg=0.0)
    rows, truth = rows_of(star_dirs(12, rng), rng, sigma=0.1, lag_us=lag, spread_us=0, rot=pan)
    slow = np.isin(rows["track"], [2, 7])
    # the pan's speed is the same throughout: the lag is a constant offset of the star's
    # direction, which the field cannot tell from where the star is; the rows stay behind
    behind = err(rows[slow], truth[slow]).mean()       # 8 °/s: ~0.12 px/ms x 10 ms
    assert behind > 1.0
    out = field.refine(rows, CAM, 4, max_lag_us=20_000.0)
    assert err(out[slow], truth[slow]).mean() > 0.9 * behind


def test_lags_are_fitted_per_track_and_kept_only_where_significant():
    rng = np.random.default_rng(8)
    n = 50
    ti = np.repeat([0, 1, 2], n)
    v = np.column_stack([np.tile(np.sin(np.linspace(0, 6, n)), 3) * 1e-3, np.zeros(3 * n)])
    v[2 * n:] = [1e-3, 0.0]                           # track 2: a pan
    resid = v * np.repeat([2000.0, 0.0, 2000.0], n)[:, None] + rng.normal(0, 0.05, (3 * n, 2))
    resid += [0.3, -0.2]                              # each track's constant offset
    lag = field._lags(resid, v, ti, np.ones(3 * n), 3)
    assert abs(lag[0] - 2000.0) < 100.0               # measured
    assert lag[1] == 0.0                              # none there: not significant
    assert lag[2] == 0.0                              # a pan's lag is an offset


def test_a_target_that_is_no_star_keeps_its_rows():
    rng = np.random.default_rng(4)
    rows, truth = rows_of(star_dirs(10, rng), rng)
    sat = np.zeros(FRAMES, CENTROID_DTYPE)           # crosses the field at its own 3 px/frame
    sat["frame"] = np.arange(FRAMES)
    sat["t"] = sat["frame"] * 10_000 + 5_000
    sat["track"], sat["sigma"], sat["source"] = 99, 0.1, "measured"
    sat["x"], sat["y"] = 40 + 3.0 * sat["frame"], 100 + 0.5 * sat["frame"]
    out = field.refine(np.concatenate([rows, sat]), CAM, 4)
    mine = out["track"] == 99
    np.testing.assert_array_equal(out["x"][mine], sat["x"])
    np.testing.assert_array_equal(out["y"][mine], sat["y"])
    assert err(out[~mine], truth).mean() < 0.6 * err(rows, truth).mean()


def test_frames_with_too_few_stars_and_untracked_rows_are_left_alone():
    rng = np.random.default_rng(5)
    rows, _ = rows_of(star_dirs(5, rng), rng)
    rows["track"][rows["frame"] % 7 == 0] = -1
    out = field.refine(rows, CAM, 6)                  # never 6 stars in a frame
    np.testing.assert_array_equal(out, rows)
    out = field.refine(rows, CAM, 4)
    loose = rows["track"] < 0
    np.testing.assert_array_equal(out[loose], rows[loose])
    assert not np.array_equal(out["x"][~loose], rows["x"][~loose])


def test_no_rows_and_no_tracks_pass_through():
    empty = np.zeros(0, CENTROID_DTYPE)
    assert len(field.refine(empty, CAM, 4)) == 0


def test_pipeline_refines_a_star_field_only_when_asked():
    motion = sim.ConstantRate(6.0, axis=np.array([0.0, 1.0, 0.0]),
                              R0=sim.attitude_from_radec(83.8, -5.4, 0.0))
    stars = sim.hipparcos_field_along(CAM, motion, 0.2, mag_limit=5.0)
    run = sim.simulate(sim.Scenario(CAM, stars, motion, 0.2), seed=8)
    res = {n: Pipeline(Config().replace(**{"estimate.field_min_stars": n})).run(
        run.events, run.imu, run.camera).centroids for n in (0, 4)}
    off, on = res[0], res[4]
    for f in ("t", "track", "frame", "sigma", "source"):
        np.testing.assert_array_equal(off[f], on[f])
    moved = (off["x"] != on["x"]) | (off["y"] != on["y"])
    assert moved.mean() > 0.5
    xy = run.truth.star_position(on["t"])                    # (rows, stars, 2)
    star = np.nanargmin(np.hypot(xy[..., 0] - off["x"][:, None], xy[..., 1] - off["y"][:, None]), 1)
    truth = xy[np.arange(len(on)), star]
    ok = err(off, truth) < 3
    assert err(on[ok], truth[ok]).mean() < err(off[ok], truth[ok]).mean()
    # without a camera the pipeline cannot tell the field's rotation: rows as estimated
    plain = {n: Pipeline(Config().replace(**{"estimate.field_min_stars": n})).run(
        run.events).centroids for n in (0, 4)}
    for f in CENTROID_DTYPE.names:                             # (NaN spreads compare equal)
        np.testing.assert_array_equal(plain[0][f], plain[4][f])


def test_bad_min_stars_is_rejected_naming_it():
    with pytest.raises(ParameterError, match="estimate.field_min_stars"):
        Config().replace(**{"estimate.field_min_stars": -1})


def test_a_streamed_star_field_equals_the_whole_run(tmp_path):
    from evstar import io

    motion = sim.ConstantRate(6.0, axis=np.array([0.0, 1.0, 0.0]),
                              R0=sim.attitude_from_radec(83.8, -5.4, 0.0))
    stars = sim.hipparcos_field_along(CAM, motion, 0.2, mag_limit=5.0)
    run = sim.simulate(sim.Scenario(CAM, stars, motion, 0.2), seed=9)
    io.write(tmp_path / "events.h5", run.events)
    cfg = Config(chunk_frames=7).replace(**{"estimate.estimator": "track"})
    whole = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
    streamed = Pipeline(cfg).run_file(tmp_path / "events.h5", run.imu, run.camera,
                                      progress=False).centroids
    assert (whole["track"] >= 0).sum() > 4 * 20                 # a field: the fit ran
    for name in CENTROID_DTYPE.names:
        np.testing.assert_array_equal(whole[name], streamed[name], err_msg=name)
