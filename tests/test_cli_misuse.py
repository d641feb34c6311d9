"""Misuse of the command line loses nothing and gives one line with exit status 2."""

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.cli import main
from granalytics.core.errors import ParameterError
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
