import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pandas as pd
import pytest

from granalytics import open_run
from granalytics.cli import main
from granalytics.datasets.synthetic import write_synthetic_run


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "run.h5"
    return write_synthetic_run(path, n_particles=600, revolutions=4.0, frames_per_revolution=4, seed=2)


def test_info_prints_frames_particles_and_metadata(run_file, capsys):
    assert main(["info", run_file]) == 0
    out = capsys.readouterr().out
    assert "frames                   17" in out and "particles" in out and "surface_tension" in out
    assert main(["info", run_file, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["file"]["frames"] == 17 and data["meta"]["n_particles"] == 600


def test_identify_writes_labels_per_frame(run_file, tmp_path, capsys):
    out = tmp_path / "labels.h5"
    assert main(["identify", run_file, "--out", str(out), "--c-agg", "0.5", "--window-rev", "1:2", "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out
    with h5py.File(out) as f, open_run(run_file) as run:
        assert f["labels"].shape == (5, 600) and list(f["frame_index"][:]) == [4, 5, 6, 7, 8]
        assert json.loads(f.attrs["params"])["c_agg"] == 0.5
        from granalytics import identify
        expected = identify(run[6], c_agg=0.5)
        assert np.array_equal(f["labels"][2], expected.labels)
        assert np.array_equal(f["ids"][2], run[6].ids)


@pytest.mark.parametrize("ext", [".csv", ".parquet"])
def test_stats_writes_time_series_and_prints_steady_state(run_file, tmp_path, capsys, ext):
    out = tmp_path / f"ts{ext}"
    sizes = tmp_path / "sizes.csv"
    assert main(["stats", run_file, "--window", "2:4", "--out", str(out), "--sizes-out", str(sizes), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "steady state over revolutions [2, 4]" in printed and "yield_fraction" in printed
    ts = pd.read_csv(out) if ext == ".csv" else pd.read_parquet(out)
    assert len(ts) == 17 and {"time_s", "revolutions", "n_granules_norm", "mean_volume_norm", "yield_fraction"} <= set(ts.columns)
    assert pd.read_csv(sizes)["count"].sum() > 0


def test_stats_plot_writes_a_png(run_file, tmp_path, capsys):
    png = tmp_path / "stats.png"
    assert main(["stats", run_file, "--window", "2:4", "--plot", str(png), "--quiet"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "granalytics", *args], capture_output=True, text=True)


def assert_one_line_error(proc, *words):
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("granalytics: error:") and "Traceback" not in proc.stderr
    for word in words:
        assert word in lines[0]


def copy_run(src, dst):
    dst.write_bytes(open(src, "rb").read())
    return dst


def test_malformed_files_give_one_line_and_exit_2(run_file, tmp_path):
    data = open(run_file, "rb").read()
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(data[: len(data) // 3])
    assert_one_line_error(run_cli("stats", str(truncated)), str(truncated))

    nan = copy_run(run_file, tmp_path / "nan.h5")
    with h5py.File(nan, "r+") as f:
        f["particles/position"][2, 41, 0] = np.nan
    assert_one_line_error(run_cli("stats", str(nan), "--quiet"), str(nan), "frame 2", "'position'", "index 41")

    bad_index = copy_run(run_file, tmp_path / "index.h5")
    with h5py.File(bad_index, "r+") as f:
        f["contacts/i"][3] = 600
    assert_one_line_error(run_cli("identify", str(bad_index), "--out", str(tmp_path / "l.h5"), "--quiet"),
                          "frame 0", "'contact_i'", "index 3", "out of range")

    assert_one_line_error(run_cli("info", str(tmp_path / "missing.h5")), "no such file")


def test_bad_options_exit_2(run_file, tmp_path, capsys):
    assert main(["stats", run_file, "--window", "9:10", "--quiet"]) == 2
    assert "no frame in the window" in capsys.readouterr().err
    assert main(["stats", run_file, "--a-agg-deg", "0", "--quiet"]) == 2
    assert "a_agg_deg" in capsys.readouterr().err
    assert main(["stats", run_file, "--out", str(tmp_path / "x.xlsx"), "--quiet"]) == 2
    with pytest.raises(SystemExit) as exit_:
        main(["stats", run_file, "--window", "5:1"])
    assert exit_.value.code == 2


def test_sensitivity_writes_summary_frames_and_heatmap(run_file, tmp_path, capsys):
    out, frames_out, png = tmp_path / "s.csv", tmp_path / "f.parquet", tmp_path / "h.png"
    argv = ["sensitivity", run_file, "--c-agg", "0.2:1.0:5", "--a-agg-deg", "10,20,90", "--window", "2:4",
            "--out", str(out), "--frames-out", str(frames_out), "--plot", str(png), "--jobs", "2", "--quiet"]
    assert main(argv) == 0
    summary = pd.read_csv(out)
    assert len(summary) == 15 and set(summary.n_frames) == {9}
    assert {"yield_fraction_mean", "yield_fraction_std", "mean_volume_norm_mean", "n_granules_norm_mean"} <= set(summary.columns)
    assert len(pd.read_parquet(frames_out)) == 9 * 15
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "yield_fraction_mean" in capsys.readouterr().out


@pytest.mark.parametrize("args, words", [
    (["--window", "7:9"], "no frame in the window"),
    (["--c-agg=-1:1:3"], "--c-agg"),
    (["--a-agg-deg", "0,20"], "--a-agg-deg"),
    (["--out", "x.txt"], "unknown table format"),
])
def test_sensitivity_rejects_empty_windows_and_impossible_ranges(run_file, capsys, args, words):
    assert main(["sensitivity", run_file, "--quiet", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]


def test_compare_methods_table_and_plot(run_file, tmp_path, capsys):
    out, png = tmp_path / "c.csv", tmp_path / "c.png"
    argv = ["compare-methods", run_file, "--methods", "gna,dbscan,community", "--set", "dbscan.eps_diameters=1.05",
            "--window-rev", "3:4", "--out", str(out), "--plot", str(png), "--quiet"]
    assert main(argv) == 0
    pairs = pd.read_csv(out)
    assert len(pairs) == 5 * 3 and pairs.ari.between(-1, 1).all()
    assert png.stat().st_size > 10_000
    assert main(["compare-methods", run_file, "--methods", "gna,dbscan", "--set", "sieve.connect=gna", "--quiet"]) == 2
    assert "not among --methods" in capsys.readouterr().err


def test_identify_refuses_its_input_run_as_output(run_file, tmp_path, capsys):
    import hashlib
    import shutil

    mine = tmp_path / "mine.h5"
    shutil.copyfile(run_file, mine)
    before = hashlib.sha256(mine.read_bytes()).hexdigest()
    assert main(["identify", str(mine), "--out", str(mine), "--overwrite", "--quiet"]) == 2
    assert "the input run" in capsys.readouterr().err
    assert hashlib.sha256(mine.read_bytes()).hexdigest() == before


def test_stats_with_a_window_outside_the_run_writes_nothing(run_file, tmp_path, capsys):
    out = tmp_path / "w.csv"
    assert main(["stats", run_file, "--window", "70:90", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no frame in the window" in err and run_file in err
    assert not out.exists()


def test_a_window_past_the_end_of_the_run_is_one_warning_line(run_file, capsys):
    with open_run(run_file) as run:
        last = run.revolutions[-1]
    assert main(["stats", run_file, "--window", f"{last - 1:g}:{last + 5:g}", "--quiet"]) == 0
    warning = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(warning) == 1 and warning[0].startswith(f"granalytics: warning: {run_file}: the window")


def test_compare_cg_refuses_existing_outputs_before_analysing(run_file, tmp_path, monkeypatch, capsys):
    import granalytics.analysis.cg

    out = tmp_path / "cg"
    out.mkdir()
    (out / "cg_table.csv").write_text("precious")

    def no_analysis(*args, **kwargs):
        raise AssertionError("analysed before refusing the outputs")

    monkeypatch.setattr(granalytics.analysis.cg, "compare_cg", no_analysis)
    assert main(["compare-cg", run_file, run_file, "--out", str(out), "--quiet"]) == 2
    assert "cg_table.csv: exists" in capsys.readouterr().err
    assert (out / "cg_table.csv").read_text() == "precious"


def test_an_output_is_replaced_only_when_complete(tmp_path):
    from granalytics.base.files import write_atomically

    path = tmp_path / "table.csv"
    path.write_text("old, complete")

    def fails_half_way(tmp):
        with open(tmp, "w") as f:
            f.write("new, cut")
        raise OSError("No space left on device")

    with pytest.raises(OSError, match="No space"):
        write_atomically(path, fails_half_way)
    assert path.read_text() == "old, complete" and [p.name for p in tmp_path.iterdir()] == ["table.csv"]
    write_atomically(path, lambda tmp: open(tmp, "w").write("new"))
    assert path.read_text() == "new"


def test_subset_every_works_on_a_run_whose_drum_does_not_turn(tmp_path, capsys):
    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
    from granalytics import RunWriter

    meta = synthetic_meta(50, drum_omega=0.0)
    src = tmp_path / "static.h5"
    with RunWriter(src, meta) as writer:
        for k in range(5):
            writer.append(synthetic_snapshot(50, time=0.1 * k, step=k, seed=k, meta=meta))
    out = tmp_path / "thin.h5"
    assert main(["subset", str(src), "--out", str(out), "--every", "2", "--quiet"]) == 0
    with open_run(out) as run:
        assert list(run.times) == pytest.approx([0.0, 0.2, 0.4])


def test_subset_window_every_thins_the_full_window(tmp_path, capsys):
    import math

    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
    from granalytics import RunWriter

    meta = synthetic_meta(30, drum_omega=2 * math.pi)  # one revolution per second
    src = tmp_path / "turning.h5"
    with RunWriter(src, meta) as writer:
        for k in range(25):
            writer.append(synthetic_snapshot(30, time=0.125 * k, step=k, seed=k, meta=meta))
    out = tmp_path / "thin.h5"
    assert main(["subset", str(src), "--out", str(out), "--every", "8", "--full-window", "2:3",
                 "--window-every", "2", "--quiet"]) == 0
    with open_run(out) as run:
        assert list(run.revolutions) == pytest.approx([0.0, 1.0, 2.0, 2.25, 2.5, 2.75, 3.0])
    capsys.readouterr()
    assert main(["subset", str(src), "--out", str(tmp_path / "no.h5"), "--window-every", "2", "--quiet"]) == 2
    assert "--window-every 2 thins --full-window" in capsys.readouterr().err
    assert not (tmp_path / "no.h5").exists()


def test_info_json_is_valid_json_for_an_empty_run(tmp_path, capsys):
    from granalytics.datasets.synthetic import synthetic_meta
    from granalytics import RunWriter

    empty = tmp_path / "empty.h5"
    with RunWriter(empty, synthetic_meta(50)):
        pass
    assert main(["info", str(empty), "--json"]) == 0
    text = capsys.readouterr().out
    json.loads(text, parse_constant=lambda name: pytest.fail(f"invalid JSON constant {name}"))


def test_compare_methods_refuses_text_for_a_numeric_setting_in_one_line(run_file, capsys):
    assert main(["compare-methods", run_file, "--methods", "gna,dbscan", "--set", "dbscan.eps_diameters=abc",
                 "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["granalytics: error: DBSCANClustering: eps_diameters must be a number > 0, got str 'abc'"]


def test_the_edges_module_and_the_custom_method_come_with_the_package():
    import granalytics as ga

    assert callable(ga.edges.to_networkx) and ga.CustomEdges.method == "custom"
    assert callable(ga.datasets.open_dataset)  # as datasets/README.md uses it after `import granalytics`
    assert issubclass(ga.RunLockedError, ga.RunFileError)


def test_stats_refuses_a_window_before_the_analysis(run_file, tmp_path, monkeypatch, capsys):
    import granalytics.cli.stats

    def no_analysis(*args, **kwargs):
        raise AssertionError("analysed before checking the window")

    monkeypatch.setattr(granalytics.cli.stats, "run_stats", no_analysis)
    assert main(["stats", run_file, "--window", "70:90", "--out", str(tmp_path / "w.csv"), "--quiet"]) == 2
    assert "no frame in the window [70, 90]" in capsys.readouterr().err


def test_numeric_checks_let_none_through():
    from granalytics.identification import make_identifier

    assert make_identifier("community", seed=None).seed is None


def test_outputs_in_missing_folders_or_unknown_figure_formats_are_refused_before_the_work(run_file, tmp_path,
                                                                                            monkeypatch, capsys):
    def no_work(*args, **kwargs):
        raise AssertionError("worked before checking the outputs")

    monkeypatch.setattr(sys.modules["granalytics.analysis.sensitivity"], "sensitivity", no_work)  # the module, not the function
    frames_out = tmp_path / "f.csv"
    base = ["sensitivity", run_file, "--window", "1:3", "--frames-out", str(frames_out), "--quiet"]
    assert main(base + ["--out", str(tmp_path / "nodir" / "s.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(base + ["--plot", str(tmp_path / "s.pdff")]) == 2
    assert "unknown figure format 'pdff'" in capsys.readouterr().err
    assert not frames_out.exists()


def test_export_vtk_refuses_existing_frame_files_without_overwrite(run_file, tmp_path, capsys):
    out = tmp_path / "vtk"
    out.mkdir()
    mine = out / "frame_00002.vtu"
    mine.write_text("a user's file")
    assert main(["export-vtk", run_file, "--out", str(out), "--quiet"]) == 2
    assert "frame_00002.vtu: exists" in capsys.readouterr().err
    assert mine.read_text() == "a user's file"


def test_tracking_reports_uneven_frame_spacing_and_bins_from_the_window(tmp_path, capsys):
    from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
    from granalytics import RunWriter

    meta = synthetic_meta(60)
    period = 2 * np.pi / meta.drum_omega
    times = [0.0, 0.2, 0.4, 0.6, 0.8, 0.85, 0.9, 0.95, 0.99995]  # thinned before 0.8 rev; the last stamped early
    src = tmp_path / "thinned.h5"
    with RunWriter(src, meta) as writer:
        for k, rev in enumerate(times):
            writer.append(synthetic_snapshot(60, time=rev * period, step=k, seed=k, meta=meta))
    assert main(["track", str(src), "--out", str(tmp_path / "t"), "--quiet"]) == 0
    assert "frames are" in capsys.readouterr().err
    assert main(["track", str(src), "--out", str(tmp_path / "w"), "--window-rev", "0.8:1", "--quiet"]) == 0
    rates = pd.read_csv(tmp_path / "w" / "rates.csv")
    assert sorted(rates["bin"].unique()) == [0] and rates["observed_s"].gt(0).all()


@pytest.mark.parametrize("command, lock", [
    (["track", "--window-rev", "1:2"], "tracking.lock"),
    (["export-vtk", "--window-rev", "1:2"], "run.pvd.lock"),
])
def test_a_second_writer_into_an_output_folder_is_refused(run_file, tmp_path, capsys, command, lock):
    from granalytics.base.files import WriterLock

    out = tmp_path / "out"
    out.mkdir()
    with WriterLock(str(out / lock.removesuffix(".lock"))):  # what a running command holds
        assert main([command[0], run_file, "--out", str(out), *command[1:], "--quiet"]) == 2
        assert "another writer holds the lock file" in capsys.readouterr().err
    assert main([command[0], run_file, "--out", str(out), *command[1:], "--quiet"]) == 0
    assert not (out / lock).exists()


def test_info_prints_floats_to_six_significant_digits(capsys):
    """info printed contacts_per_frame_mean as 232.60330578512398; --json keeps every digit."""
    from pathlib import Path

    run_file = str(Path(__file__).parents[1] / "datasets" / "lab-cg3.h5")
    assert main(["info", run_file]) == 0
    out = capsys.readouterr().out
    mean = float(next(line.split()[1] for line in out.splitlines() if "contacts_per_frame_mean" in line))
    with open_run(run_file) as run:
        exact = run.info()["contacts_per_frame_mean"]
    assert mean == float(f"{exact:.6g}") and len(str(exact)) > 10
    assert main(["info", run_file, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["file"]["contacts_per_frame_mean"] == exact


@pytest.mark.parametrize("value, error, shown", [
    (3, 0.0907, "3.000 ± 0.091"), (0.34012, 0.0151, "0.340 ± 0.015"), (12.345, 1.87, "12.3 ± 1.9"),
    (12345, 870, "12340 ± 870"), (0.5, float("nan"), "0.5 ± n/a"),
])
def test_a_mean_and_its_error_are_printed_to_the_errors_figures(value, error, shown):
    """compare-cg and study printed '3 ± 0.0907': the mean is now given to the error's last figure."""
    from granalytics.report.tables import plus_minus

    assert plus_minus(value, error) == shown


def test_stats_says_what_its_errors_are_and_why_one_is_nan(capsys):
    """A 0.25-revolution window printed 'sem NaN' with no note; neither std nor sem was named."""
    from pathlib import Path

    run = str(Path(__file__).parents[1] / "datasets" / "lab-cg3.h5")
    assert main(["stats", run, "--window", "3:3.25", "--window-rev", "3:3.3", "--quiet"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert "block_sem" in lines[1] and "NaN" not in "".join(lines) and lines[3].split()[3] == "n/a"
    assert lines[-2].startswith("std: over the frames of the window; block_sem: standard error")
    assert lines[-1].startswith("n/a: n_granules_norm, mean_volume_norm") and "a single block" in lines[-1]
    assert main(["stats", run, "--window", "3:4", "--window-rev", "3:4", "--quiet"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("std: over the frames") and "n/a" not in last


def test_size_unit_original_gives_sizes_in_original_particle_equivalents(tmp_path, capsys):
    """stats --sizes-out and track's kernel in α³·n on a CG3 run: the bins are 27 times the
    particle-unit ones, the counts the same."""
    from granalytics.datasets import dataset_path

    run = str(dataset_path("lab-cg3"))
    tables = {}
    for unit in ("particles", "original"):
        out = tmp_path / f"sizes-{unit}.csv"
        assert main(["stats", run, "--window", "3:4", "--sizes-out", str(out), "--size-unit", unit, "--quiet"]) == 0
        tables[unit] = pd.read_csv(out)
        assert main(["track", run, "--window-rev", "3:3.5", "--out", str(tmp_path / f"track-{unit}"),
                     "--size-unit", unit, "--quiet"]) == 0
        tables[f"kernel-{unit}"] = pd.read_csv(tmp_path / f"track-{unit}" / "kernel.csv")
    assert np.allclose(tables["original"].size_min, 27 * tables["particles"].size_min)
    assert (tables["original"]["count"] == tables["particles"]["count"]).all()
    assert np.allclose(tables["kernel-original"].size_min_i, 27 * tables["kernel-particles"].size_min_i)
    assert np.allclose(tables["kernel-original"].beta_per_s, tables["kernel-particles"].beta_per_s, equal_nan=True)


def test_info_names_the_simulators_contact_law(capsys):
    """A run of our simulator says which contact law made it (bundled runs predate the names:
    the linear law, the only one then); a run of another code says nothing of it."""
    from granalytics.datasets import dataset_path

    assert main(["info", str(dataset_path("lab-cg3"))]) == 0
    lines = [line.split() for line in capsys.readouterr().out.splitlines()]
    assert ["contact", "law", "linear_coulomb"] == next(line[:3] for line in lines if line[:2] == ["contact", "law"])
    assert main(["info", os.path.join(os.path.dirname(str(dataset_path("lab-cg3"))), "yade-wet-drum.h5")]) == 0
    assert "contact law" not in capsys.readouterr().out


def test_every_command_takes_its_identification_defaults_from_the_gna_constructor():
    import argparse
    import inspect

    from granalytics.cli import build_parser
    from granalytics.identification.gna import GraphNetworkAnalysis

    defaults = {name: p.default for name, p in inspect.signature(GraphNetworkAnalysis).parameters.items()}
    subparsers = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    checked = 0
    for command, parser in subparsers.choices.items():
        for action in parser._actions:
            if action.dest in ("c_agg", "a_agg_deg", "radius", "backend", "min_size", "comotion", "cohesion") \
                    and action.default is not None and not isinstance(action.default, (list, np.ndarray)) \
                    and (command, action.dest) != ("study", "cohesion"):  # study's default: both conventions
                assert action.default == defaults[action.dest], (command, action.dest, action.default)
                checked += 1
    assert checked >= 10
