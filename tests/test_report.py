"""The report layer (granalytics.report): one door out. ``granalytics.save`` and ``granalytics.draw``
dispatch on the result's type; the analyses and the identification never write; the command line
and ``ga.save`` write the same files through the same code."""

import ast
import pathlib

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

import granalytics as ga  # noqa: E402
from granalytics import ParameterError  # noqa: E402
from granalytics.cli import main  # noqa: E402
from granalytics.datasets import DATASET_DIR  # noqa: E402
from granalytics.report import output_names, output_paths  # noqa: E402
from conftest import make_snapshot  # noqa: E402

#: the lab runs are small drums at CG factors 2 and 3: the confinement and CG-rule warnings are not this file's subject
pytestmark = [pytest.mark.filterwarnings("ignore:.*D/d = .* is below:UserWarning"),
              pytest.mark.filterwarnings("ignore:.*CG rule weber at:UserWarning")]

ROOT = pathlib.Path(__file__).resolve().parents[1]
CG_RUNS = [str(DATASET_DIR / "lab-cg2.h5"), str(DATASET_DIR / "lab-cg3.h5")]
WINDOW = (3, 4)
TRACK_WINDOW = (3, 3.5)


@pytest.fixture(scope="module")
def comparison():
    return ga.compare_cg(CG_RUNS, window=WINDOW)


@pytest.fixture(scope="module")
def calibration():
    measured = ga.read_sieve_csv(DATASET_DIR / "sieve" / "example-sieve.csv")
    return ga.calibrate_thresholds(str(DATASET_DIR / "lab-cg3.h5"), measured, [0.3, 0.6], [20.0, 40.0], window=WINDOW,
                                   n_boot=20)


@pytest.fixture(scope="module")
def tracks():
    with ga.open_run(DATASET_DIR / "lab-cg3.h5") as run:
        return ga.track_run(run.select(revolutions=TRACK_WINDOW), cohesion="acting"), run.meta


@pytest.fixture(scope="module")
def prediction():
    with ga.open_run(str(DATASET_DIR / "lab-cg3.h5")) as run:
        return ga.pbm_from_run(run, (1, 2), (2, 4), cohesion="acting")


def _files(folder):
    return sorted(p.name for p in pathlib.Path(folder).iterdir())


# --- save and draw, one result type at a time ---------------------------------------------------


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_is_saved_by_its_suffix_and_never_overwritten(tmp_path, suffix):
    table = pd.DataFrame({"a": [1, 2], "b": [0.5, np.nan]})
    path = tmp_path / f"t{suffix}"
    assert ga.save(table, path) == [str(path)]
    back = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, table)
    with pytest.raises(ParameterError, match=r"exists \(overwrite=True, or --overwrite on the command line, replaces"):
        ga.save(table, path)
    ga.save(table * 2, path, overwrite=True)
    assert (pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path))["a"].tolist() == [2, 4]
    with pytest.raises(ParameterError, match="unknown table format"):
        ga.save(table, tmp_path / "t.xlsx")


def test_a_named_index_is_written_as_the_first_columns(tmp_path):
    table = pd.DataFrame({"mean": [1.0, 2.0]}, index=pd.Index(["x", "y"], name="metric"))
    ga.save(table, tmp_path / "t.csv")
    assert (tmp_path / "t.csv").read_text() == "metric,mean\nx,1.0\ny,2.0\n"


def test_a_cg_comparison_is_saved_as_its_tables_and_figures_and_drawn_as_its_figures(tmp_path, comparison):
    written = ga.save(comparison, tmp_path / "cg")
    assert sorted(pathlib.Path(p).name for p in written) == _files(tmp_path / "cg") == sorted(output_names(ga.CGComparison))
    assert pd.read_csv(tmp_path / "cg" / "cg_table.csv")["run"].tolist() == comparison.table["run"].tolist()
    with pytest.raises(ParameterError, match="exists"):
        output_paths(ga.CGComparison, tmp_path / "cg")
    figures = ga.draw(comparison)
    assert sorted(figures) == ["fig3_mean_volume", "fig4_granule_number", "fig5_size_distribution", "fig6_yield"]
    assert all(isinstance(fig, matplotlib.figure.Figure) for fig in figures.values())
    for fig in figures.values():
        plt.close(fig)


def test_a_calibration_is_saved_as_its_tables_json_and_figures(tmp_path, calibration):
    import json

    written = ga.save(calibration, tmp_path / "cal")
    assert sorted(pathlib.Path(p).name for p in written) == _files(tmp_path / "cal") == sorted(output_names(ga.Calibration))
    assert json.loads((tmp_path / "cal" / "calibration.json").read_text()) == calibration.to_json()
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "cal" / "calibration_grid.csv"), calibration.grid,
                                  check_dtype=False)
    with pytest.raises(ParameterError, match="exists"):
        ga.save(calibration, tmp_path / "cal")
    figures = ga.draw(calibration)
    assert sorted(figures) == ["calibration_distributions", "calibration_objective"]
    for fig in figures.values():
        plt.close(fig)


def test_granule_tracks_are_saved_as_their_events_tracks_rates_and_figure_and_drawn_as_it(tmp_path, tracks, capsys):
    tracks, meta = tracks
    period = 2 * np.pi / abs(meta.drum_omega)
    written = ga.save(tracks, tmp_path / "track", revolution_period_s=period, size_unit="original", alpha=meta)
    assert capsys.readouterr().out == ""  # the library prints nothing; the command says what it wrote
    assert [pathlib.Path(p).name for p in written] == output_names(ga.GranuleTracks)
    assert _files(tmp_path / "track") == sorted(output_names(ga.GranuleTracks))
    assert len(pd.read_csv(tmp_path / "track" / "events.csv")) == len(tracks.events)
    rates = pd.read_csv(tmp_path / "track" / "rates.csv")
    np.testing.assert_allclose(rates["rate_per_rev"], ga.event_rates(tracks, period)["rate_per_rev"])
    kernel = pd.read_csv(tmp_path / "track" / "kernel.csv")
    expected = ga.coalescence_kernel(tracks, size_unit="original", alpha=meta)
    np.testing.assert_allclose(kernel["size_min_i"], expected["size_min_i"])
    assert (kernel["size_min_i"] % 27 == 0).all()  # lab-cg3: α = 3, sizes in original particles α³·n
    with pytest.raises(ParameterError, match="exists"):
        ga.save(tracks, tmp_path / "track")
    fig = ga.draw(tracks, revolution_period_s=period, title="lab-cg3")
    assert isinstance(fig, matplotlib.figure.Figure) and len(fig.axes) >= 3
    plt.close(fig)


def test_a_population_balance_prediction_is_saved_as_its_tables_settings_and_figure(tmp_path, prediction, capsys):
    import json

    written = ga.save(prediction, tmp_path / "pbm")
    assert capsys.readouterr().out == ""
    assert [pathlib.Path(p).name for p in written] == output_names(ga.PBMPrediction)
    assert _files(tmp_path / "pbm") == sorted(output_names(ga.PBMPrediction))
    settings = json.loads((tmp_path / "pbm" / "settings.json").read_text())
    assert settings == json.loads(json.dumps(prediction.to_json()))
    assert settings["run"] == str(DATASET_DIR / "lab-cg3.h5") and settings["fit_window_rev"] == [1.0, 2.0]
    assert settings["bins_per_decade"] == 4 and settings["cohesion"] == "acting"
    summary = pd.read_csv(tmp_path / "pbm" / "summary.csv")
    pd.testing.assert_frame_equal(summary, prediction.summary(), check_dtype=False)
    with pytest.raises(ParameterError, match="exists"):
        ga.save(prediction, tmp_path / "pbm")


def test_a_measured_distribution_is_saved_as_the_csv_that_is_read_back(tmp_path):
    measured = ga.read_sieve_csv(DATASET_DIR / "sieve" / "example-sieve.csv")
    ga.save(measured, tmp_path / "sieve.csv")
    back = ga.read_sieve_csv(tmp_path / "sieve.csv")
    np.testing.assert_allclose(back.edges_m, measured.edges_m, rtol=1e-5)
    np.testing.assert_allclose(back.fractions, measured.fractions, rtol=1e-5)


def test_an_identified_frame_is_drawn_in_3d():
    snapshot = make_snapshot(4, pairs=[(0, 1)], f_norm=[1.0])
    fig = ga.draw(ga.identify(snapshot))
    assert fig.axes[0].name == "3d"
    plt.close(fig)


def test_a_population_balance_prediction_is_drawn_beside_its_dem():
    with ga.open_run(DATASET_DIR / "lab-cg3.h5") as run:
        prediction = ga.pbm_from_run(run, (3, 4), (4, 5))
    fig = ga.draw(prediction, title="lab-cg3")
    assert isinstance(fig, matplotlib.figure.Figure) and fig.axes
    plt.close(fig)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_in_pieces_is_streamed_into_one_file(tmp_path, suffix):
    from granalytics.report.files import stream_table

    pieces = [pd.DataFrame({"frame": [k, k], "x": [0.5 * k, 1.0]}) for k in range(3)]
    path = tmp_path / f"t{suffix}"
    assert stream_table(iter(pieces), path) == 6
    back = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, pd.concat(pieces, ignore_index=True))


def test_a_result_of_no_known_type_is_refused_with_the_types_there_are(tmp_path):
    with pytest.raises(ParameterError, match="no writer for a list .*CGComparison.*DataFrame"):
        ga.save([1, 2], tmp_path / "x.csv")
    with pytest.raises(ParameterError, match="no figure for a DataFrame .*CGComparison"):
        ga.draw(pd.DataFrame({"a": [1]}))
    with pytest.raises(ParameterError, match="not saved to a folder"):
        output_names(pd.DataFrame)
    assert not (tmp_path / "x.csv").exists()


# --- the analyses never write --------------------------------------------------------------------

#: calls that write a file: methods, and functions of these modules
_WRITING_METHODS = {"to_csv", "to_parquet", "to_hdf", "to_json", "to_excel", "to_pickle", "savefig", "write_text",
                    "write_bytes", "savez", "savez_compressed", "savetxt", "dump"}
_WRITING_FUNCTIONS = {"write_atomically", "replaced_atomically", "staged_outputs", "output_folder", "swap_folder",
                      "write_table", "write_json", "stream_table", "save_figure", "save"}
_WRITE_MODES = ("w", "a", "x", "r+", "wb", "ab", "w+", "a+")


def _mode(call, position):
    """The mode argument of ``open``/``h5py.File`` (positional ``position`` or ``mode=``), if a string."""
    args = [a for a in call.args[position:position + 1]] + [k.value for k in call.keywords if k.arg == "mode"]
    return next((a.value for a in args if isinstance(a, ast.Constant) and isinstance(a.value, str)), None)


def _writes(tree):
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else None
        if isinstance(func, ast.Attribute) and name in _WRITING_METHODS:
            if name == "dump" and not (isinstance(func.value, ast.Name) and func.value.id in ("json", "pickle")):
                continue
            yield node.lineno, name
        elif name in _WRITING_FUNCTIONS:
            yield node.lineno, name
        elif name == "open" and isinstance(func, ast.Name) and (_mode(node, 1) or "r") in _WRITE_MODES:
            yield node.lineno, f"open(..., {_mode(node, 1)!r})"
        elif name == "File" and _mode(node, 1) in _WRITE_MODES:
            yield node.lineno, f"h5py.File(..., {_mode(node, 1)!r})"
        elif name in ("RunWriter", "ParquetWriter"):
            yield node.lineno, name


def _sources(*packages):
    for package in packages:
        yield from sorted((ROOT / "granalytics" / package).rglob("*.py"))


def test_the_scan_finds_what_writes():
    code = ("import json, h5py\nt.to_csv('x')\nfig.savefig('f.png')\nopen(p, 'w')\nopen(p)\njson.dump(v, fh)\n"
            "h5py.File(p, 'w')\nh5py.File(p, 'r')\nh5py.File(p, mode='a')\nwrite_atomically(p, f)\n")
    assert [what for _, what in _writes(ast.parse(code))] == [
        "to_csv", "savefig", "open(..., 'w')", "dump", "h5py.File(..., 'w')", "h5py.File(..., 'a')", "write_atomically"]


def test_no_module_of_the_analyses_or_the_identification_writes_a_file():
    offenders = [f"{path.relative_to(ROOT)}:{line} {what}" for path in _sources("analysis", "identification")
                 for line, what in _writes(ast.parse(path.read_text()))]
    assert offenders == []


def test_no_module_of_the_analyses_or_the_identification_imports_the_report_layer():
    offenders = []
    for path in _sources("analysis", "identification"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(ROOT)}:{node.lineno} {n}" for n in names
                          if n.startswith("granalytics.report")]
    assert offenders == []


# --- the command line and ga.save: the same files -------------------------------------------------


def test_compare_cg_and_save_write_the_same_files(tmp_path, comparison, capsys):
    assert main(["compare-cg", *CG_RUNS, "--window", f"{WINDOW[0]}:{WINDOW[1]}", "--out", str(tmp_path / "cli"),
                 "--quiet"]) == 0
    capsys.readouterr()
    ga.save(comparison, tmp_path / "py")
    assert _files(tmp_path / "cli") == _files(tmp_path / "py")
    for name in _files(tmp_path / "py"):
        if name.endswith(".csv"):
            assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name


def test_stats_and_save_write_the_same_tables(tmp_path, capsys):
    run_path = str(DATASET_DIR / "lab-cg3.h5")
    cli = {name: tmp_path / f"cli-{name}.csv" for name in ("ts", "steady")}
    assert main(["stats", run_path, "--window", f"{WINDOW[0]}:{WINDOW[1]}", "--out", str(cli["ts"]),
                 "--steady-out", str(cli["steady"]), "--quiet"]) == 0
    capsys.readouterr()
    with ga.open_run(run_path) as run:
        ts = ga.run_stats(run)
    steady = ga.steady_state(ts, window=WINDOW)
    ga.save(ts, tmp_path / "py-ts.csv")
    ga.save(steady, tmp_path / "py-steady.csv")
    assert cli["ts"].read_bytes() == (tmp_path / "py-ts.csv").read_bytes()
    assert cli["steady"].read_bytes() == (tmp_path / "py-steady.csv").read_bytes()


def test_track_and_save_write_the_same_files(tmp_path, tracks, capsys):
    run_path = str(DATASET_DIR / "lab-cg3.h5")
    assert main(["track", run_path, "--window-rev", f"{TRACK_WINDOW[0]}:{TRACK_WINDOW[1]}", "--out",
                 str(tmp_path / "cli"), "--quiet"]) == 0
    capsys.readouterr()
    tracks, meta = tracks
    ga.save(tracks, tmp_path / "py", revolution_period_s=2 * np.pi / abs(meta.drum_omega), alpha=meta,
            title="lab-cg3.h5: gna (cohesion=acting), min_fragment=2")
    assert _files(tmp_path / "cli") == _files(tmp_path / "py") == sorted(output_names(ga.GranuleTracks))
    for name in _files(tmp_path / "py"):
        if name.endswith(".csv"):
            assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name


def test_pbm_and_save_write_the_same_files(tmp_path, prediction, capsys):
    assert main(["pbm", str(DATASET_DIR / "lab-cg3.h5"), "--fit-window", "1:2", "--predict", "2:4", "--out",
                 str(tmp_path / "cli"), "--quiet"]) == 0
    capsys.readouterr()
    ga.save(prediction, tmp_path / "py")
    assert _files(tmp_path / "cli") == _files(tmp_path / "py") == sorted(output_names(ga.PBMPrediction))
    for name in _files(tmp_path / "py"):
        if not name.endswith(".png"):
            assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name


def test_compare_cg_over_a_threshold_grid_and_save_write_the_same_files(tmp_path, capsys):
    c_agg, a_agg = [0.4, 0.6], [20.0]
    assert main(["compare-cg", *CG_RUNS, "--window", f"{WINDOW[0]}:{WINDOW[1]}", "--c-agg", "0.4,0.6",
                 "--a-agg-deg", "20", "--out", str(tmp_path / "cli"), "--quiet"]) == 0
    capsys.readouterr()
    comparison = ga.compare_cg_thresholds(CG_RUNS, c_agg, a_agg, window=WINDOW)
    assert comparison.finest == comparison.table.loc[comparison.table["alpha"].idxmin(), "run"]
    written = ga.save(comparison, tmp_path / "py")
    assert [pathlib.Path(p).name for p in written] == output_names(ga.CGThresholdComparison)
    assert _files(tmp_path / "cli") == _files(tmp_path / "py") == sorted(output_names(ga.CGThresholdComparison))
    assert (tmp_path / "cli" / "cg_thresholds.csv").read_bytes() == (tmp_path / "py" / "cg_thresholds.csv").read_bytes()
    with pytest.raises(ParameterError, match="exists"):
        ga.save(comparison, tmp_path / "py")
    figures = ga.draw(comparison)
    assert sorted(figures) == [name.removesuffix(".png") for name in sorted(output_names(ga.CGThresholdComparison))[1:]]
    for fig in figures.values():
        plt.close(fig)


@pytest.mark.parametrize("path", [None, b"table.csv", 3.0])
def test_a_path_that_is_not_a_file_name_is_refused_in_one_line(path, comparison):
    with pytest.raises(ParameterError, match="save: path must be a file or folder name"):
        ga.save(pd.DataFrame({"a": [1]}), path)
    with pytest.raises(ParameterError, match="save: path must be a file or folder name"):
        ga.save(comparison, path)
    with pytest.raises(ParameterError, match="save: path must be a file or folder name"):
        output_paths(ga.CGComparison, path)
