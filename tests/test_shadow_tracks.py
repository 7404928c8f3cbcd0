"""evstar.estimation.without_shadows: a star has one track; a short, much less certain
track lying on a longer one is its outliers, while a real companion star is kept."""
import numpy as np

from evstar.estimation import SHADOW_PX, SHADOW_SIGMA_RATIO, without_shadows
from evstar.extract import CENTROID_DTYPE


def track(tid, t, x, y, sigma):
    rows = np.zeros(len(t), CENTROID_DTYPE)
    rows["track"], rows["t"], rows["x"], rows["y"], rows["sigma"] = tid, t, x, y, sigma
    rows["source"] = "measured"
    return rows


def scene(offset_px, sigma_ratio, span=(300_000, 400_000)):
    t = np.arange(0, 1_000_000, 10_000) + 5_000
    main = track(0, t, 100 + 40e-6 * t, 50.0, 0.05)
    ts = np.arange(span[0], span[1], 10_000) + 5_000
    rng = np.random.default_rng(0)
    wobble = rng.uniform(-0.3, 0.3, len(ts))
    other = track(1, ts, 100 + 40e-6 * ts + offset_px + wobble, 50.0, 0.05 * sigma_ratio)
    far = track(2, ts, 20.0, 20.0, 0.5)          # a short noisy track elsewhere: a star too
    return np.concatenate([main, other, far])


def test_a_short_uncertain_track_on_a_longer_one_is_dropped():
    rows = without_shadows(scene(1.5, 2 * SHADOW_SIGMA_RATIO))
    assert set(np.unique(rows["track"])) == {0, 2}


def test_a_companion_as_certain_as_its_neighbour_is_kept():
    rows = without_shadows(scene(2.0, 1.5))
    assert set(np.unique(rows["track"])) == {0, 1, 2}


def test_a_track_that_leaves_the_other_or_outlives_it_is_kept():
    assert 1 in without_shadows(scene(SHADOW_PX + 0.5, 10))["track"]
    assert 1 in without_shadows(scene(1.0, 10, span=(900_000, 1_100_000)))["track"]


def test_untracked_rows_pass_untouched():
    rows = scene(1.0, 10)
    rows["track"][rows["track"] == 2] = -1
    out = without_shadows(rows)
    assert (out["track"] == -1).sum() == (rows["track"] == -1).sum()


def test_a_brief_track_of_lone_lobes_beside_a_long_one_is_its_star_s():
    """A few rows of one-polarity clusters 2–6 px beside a star's long track, however
    certain, are that star's lone lobes linked into a track of their own; further off,
    longer, or of both polarities (a star's) they are kept."""
    from evstar.estimation import BRIEF_PX, BRIEF_ROWS

    def brief(offset_px, rows, n_on=(8, 0)):
        out = scene(offset_px, 1.0, span=(300_000, 300_000 + rows * 10_000))
        out["n_events"] = 8
        out["n_on"] = np.where(np.arange(len(out)) % 2, *n_on)      # ON-only, OFF-only, ...
        return out

    assert set(np.unique(without_shadows(brief(BRIEF_PX - 1.5, BRIEF_ROWS))["track"])) == {0, 2}
    assert 1 in without_shadows(brief(BRIEF_PX + 0.5, BRIEF_ROWS))["track"]
    assert 1 in without_shadows(brief(BRIEF_PX - 1.5, BRIEF_ROWS + 1))["track"]
    assert 1 in without_shadows(brief(BRIEF_PX - 1.5, BRIEF_ROWS, n_on=(4, 4)))["track"]
