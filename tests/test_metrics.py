"""Denoising metrics: the paper's SNR, retention, hot pixels, ROC, E-MLB's ESR."""
import math

import numpy as np
import pytest

import evstar
from evstar import denoise, metrics


def test_snr_is_ten_log10_of_event_counts():
    assert metrics.snr_db(100, 10) == pytest.approx(10.0)
    assert metrics.snr_db(1, 1000) == pytest.approx(-30.0)
    assert metrics.snr_db(5, 0) == math.inf
    assert metrics.snr_db(0, 5) == -math.inf
    assert math.isnan(metrics.snr_db(0, 0))


def test_denoise_scores_by_hand():
    is_signal = np.array([1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0], bool)
    keep = np.array([1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0], bool)
    s = metrics.denoise_scores(is_signal, keep)
    assert (s["signal_before"], s["noise_before"], s["signal_after"], s["noise_after"]) == (4, 8, 3, 1)
    assert s["snr_before_db"] == pytest.approx(10 * np.log10(4 / 8))
    assert s["snr_after_db"] == pytest.approx(10 * np.log10(3 / 1))
    assert s["snr_gain_db"] == pytest.approx(10 * np.log10(3 / 1) - 10 * np.log10(4 / 8))
    assert s["signal_retained"] == pytest.approx(0.75)
    assert s["noise_removed"] == pytest.approx(7 / 8)
    with pytest.raises(ValueError, match="equal length"):
        metrics.denoise_scores(is_signal, keep[:-1])


def test_roc_from_masks_endpoints_and_area():
    rng = np.random.default_rng(0)
    is_signal = rng.random(5000) < 0.2
    fpr, tpr, auc = metrics.roc_from_masks(is_signal, [is_signal])  # a perfect filter
    assert auc == pytest.approx(1.0) and fpr[0] == 0 and tpr[-1] == 1
    _, _, auc = metrics.roc_from_masks(is_signal, [rng.random(5000) < q for q in np.linspace(0, 1, 21)])
    assert auc == pytest.approx(0.5, abs=0.05)
    with pytest.raises(ValueError, match="both"):
        metrics.roc_from_masks(np.ones(4, bool), [np.ones(4, bool)])


def test_threshold_sweep_over_all_counts_equals_sklearn_auc():
    rng = np.random.default_rng(1)
    is_signal = rng.random(3000) < 0.3
    scores = rng.poisson(np.where(is_signal, 6.0, 3.0))
    masks = [scores >= th for th in np.unique(scores)]
    _, _, auc = metrics.roc_from_masks(is_signal, masks)
    assert auc == pytest.approx(metrics.roc_auc_from_scores(is_signal, scores), abs=1e-12)


@pytest.fixture(scope="module")
def simulation():
    from evstar import sim
    return sim.simulate(sim.paper_preset(12.0), seed=2)


def test_sweep_with_a_filter_on_a_simulation(simulation):
    ev, labels = simulation.events, simulation.truth.labels
    out = metrics.threshold_sweep(lambda th: denoise.NDSEF(10_000, 5, th), ev, labels >= 0, [1, 2, 4, 8, 16, 32])
    assert out["auc"] > 0.95
    assert np.all(np.diff(out["tpr"]) >= 0) and len(out["masks"]) == 6


def test_hot_pixels_found_and_scored(simulation):
    ev, truth = simulation.events, simulation.truth
    found = metrics.find_hot_pixels(ev)
    np.testing.assert_array_equal(np.sort(found), np.sort(truth.hot_pixels))
    none = metrics.hot_pixel_scores(ev, np.ones(len(ev), bool))
    assert none["hot_events_removed"] == 0 and none["hot_pixels_removed"] == 0
    allgone = metrics.hot_pixel_scores(ev, np.zeros(len(ev), bool), truth.hot_pixels)
    assert allgone["hot_events_removed"] == 1 and allgone["hot_pixels_removed"] == 1
    on_hot = np.isin(ev.y.astype(np.int64) * ev.width + ev.x, truth.hot_pixels)
    assert allgone["hot_events"] == on_hot.sum() >= (truth.labels == -2).sum()


def esr_by_formula(x, y, width, height, m):
    n = len(x)
    counts = np.zeros(width * height)
    np.add.at(counts, y * width + x, 1)
    ntss = np.sum(counts * (counts - 1)) / (n * (n - 1))
    l_n = width * height - np.sum((1 - m / n) ** counts)
    return np.sqrt(ntss * l_n)


def test_esr_follows_the_emlb_formula():
    rng = np.random.default_rng(3)
    n, w, h = 90_000, 50, 40
    x, y = rng.integers(0, w, n), rng.integers(0, h, n)
    ev = evstar.Events(np.arange(n), x, y, np.ones(n), w, h)
    expect = np.mean([esr_by_formula(x[i:i + 30_000], y[i:i + 30_000], w, h, 20_000) for i in (0, 30_000, 60_000)])
    assert metrics.esr(ev) == pytest.approx(expect, rel=1e-12)
    short = ev[:1000]
    assert metrics.esr(short, reference_events=500) == pytest.approx(esr_by_formula(x[:1000], y[:1000], w, h, 500))
    assert math.isnan(metrics.esr(ev[:1]))
    with pytest.raises(ValueError, match="packet_events"):
        metrics.esr(ev, packet_events=1)


def test_esr_rewards_structure():
    rng = np.random.default_rng(4)
    n, w, h = 60_000, 64, 48
    uniform = evstar.Events(np.arange(n), rng.integers(0, w, n), rng.integers(0, h, n), np.ones(n), w, h)
    blob = evstar.Events(np.arange(n), np.clip(rng.normal(30, 3, n), 0, w - 1).astype(int),
                         np.clip(rng.normal(20, 3, n), 0, h - 1).astype(int), np.ones(n), w, h)
    assert metrics.esr(blob) > 1.5 * metrics.esr(uniform)


def test_write_report_writes_the_table_page_and_its_json(tmp_path):
    import json

    from evstar import profiling

    rows = [{"k": 2, "lag": 3.21}]
    text = profiling.table(rows, [("k", "k", ""), ("lag", "lag ms", ".1f")])
    for _ in range(2):                           # a second run rewrites them
        profiling.write_report(tmp_path / "results", "study_x", rows, "A study (seed 1)", text,
                               {"seed": 1})
    page = (tmp_path / "results" / "study_x.md").read_text()
    assert page == "# A study (seed 1)\n\n| k | lag ms |\n|---|---|\n| 2 | 3.2 |\n"
    doc = json.loads((tmp_path / "results" / "study_x.json").read_text())
    assert doc["rows"] == rows and doc["meta"] == {"seed": 1}


def test_time_call_reports_the_cpu_time_of_its_runs():
    from evstar import profiling

    def burn():
        return sum(i * i for i in range(20_000))

    r = profiling.time_call(burn, repeats=3)
    assert set(r) == {"first_s", "median_s", "runs_s", "cpu_median_s"}
    assert len(r["runs_s"]) == 3 and r["cpu_median_s"] > 0


def test_field_bench_rows_carry_cpu_time_and_render():
    from evstar import bench, profiling

    rows = bench.field_run("--preset davis346 --stars 3 --rate 10 --duration 0.2".split(),
                           modes=("none",), repeats=2, progress=lambda *_: None)
    (row,) = rows
    assert row["events"] > 0 and row["cpu_s"] > 0 and row["realtime"] > 0
    assert "CPU s" in profiling.table(rows, bench.FIELD_COLUMNS)
