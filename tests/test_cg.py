"""CG comparison (paper §3.1, Figs 3–6) and run subsets."""

import math

import h5py
import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.analysis.cg import compare_cg
from granalytics.cli import main
from granalytics.base.errors import ParameterError
from granalytics.core import RunWriter, subset_run
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
from conftest import expects_small_run_warnings


def write_run(path, n_particles, alpha, final_fraction=0.55, wall_per_sim_s=None, revolutions=4.0, seed=0):
    """A physics-free run with a granulation curve, and the wall time a simulator would record."""
    meta = synthetic_meta(n_particles, alpha)
    period = 2 * math.pi / meta.drum_omega
    with RunWriter(path, meta) as writer:
        for k in range(int(revolutions * 10) + 1):
            rev = k / 10
            writer.append(synthetic_snapshot(
                n_particles, granulated_fraction=final_fraction * (1 - math.exp(-rev / 0.7)), time=rev * period,
                step=k * 100, alpha=alpha, seed=seed * 1000 + k, meta=meta))
        if wall_per_sim_s is not None:
            writer.update_provenance(wall_time_per_simulated_s=wall_per_sim_s, wall_time_s=wall_per_sim_s * revolutions * period)
    return path


@pytest.fixture(scope="module")
def cg_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("cg")
    # one system: 8 100 original particles, 300 at CG3
    return [write_run(d / "cg1.h5", 8100, 1.0, wall_per_sim_s=40.0, seed=1),
            write_run(d / "cg3.h5", 300, 3.0, wall_per_sim_s=2.0, seed=2),
            write_run(d / "low.h5", 300, 3.0, final_fraction=0.3, wall_per_sim_s=2.0, seed=3)]


def test_equal_granulation_agrees_and_a_different_one_is_flagged(cg_runs):
    cg1, cg3, low = cg_runs
    comparison = compare_cg([cg3, cg1, low], labels=["cg3", "cg1", "low"], window=(2, 4), c_agg=0.6, a_agg_deg=20)
    table = comparison.table.set_index("run")
    assert comparison.reference == "cg1"  # the smallest α, wherever it is listed
    assert table.loc["cg1", "yield_fraction_rel_dev"] == 0 and table.loc["cg1", "ks_distance"] == 0
    assert abs(table.loc["cg3", "yield_fraction_rel_dev"]) < 0.1
    assert table.loc["low", "yield_fraction_rel_dev"] < -0.3  # 0.3 planted against 0.55
    # yields are the steady-state means of the time series in the window
    ts = comparison.timeseries
    inside = ts[(ts["run"] == "cg3") & (ts["revolutions"] >= 2) & (ts["revolutions"] <= 4)]
    assert table.loc["cg3", "yield_fraction_mean"] == pytest.approx(inside["yield_fraction"].mean())
    assert table.loc["cg3", "n_frames"] == len(inside)
    # the KS distance is that of the pooled sizes
    from scipy.stats import ks_2samp

    assert table.loc["low", "ks_distance"] == pytest.approx(ks_2samp(comparison.sizes["low"], comparison.sizes["cg1"]).statistic)
    # speed-up from the wall time per simulated second each run recorded
    assert table.loc["cg3", "speedup"] == pytest.approx(20.0) and table.loc["cg3", "paper_speedup"] == 32
    assert (table["cohesion"] == "acting").all() and (table["method"] == "gna").all()
    assert set(comparison.distributions["run"]) == {"cg1", "cg3", "low"}


def test_runs_without_wall_time_have_no_speedup_and_default_labels(tmp_path, cg_runs):
    plain = write_run(tmp_path / "plain.h5", 300, 3.0)
    comparison = compare_cg([cg_runs[0], plain], window=(2, 4), cohesion="bridge")
    assert list(comparison.table["run"]) == ["CG1 (8100 particles)", "CG3 (300 particles)"]
    assert math.isnan(comparison.table["speedup"].iloc[1])
    assert (comparison.table["cohesion"] == "bridge").all() and "cohesion=bridge" in comparison.description


def test_bad_requests_are_refused(cg_runs):
    with pytest.raises(ParameterError, match="at least two"):
        compare_cg(cg_runs[:1])
    with pytest.raises(ParameterError, match="labels"):
        compare_cg(cg_runs[:2], labels=["a"])
    with pytest.raises(ParameterError, match="labelled"):
        compare_cg(cg_runs[:2], labels=["a", "a"], window=(2, 4))
    with pytest.raises(ParameterError, match="no frame in the window"):
        compare_cg(cg_runs[:2], window=(7, 8))


def test_save_writes_the_three_tables_and_the_figures_and_never_overwrites(tmp_path, cg_runs):
    from granalytics.report import output_paths

    comparison = compare_cg(cg_runs[:2], window=(2, 4))
    written = ga.save(comparison, tmp_path / "out")
    figures = [f"{name}.{ext}" for name in ("fig3_mean_volume", "fig4_granule_number", "fig5_size_distribution",
                                            "fig6_yield") for ext in ("pdf", "png")]
    assert sorted(p.rsplit("/", 1)[-1] for p in map(str, written)) == sorted(["cg_sizes.csv", "cg_table.csv",
                                                                              "cg_timeseries.csv", *figures])
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(["cg_sizes.csv", "cg_table.csv",
                                                                           "cg_timeseries.csv", *figures])
    table = pd.read_csv(tmp_path / "out" / "cg_table.csv")
    np.testing.assert_allclose(table["yield_fraction_mean"], comparison.table["yield_fraction_mean"])
    with pytest.raises(ParameterError, match="exists"):
        ga.save(comparison, tmp_path / "out")
    ga.save(comparison, tmp_path / "out", overwrite=True)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "fig3_mean_volume.png").write_text("")
    with pytest.raises(ParameterError, match="fig3_mean_volume.png: exists"):  # checked before the analysis
        output_paths(ga.CGComparison, tmp_path / "other")


def test_compare_cg_cli(tmp_path, cg_runs, capsys):
    out = tmp_path / "cli"
    args = ["compare-cg", str(cg_runs[0]), str(cg_runs[1]), "--out", str(out), "--window", "2:4", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "cohesion=acting" in printed and "CG3 (300 particles)" in printed and "20.0×" in printed
    assert "mean ± block s.e.m." in printed and "deviation ± s.e." in printed  # every error column named
    assert "wrote 11 files" in printed
    # the tables and the four figures (the paper's Figs 3-6) in two formats
    figures = [f"{f}.{e}" for f in ("fig3_mean_volume", "fig4_granule_number", "fig5_size_distribution", "fig6_yield")
               for e in ("png", "pdf")]
    assert sorted(p.name for p in out.iterdir()) == sorted(["cg_table.csv", "cg_timeseries.csv", "cg_sizes.csv",
                                                            *figures])
    assert (out / "fig5_size_distribution.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "fig6_yield.pdf").read_bytes()[:4] == b"%PDF"
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "exists" in err and "\n" not in err
    for table in ("cg_table.csv", "cg_timeseries.csv", "cg_sizes.csv"):  # a figure alone is refused too
        (out / table).unlink()
    assert main(args) == 2
    assert "fig3_mean_volume.png: exists" in capsys.readouterr().err
    assert main(args + ["--overwrite", "--cohesion", "bridge"]) == 0
    assert "cohesion=bridge" in capsys.readouterr().out
    assert main(["compare-cg", str(cg_runs[0]), "--out", str(out), "--quiet"]) == 2


def test_subset_keeps_the_window_and_every_nth_frame_as_float32(tmp_path, cg_runs, capsys):
    src = cg_runs[0]
    dst = tmp_path / "sub.h5"
    assert main(["subset", str(src), "--out", str(dst), "--full-window", "2:4", "--every", "4", "--float32", "--quiet"]) == 0
    with ga.open_run(src) as full, ga.open_run(dst) as sub:
        revs = full.revolutions
        expected = [k for k in range(len(full)) if k % 4 == 0 or 2 <= revs[k] <= 4]
        assert sub.meta.provenance["subset_of"]["frames_kept"] == expected
        np.testing.assert_array_equal(sub.times, full.times[expected])
        a, b = full[expected[-1]], sub[len(sub) - 1]
        assert b.position.dtype == np.float64
        np.testing.assert_allclose(b.position, a.position, rtol=1e-7)
        np.testing.assert_array_equal(b.contact_i, a.contact_i)
    with h5py.File(dst) as f:
        assert f["particles/position"].dtype == np.float32 and f["frames/time"].dtype == np.float64
    assert main(["subset", str(src), "--out", str(dst), "--quiet"]) == 2  # exists
    assert main(["subset", str(src), "--out", str(src), "--overwrite", "--quiet"]) == 2  # its own input
    with pytest.raises(ga.ValidationError, match="increasing"):
        subset_run(src, tmp_path / "bad.h5", [3, 1])


def test_runs_of_different_simulator_physics_versions_are_flagged(tmp_path, cg_runs):
    def versioned(name, version):
        path = write_run(tmp_path / name, 300, 3.0, revolutions=3.0, seed=4)
        with RunWriter.continue_from(path, 31) as writer:
            writer.update_provenance(physics_version=version)
        return path

    old, new = versioned("old.h5", 1), versioned("new.h5", 2)
    with pytest.warns(UserWarning, match="different simulator physics versions.*old: 1, new: 2"):
        compare_cg([old, new], labels=["old", "new"], window=(2, 3))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # one version (or none recorded): no warning
        compare_cg([new, versioned("same.h5", 2), cg_runs[0]], labels=["a", "b", "c"], window=(2, 3))


def test_runs_of_different_systems_are_refused_or_with_mixed_systems_flagged(tmp_path, cg_runs):
    other = write_run(tmp_path / "other.h5", 100, 3.0, seed=5)  # 2 700 original particles, not 8 100
    with pytest.raises(ga.ParameterError, match="not coarse-grained from one system.*original particle counts.*8100"
                                                ".*2700.*mixed_systems=True"):
        compare_cg([cg_runs[0], other], labels=["cg1", "other"], window=(2, 4))
    with pytest.warns(UserWarning, match="not coarse-grained from one system.*original particle counts.*8100.*2700"):
        compare_cg([cg_runs[0], other], labels=["cg1", "other"], window=(2, 4), mixed_systems=True)


def test_cg_deviation_at_every_threshold_pair(tmp_path, cg_runs, capsys):
    """compare_cg_thresholds: the finest run's row has zero deviation, the others (run − finest)/finest
    at each pair, equal to what compare_cg gives at that single pair; the command writes a table and
    one heatmap per statistic."""
    from granalytics.cli import main

    runs = [str(p) for p in cg_runs[:2]]
    table = ga.compare_cg_thresholds(runs, [0.3, 0.6], [20.0, 45.0], window=(2, 4)).table
    assert len(table) == len(runs) * 4
    finest = table[table.alpha == table.alpha.min()]
    assert (finest.filter(like="_rel_dev").fillna(0) == 0).all().all()
    single = ga.compare_cg(runs, window=(2, 4), c_agg=0.6, a_agg_deg=45.0).table.set_index("alpha")
    row = table[(table.c_agg == 0.6) & (table.a_agg_deg == 45.0)].set_index("alpha")
    for alpha in row.index:
        assert row.loc[alpha, "yield_fraction_mean"] == pytest.approx(single.loc[alpha, "yield_fraction_mean"])
        assert row.loc[alpha, "yield_fraction_rel_dev"] == pytest.approx(single.loc[alpha, "yield_fraction_rel_dev"],
                                                                         nan_ok=True)
    out = tmp_path / "cg"
    assert main(["compare-cg", *runs, "--window", "2:4", "--c-agg", "0.3,0.6", "--a-agg-deg", "20,45", "--out",
                 str(out), "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["cg_thresholds.csv", "cg_thresholds_mean_volume_norm.png",
                                                     "cg_thresholds_n_granules_norm.png",
                                                     "cg_thresholds_yield_fraction.png"]
    assert "largest |deviation|" in capsys.readouterr().out


@expects_small_run_warnings
def test_size_bins_start_at_the_smallest_size_that_can_occur():
    """Round four, C1: with --min-size 3, CG1 and CG2 kept a first bin [2, 3] of density count/2
    and CG3 an empty [2, 2] bin: the small-size end differed by 2x for no physical reason."""
    from granalytics.datasets import dataset_path
    from granalytics.report.figures import cg_figures

    cg = compare_cg([dataset_path("lab-cg2"), dataset_path("lab-cg3")], window=(3.0, 4.0), min_size=3,
                    comotion="rigid")
    first = cg.distributions.groupby("run")["size_min"].min()
    assert (first == 3).all(), first
    fig5 = cg_figures(cg)["fig5_size_distribution"]
    for line in fig5.axes[0].get_lines():
        if len(line.get_xdata()):
            assert min(line.get_xdata()) >= 3


def test_the_description_names_every_threshold_the_identification_used(cg_runs):
    """Round four, C2: figures named C_agg only when it was not the default."""
    cg = compare_cg(cg_runs[:2], labels=["cg1", "cg3"], window=(2, 4))
    assert "c_agg=0.6, a_agg_deg=20, min_size=2" in cg.description
    rigid = compare_cg(cg_runs[:2], labels=["cg1", "cg3"], window=(2, 4), comotion="rigid", min_size=3)
    assert "rigid_tol=" in rigid.description and "min_size=3" in rigid.description


def test_threshold_grid_deviations_carry_their_standard_error():
    """Round four, C12: cg_thresholds.csv and its heatmaps had no error on the deviations."""
    from granalytics import compare_cg_thresholds
    from granalytics.datasets import dataset_path

    table = compare_cg_thresholds([dataset_path("lab-cg2"), dataset_path("lab-cg3")], [0.4, 0.6], [20],
                                  window=(3.0, 4.5)).table
    cg3 = table[table["alpha"] == 3.0]
    assert (cg3["yield_fraction_rel_dev_se"] > 0).all() and (cg3["yield_fraction_sem"] > 0).all()
    ratio = cg3["yield_fraction_mean"] / table[table["alpha"] == 2.0]["yield_fraction_mean"].to_numpy()
    expected = ratio * np.hypot(cg3["yield_fraction_sem"] / cg3["yield_fraction_mean"],
                                table[table["alpha"] == 2.0]["yield_fraction_sem"].to_numpy()
                                / table[table["alpha"] == 2.0]["yield_fraction_mean"].to_numpy())
    assert np.allclose(cg3["yield_fraction_rel_dev_se"], expected)
    assert table[table["alpha"] == 2.0]["yield_fraction_rel_dev_se"].isna().all()


def test_a_threshold_pairs_error_is_the_one_steady_state_gives_its_frames():
    """compare_cg_thresholds cut its own blocks, without the window's tolerance: lab-cg3's frame of
    revolution 3 (stamped 2.99995) became a block of its own, and its errors were up to 1.35x
    those of stats for the same frames."""
    from granalytics import compare_cg_thresholds
    from granalytics.datasets import dataset_path

    paths = [dataset_path("lab-cg2"), dataset_path("lab-cg3")]
    table = compare_cg_thresholds(paths, [0.6], [20], window=(3, 6)).table
    for path, alpha in zip(paths, (2.0, 3.0)):
        with ga.open_run(path) as run:
            steady = ga.steady_state(ga.run_stats(run.select(revolutions=(3, 6)), c_agg=0.6, a_agg_deg=20), (3, 6))
        row = table[table["alpha"] == alpha].iloc[0]
        for metric in ("yield_fraction", "mean_volume_norm", "n_granules_norm"):
            assert row[f"{metric}_sem"] == pytest.approx(steady.loc[metric, "sem"], rel=1e-12)


def test_a_cg_run_without_granules_keeps_the_error_of_its_deviation():
    """(m - r)/r at m = 0 had the error |m/r|·hypot(se/m, ...) = 0·inf = NaN; it is se/|r|."""
    from granalytics.analysis.cg import _relative_deviation

    dev, se = _relative_deviation(0.0, 0.002, 0.05, 0.004)
    assert dev == -1.0 and se == pytest.approx(0.04)
    dev, se = _relative_deviation(0.04, 0.002, 0.05, 0.004)
    assert se == pytest.approx(0.8 * math.hypot(0.002 / 0.04, 0.004 / 0.05))  # as before where m != 0
