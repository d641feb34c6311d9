"""Misuse of the command line loses nothing and gives one line with exit status 2."""

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.cli import main
from granalytics.base.errors import ParameterError
from granalytics.core import RunWriter
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot, write_synthetic_run


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("hard") / "run.h5"
    return write_synthetic_run(path, n_particles=400, revolutions=3.0, frames_per_revolution=4, seed=5)


def one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert err.startswith("granalytics: error:") and "\n" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


def test_identify_never_replaces_a_file_without_overwrite(run_file, tmp_path, capsys):
    out = tmp_path / "labels.h5"
    out.write_bytes(b"precious")
    assert main(["identify", run_file, "--out", str(out), "--quiet"]) == 2
    one_line_error(capsys, "exists", "--overwrite")
    assert out.read_bytes() == b"precious"
    assert main(["identify", run_file, "--out", str(out), "--quiet", "--overwrite"]) == 0
    assert out.read_bytes()[:4] == b"\x89HDF"


def test_a_failed_identify_leaves_no_labels_file(run_file, tmp_path, capsys, monkeypatch):
    out = tmp_path / "labels.h5"
    calls = {"n": 0}
    real = ga.GraphNetworkAnalysis.identify

    def fail_on_third_frame(self, snapshot):
        calls["n"] += 1
        if calls["n"] == 3:
            raise ParameterError("injected failure in frame 3")
        return real(self, snapshot)

    monkeypatch.setattr(ga.GraphNetworkAnalysis, "identify", fail_on_third_frame)
    assert main(["identify", run_file, "--out", str(out), "--quiet"]) == 2
    one_line_error(capsys, "injected failure")
    assert not out.exists() and not (tmp_path / "labels.h5.tmp").exists()


def test_outputs_must_be_distinct_new_files(run_file, tmp_path, capsys):
    table = tmp_path / "t.csv"
    assert main(["stats", run_file, "--window", "1:3", "--out", str(table), "--sizes-out", str(table), "--quiet"]) == 2
    one_line_error(capsys, "given twice")
    assert main(["stats", run_file, "--window", "1:3", "--out", str(run_file), "--quiet"]) == 2
    one_line_error(capsys, "input run")
    table.write_text("keep me")
    assert main(["sensitivity", run_file, "--window", "1:3", "--out", str(table), "--quiet"]) == 2
    one_line_error(capsys, "exists")
    assert table.read_text() == "keep me"
    assert main(["stats", run_file, "--window", "1:3", "--out", str(table), "--overwrite", "--quiet"]) == 0
    assert "yield_fraction" in table.read_text()


def test_export_vtk_refuses_a_file_and_an_earlier_export(run_file, tmp_path, capsys):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("x")
    assert main(["export-vtk", run_file, "--out", str(not_a_folder), "--quiet", "--window-rev", "2:2.3"]) == 2
    one_line_error(capsys, "not a folder")
    folder = tmp_path / "vtk"
    assert main(["export-vtk", run_file, "--out", str(folder), "--quiet", "--window-rev", "2:2.3"]) == 0
    assert main(["export-vtk", run_file, "--out", str(folder), "--quiet", "--window-rev", "2:2.3"]) == 2
    one_line_error(capsys, "run.pvd", "--overwrite")


def test_an_unwritable_output_is_one_line(run_file, tmp_path, capsys):
    assert main(["stats", run_file, "--window", "1:3", "--plot", str(tmp_path / "no" / "such" / "dir.png"), "--quiet"]) == 2
    one_line_error(capsys, "dir.png")


@pytest.mark.parametrize("bad", [True, "abc", math.nan, 0, 200])
def test_thresholds_that_are_not_numbers_in_range_are_refused(bad):
    snapshot = synthetic_snapshot(100, seed=1)
    with pytest.raises(ParameterError, match="a_agg_deg"):
        ga.identify(snapshot, a_agg_deg=bad)
    if bad not in (0, 200):
        with pytest.raises(ParameterError, match="c_agg"):
            ga.identify(snapshot, c_agg=bad)
        with pytest.raises(ParameterError, match="c_agg"):
            ga.sensitivity([snapshot], [0.5, bad], [20])


def test_stats_over_a_time_window_for_a_run_without_rotation(tmp_path, capsys):
    meta = dataclasses.replace(synthetic_meta(300), drum_omega=0.0)
    path = tmp_path / "static.h5"
    with RunWriter(path, meta) as writer:
        for k in range(12):
            writer.append(synthetic_snapshot(300, granulated_fraction=0.4, time=0.1 * k, step=k, seed=k, meta=meta))
    assert main(["stats", str(path), "--quiet"]) == 2
    one_line_error(capsys, "--window-time")
    out = tmp_path / "ts.csv"
    assert main(["stats", str(path), "--window-time", "0.3:1.1", "--out", str(out), "--plot", str(tmp_path / "s.png"),
                 "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "time [s] [0.3, 1.1]" in printed
    ts = pd.read_csv(out)
    steady = ga.steady_state(ts, window=(0.3, 1.1), by="time_s")
    inside = ts[(ts["time_s"] >= 0.3 - 1e-12) & (ts["time_s"] <= 1.1 + 1e-12)]
    assert steady.loc["yield_fraction", "n_frames"] == len(inside) == 9
    assert steady.loc["yield_fraction", "mean"] == pytest.approx(inside["yield_fraction"].mean())
    assert steady.loc["yield_fraction", "n_blocks"] == 5
    assert np.isfinite(steady.loc["yield_fraction", "sem"])


# ------------------------------------------------------------------ round three (issue 33)
@pytest.mark.parametrize("value", ["no", "yes", "0", "off"])
def test_a_flag_given_as_text_is_refused_not_read_by_its_truth(run_file, capsys, value):
    """dbscan bridged_only='no' was taken as true (any non-empty text is truthy)."""
    assert main(["compare-methods", run_file, "--methods", "gna,dbscan", "--set", f"dbscan.bridged_only={value}",
                 "--quiet"]) == 2
    one_line_error(capsys, "bridged_only must be True or False", repr(int(value) if value.isdigit() else value))


def test_the_api_refuses_a_flag_that_is_not_a_bool(run_file):
    with ga.open_run(run_file) as run:
        snapshot = run[2]
    for value in ("no", 1, None):
        with pytest.raises(ParameterError, match="bridged_only must be True or False"):
            ga.identify(snapshot, method="dbscan", bridged_only=value)
        with pytest.raises(ParameterError, match="bridged_only must be True or False"):
            ga.DBSCANClustering(bridged_only=value).identify(snapshot)
    assert ga.identify(snapshot, method="dbscan", bridged_only=np.bool_(False)).n_granules >= 0


def test_a_sensitivity_grid_out_of_reach_is_refused_with_its_size(run_file, capsys, monkeypatch):
    """A 10 000 × 10 000 grid ran (for hours, towards hundreds of GB) instead of being refused."""
    import granalytics.base.resources

    monkeypatch.setattr(granalytics.base.resources, "physical_memory", lambda: 16 * 10**9)
    assert main(["sensitivity", run_file, "--c-agg", "0:1:10000", "--a-agg-deg", "1:90:10000", "--window", "0:3",
                 "--quiet"]) == 2
    one_line_error(capsys, "100000000 grid points", "GB of memory", "refused before starting")


@pytest.mark.parametrize("argv, words", [
    (["--revolutions", "1e12"], "PB of disk"), (["--particles", "1000000000"], "GB of memory"),
    (["--revolutions", "nan"], "revolutions must be a finite number"),
    (["--frames-per-revolution", "0"], "frames_per_revolution must be a whole number >= 1"),
])
def test_synthetic_refuses_a_run_out_of_reach_before_writing(tmp_path, capsys, monkeypatch, argv, words):
    import granalytics.base.resources

    monkeypatch.setattr(granalytics.base.resources, "physical_memory", lambda: 16 * 10**9)
    assert main(["synthetic", "--out", str(tmp_path / "s.h5"), *argv]) == 2
    one_line_error(capsys, words)
    assert list(tmp_path.iterdir()) == []


#: what an error about a snapshot argument says it must be
HINT = "(open the run with granalytics.open_run and pass one frame, e.g. run[0])"


@pytest.mark.parametrize("call, words", [
    (lambda s: ga.Snapshot(time=0, step=0, **{**_fields(s), "position": [[0.0, 0.0, 0.0]] * (s.n_particles - 1) + [[1.0, 2.0]]}),
     "'position': must be an array of numbers of shape (n,3)"),
    (lambda s: ga.Snapshot(time=0, step=0, **{**_fields(s), "ids": [[1, 2], [3]]}), "'ids': must be an array"),
    (lambda s: ga.identify(s, method=["gna"]), "unknown method ['gna']"),
    (lambda s: ga.GraphNetworkAnalysis().identify("run.h5"), "GraphNetworkAnalysis.identify: snapshot must be"),
    (lambda s: ga.run_stats([1, 2]), f"GraphNetworkAnalysis.identify: snapshot must be a granalytics Snapshot {HINT}, got int 1"),
    (lambda s: ga.compare_cg(5), "compare_cg: runs must be a list"),
    (lambda s: ga.compare_cg([1, 2]), "compare_cg: a run must be a run file's path, an open run or its RunStatistics, got int"),
    (lambda s: ga.compare_cg(["a.h5", "b.h5"], window="3:6"), "compare_cg: window must be a pair of finite numbers (lo, hi) with lo <= hi, got str '"),
    (lambda s: ga.subset_run("a.h5", "b.h5", [[0, 1], [2]]), "subset_run: frames must be a sequence of numbers"),
    (lambda s: ga.study_table(5), "study_table: sweep_dir must be a folder (str or path-like) or a list of them, got int 5"),
    (lambda s: __import__("granalytics.identification.edges", fromlist=["edge_table"]).edge_table(None),
     "edge_table: result must be an IdentificationResult"),
    (lambda s: ga.replica_steady_state(None), "replica_steady_state: timeseries must be a list of run_stats tables"),
    (lambda s: ga.size_distribution("abc"), "size_distribution: sizes must be a sequence of numbers or one array of "
                                             "sizes per frame, got str 'abc'"),
    (lambda s: ga.size_distribution(None), "size_distribution: sizes must be a sequence of numbers or one array of "
                                           "sizes per frame, got NoneType None"),
    (lambda s: ga.track_granules(None, [], []), "track_granules: labels_by_frame must be a sequence"),
    (lambda s: ga.track_granules([[0]], [[1]], ["a"]), "track_granules: times_s must be a sequence of numbers"),
    (lambda s: ga.run_stats(None), "frames must be a Run, a RunSlice or a sequence of Snapshot"),
    # issue 33, A9 leftover: these ended in AttributeError, TypeError or numpy's ValueError
    (lambda s: ga.granule_table(None, np.zeros(s.n_particles, int)), "granule_table: snapshot must be a granalytics Snapshot"),
    (lambda s: ga.granule_table(s, [[1, 2], [3]]), "granule_table: labels must be a sequence of whole numbers"),
    (lambda s: ga.cohesive_force("run.h5"), f"cohesive_force: snapshot must be a granalytics Snapshot {HINT}, got str 'run.h5'"),
    (lambda s: ga.steady_state(pd.DataFrame({"revolutions": [0.0, 1.0]}), columns=None),
     "steady_state: columns must be a metric name or a sequence of str, got NoneType None"),
    (lambda s: ga.steady_state(pd.DataFrame({"revolutions": [0.0, 1.0], "yield_fraction": 0.5}), (0, 1),
                               ["yield_fraction"], n_blocks="abc"), "steady_state: n_blocks must be a whole number"),
    (lambda s: ga.fit_granule_growth("abc", [1, 2, 3]), "fit_granule_growth: gamma must be an array of numbers, got str"),
    (lambda s: ga.fit_granule_growth([[1, 2], [3]], [1, 2, 3]), "fit_granule_growth: gamma must be an array of numbers"),
    (lambda s: ga.fit_surrogate({"gamma": [1]}), "fit_surrogate: table must be a study table (a DataFrame"),
    (lambda s: ga.fit_confinement_curve({"a": 1}, [1, 2, 3], [0.1] * 3), "fit_confinement_curve: drum_ratio must be"),
    (lambda s: ga.confinement_table(None), "confinement_table: groups must be a list of runs"),
    (lambda s: ga.RunWriter(None, s.meta), "RunWriter: path must be a file name (str or path-like), got NoneType"),
    (lambda s: ga.subset_run(None, "b.h5", [0]), "subset_run: src must be a file name"),
    (lambda s: ga.subset_run("a.h5", 5, [0]), "subset_run: dst must be a file name"),
    (lambda s: ga.WriterLock({"a": 1}), "WriterLock: target must be a file name"),
    (lambda s: ga.confinement_of_run(None), "confinement_of_run: meta must be a RunMeta"),
    (lambda s: ga.wall_touching(s, "meta"), "wall_touching: meta must be a RunMeta"),
    (lambda s: ga.CommunityDetection(resolution="abc").identify(s),
     "CommunityDetection: resolution must be a number > 0, got str 'abc'"),
    (lambda s: ga.track_run([s], window=5), "track_run: window must be a pair of finite numbers"),
    (lambda s: ga.event_rates(None), "event_rates: tracks must be a GranuleTracks"),
    (lambda s: ga.coalescence_kernel("tracks"), "coalescence_kernel: tracks must be a GranuleTracks"),
    (lambda s: ga.breakage_rate([1, 2]), "breakage_rate: tracks must be a GranuleTracks"),
])
def test_wrong_types_get_the_librarys_error_naming_the_argument(run_file, call, words):
    """Ragged arrays, None, strings and ints ended in numpy / int() / AttributeError errors."""
    with ga.open_run(run_file) as run:
        snapshot = run[1]
    with pytest.raises(ga.GranalyticsError) as exc:
        call(snapshot)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_a_run_indexed_or_sliced_with_wrong_types_gets_the_librarys_error(run_file):
    """run[None] raised a bare TypeError and RunSlice(run, "abc") int()'s ValueError."""
    with ga.open_run(run_file) as run:
        for key in (None, "abc", [[1, 2], [3]], {"a": 1}):
            with pytest.raises(ga.ParameterError, match="frames are indexed by int or slice") as exc:
                run[key]
            assert isinstance(exc.value, TypeError)  # what Python's sequences raise for such a key
            with pytest.raises(ga.ParameterError, match="RunSlice: indices must be a sequence of whole numbers"):
                ga.RunSlice(run, key)
        with pytest.raises(ga.ParameterError, match=r"RunSlice: frame indices must lie in \[0, "):
            ga.RunSlice(run, [0, len(run)])
        with pytest.raises(ga.ParameterError, match="RunSlice: run must be an open Run"):
            ga.RunSlice(run_file, [0])
        assert len(ga.RunSlice(run, [0, 2])) == 2 and len(ga.RunSlice(run, [])) == 0


def _fields(s):
    return {name: getattr(s, name) for name in ("ids", "radius", "position", "velocity", "angular_velocity",
                                                 "film_volume", "contact_i", "contact_j", "f_cap", "f_normal", "gap",
                                                 "bridge_volume")}


def test_run_select_refuses_a_window_that_is_not_two_numbers(run_file):
    with ga.open_run(run_file) as run:
        for window in ("0:1", ("0", "1"), (0, 1, 2)):
            with pytest.raises(ga.ParameterError, match="select: revolutions must be"):
                run.select(revolutions=window)
        with pytest.raises(ga.ParameterError, match=r"select: revolutions must be a pair of finite numbers \(lo, hi\) with lo <= hi, got tuple \(2, 1\)"):
            run.select(revolutions=(2, 1))


def test_a_c_agg_that_no_contact_can_pass_is_warned_of_in_one_line(capsys):
    """--c-agg 1.5 was accepted silently and gave zeros: no pair scores above F_cap(0⁺) ≈ 0.855·2πγR*."""
    from pathlib import Path

    run = str(Path(__file__).parents[1] / "datasets" / "lab-cg3.h5")
    assert main(["stats", run, "--window-rev", "3:3.5", "--window", "3:3.5", "--c-agg", "1.5", "--quiet"]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "C_agg" in line]
    assert len(warned) == 1 and warned[0].startswith(f"granalytics: warning: {run}: C_agg 1.5 is above the largest")
    assert "0.855" in warned[0] or "0.854" in warned[0]
    assert main(["stats", run, "--window-rev", "3:3.5", "--window", "3:3.5", "--quiet"]) == 0
    assert "largest F_coh" not in capsys.readouterr().err
    # a grid that crosses the cliff is what a sweep is for; one wholly above it finds nothing
    assert main(["sensitivity", run, "--window", "3:3.5", "--c-agg", "0.6,0.8,0.9,1.2", "--a-agg-deg", "20",
                 "--quiet"]) == 0
    assert "largest F_coh" not in capsys.readouterr().err
    assert main(["sensitivity", run, "--window", "3:3.5", "--c-agg", "0.9,1.2", "--a-agg-deg", "20", "--quiet"]) == 0
    assert "every C_agg of the grid (from 0.9) is above the largest" in capsys.readouterr().err


def test_track_window_is_retired_for_window_rev(run_file, tmp_path, capsys):
    """In track --window selected frames, everywhere else it is the steady-state window: one name,
    one meaning. The old spelling is gone (round four, C8); the error names the new one."""
    assert main(["track", run_file, "--out", str(tmp_path / "old"), "--window", "1:2", "--quiet"]) == 2
    assert "--window: did you mean --window-rev?" in capsys.readouterr().err
    assert main(["track", run_file, "--out", str(tmp_path / "new"), "--window-rev", "1:2", "--quiet"]) == 0


def test_usage_errors_are_one_line_and_a_misspelt_option_gets_a_suggestion(capsys):
    """Round four, C6: a usage error printed a 14-line usage block before its line, and --cagg got
    no hint."""
    from granalytics.cli import main

    for argv, words in ((["stats", "datasets/lab-cg3.h5", "--window", "3-6"], "argument --window"),
                        (["stats", "datasets/lab-cg3.h5", "--cagg", "0.4"], "--cagg: did you mean --c-agg?")):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse's own errors exit from the parser
            status = exc.code
        assert status == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0] and err[0].endswith("(see granalytics stats --help)"), err


def test_a_dump_or_a_foreign_hdf5_file_points_to_convert(tmp_path, capsys):
    """Round four, C7: 'not a run file' said nothing of granalytics convert."""
    import h5py

    from granalytics.cli import main

    dump = tmp_path / "atoms.dump"
    dump.write_text("ITEM: TIMESTEP\n0\n")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = [1, 2]
    for path in (dump, foreign):
        assert main(["stats", str(path)]) == 2
        err = capsys.readouterr().err
        assert "granalytics convert" in err and "docs/readers.md" in err


@pytest.mark.parametrize("command", ["stats", "sensitivity"])
def test_rigid_options_without_the_rigid_test_are_refused(command, capsys):
    """Round four, B7: --rigid-tol without --comotion rigid was accepted and ignored."""
    from granalytics.cli import main

    assert main([command, "datasets/lab-cg3.h5", "--rigid-tol", "0.3", "--quiet"]) == 2
    assert "--rigid-tol set the rigid co-motion test: give --comotion rigid too" in capsys.readouterr().err


def test_inputs_no_analysis_can_use_are_refused_in_one_line(tmp_path, capsys):
    """Round four, B7: pbm --c-agg 1e9 wrote NaN with exit 0; --min-fragment larger than the run,
    a CG factor of 0.5 or 1e6 and study --predict gamma=-1 were accepted without a word."""
    from granalytics import RunMeta, ValidationError
    from granalytics.cli import main
    from granalytics.cli.study import parse_predict

    assert main(["pbm", "datasets/lab-cg3.h5", "--c-agg", "1e9", "--fit-window", "2:4", "--predict", "4:6",
                 "--out", str(tmp_path / "pbm"), "--quiet"]) == 2
    assert "no granule in the fit window" in capsys.readouterr().err and not (tmp_path / "pbm").exists()
    assert main(["track", "datasets/lab-cg3.h5", "--out", str(tmp_path / "t"), "--window-rev", "3:3.5",
                 "--min-fragment", "1000", "--quiet"]) == 2
    assert "larger than the run's 111 particles" in capsys.readouterr().err
    for alpha in (0.5, 1e6):
        with pytest.raises(ValidationError, match=r"alpha.: must be a number in \[1, 100\]"):
            RunMeta(surface_tension=0.1, density=2500.0, drum_omega=2.0, n_particles=10, mean_radius=1e-3, alpha=alpha)
    with pytest.raises(ga.ParameterError, match="gamma is a surface tension"):
        parse_predict("gamma=-1,omega=2")


@pytest.mark.parametrize("argv, hint", [(["stat", "run.h5"], "did you mean 'stats'?"),
                                        (["stats", "run.h5", "--cohesion", "actin"], "did you mean 'acting'?")])
def test_a_mistyped_command_or_choice_gets_the_closest_one(argv, hint, capsys):
    from granalytics.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(argv)
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and hint in err and len(err.strip().splitlines()) == 1


def test_a_grid_holds_the_values_a_user_would_write():
    from granalytics.cli.options import grid

    assert list(grid("0.1:1.0:19"))[1] == 0.15 and repr(float(grid("0.1:1.0:19")[1])) == "0.15"


def test_progress_bars_written_to_a_log_update_at_most_every_few_seconds(monkeypatch):
    import os
    import subprocess
    import sys

    from granalytics.base.progress import throttle_bars_off_terminal
    from granalytics.datasets import dataset_path

    monkeypatch.delenv("TQDM_MININTERVAL", raising=False)
    throttle_bars_off_terminal(7)  # pytest's stderr is captured: not a terminal
    assert os.environ["TQDM_MININTERVAL"] == "7"
    monkeypatch.setenv("TQDM_MININTERVAL", "0.5")
    throttle_bars_off_terminal(7)  # the user's own setting is kept
    assert os.environ["TQDM_MININTERVAL"] == "0.5"
    monkeypatch.delenv("TQDM_MININTERVAL")
    done = subprocess.run([sys.executable, "-m", "granalytics", "stats", str(dataset_path("lab-cg3"))],
                          capture_output=True, text=True, timeout=300)
    updates = [line for line in done.stderr.replace("\r", "\n").splitlines() if "frame" in line]
    assert done.returncode == 0 and 1 <= len(updates) <= 6, updates
