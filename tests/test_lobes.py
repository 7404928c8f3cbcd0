"""A slow star's ON-only and OFF-only clusters joined into one target (evstar.lobes)."""
import numpy as np
import pytest

from evstar import Events
from evstar.errors import ParameterError
from evstar.extract import Extractor


def lobes_scene(centre=(60.0, 40.0), gap=5.5, n=12, frames=5, sigma=0.6, seed=0, lone_on=None):
    """Per 10 ms frame: an ON blob gap/2 ahead of `centre` (+x) and an OFF blob gap/2 behind
    (a slow star's two lobes); lone_on: (x, y) of a further ON-only blob (another target)."""
    rng = np.random.default_rng(seed)
    parts = []
    blobs = [(centre[0] + gap / 2, centre[1], 1), (centre[0] - gap / 2, centre[1], 0)]
    if lone_on is not None:
        blobs.append((*lone_on, 1))
    for f in range(frames):
        for x, y, p in blobs:
            t = f * 10_000 + rng.integers(0, 10_000, n)
            parts.append(np.column_stack([t, np.round(x + rng.normal(0, sigma, n)),
                                          np.round(y + rng.normal(0, sigma, n)), np.full(n, p)]))
    a = np.concatenate(parts).astype(np.int64)
    a = a[np.argsort(a[:, 0], kind="stable")]
    return Events(a[:, 0], a[:, 1], a[:, 2], a[:, 3], 120, 80)


@pytest.mark.parametrize("clustering", ["grid", "sklearn"])
def test_two_lobes_become_one_centroid_at_the_star(clustering):
    ev = lobes_scene()
    apart = Extractor(lobe_gap_px=None, clustering=clustering).centroids(ev)
    joined = Extractor(clustering=clustering).centroids(ev)
    assert len(apart) == 10                               # two lobes per frame
    assert len(joined) == 5 and joined["n_events"].sum() == 120   # every event in a star
    assert np.all(np.abs(joined["x"] - 60.0) < 0.5) and np.all(np.abs(joined["y"] - 40.0) < 0.5)
    assert np.all(joined["spread"] > 2.5)                 # both lobes' events are in it


def test_lobes_farther_than_the_gap_stay_apart():
    ev = lobes_scene(gap=10.0)
    assert len(Extractor(lobe_gap_px=8.0).centroids(ev)) == 10
    assert len(Extractor(lobe_gap_px=12.0).centroids(ev)) == 5


def test_a_dark_sky_trail_of_off_events_is_no_star():
    """A star's cluster (both polarities) and, 20 px behind it, OFF events alone (a slow
    photoreceptor relaxing after the star passed): one centroid, the star's."""
    rng = np.random.default_rng(4)
    parts = []
    for f in range(5):
        for x, p, n in ((60.0 + 6 * f, 1, 40), (58.0 + 6 * f, 0, 40), (40.0 + 6 * f, 0, 8)):
            t = f * 10_000 + rng.integers(0, 10_000, n)
            parts.append(np.column_stack([t, np.round(x + rng.normal(0, 0.6, n)),
                                          np.round(40 + rng.normal(0, 0.6, n)), np.full(n, p)]))
    a = np.concatenate(parts).astype(np.int64)
    a = a[np.argsort(a[:, 0], kind="stable")]
    ev = Events(a[:, 0], a[:, 1], a[:, 2], a[:, 3], 120, 80)
    c = Extractor().centroids(ev)
    assert len(c) == 5 and np.all(np.abs(c["x"] - (59.0 + 6 * c["frame"])) < 1.0)
    assert len(Extractor(lobe_gap_px=None).centroids(ev)) == 10


def test_a_lobe_pairs_only_with_its_mutual_nearest_opposite():
    # a second ON-only target beyond the star's ON lobe: the OFF lobe pairs with the nearer
    ev = lobes_scene(lone_on=(71.0, 40.0))
    c = Extractor().centroids(ev)
    assert len(c) == 10
    star = c[np.abs(c["x"] - 60.0) < 1.0]
    assert len(star) == 5 and np.all(star["n_events"] >= 20)


def test_mixed_polarity_clusters_are_never_joined():
    rng = np.random.default_rng(3)
    n = 40
    t = np.sort(rng.integers(0, 10_000, 2 * n))
    x = np.r_[np.round(30 + rng.normal(0, 0.6, n)), np.round(36 + rng.normal(0, 0.6, n))]
    y = np.round(20 + rng.normal(0, 0.6, 2 * n))
    p = rng.integers(0, 2, 2 * n)                          # both clusters mixed
    ev = Events(t, x, y, p, 60, 40, sort=True)
    assert len(Extractor().centroids(ev)) == 2


@pytest.mark.parametrize("bad", [0.0, -1.0, "wide"])
def test_bad_lobe_gap_is_rejected_by_name(bad):
    with pytest.raises(ParameterError, match="lobe_gap_px"):
        Extractor(lobe_gap_px=bad)


@pytest.mark.parametrize("clustering", ["grid", "sklearn"])
def test_centroids_count_their_on_events(clustering):
    apart = Extractor(lobe_gap_px=None, clustering=clustering).centroids(lobes_scene())
    ahead = apart["x"] > 60.0                          # the ON blobs lie ahead
    assert np.array_equal(apart["n_on"], np.where(ahead, apart["n_events"], 0))
    joined = Extractor(clustering=clustering).centroids(lobes_scene())
    assert np.all(joined["n_on"] == 12) and np.all(joined["n_events"] > 12)   # 12 ON a frame


def lobed_track(shares, beta=4.0, speed=40.0, sigma=0.05, seed=1):
    """Centroids of a star moving +x at `speed` px/s, one per 10 ms frame, each with ON
    share `shares[i]`, sitting beta·(share − ½) ahead of it; and its true x per centroid."""
    from evstar.extract import CENTROID_DTYPE

    rng = np.random.default_rng(seed)
    shares = np.asarray(shares, float)
    c = np.zeros(len(shares), CENTROID_DTYPE)
    c["frame"] = np.arange(len(shares))
    c["t"] = c["frame"] * 10_000 + 5_000
    c["track"], c["n_events"], c["spread"] = 0, 20, 1.0
    c["n_on"] = np.round(shares * 20)
    truth = 30.0 + speed * c["t"] * 1e-6
    c["x"] = truth + beta * (c["n_on"] / 20 - 0.5) + rng.normal(0, sigma, len(c))
    c["y"] = 40.0 + rng.normal(0, sigma, len(c))
    return c, truth


def test_a_tracks_lobe_bias_is_measured_and_removed():
    from evstar.lobes import debiased
    from evstar.smoothing import TrackSmoother

    c, truth = lobed_track(np.resize([1.0, 0.0, 0.5, 0.9, 0.1], 30))
    fixed, changed = debiased(c, TrackSmoother(10_000, process_noise=1.0).smooth(c, 0))
    assert list(changed) == [0]
    assert np.abs(c["x"] - truth).max() > 1.5                   # one-lobe centroids: ±2 px
    assert np.abs(fixed["x"] - truth).max() < 0.3
    assert np.abs(fixed["y"] - c["y"]).max() < 0.02            # the motion is along x


@pytest.mark.parametrize("case", ["balanced", "few", "off_ahead"])
def test_tracks_without_a_measurable_lobe_bias_are_left_alone(case):
    from evstar.lobes import MIN_LOBE_CENTROIDS, debiased
    from evstar.smoothing import TrackSmoother

    shares = {"balanced": np.full(30, 0.5), "few": [1.0, 0.0] * (MIN_LOBE_CENTROIDS // 2 - 1),
              "off_ahead": np.resize([1.0, 0.0], 30)}[case]
    c, _ = lobed_track(shares, beta=-4.0 if case == "off_ahead" else 4.0)
    fixed, changed = debiased(c, TrackSmoother(10_000, process_noise=1.0).smooth(c, 0))
    assert len(changed) == 0 and np.array_equal(fixed, c)


def test_a_wild_centroid_does_not_set_the_lobe_bias():
    from evstar.lobes import debiased
    from evstar.smoothing import TrackSmoother

    c, truth = lobed_track(np.resize([1.0, 0.0, 0.5, 0.9, 0.1], 30))
    c["y"][0] += 35.0                                         # another star's, taken by the tracker
    c["x"][0] -= 20.0
    fixed, changed = debiased(c, TrackSmoother(10_000, process_noise=1.0).smooth(c, 0))
    assert list(changed) == [0]
    assert np.abs(fixed["x"][1:] - truth[1:]).max() < 0.3


def test_a_centroid_is_balanced_when_both_polarities_hold_more_than_a_third():
    from evstar.extract import CENTROID_DTYPE
    from evstar.lobes import balanced

    c = np.zeros(5, CENTROID_DTYPE)
    c["n_events"], c["n_on"] = [9, 9, 9, 9, 0], [0, 3, 4, 6, 0]
    assert list(balanced(c)) == [False, False, True, False, False]


def test_a_track_of_off_lobes_alone_is_a_trail_and_not_reported():
    from evstar import Config, estimation
    from evstar.lobes import TRAIL_ON_SHARE, trail_tracks

    star, _ = lobed_track(np.full(30, 0.5))
    trail, _ = lobed_track(np.full(30, 0.0), beta=0.0)      # OFF events alone, 9 px behind
    trail["x"] -= 9.0
    trail["track"] = 1
    trail["n_on"][::10] = 1                                  # a stray ON event now and then
    # a dim star's ON share may run low, but not to the trail's
    dim, _ = lobed_track(np.full(30, 0.5), seed=2)
    dim["y"] += 20.0
    dim["track"] = 2
    dim["n_on"] = np.round(dim["n_events"] * (TRAIL_ON_SHARE + 0.05))
    c = np.concatenate([star, trail, dim])
    c = c[np.argsort(c["t"], kind="stable")]
    assert list(trail_tracks(c)) == [1]
    rows = estimation.estimate(c, Config().replace(**{"estimate.estimator": "track"}), 0)
    assert set(np.unique(rows["track"])) == {0, 2}
    c["n_on"] = 0                                            # polarities not counted
    assert len(trail_tracks(c)) == 0


def test_an_untracked_off_lobe_behind_a_track_is_a_trail():
    from evstar.extract import CENTROID_DTYPE
    from evstar.lobes import of_tracks
    from evstar.smoothing import ESTIMATE_DTYPE

    track = np.zeros(1, ESTIMATE_DTYPE)
    track["frame"], track["x"], track["y"], track["vx"] = 3, 100.0, 50.0, 800.0   # moving +x
    loose = np.zeros(5, CENTROID_DTYPE)
    loose["frame"], loose["n_events"] = 3, 20
    loose["x"] = [91.0, 91.0, 109.0, 91.0, 91.0]            # 9 px behind; one ahead
    loose["y"] = [50.5, 50.5, 50.0, 56.0, 50.0]             # one off the star's line
    loose["n_on"] = [0, 10, 0, 0, 0]                        # one of both polarities
    loose["frame"][4] = 4                                   # one in another frame
    assert list(of_tracks(loose, track)) == [True, False, False, False, False]


def test_an_untracked_on_lobe_just_ahead_of_a_track_is_its_lobe():
    """A slow star's lone ON lobe ~2 px ahead of its track is the star's; an ON cluster
    further ahead, off its line, or of both polarities is not."""
    from evstar.extract import CENTROID_DTYPE
    from evstar.lobes import LOBE_AHEAD_PX, of_tracks
    from evstar.smoothing import ESTIMATE_DTYPE

    track = np.zeros(1, ESTIMATE_DTYPE)
    track["frame"], track["x"], track["y"], track["vy"] = 3, 100.0, 50.0, -20.0   # moving -y
    loose = np.zeros(5, CENTROID_DTYPE)
    loose["frame"], loose["n_events"], loose["n_on"] = 3, 8, 8
    loose["x"] = [100.3, 100.0, 100.0, 104.0, 100.0]
    loose["y"] = [48.0, 50.0 - LOBE_AHEAD_PX - 1, 52.0, 48.0, 48.0]  # ahead; far; behind; aside
    loose["n_on"][4] = 4                                             # both polarities
    assert list(of_tracks(loose, track)) == [True, False, False, False, False]
