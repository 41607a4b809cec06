"""Bootstrapped confidence intervals over runs."""

import numpy as np
import pytest

from mjregen.search.stats import bootstrap_curves, group_stats, plot_panels


def test_bootstrap_ci_covers_the_mean_and_shrinks_with_more_runs():
    rng = np.random.default_rng(0)
    few = bootstrap_curves(rng.normal(5.0, 1.0, size=(5, 3)))
    many = bootstrap_curves(rng.normal(5.0, 1.0, size=(200, 3)))
    assert np.all(few.low <= few.mean) and np.all(few.mean <= few.high)
    assert np.all((many.high - many.low) < (few.high - few.low))
    # for 200 samples of N(5, 1) the 95 % CI of the mean is about ±1.96/sqrt(200) = ±0.139
    assert np.allclose(many.high - many.low, 2 * 1.96 / np.sqrt(200), rtol=0.15)
    assert np.all((many.low < 5.0) & (5.0 < many.high))


def test_identical_runs_give_a_zero_width_interval():
    stats = bootstrap_curves(np.tile([1.0, 2.0, 3.0], (4, 1)))
    assert np.array_equal(stats.mean, [1, 2, 3]) and np.array_equal(stats.low, stats.high)


def test_group_stats_reads_metrics_and_plots(tmp_path):
    for i, curve in enumerate(([1, 2, 3, 4], [2, 3, 4])):
        run = tmp_path / f"run{i}"
        run.mkdir()
        (run / "config.json").write_text('{"task": {"task": "locomotion"}}')
        (run / "metrics.csv").write_text("generation,best\n" + "".join(f"{g},{b}\n" for g, b in enumerate(curve)))
    stats = group_stats([tmp_path / "run0", tmp_path / "run1"])
    assert stats.n_runs == 2 and np.allclose(stats.mean, [1.5, 2.5, 3.5])
    assert stats.truncated and stats.run_lengths == (4, 3)
    plot_panels({"best": {"a": stats}}, tmp_path / "curves.png")
    assert (tmp_path / "curves.png").read_bytes()[:4] == b"\x89PNG"
    (tmp_path / "missing").mkdir()
    (tmp_path / "missing" / "config.json").write_text('{"task": {"task": "locomotion"}}')
    with pytest.raises(FileNotFoundError, match="metrics.csv"):
        group_stats([tmp_path / "missing"])


def test_few_runs_get_their_range_not_a_ci():
    """Below MIN_CI_RUNS runs a percentile bootstrap covers far less than 95 % (two runs: it
    is their range whatever the level), so the band is the runs' range and says so."""
    from mjregen.search.stats import MIN_CI_RUNS

    two = bootstrap_curves(np.array([[1.0, 4.0], [3.0, 2.0]]))
    assert two.band == "range" and MIN_CI_RUNS > 2
    assert np.array_equal(two.low, [1.0, 2.0]) and np.array_equal(two.high, [3.0, 4.0])
    enough = bootstrap_curves(np.random.default_rng(1).normal(size=(MIN_CI_RUNS, 2)))
    assert enough.band == "95 % CI"
