"""What the figures say, read from their matplotlib objects (legends, labels, colours, colour
bars), not their pixels; and granule sizes in original-particle equivalents (α³·n) for CG runs."""

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_hex  # noqa: E402

import granalytics as ga  # noqa: E402
from granalytics.report import figures as report_figures  # noqa: E402
from granalytics.analysis.metrics import BY_FIGURE, HEADLINE  # noqa: E402
from granalytics.core import RunWriter  # noqa: E402
from granalytics.base.errors import ParameterError  # noqa: E402
from granalytics.datasets import dataset_path  # noqa: E402
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot  # noqa: E402


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def legend_texts(legend):
    return [t.get_text() for t in legend.get_texts()]


def colour(artist):
    return to_hex(artist.get_color())


# ----------------------------------------------------------------------------------------------
# B10: sizes of CG runs in original-particle equivalents

@pytest.fixture(scope="module")
def lab_cg3():
    """The bundled lab drum at CG3 (α = 3): the granule sizes of revolutions 3–4, and its tracks."""
    with ga.open_run(dataset_path("lab-cg3")) as run:
        meta = run.meta
        frames = run.select(revolutions=(3, 4))
        _, sizes = ga.run_stats(frames, return_sizes=True, c_agg=0.6, a_agg_deg=20)
        tracks = ga.track_run(run, window=(3, 4), c_agg=0.6, a_agg_deg=20)
    return meta, sizes, tracks


def test_the_size_distribution_of_a_cg_run_in_original_equivalents_is_alpha_cubed_times_its_own(lab_cg3):
    meta, sizes, _ = lab_cg3
    assert meta.alpha == 3.0
    own = ga.size_distribution(sizes)
    original = ga.size_distribution(sizes, size_unit="original", alpha=meta)  # α read from the run's metadata
    assert own.attrs["size_unit"] == "particles" and original.attrs["size_unit"] == "original"
    assert original.attrs["alpha"] == 3.0
    for column in ("size_min", "size_max", "size_center"):
        np.testing.assert_allclose(original[column], 27 * own[column])
    np.testing.assert_array_equal(original["count"], own["count"])
    np.testing.assert_allclose(original["probability"], own["probability"])
    np.testing.assert_allclose(original["density"], own["density"] / 27)  # per original particle: still sums to 1
    widths = (original["size_max"] - original["size_min"] + 27)
    assert (original["density"] * widths).sum() == pytest.approx(1.0)
    pd.testing.assert_frame_equal(original, ga.size_distribution(sizes, size_unit="original", alpha=3))
    with pytest.raises(ParameterError, match="size_unit='original' needs the CG factor alpha"):
        ga.size_distribution(sizes, size_unit="original")
    with pytest.raises(ParameterError, match="size_distribution: size_unit must be one of 'particles', 'original', got str 'volume'"):
        ga.size_distribution(sizes, size_unit="volume")
    with pytest.raises(ParameterError, match="alpha must be a positive number"):
        ga.size_distribution(sizes, size_unit="original", alpha=-1)


def test_the_kernel_and_breakage_rate_of_a_cg_run_in_original_equivalents(lab_cg3):
    meta, _, tracks = lab_cg3
    own = ga.coalescence_kernel(tracks)
    original = ga.coalescence_kernel(tracks, size_unit="original", alpha=meta)
    for column in ("size_min_i", "size_max_i", "size_min_j", "size_max_j"):
        np.testing.assert_allclose(original[column], 27 * own[column])
    pd.testing.assert_series_equal(original["beta_per_s"], own["beta_per_s"])  # β is per pair of granules
    assert original.attrs == {"size_unit": "original", "alpha": 3.0}
    breakage = ga.breakage_rate(tracks, size_unit="original", alpha=3.0)
    np.testing.assert_allclose(breakage["size_min"], 27 * ga.breakage_rate(tracks)["size_min"])
    with pytest.raises(ParameterError, match="coalescence_kernel: size_unit='original' needs"):
        ga.coalescence_kernel(tracks, size_unit="original")
    # the figure says the unit on its axes, the histories in the kernel's unit
    fig = report_figures.tracking_figure(tracks, ga.event_rates(tracks, revolution_period_s=2 * math.pi / meta.drum_omega),
                               original)
    rates_ax, histories, kernel_ax = fig.axes[:3]
    assert histories.get_ylabel() == "original-particle equivalents per granule (α³·n)"
    assert "α³·n" in kernel_ax.get_xlabel() and "α³·n" in kernel_ax.get_ylabel()
    biggest = max(max(s) for s in tracks.tracks["sizes"])
    assert max(line.get_ydata().max() for line in histories.lines) <= 27 * biggest
    assert max(line.get_ydata().max() for line in histories.lines) % 27 == 0


# ----------------------------------------------------------------------------------------------
# B6: the kinetics figure with one bin; legends below the panels

def test_a_one_revolution_kinetics_figure_draws_bars_with_poisson_errors_and_legends_below(lab_cg3):
    meta, _, tracks = lab_cg3
    rates = ga.event_rates(tracks, revolution_period_s=2 * math.pi / meta.drum_omega)
    assert rates["bin"].nunique() == 1
    fig = report_figures.tracking_figure(tracks, rates)
    rates_ax, histories = fig.axes
    bars = [p for p in rates_ax.patches if isinstance(p, matplotlib.patches.Rectangle)]
    assert len(bars) == 4
    heights = sorted(b.get_height() for b in bars)
    assert heights == pytest.approx(sorted(rates["rate_per_rev"]))
    assert [t.get_text() for t in rates_ax.get_xticklabels()] == ["birth", "death", "coalescence", "breakage"]
    assert sorted(t.get_text() for t in rates_ax.texts) == sorted(str(c) for c in rates["count"])
    assert "Poisson" in rates_ax.get_title()
    fig.canvas.draw()
    for ax in (rates_ax, histories):  # every legend below its panel: never over the tracks
        legend = ax.get_legend()
        assert legend.get_window_extent().y1 < ax.get_window_extent().y0


def test_kinetics_over_several_bins_are_markers_and_lines_with_error_bars(lab_cg3):
    meta, _, tracks = lab_cg3
    rates = ga.event_rates(tracks, revolution_period_s=2 * math.pi / meta.drum_omega, bin_width=0.25)
    fig = report_figures.tracking_figure(tracks, rates)
    ax = fig.axes[0]
    assert len(ax.containers) == 4 and not [p for p in ax.patches]  # one errorbar per kind, no bars
    births = rates[rates["kind"] == "birth"]
    line = ax.containers[0].lines[0]
    assert line.get_marker() == "o" and line.get_linestyle() == "-"
    np.testing.assert_allclose(np.asarray(line.get_ydata(), dtype=float), births["rate_per_rev"].to_numpy(dtype=float))


# ----------------------------------------------------------------------------------------------
# B6 / B5: the CG figures (Figs 3–6)

def _write_run(path, n_particles, alpha, seed):
    meta = synthetic_meta(n_particles, alpha)
    period = 2 * math.pi / meta.drum_omega
    with RunWriter(path, meta) as writer:
        for k in range(41):
            rev = k / 10
            writer.append(synthetic_snapshot(n_particles, granulated_fraction=0.55 * (1 - math.exp(-rev / 0.7)),
                                             time=rev * period, step=k * 100, alpha=alpha, seed=seed * 1000 + k,
                                             meta=meta))
    return path


@pytest.fixture(scope="module")
def comparison(tmp_path_factory):
    d = tmp_path_factory.mktemp("figures")
    runs = [_write_run(d / "cg1.h5", 2700, 1.0, 1), _write_run(d / "cg3.h5", 100, 3.0, 2),
            _write_run(d / "cg3b.h5", 100, 3.0, 3)]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ga.compare_cg([runs[0], runs[1:]], labels=["cg1", "cg3"], window=(2, 4))


def test_a_replica_group_has_a_spread_at_its_common_frames_and_one_pooled_size_distribution(comparison):
    spread = comparison.replica_spread("cg3", "yield_fraction")
    group = comparison.timeseries[comparison.timeseries["run"] == "cg3"]
    wide = group.pivot(index="revolutions", columns="replica", values="yield_fraction")
    assert len(spread) == len(wide) == 41 and wide.shape[1] == 2
    np.testing.assert_allclose(spread.index, wide.index, atol=1e-6)
    np.testing.assert_allclose(spread["mean"], wide.mean(axis=1))
    np.testing.assert_allclose(spread["min"], wide.min(axis=1))
    np.testing.assert_allclose(spread["max"], wide.max(axis=1))
    one = comparison.replica_spread("cg1", "yield_fraction")  # a single run: its own curve
    assert (one["min"] == one["max"]).all() and (one["mean"] == one["max"]).all()
    with pytest.raises(ParameterError, match="run must be one of 'cg1', 'cg3', got 'cg2'"):
        comparison.replica_spread("cg2", "yield_fraction")
    dists = comparison.size_distributions()
    assert list(dists) == ["cg1", "cg3"]
    pd.testing.assert_frame_equal(dists["cg3"], ga.size_distribution(comparison.sizes["cg3"], ci=0.95))
    original = comparison.size_distributions("original")["cg3"]
    assert original.attrs["size_unit"] == "original"
    np.testing.assert_allclose(original["size_center"], 27 * dists["cg3"]["size_center"])
    np.testing.assert_allclose(original["density_hi"], dists["cg3"]["density_hi"] / 27)


def test_the_time_series_figures_name_the_window_the_mean_lines_and_their_errors(comparison):
    figures = report_figures.cg_figures(comparison)
    assert set(figures) == {"fig3_mean_volume", "fig4_granule_number", "fig5_size_distribution", "fig6_yield"}
    for key in ("fig3_mean_volume", "fig4_granule_number", "fig6_yield"):
        texts = legend_texts(figures[key].axes[0].get_legend())
        assert "steady-state window [2, 4] rev" in texts
        # the errors of the comparison's table: block s.e.m. of one run, replica s.e. of a group
        assert "steady-state mean ± block s.e.m. (replica groups: replica s.e.)" in texts
        assert "band over the curve: range (min–max) of the replicas" in texts


def test_each_run_keeps_its_colour_in_every_cg_figure(comparison):
    figures = report_figures.cg_figures(comparison)
    seen = {}
    for key, fig in figures.items():
        ax = fig.axes[0]
        for handle, text in zip(*ax.get_legend_handles_labels()):
            run = text.split(":")[0].split(" ")[0]
            if run in ("cg1", "cg3"):
                seen.setdefault(run, set()).add(colour(handle))
    assert set(seen) == {"cg1", "cg3"}
    assert all(len(c) == 1 for c in seen.values()), seen
    assert seen["cg1"] != seen["cg3"]


def test_fig5_draws_a_bootstrap_band_says_so_and_its_unit(comparison):
    figures = report_figures.cg_figures(comparison)
    ax = figures["fig5_size_distribution"].axes[0]
    assert ax.get_xlabel() == "particles per granule"
    texts = legend_texts(ax.get_legend())
    assert "band: bootstrap 95% CI over the granules" in texts
    assert [t.split(":")[0] for t in texts[:2]] == ["cg1", "cg3"]  # the runs first, then the keys
    bands = [c for c in ax.collections if len(c.get_paths()) and len(c.get_paths()[0].vertices)]
    assert len(bands) == 2  # one per run
    own = {t.split(":")[0]: h for h, t in zip(*ax.get_legend_handles_labels())}
    original = report_figures.cg_figures(comparison, size_unit="original")["fig5_size_distribution"].axes[0]
    assert original.get_xlabel() == "original-particle equivalents per granule (α³·n)"
    moved = {t.split(":")[0]: h for h, t in zip(*original.get_legend_handles_labels())}
    np.testing.assert_allclose(moved["cg3"].get_xdata(), 27 * own["cg3"].get_xdata())
    np.testing.assert_allclose(moved["cg1"].get_xdata(), own["cg1"].get_xdata())


def test_bins_of_fewer_than_three_granules_get_open_markers_and_a_legend_entry():
    sizes = np.r_[np.full(200, 2), np.full(50, 5), [40, 41]]  # the last bin rests on 2 granules
    dist = ga.size_distribution(sizes, ci=0.95)
    ax = report_figures.plot_size_distribution(dist, label="run")
    open_markers = [line for line in ax.lines if line.get_markerfacecolor() == "white" and len(line.get_xdata())]
    assert len(open_markers) == 1
    assert open_markers[0].get_xdata().tolist() == [dist.loc[dist["count"] == 2, "size_center"].iloc[0]]
    texts = [t for t in ax.get_legend_handles_labels()[1]]
    assert "open marker: < 3 granules in the bin" in texts and "band: bootstrap 95% CI over the granules" in texts
    report_figures.plot_size_distribution(dist, ax=ax, label="again")  # keys once per axes
    assert ax.get_legend_handles_labels()[1].count("open marker: < 3 granules in the bin") == 1


def test_the_bootstrap_band_holds_the_density_and_narrows_with_more_granules():
    rng = np.random.default_rng(0)
    sizes = np.round(2 * rng.pareto(1.5, 400) + 2).astype(int)
    small = ga.size_distribution(sizes, ci=0.95)
    assert ((small["density_lo"] <= small["density"]) & (small["density"] <= small["density_hi"])).all()
    pd.testing.assert_frame_equal(small, ga.size_distribution(sizes, ci=0.95))  # seeded
    large = ga.size_distribution(np.tile(sizes, 100), ci=0.95)
    first = (small["density_hi"] - small["density_lo"]).iloc[0] / (large["density_hi"] - large["density_lo"]).iloc[0]
    assert 7 < first < 13  # √100
    with pytest.raises(ParameterError, match=r"size_distribution: ci must be a number in \(0, 1\) or None, got int 95"):
        ga.size_distribution(sizes, ci=95)


# ----------------------------------------------------------------------------------------------
# demo-stats, compare.png, sensitivity, CG threshold heatmaps

def test_the_stats_figure_names_the_window_and_the_mean_with_its_error():
    rng = np.random.default_rng(1)
    revs = np.arange(0, 121) * 0.05
    ts = pd.DataFrame({"revolutions": revs, "time_s": revs * 2.0,
                       **{m: 0.3 + 0.05 * rng.standard_normal(revs.size) for m in BY_FIGURE}})
    fig = report_figures.stats_figure(ts, ga.size_distribution(np.r_[np.full(30, 2), [3, 9]]), window=(3, 6))
    texts = legend_texts(fig.legends[0])
    assert texts == ["per frame", "steady-state window [3, 6] rev", "steady-state mean ± block s.e.m."]
    steady = ga.steady_state(ts, window=(3, 6), columns=list(BY_FIGURE))
    for ax, metric in zip(fig.axes, BY_FIGURE):
        mean_line = ax.collections[-2] if len(ax.collections) > 1 else ax.collections[-1]
        ys = {round(float(y), 12) for seg in mean_line.get_segments() for y in seg[:, 1]}
        assert ys == {round(float(steady.loc[metric, "mean"]), 12)}
    assert "open marker: < 3 granules in the bin" in legend_texts(fig.axes[-1].get_legend())


def test_compare_methods_figure_keeps_one_colour_per_method_and_gives_pairs_others():
    revs = np.arange(10) * 0.1
    methods = ["gna", "dbscan", "sieve"]
    stats = pd.concat([pd.DataFrame({"method": m, "revolutions": revs, **{h: k + revs for h in HEADLINE}})
                       for k, m in enumerate(methods)])
    pairs = pd.concat([pd.DataFrame({"method_a": a, "method_b": b, "revolutions": revs, "ari": 0.5})
                       for a, b in (("gna", "dbscan"), ("gna", "sieve"), ("dbscan", "sieve"))])
    fig = report_figures.comparison_figure(stats, pairs)
    *metric_axes, ari = fig.axes
    per_panel = [[colour(line) for line in ax.lines] for ax in metric_axes]
    assert all(c == per_panel[0] for c in per_panel) and len(set(per_panel[0])) == len(methods)
    pair_colours = {colour(line) for line in ari.lines}
    assert len(pair_colours) == 3 and not pair_colours & set(per_panel[0])
    assert legend_texts(fig.legends[0]) == methods


def test_a_method_with_the_statistics_of_an_earlier_one_is_named_and_drawn_dotted_over_it():
    revs = np.arange(5) * 0.1
    values = {"gna": revs, "dbscan": revs + 1, "sieve": revs, "community": revs}
    stats = pd.concat([pd.DataFrame({"method": m, "revolutions": revs, **{h: v for h in HEADLINE}})
                       for m, v in values.items()])
    stats.loc[stats["method"] != "dbscan", "n_granules_norm"] = np.nan  # NaN equals NaN
    assert ga.identical_methods(stats) == {"sieve": "gna", "community": "gna"}  # never a copy of a copy
    assert ga.identical_methods(stats, ["yield_fraction"]) == {"sieve": "gna", "community": "gna"}
    different = stats.assign(yield_fraction=np.where(stats["method"] == "sieve", 9.0, stats["yield_fraction"]))
    assert ga.identical_methods(different) == {"community": "gna"}
    pairs = pd.DataFrame({"method_a": "gna", "method_b": "sieve", "revolutions": revs, "ari": 1.0})
    fig = report_figures.comparison_figure(stats, pairs)
    assert legend_texts(fig.legends[0]) == ["gna", "dbscan", "sieve (identical to gna)", "community (identical to gna)"]
    assert [line.get_linestyle() for line in fig.axes[0].lines] == ["-", "-", ":", ":"]
    assert legend_texts(fig.axes[-1].get_legend()) == ["gna vs sieve (identical: ARI 1)"]


def _sensitivity_summary():
    rows = []
    for a in (10.0, 20.0):
        for c in (0.2, 0.4, 0.6):
            rows.append({"c_agg": c, "a_agg_deg": a, **{f"{m}_mean": v for m, v in
                                                        (("yield_fraction", 0.3), ("n_granules_norm", 0.1),
                                                         ("mean_volume_norm", 2 + 5 * c * a / 20))},
                         **{f"{m}_std": 0.05 for m in HEADLINE}, "n_frames": 10})
    return pd.DataFrame(rows)


def test_the_sensitivity_figure_says_its_bars_are_std_and_labels_log_ticks_plainly():
    fig = report_figures.sensitivity_figure(_sensitivity_summary())
    fig.canvas.draw()
    bottom = [ax for ax in fig.axes if ax.get_legend() is not None]
    assert bottom and bottom[0].get_legend().get_title().get_text() == "bars: ± std over the frames"
    log_axes = [ax for ax in fig.axes if ax.get_yscale() == "log"]
    assert log_axes
    for ax in log_axes:  # ⟨V_g⟩/V_p spans less than a decade: minor ticks labelled 2, 3, … not 6×10⁰
        labels = [t.get_text() for t in ax.get_yticklabels(which="both") if t.get_text()]
        assert labels and all("times" not in s and "×" not in s and "$" not in s for s in labels), labels
        assert {"2", "3", "4"} <= set(labels)


def test_the_cg_threshold_heatmaps_colour_bar_is_in_percent_like_its_cells():
    rows = []
    for run, alpha, dev in (("cg1", 1.0, 0.0), ("cg3", 3.0, -0.25)):
        for a in (10.0, 20.0):
            for c in (0.4, 0.6):
                rows.append({"run": run, "alpha": alpha, "a_agg_deg": a, "c_agg": c,
                             **{f"{m}_rel_dev": dev * (1 + c) for m in BY_FIGURE}})
    table = pd.DataFrame(rows)
    fig = report_figures.cg_threshold_figures(table)["cg_thresholds_yield_fraction"]
    panel, bar = fig.axes
    assert bar.get_ylabel() == "relative deviation from cg1 [%]"
    mesh = panel.collections[0]
    assert mesh.norm.vmax == pytest.approx(100 * 0.25 * 1.6) and mesh.norm.vmin == pytest.approx(-40)
    assert sorted(t.get_text() for t in panel.texts) == sorted(["-35", "-40", "-35", "-40"])
    fig.canvas.draw()
    ticks = [t.get_text() for t in bar.get_yticklabels() if t.get_text()]
    assert "-20" in ticks or "−20" in ticks
    assert all(abs(float(t.replace("−", "-"))) <= 40 for t in ticks)
