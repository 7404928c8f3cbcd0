"""Level-paired ON/OFF times mark when a star's centre passes each pixel."""
import numpy as np
import pytest

from evstar import sim
from evstar.crossings import pixel_crossings


def along_track_residuals(run, crossings):
    """(pixel − true centre at the crossing time) projected on the motion direction, px."""
    t = np.round(crossings["t"]).astype(np.int64)
    s = run.truth.star_position(t).reshape(len(t), -1)[:, :2]
    u = run.truth.star_position(t + 1000).reshape(len(t), -1)[:, :2] - s
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    q = np.column_stack([crossings["x"], crossings["y"]]).astype(float)
    return ((q - s) * u).sum(1)


def star_events(run):
    m = run.truth.labels >= 0
    ev = run.events
    return ev.t[m], ev.x[m], ev.y[m], ev.p[m]


@pytest.mark.parametrize("rate,sensor", [
    (4.0, sim.SensorSpec.ideal()),
    (12.0, sim.SensorSpec()),                                  # mismatch, jitter, refractory
    (8.0, sim.SensorSpec(threshold_on=0.15, threshold_off=0.15)),
])
def test_crossing_times_are_the_times_the_centre_passes_the_pixel(rate, sensor):
    run = sim.simulate(sim.paper_preset(rate, sensor=sensor, duration_s=0.3), seed=2)
    r = along_track_residuals(run, pixel_crossings(*star_events(run)))
    assert len(r) > 30
    assert abs(np.median(r)) < 0.05 and np.median(np.abs(r)) < 0.1


def test_crossings_beat_the_event_mean_which_leads_with_on_and_trails_with_off():
    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3), seed=4)
    t, x, y, p = star_events(run)
    s = run.truth.star_position(t).reshape(len(t), -1)[:, :2]
    u = run.truth.star_position(t + 1000).reshape(len(t), -1)[:, :2] - s
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    along = ((np.column_stack([x, y]) - s) * u).sum(1)
    assert along[p == 1].mean() > 1.0 and along[p == 0].mean() < -1.0   # the two lobes
    r = along_track_residuals(run, pixel_crossings(t, x, y, p))
    assert np.median(np.abs(r)) < 0.25 * np.abs(along).mean()


def test_one_synthetic_pixel_pairs_levels_outwards_from_the_polarity_change():
    #        ON ON ON | OFF OFF        (change between index 2 and 3)
    t = np.array([10, 20, 30, 50, 70])
    p = np.array([1, 1, 1, 0, 0])
    c = pixel_crossings(t, np.zeros(5, int), np.zeros(5, int), p, max_pairs=4)
    # pairs (20, 50) and (10, 70): midpoints 35 and 40
    assert len(c) == 1 and c["pairs"][0] == 2 and c["t"][0] == pytest.approx(37.5)
    assert c["t_spread"][0] == pytest.approx(2.5)
    one = pixel_crossings(t, np.zeros(5, int), np.zeros(5, int), p, max_pairs=1)
    assert one["t"][0] == pytest.approx(35.0)


def test_pixels_without_both_flanks_give_no_crossing():
    t = np.arange(6)
    x = np.array([0, 0, 1, 1, 2, 2])
    p = np.array([1, 1, 0, 0, 0, 1])     # ON only; OFF only; OFF then ON (no ON->OFF change)
    assert len(pixel_crossings(t, x, np.zeros(6, int), p)) == 0


def test_frames_without_centroids_but_with_crossings_get_positions():
    from evstar import Config, Pipeline, accuracy, estimation

    run = sim.simulate(sim.paper_preset(8.0, duration_s=0.3), seed=6)
    cfg = Config().replace(**{"estimate.estimator": "mean"})
    res = Pipeline(cfg).run(run.events)
    linked = res.centroids[res.centroids["track"] >= 0]
    gap = (linked["frame"] >= 10) & (linked["frame"] < 20)   # 100 ms without centroids
    crossings = estimation.chunk_crossings(run.events, res.keep, 3.0)
    rows = estimation.estimate(linked[~gap], cfg.replace(**{"estimate.estimator": "crossings"}),
                               int(run.events.t[0]), crossings)
    in_gap = (rows["frame"] >= 10) & (rows["frame"] < 20)
    assert in_gap.sum() == 10 and (rows["source"][in_gap] == "measured").all()
    _, err = accuracy.match(rows[in_gap], run.truth.star_position)
    assert err.max() < 0.1


@pytest.mark.parametrize("rate,mag,psf", [(4.0, 3.0, 1.0), (12.0, 5.0, 0.8), (8.0, 4.0, 1.3)])
def test_positions_beat_the_single_frame_bound_on_a_small_grid(rate, mag, psf):
    """σ_PSF/√N is the best one frame of N events can do; pooled along the track with the
    crossings, the default estimator must do better than that (and than the per-frame mean)."""
    from evstar import Config, Pipeline, accuracy

    run = sim.simulate(sim.paper_preset(rate, magnitude=mag, psf_sigma_px=psf, duration_s=0.3),
                       seed=11)
    n_per_frame = (run.truth.labels >= 0).sum() / 30
    bound = psf / np.sqrt(n_per_frame)
    errors = {}
    for estimator in ("mean", "crossings"):
        rows = Pipeline(Config().replace(**{"estimate.estimator": estimator})).run(run.events).centroids
        star, err = accuracy.match(rows, run.truth.star_position)
        errors[estimator] = err[star >= 0].mean()
    assert errors["crossings"] < 0.5 * bound and errors["crossings"] < 0.5 * errors["mean"], errors
