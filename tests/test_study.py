"""Analysis of a sweep folder (granalytics/analysis/study.py): the study table, the Fig 7 growth fit, the
Gaussian-process surrogate with leave-one-out errors, the figure and the ``study`` command.

The sweep folder here is fake: a hand-written manifest and tiny synthetic (physics-free) runs
whose metadata say what ``sim`` would record, so no simulation and no dask is needed.
"""

import argparse
import math
import sys

import numpy as np
import pandas as pd
import pytest

from granalytics import GranalyticsError, ParameterError, RunMeta, RunWriter
from granalytics.analysis.study import (
    PAPER_BETA,
    PAPER_GAMMA_1,
    fit_granule_growth,
    fit_surrogate,
    growth_points,
    study_table,
)
from granalytics.cli.study import add_study_parser, parse_predict
from granalytics.core.manifest import file_sha256
from granalytics.report.figures import growth_figure
from granalytics.datasets.synthetic import synthetic_snapshot

ALPHA = 2.0
GAMMAS = (0.02, 0.06, 0.12, 0.24)
OMEGAS = (2.0, 3.0)


def write_point(path, gamma, omega, seed):
    """Frames at revolutions 3, 3.5, …, 6 of 150 particles; granules grow with γ (none at 0.02)."""
    n = 150
    meta = RunMeta(surface_tension=ALPHA * gamma, density=2500.0, drum_omega=omega, n_particles=n,
                   mean_radius=0.75e-3 * ALPHA, alpha=ALPHA,
                   sim_config={"original": {"surface_tension": gamma, "drum_omega": omega}})
    period = 2 * math.pi / omega
    fraction = 0.5 if gamma > 0.03 else 0.0
    with RunWriter(path, meta, overwrite=True) as writer:
        for k, rev in enumerate(np.arange(3.0, 6.01, 0.5)):
            writer.append(synthetic_snapshot(n, granulated_fraction=fraction, mean_blob_size=2 + 40 * gamma,
                                             time=rev * period, step=k, seed=seed * 100 + k, meta=meta,
                                             alpha=ALPHA))


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("study") / "sweep"
    (root / "points").mkdir(parents=True)
    rows = []
    for i, (gamma, omega) in enumerate((g, w) for g in GAMMAS for w in OMEGAS):
        name = f"gamma={gamma:g}_omega={omega:g}"
        write_point(root / "points" / f"{name}.h5", gamma, omega, seed=i)
        rows.append({"point": name, "status": "done", "gamma": gamma, "omega": omega, "alpha": ALPHA, "seed": 0,
                     "particles": 1200, "preset": "lab-cg2", "revolutions": 6.0, "frame_every_rev": 0.5,
                     "wall_time_s": 1.0, "resumed": False, "file": f"points/{name}.h5",
                     "sha256": file_sha256(root / "points" / f"{name}.h5"), "error": "",
                     "finished_utc": ""})
    rows.append({**rows[0], "point": "gamma=0.5_omega=2", "status": "failed", "gamma": 0.5, "file": "points/none.h5",
                 "error": "RuntimeError: boom"})
    rows.append({**rows[0], "point": "gamma=0.6_omega=2", "status": "running", "gamma": 0.6, "file": "points/x.h5"})
    pd.DataFrame(rows).to_csv(root / "manifest.csv", index=False)
    return root


@pytest.fixture(scope="module")
def table(sweep_dir):
    return study_table(sweep_dir, window=(3, 6))


# ----------------------------------------------------------------------------- table

def test_table_has_one_row_per_finished_point_and_convention_with_original_gamma(table):
    assert len(table) == 2 * len(GAMMAS) * len(OMEGAS)
    assert sorted(table["cohesion"].unique()) == ["acting", "bridge"]
    assert not table["point"].str.contains("0.5|0.6").any()  # failed and running points are left out
    # γ and Ω of the ORIGINAL system, from the run metadata; the CG run has γ_run = α·γ
    assert sorted(table["gamma"].unique()) == list(GAMMAS)
    assert sorted(table["omega"].unique()) == list(OMEGAS)
    assert (table["alpha"] == ALPHA).all()
    assert np.allclose(table["gamma_run"], ALPHA * table["gamma"])
    for metric in ("yield_fraction", "mean_volume_norm", "n_granules_norm"):
        for stat in ("mean", "std", "sem"):
            assert f"{metric}_{stat}" in table
    assert (table["n_frames"] == 7).all() and (table["window"] == "3:6").all()
    assert table["seed"].eq(0).all() and table["particles"].eq(1200).all()  # manifest parameters are kept
    acting = table[table["cohesion"] == "acting"].groupby("gamma")["mean_volume_norm_mean"].mean()
    assert acting.loc[0.24] > acting.loc[0.06]  # bigger planted granules at higher γ


def test_table_refuses_a_folder_without_manifest_and_bad_windows(tmp_path, sweep_dir):
    with pytest.raises(ParameterError, match="no sweep manifest"):
        study_table(tmp_path)
    with pytest.raises(ParameterError, match="no frame in the window"):
        study_table(sweep_dir, window=(7, 8))
    with pytest.raises(ParameterError, match="cohesion"):
        study_table(sweep_dir, cohesion="wet")


def test_the_window_and_single_convention_are_honoured(sweep_dir):
    one = study_table(sweep_dir, window=(3, 4), cohesion="acting", c_agg=0.6, a_agg_deg=20)
    assert (one["cohesion"] == "acting").all() and len(one) == len(GAMMAS) * len(OMEGAS)
    assert (one["n_frames"] == 3).all()


# ----------------------------------------------------------------------------- growth fit

def synthetic_growth(rng, beta=70.0, gamma_1=0.027, noise=0.6):
    gamma = np.tile(np.linspace(0.01, 0.45, 12), 3)
    sem = np.where(gamma > gamma_1, noise * (1 + 2 * gamma), np.nan)
    volume = beta * np.maximum(0.0, gamma - gamma_1) + rng.normal(0.0, 1.0, gamma.size) * np.nan_to_num(sem)
    volume[gamma <= gamma_1] = np.nan  # no granules below the onset
    return gamma, volume, sem


@pytest.mark.parametrize("model", ["hinge", "linear"])
def test_growth_fit_recovers_known_slope_and_onset_within_its_intervals(model):
    rng = np.random.default_rng(7)
    gamma, volume, sem = synthetic_growth(rng)
    fit = fit_granule_growth(gamma, volume, sem, model=model)
    assert fit.beta_ci[0] <= 70.0 <= fit.beta_ci[1]
    assert fit.gamma_1_ci[0] <= 0.027 <= fit.gamma_1_ci[1]
    assert fit.beta == pytest.approx(70.0, rel=0.05) and fit.gamma_1 == pytest.approx(0.027, abs=0.01)
    assert fit.weighted and fit.n_points == 36 and fit.n_no_granules == 3 and fit.confidence == 0.95
    assert fit.n_used == 33 and fit.dof == 31
    assert fit.predict([0.0, 0.027 + 1.0 / fit.beta + (fit.gamma_1 - 0.027)])[0] == 0.0
    assert "m/N (paper ≈ 70 m/N)" in fit.summary() and "γ₁" in fit.summary()  # β carries its unit


def test_growth_fit_intervals_cover_the_truth_about_95_percent_of_the_time():
    rng = np.random.default_rng(11)
    hits = np.zeros(2)
    n = 120
    for _ in range(n):
        gamma, volume, sem = synthetic_growth(rng, beta=55.0, gamma_1=0.04, noise=1.0)
        fit = fit_granule_growth(gamma, volume, sem)
        hits += [fit.beta_ci[0] <= 55.0 <= fit.beta_ci[1], fit.gamma_1_ci[0] <= 0.04 <= fit.gamma_1_ci[1]]
    assert (hits / n > 0.88).all() and (hits / n < 0.995).all()


def test_hinge_fit_uses_points_without_granules_above_the_onset():
    gamma = np.array([0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4])
    volume = 70 * np.maximum(0, gamma - 0.027)
    unweighted = fit_granule_growth(gamma, np.where(gamma < 0.03, np.nan, volume))
    assert unweighted.beta == pytest.approx(70.0) and unweighted.gamma_1 == pytest.approx(0.027)
    assert not unweighted.weighted and unweighted.n_used == 5  # exact zeros below the onset carry nothing
    # a point without granules at γ = 0.05 pushes the hinge's onset up, the line ignores it
    volume[2] = np.nan
    assert fit_granule_growth(gamma, volume).gamma_1 > 0.03
    assert fit_granule_growth(gamma, volume, model="linear").gamma_1 == pytest.approx(0.027)


@pytest.mark.parametrize("gamma, volume, words", [
    ([0.1, 0.2], [1.0, 2.0], "at least three points with granules"),
    ([0.1, 0.1, 0.1], [1.0, 2.0, 3.0], "two or more"),
    ([0.1, 0.2, 0.3], [3.0, 2.0, 1.0], "no growth"),
    ([0.1, 0.2], [1.0], "γ values for"),
    ([0.1, np.nan, 0.3], [1.0, 2.0, 3.0], "finite"),
])
def test_growth_fit_refuses_unusable_data(gamma, volume, words):
    with pytest.raises(ParameterError, match=words):
        fit_granule_growth(gamma, volume)


# ----------------------------------------------------------------------------- surrogate

def smooth(gamma, omega):
    return 20 * gamma + 3 * np.sin(omega), 0.5 * np.tanh(8 * gamma) - 0.02 * omega


@pytest.fixture(scope="module")
def surrogate():
    rng = np.random.default_rng(3)
    g, w = np.meshgrid(np.linspace(0.05, 0.45, 4), np.linspace(1.0, 4.0, 4))
    frame = pd.DataFrame({"gamma": g.ravel(), "omega": w.ravel(), "cohesion": "acting"})
    a, b = smooth(frame["gamma"], frame["omega"])
    frame["mean_volume_norm_mean"] = a + rng.normal(0, 0.05, len(frame))
    frame["yield_fraction_mean"] = b + rng.normal(0, 0.002, len(frame))
    bridge = frame.assign(cohesion="bridge", yield_fraction_mean=np.nan)  # must be ignored
    table = pd.concat([frame, bridge], ignore_index=True)
    return fit_surrogate(table, outputs=["mean_volume_norm_mean", "yield_fraction_mean"], n_restarts=1)


def test_surrogate_predicts_a_smooth_function_and_its_leave_one_out_error_is_small(surrogate):
    loo = surrogate.loo
    assert list(loo.index) == ["mean_volume_norm_mean", "yield_fraction_mean"]
    assert (loo["n_points"] == 16).all()
    assert (loo["rmse"] < 0.15 * loo["output_std"]).all()
    assert (loo["mae"] <= loo["rmse"]).all()
    # the leave-one-out predictions are refits: not the in-sample predictions
    preds = surrogate.loo_predictions
    assert len(preds) == 32 and set(preds["output"]) == set(loo.index)
    insample = surrogate.predict(preds[preds["output"] == "yield_fraction_mean"][["gamma", "omega"]])
    assert not np.allclose(insample["yield_fraction_mean"], preds[preds["output"] == "yield_fraction_mean"]["predicted"])
    out = surrogate.predict({"gamma": [0.2, 0.3], "omega": [2.5, 3.0]})
    truth_v, truth_y = smooth(np.array([0.2, 0.3]), np.array([2.5, 3.0]))
    assert list(out.columns) == ["gamma", "omega", "mean_volume_norm_mean", "mean_volume_norm_mean_std",
                                 "yield_fraction_mean", "yield_fraction_mean_std"]
    assert np.allclose(out["mean_volume_norm_mean"], truth_v, atol=0.5)
    assert np.allclose(out["yield_fraction_mean"], truth_y, atol=0.03)
    assert (out["mean_volume_norm_mean_std"] > 0).all()


def test_surrogate_refuses_bad_prediction_inputs(surrogate):
    with pytest.raises(ParameterError, match="unknown input 'alpha'"):
        surrogate.predict({"gamma": 0.2, "omega": 3, "alpha": 2})
    with pytest.raises(ParameterError, match="missing input 'omega'"):
        surrogate.predict({"gamma": 0.2})
    with pytest.raises(ParameterError, match="numbers"):
        surrogate.predict({"gamma": "x", "omega": 3})
    with pytest.raises(ParameterError, match="no column"):
        fit_surrogate(pd.DataFrame({"gamma": [1.0]}), outputs=["yield_fraction_mean"])


# ----------------------------------------------------------------------------- --predict parsing

def test_predict_parsing_accepts_only_the_inputs_as_numbers():
    assert parse_predict("gamma=0.2,omega=3") == {"gamma": 0.2, "omega": 3.0}
    assert parse_predict(" omega = 3e0 , gamma=2e-1 ") == {"gamma": 0.2, "omega": 3.0}


@pytest.mark.parametrize("text, words", [
    ("gamma=0.2,omega=3,alpha=2", "unknown input 'alpha'"),
    ("gamma=0.2,foo=1", "unknown input 'foo'"),
    ("gamma=abc,omega=3", "must be a number"),
    ("gamma=__import__('os').getpid(),omega=3", "must be a number"),
    ("gamma=nan,omega=3", "finite"),
    ("gamma=inf,omega=3", "finite"),
    ("gamma=0.2", "missing omega"),
    ("gamma=0.2,gamma=0.3,omega=3", "twice"),
    ("gamma 0.2,omega=3", "NAME=VALUE"),
])
def test_predict_parsing_refuses_unknown_keys_and_non_numbers(text, words):
    with pytest.raises(ParameterError, match=words):
        parse_predict(text)


# ----------------------------------------------------------------------------- figure

def test_growth_figure_follows_the_paper_fig7_convention(table):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = growth_figure(table, cohesion="bridge")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "γ of the original system [N/m] (paper Fig 7 convention)"
    assert "cohesion convention: bridge" in ax.get_title() and "CG2" in ax.get_title()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "Ω = 2 rad/s" in labels and "Ω = 3 rad/s" in labels
    # the synthetic sweep grows with an onset below its smallest γ: "no growth" by the one rule, no law drawn
    assert any(label.startswith("no growth law: the onset") for label in labels)
    assert not any(label.startswith("fit: β =") for label in labels)
    assert f"paper: β ≈ {PAPER_BETA:g}, γ₁ ≈ {PAPER_GAMMA_1:g} N/m" in labels
    plt.close(fig)


def test_growth_points_combine_the_rows_of_one_point_and_count_no_granules_as_zero():
    table = pd.DataFrame({
        "cohesion": ["acting"] * 5 + ["bridge"],
        "omega": [2.0, 2.0, 2.0, 3.0, 3.0, 2.0],
        "gamma": [0.05, 0.05, 0.02, 0.05, 0.02, 0.05],
        "mean_volume_norm_mean": [2.0, 4.0, np.nan, 3.0, 0.0, 9.0],
        "mean_volume_norm_sem": [0.3, 0.4, np.nan, 0.5, np.nan, 0.1],
    })
    points = growth_points(table)  # acting by default
    assert points[["omega", "gamma"]].values.tolist() == [[2.0, 0.02], [2.0, 0.05], [3.0, 0.02], [3.0, 0.05]]
    seeds = points.iloc[1]  # two seeds at Ω = 2, γ = 0.05
    assert seeds["mean_volume_norm"] == 3.0 and seeds["block_sem"] == pytest.approx(0.5 / 2)  # √(0.3² + 0.4²)/2
    assert seeds["replica_sem"] == pytest.approx(np.std([2.0, 4.0], ddof=1) / math.sqrt(2))
    assert points["no_granules"].tolist() == [True, False, True, False]
    assert points.loc[points["no_granules"], "mean_volume_norm"].tolist() == [0.0, 0.0]
    assert points["replica_sem"].isna().tolist() == [True, False, True, True]  # one run: no replica error
    assert growth_points(table, "bridge")["mean_volume_norm"].tolist() == [9.0]
    combined = table.iloc[[3]].assign(mean_volume_norm_replica_sem=0.2)  # a row study_table(replicas=...) combined
    assert growth_points(combined)["replica_sem"].tolist() == [0.2]
    with pytest.raises(ParameterError, match="no column 'omega'"):
        growth_points(table.drop(columns="omega"))
    with pytest.raises(ParameterError, match=r"^growth_points: cohesion must be one of 'acting', 'bridge' or None"):
        growth_points(table, "wet")
    with pytest.raises(ParameterError, match=r"^growth_points: table must be a study table"):
        growth_points(table.to_dict("list"))


# ----------------------------------------------------------------------------- command line

def study_cli(argv):
    """The ``study`` subcommand as ``granalytics study`` runs it (errors: one line, exit 2)."""
    parser = argparse.ArgumentParser(prog="granalytics")
    add_study_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["study", *argv])
    try:
        return args.func(args)
    except (GranalyticsError, OSError, ValueError) as exc:
        print(f"granalytics: error: {exc}", file=sys.stderr)
        return 2


def test_study_command_prints_table_fit_and_surrogate_and_writes_outputs(sweep_dir, tmp_path, capsys):
    csv, png = tmp_path / "table.csv", tmp_path / "fig7.png"
    argv = [str(sweep_dir), "--window", "3:6", "--cohesion", "acting", "--out", str(csv), "--plot", str(png),
            "--predict", "gamma=0.2,omega=3", "--quiet"]
    assert study_cli(argv) == 0
    out = capsys.readouterr().out
    assert "8 finished points of 10 in the manifest" in out
    assert "growth fit (cohesion=acting)" in out
    assert "paper ≈ 70" in out and "paper ≈ 0.027 N/m" in out and "95 % intervals" in out
    assert "leave-one-out error" in out and "rmse" in out
    assert "prediction at gamma=0.2, omega=3 (cohesion=acting): yield_fraction_mean =" in out
    written = pd.read_csv(csv)
    assert len(written) == 8 and (written["cohesion"] == "acting").all()
    assert png.stat().st_size > 0
    # existing outputs are refused before any work, unless --overwrite
    assert study_cli(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0] and "--overwrite" in err[0]


@pytest.mark.parametrize("predict, words", [
    ("gamma=0.2,foo=1", "unknown input 'foo'"),
    ("gamma=abc,omega=3", "must be a number"),
])
def test_study_command_refuses_bad_predict_in_one_line(sweep_dir, capsys, predict, words):
    assert study_cli([str(sweep_dir), "--predict", predict, "--quiet"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("granalytics: error: --predict") and words in err[0]
    assert captured.out == ""  # refused before any analysis


def test_study_command_on_a_folder_without_manifest_is_one_line(tmp_path, capsys):
    assert study_cli([str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no sweep manifest" in err[0]
    assert study_cli([str(tmp_path / "nope"), "--quiet"]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_study_names_left_out_points_warns_on_extrapolation_and_keeps_the_sweep_folder(sweep_dir, capsys):
    with pytest.warns(UserWarning, match=r"extrapolating outside the sweep.*gamma = 5 \(trained on"):
        assert study_cli([str(sweep_dir), "--cohesion", "acting", "--predict", "gamma=5,omega=3", "--quiet"]) == 0
    assert "left out: " in capsys.readouterr().out
    assert study_cli([str(sweep_dir), "--out", str(sweep_dir / "manifest.csv"), "--overwrite", "--quiet"]) == 2
    assert "inside the sweep folder" in capsys.readouterr().err


def test_one_rule_for_no_growth_reported_and_never_drawn():
    """An onset outside the data or a slope interval that includes 0 is 'no growth': said in the
    summary, not drawn as a law (it was drawn: β = 0.095, γ₁ = −29 N/m on lab-cg3)."""
    import matplotlib

    matplotlib.use("Agg")
    rng = np.random.default_rng(3)
    gamma = np.repeat([0.01, 0.03, 0.06, 0.1, 0.2, 0.3, 0.44], 3)
    flat = 3.0 + 0.02 * gamma + rng.normal(0, 0.2, gamma.size)  # no growth: noise around a constant
    fit = fit_granule_growth(gamma, flat, np.full(gamma.size, 0.1))
    assert not fit.shows_growth and fit.summary().startswith("no growth law (")
    assert fit.to_dict()["shows_growth"] is False
    table = pd.DataFrame({"gamma": gamma, "omega": 2.0, "alpha": 2.0, "cohesion": "acting",
                          "mean_volume_norm_mean": flat, "mean_volume_norm_sem": 0.1})
    fig = growth_figure(table, fit, cohesion="acting")
    labels = [line.get_label() for line in fig.axes[0].get_lines()]
    assert not any(label.startswith("fit:") for label in labels) and any("no growth" in label for label in labels)
    grows = fit_granule_growth(gamma, 50 * np.maximum(0, gamma - 0.03) + rng.normal(0, 0.05, gamma.size))
    assert grows.shows_growth and not grows.summary().startswith("no growth")
    with pytest.raises(ParameterError, match="sem must be >= 0, got -0.1"):
        fit_granule_growth(gamma, flat, np.r_[-0.1, np.full(gamma.size - 1, 0.1)])
    with pytest.warns(UserWarning, match="1 sem\\(s\\) zero or NaN at points with granules"):
        fit_granule_growth(gamma, 50 * np.maximum(0, gamma - 0.03) + 1, np.r_[np.nan, np.full(gamma.size - 1, 0.1)])


def test_a_replaced_point_file_or_one_outside_the_folder_is_refused(sweep_dir, tmp_path):
    """Round four, B2: study read a sweep whose point file was replaced by another point (γ 0.03
    twice, γ 0.01 gone) and followed a manifest entry ../outside/x.h5."""
    import shutil

    copy = tmp_path / "sweep"
    shutil.copytree(sweep_dir, copy)
    manifest = pd.read_csv(copy / "manifest.csv")
    first, second = manifest["file"][0], manifest["file"][1]
    shutil.copyfile(copy / second, copy / first)  # another point's file under this point's name
    with pytest.raises(ParameterError, match="its sha256 is not the one the manifest records"):
        study_table(copy, window=(3, 6))
    manifest.loc[0, "sha256"] = file_sha256(copy / first)  # the sum updated too: its own parameters tell
    manifest.to_csv(copy / "manifest.csv", index=False)
    with pytest.raises(ParameterError, match="the run's omega is .*, the manifest's point .* says"):
        study_table(copy, window=(3, 6))
    (tmp_path / "outside").mkdir()
    shutil.copyfile(sweep_dir / second, tmp_path / "outside" / "x.h5")
    manifest.loc[0, "file"] = "../outside/x.h5"
    manifest.to_csv(copy / "manifest.csv", index=False)
    with pytest.raises(ParameterError, match="lies outside the sweep folder"):
        study_table(copy, window=(3, 6))


def test_the_papers_growth_law_is_zero_below_its_onset_and_grows_by_beta():
    from granalytics.analysis.study import PAPER_BETA, PAPER_GAMMA_1, paper_growth_law

    assert np.array_equal(paper_growth_law([0.0, PAPER_GAMMA_1]), [0.0, 0.0])
    assert paper_growth_law(PAPER_GAMMA_1 + 0.01) == pytest.approx(PAPER_BETA * 0.01)
