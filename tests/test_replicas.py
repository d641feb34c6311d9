"""Replica statistics (issue 25, item 4): groups of runs that differ only in their seed give the
mean over replicas with the replica standard error beside the block s.e.m., in
:func:`combine_replicas`, :func:`compare_cg`, :func:`study_table` and their figures and commands."""

import math

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.analysis.cg import compare_cg, group_replicas
from granalytics.cli import main
from granalytics.report.tables import plus_minus
from granalytics.base.errors import ParameterError
from granalytics.core.manifest import file_sha256
from granalytics.report.figures import cg_figures, growth_figure
from granalytics.analysis.stats import combine_replicas
from granalytics.analysis.study import study_table
from test_cg import write_run
from test_study import write_point


def test_combine_replicas_follows_its_closed_form():
    means = pd.DataFrame([[1.0, 2.0, 4.0], [0.5, 0.5, 0.5]], index=["a", "b"])
    sems = pd.DataFrame([[0.1, 0.2, 0.2], [0.3, np.nan, 0.3]], index=["a", "b"])
    out = combine_replicas(means, sems)
    assert out.loc["a", "mean"] == pytest.approx(7 / 3)
    assert out.loc["a", "replica_std"] == pytest.approx(np.std([1, 2, 4], ddof=1))
    assert out.loc["a", "replica_sem"] == pytest.approx(np.std([1, 2, 4], ddof=1) / math.sqrt(3))
    assert out.loc["a", "block_sem"] == pytest.approx(math.sqrt(0.01 + 0.04 + 0.04) / 3)
    assert out.loc["b", "replica_sem"] == 0 and math.isnan(out.loc["b", "block_sem"])  # a replica without error
    assert (out["n_replicas"] == 3).all()
    single = combine_replicas(means[[0]], sems[[0]])  # one replica: no run-to-run error, its own block error
    assert math.isnan(single.loc["a", "replica_sem"]) and single.loc["a", "block_sem"] == pytest.approx(0.1)
    with pytest.raises(ParameterError, match="metrics × replicas"):
        combine_replicas(means, sems[[0, 1]])


@pytest.fixture(scope="module")
def replica_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("replicas")
    cg1 = write_run(d / "cg1.h5", 8100, 1.0, wall_per_sim_s=40.0, seed=1)
    cg3 = [write_run(d / f"cg3-{k}.h5", 300, 3.0, final_fraction=f, wall_per_sim_s=2.0, seed=10 + k)
           for k, f in enumerate((0.45, 0.55, 0.65))]
    return cg1, cg3


def test_a_group_of_replicas_is_compared_by_its_mean_with_the_replica_error(replica_runs):
    cg1, cg3 = replica_runs
    grouped = compare_cg([cg1, cg3], window=(2, 4), c_agg=0.6, a_agg_deg=20)
    singles = [compare_cg([cg1, run], window=(2, 4), c_agg=0.6, a_agg_deg=20) for run in cg3]
    row = grouped.table.iloc[1]
    levels = [s.table.iloc[1]["yield_fraction_mean"] for s in singles]
    sems = [s.table.iloc[1]["yield_fraction_sem"] for s in singles]
    assert row["run"] == "CG3 (300 particles, 3 replicas)" and row["n_replicas"] == 3
    assert row["yield_fraction_mean"] == pytest.approx(np.mean(levels))
    assert row["yield_fraction_replica_sem"] == pytest.approx(np.std(levels, ddof=1) / math.sqrt(3))
    assert row["yield_fraction_sem"] == pytest.approx(math.sqrt(sum(s * s for s in sems)) / 3)
    # the planted levels (0.45, 0.55, 0.65) differ by far more than the frames scatter
    assert row["yield_fraction_replica_sem"] > 3 * row["yield_fraction_sem"]
    ref = grouped.table.iloc[0]
    assert ref["n_replicas"] == 1 and math.isnan(ref["yield_fraction_replica_sem"])
    assert row["yield_fraction_rel_dev"] == pytest.approx(np.mean(levels) / ref["yield_fraction_mean"] - 1)
    # its error: the group's replica s.e. and the single reference run's block s.e.m.
    ratio = row["yield_fraction_mean"] / ref["yield_fraction_mean"]
    assert row["yield_fraction_rel_dev_se"] == pytest.approx(ratio * math.hypot(
        row["yield_fraction_replica_sem"] / row["yield_fraction_mean"], ref["yield_fraction_sem"] / ref["yield_fraction_mean"]))
    # the pooled sizes and the time series keep every replica
    assert grouped.sizes[row["run"]].size == sum(s.sizes[s.table.iloc[1]["run"]].size for s in singles)
    ts = grouped.timeseries[grouped.timeseries["run"] == row["run"]]
    assert sorted(ts["replica"].unique()) == [0, 1, 2]
    assert grouped.runs.iloc[1]["path"].count(";") == 2


def test_replicas_that_agree_by_chance_keep_their_block_error(tmp_path, replica_runs):
    """Two replicas whose means agree far closer than their frames scatter: the deviation's error
    is their block s.e.m., not the chance replica s.e. (it printed "± 0 %")."""
    cg1 = replica_runs[0]
    twins = [write_run(tmp_path / f"cg3-{k}.h5", 300, 3.0, wall_per_sim_s=2.0, seed=20 + k) for k in range(2)]
    ref, row = (r for _, r in compare_cg([cg1, twins], window=(2, 4), c_agg=0.6, a_agg_deg=20).table.iterrows())
    assert row["yield_fraction_replica_sem"] < row["yield_fraction_sem"]
    ratio = row["yield_fraction_mean"] / ref["yield_fraction_mean"]
    assert row["yield_fraction_rel_dev_se"] == pytest.approx(ratio * math.hypot(
        row["yield_fraction_sem"] / row["yield_fraction_mean"], ref["yield_fraction_sem"] / ref["yield_fraction_mean"]))


def test_replica_bands_are_drawn_and_bad_groups_are_refused(replica_runs):
    import matplotlib.pyplot as plt

    cg1, cg3 = replica_runs
    grouped = compare_cg([cg1, cg3], window=(2, 4), c_agg=0.6, a_agg_deg=20)
    single = compare_cg([cg1, cg3[0]], window=(2, 4), c_agg=0.6, a_agg_deg=20)
    bands = {}
    for name, comp in (("grouped", grouped), ("single", single)):
        fig = cg_figures(comp)["fig6_yield"]
        bands[name] = len(fig.axes[0].collections)
        if name == "grouped":
            labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
            assert any("replica mean, range" in label for label in labels)
        plt.close("all")
    assert bands["grouped"] > bands["single"]  # the replicas' range over time is a band of its own
    with pytest.raises(ParameterError, match="not a replica"):
        compare_cg([cg1, [cg3[0], cg1]], window=(2, 4))
    with pytest.raises(ParameterError, match="empty group"):
        compare_cg([cg1, []], window=(2, 4))
    with pytest.raises(ParameterError, match="--replicas"):
        compare_cg([cg1, cg3[0], cg3[1]], window=(2, 4))


def test_group_replicas_and_the_command(replica_runs, tmp_path, capsys):
    cg1, cg3 = replica_runs
    groups = group_replicas([cg3[0], cg1, cg3[1], cg3[2]])
    assert groups == [[cg3[0], cg3[1], cg3[2]], [cg1]]
    out = tmp_path / "cg"
    assert main(["compare-cg", str(cg1), *map(str, cg3), "--replicas", "--window", "2:4", "--out", str(out),
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    table = pd.read_csv(out / "cg_table.csv")
    assert list(table["n_replicas"]) == [1, 3] and "yield_fraction_replica_sem" in table
    # the ± is the replica s.e. (so named), the block s.e.m. its own column (issue 33, B5)
    lines = text.splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("yield "))
    assert "mean ± replica s.e." in lines[header] and "block s.e.m." in lines[header]
    assert "deviation ± s.e." in lines[header]
    group = table.iloc[1]
    cg3_line = lines[header + 2]
    assert cg3_line.startswith("CG3 (300 particles, 3 replicas)")
    assert plus_minus(group["yield_fraction_mean"], group["yield_fraction_replica_sem"]) in cg3_line
    assert f"{group['yield_fraction_sem']:#.2g}" in cg3_line
    assert lines[header + 1].startswith("CG1") and "± n/a" in lines[header + 1] and "reference" in lines[header + 1]
    assert any(line.startswith("n/a: CG1 (8100 particles): a single run has no replica s.e.") for line in lines)
    assert "NaN" not in text and "nan" not in text
    assert main(["compare-cg", str(cg1), *map(str, cg3), "--replicas", "--c-agg", "0.4,0.6", "--out",
                 str(tmp_path / "grid"), "--quiet"]) != 0


@pytest.fixture(scope="module")
def replica_sweep(tmp_path_factory):
    """Two γ × three seeds at one Ω: fake points (see test_study.write_point)."""
    root = tmp_path_factory.mktemp("replica-sweep") / "sweep"
    (root / "points").mkdir(parents=True)
    rows = []
    for gamma in (0.06, 0.24):
        for seed in (0, 1, 2):
            name = f"gamma={gamma:g}_omega=2_seed={seed}"
            write_point(root / "points" / f"{name}.h5", gamma, 2.0, seed=seed + 7)
            rows.append({"point": name, "status": "done", "gamma": gamma, "omega": 2.0, "seed": seed,
                         "physics_version": 3, "file": f"points/{name}.h5",
                         "sha256": file_sha256(root / "points" / f"{name}.h5"),
                         "source_sha256": f"{seed + 1}" * 64})  # bookkeeping differs per point, as in a bundle
    pd.DataFrame(rows).to_csv(root / "manifest.csv", index=False)
    return root


def test_study_table_combines_replicas_and_the_figure_draws_their_band(replica_sweep):
    import matplotlib.pyplot as plt

    single = study_table(replica_sweep, window=(3, 6), cohesion="acting")
    combined = study_table(replica_sweep, window=(3, 6), cohesion="acting", replicas="seed")
    assert len(single) == 6 and len(combined) == 2
    for row in combined.itertuples():
        part = single[single["gamma"] == row.gamma]
        values = part["mean_volume_norm_mean"].to_numpy()
        assert row.n_replicas == 3 and row.seed == "0; 1; 2" and row.point.count(";") == 2
        assert row.mean_volume_norm_mean == pytest.approx(values.mean())
        assert row.mean_volume_norm_replica_sem == pytest.approx(values.std(ddof=1) / math.sqrt(3))
        assert row.mean_volume_norm_sem == pytest.approx(np.sqrt((part["mean_volume_norm_sem"] ** 2).sum()) / 3)
        assert row.n_frames == part["n_frames"].sum()
    for table in (single, combined):  # the same band whether the table was combined first or not
        fig = growth_figure(table, cohesion="acting")
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        assert any("replica s.e." in label for label in labels)
        plt.close(fig)
    with pytest.raises(ParameterError, match="no grid column 'replica'"):
        study_table(replica_sweep, window=(3, 6), cohesion="acting", replicas="replica")


def test_study_command_with_replicas(replica_sweep, capsys):
    assert main(["study", str(replica_sweep), "--replicas", "seed", "--cohesion", "acting", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "6 finished points of 6" in text and "replica s.e." in text and "n_replicas" in text
    # the ± is the replica s.e., the block s.e.m. in a column of its own; both named (issue 33, B5)
    assert "yield_fraction ± replica s.e." in text and "yield_fraction block s.e.m." in text
    assert main(["study", str(replica_sweep), "--cohesion", "acting", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "yield_fraction ± block s.e.m." in text and "replica s.e." not in text


def test_steady_state_of_a_list_is_over_replicas_and_the_stats_command_takes_replicas(replica_runs, capsys):
    _, cg3 = replica_runs
    series = []
    for path in cg3:
        with ga.open_run(path) as run:
            series.append(ga.run_stats(run))
    over = ga.steady_state(series, window=(2, 4))
    assert over.equals(ga.replica_steady_state(series, window=(2, 4)))
    assert over.loc["yield_fraction", "n_replicas"] == 3
    with pytest.raises(ParameterError, match="at least two replicas"):
        ga.steady_state(series[:1], window=(2, 4))
    assert main(["stats", str(cg3[0]), "--replica", str(cg3[1]), "--replica", str(cg3[2]), "--window", "2:4",
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "and 2 replica(s)" in text and "replica_sem" in text
    line = next(line for line in text.splitlines() if line.startswith("yield_fraction"))
    assert float(line.split()[1]) == pytest.approx(over.loc["yield_fraction", "mean"], rel=1e-4)


def test_a_sweep_and_its_replicas_in_another_folder_are_one_table(replica_sweep, tmp_path):
    import shutil

    manifest = pd.read_csv(replica_sweep / "manifest.csv")
    parts = []
    for name, seeds in (("seed0", [0]), ("later", [1, 2])):
        folder = tmp_path / name
        shutil.copytree(replica_sweep / "points", folder / "points")
        manifest[manifest.seed.isin(seeds)].to_csv(folder / "manifest.csv", index=False)
        parts.append(folder)
    together = study_table(parts, window=(3, 6), cohesion="acting", replicas="seed")
    whole = study_table(replica_sweep, window=(3, 6), cohesion="acting", replicas="seed")
    columns = ["gamma", "n_replicas", "mean_volume_norm_mean", "mean_volume_norm_replica_sem", "yield_fraction_sem"]
    pd.testing.assert_frame_equal(together[columns], whole[columns])
    with pytest.raises(ParameterError, match="no sweep folder"):
        study_table([], cohesion="acting")


def test_a_replica_without_a_value_is_left_out_of_that_metric_and_said():
    """A replica with no granule in its window has no <V_g>/V_p: pandas skipped it in the mean and
    std but n counted it, so the replica s.e. was std(2 means)/sqrt(3)."""
    means = pd.DataFrame({"a": [0.5, 3.0], "b": [0.6, 3.4], "c": [0.7, math.nan]}, index=["yield", "volume"])
    sems = pd.DataFrame({"a": [0.01, 0.1], "b": [0.01, 0.1], "c": [0.01, math.nan]}, index=means.index)
    with pytest.warns(UserWarning, match=r"volume has no value in replica\(s\) c: .*over the replicas that have one"):
        out = combine_replicas(means, sems)
    assert out.loc["volume", "n_replicas"] == 2 and out.loc["yield", "n_replicas"] == 3
    assert out.loc["volume", "replica_sem"] == pytest.approx(np.std([3.0, 3.4], ddof=1) / math.sqrt(2))
    assert out.loc["volume", "block_sem"] == pytest.approx(math.sqrt(2 * 0.1**2) / 2)
    assert out.loc["yield", "replica_sem"] == pytest.approx(np.std([0.5, 0.6, 0.7], ddof=1) / math.sqrt(3))


def test_a_metric_no_replica_has_is_undefined_without_a_warning():
    import warnings

    means = pd.DataFrame({"a": [0.5, math.nan], "b": [0.6, math.nan]}, index=["yield", "volume"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = combine_replicas(means, means * 0.1)
    assert math.isnan(out.loc["volume", "mean"]) and out.loc["volume", "n_replicas"] == 0
    tables = [pd.DataFrame({"mean": [0.5, v], "sem": [0.01, 0.1]}, index=["yield", "volume"]) for v in (3.0, math.nan)]
    with pytest.warns(UserWarning, match=r"volume has no value in replica\(s\) 2:"):
        ga.analysis.stats.combine_steady_states(tables)
