"""The metric registry drives every consumer: a fourth headline metric registered in a scratch
registry appears in every table, figure and printed column, and is gone after the block."""

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.analysis import metrics
from granalytics.analysis.metrics import HEADLINE, METRICS, GranuleCounts, Metric, registered
from test_cg import write_run
from test_study import sweep_dir  # noqa: F401  (fixture)
from conftest import expects_small_run_warnings

#: the share of free particles, 1 − yield: a headline metric the code has never heard of
FREE = Metric("free_fraction", "free share", "", ".3f", headline=True, order=3, title="free particles",
              value=lambda c: 1.0 - np.asarray(c.n_in_granules) / c.n_particles)


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    path = write_run(tmp_path_factory.mktemp("metrics") / "run.h5", 400, 1.0, revolutions=1.0)
    run = ga.open_run(path)
    yield run.select(revolutions=(0.5, 1.0))
    run.close()


def test_the_registered_metrics_compute_from_the_granule_counts():
    counts = GranuleCounts(n_granules=np.array([0, 4]), n_in_granules=np.array([0, 10]),
                           granule_volume_m3=np.array([0.0, 8e-9]), n_particles=50, n_initial=40,
                           mean_particle_volume_m3=1e-9)
    values = metrics.metric_values(counts)
    assert np.allclose(values["yield_fraction"], [0.0, 0.2])
    assert np.allclose(values["n_granules_norm"], [0.0, 0.1])
    assert np.isnan(values["mean_volume_norm"][0]) and values["mean_volume_norm"][1] == pytest.approx(2.0)
    assert values["mean_granule_size"][1] == pytest.approx(2.5)


@expects_small_run_warnings
def test_a_scratch_metric_is_carried_by_every_consumer_and_removed_after(frames, tmp_path, sweep_dir, capsys):  # noqa: F811
    import matplotlib

    matplotlib.use("Agg")
    from granalytics.cli import main
    from granalytics.report.figures import cg_figures, comparison_figure, sensitivity_figure, stats_figure

    with registered(FREE):
        assert list(HEADLINE) == ["yield_fraction", "mean_volume_norm", "n_granules_norm", "free_fraction"]
        ts = ga.run_stats(frames)
        assert np.allclose(ts["free_fraction"], 1 - ts["yield_fraction"])
        steady = ga.steady_state(ts, window=(0.5, 1.0))
        assert "free_fraction" in steady.index
        table = ga.sensitivity(frames, [0.3, 0.6], [20.0])
        assert np.allclose(table["free_fraction"], 1 - table["yield_fraction"])
        summary = ga.sensitivity_summary(table)
        assert "free_fraction_mean" in summary
        stats, pairs = ga.compare_methods(frames, {"gna": ("gna", {}), "sieve": ("sieve", {})})
        assert "free_fraction" in stats and "d_free_fraction" in pairs
        study = ga.study_table(sweep_dir, window=(3, 6))
        assert "free_fraction_mean" in study
        assert len(stats_figure(ts).axes) == 4
        assert len(sensitivity_figure(summary).axes) >= 8  # a heatmap (with its colour bar) and a line plot each
        assert len(comparison_figure(stats, pairs).axes) == 5
        comparison = ga.compare_cg([frames.path, frames.path], labels=["a", "b"], window=(0.5, 1.0))
        assert "free_fraction_mean" in comparison.table and "free_fraction" in cg_figures(comparison)
        assert main(["sensitivity", frames.path, "--c-agg", "0.3,0.6", "--a-agg-deg", "20", "--window", "0.5:1",
                     "--quiet"]) == 0
        assert "free_fraction_mean" in capsys.readouterr().out
        assert main(["compare-methods", frames.path, "--methods", "gna,sieve", "--window", "0.5:1", "--quiet"]) == 0
        assert "d_free_fraction" in capsys.readouterr().out
    assert "free_fraction" not in METRICS and "free_fraction" not in ga.run_stats(frames)
    assert len(HEADLINE) == 3


def test_a_metric_needs_a_value_function_and_a_new_name():
    with pytest.raises(TypeError, match="value must be a function"):
        Metric("x", "x")
    with pytest.raises(ValueError, match="exists"):
        metrics.register(Metric("yield_fraction", "yield", value=lambda c: 0.0))
    assert isinstance(pd.Index(HEADLINE), pd.Index)  # the live list works where pandas wants a list
