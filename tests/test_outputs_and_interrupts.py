"""Nothing written outside its place, nothing destroyed by Ctrl-C or by --overwrite, every error one
line (found by the second hostile round). Each test failed on the code before the fix it names."""

import hashlib
import os
import shutil

import pandas as pd
import pytest

import granalytics as ga
from granalytics.cli import main
from granalytics.datasets.synthetic import write_synthetic_run


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("round2") / "run.h5"
    return write_synthetic_run(path, n_particles=300, revolutions=2.0, frames_per_revolution=4, seed=7)


def _digest(folder):
    h = hashlib.sha256()
    for root, _, files in sorted(os.walk(folder)):
        for name in sorted(files):
            h.update(name.encode())
            h.update(open(os.path.join(root, name), "rb").read())
    return h.hexdigest()


def _one_line(capsys, *needles, prefix="granalytics: error:"):
    err = capsys.readouterr().err.strip()
    assert err.startswith(prefix) and "\n" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


@pytest.fixture
def sweep(tmp_path, run_file):
    """A sweep folder with one finished point (a copy of the synthetic run)."""
    src = tmp_path / "sweep"
    (src / "points").mkdir(parents=True)
    shutil.copy(run_file, src / "points" / "p0.h5")
    pd.DataFrame([{"point": "p0", "status": "done", "gamma": 0.1, "file": "points/p0.h5", "sha256": "x"}]).to_csv(
        src / "manifest.csv", index=False)
    return src


# 1 ------------------------------------------------------------------------------------------
def test_bundle_sweep_refuses_a_manifest_file_outside_its_points_folder(sweep, tmp_path, run_file, capsys):
    (tmp_path / "x").mkdir()
    shutil.copy(run_file, tmp_path / "x" / "evil.h5")
    table = pd.read_csv(sweep / "manifest.csv")
    for bad in ("../x/evil.h5", "../../x/evil.h5", str(tmp_path / "x" / "evil.h5"), "p0.h5"):
        table.loc[0, "file"] = bad
        table.to_csv(sweep / "manifest.csv", index=False)
        dst = tmp_path / "bundle"
        assert main(["datasets", "bundle-sweep", str(sweep), str(dst)]) == 2
        err = capsys.readouterr().err
        assert "point p0" in err and repr(bad) in err and "not inside" in err
        assert not dst.exists()
    assert sorted(os.listdir(tmp_path / "x")) == ["evil.h5"]  # nothing written beside the source


# 2 ------------------------------------------------------------------------------------------
def test_overwrite_never_destroys_a_source(sweep, tmp_path, run_file, capsys):
    before = _digest(sweep)
    for dst in (sweep, sweep / "inside", tmp_path):  # the same folder, inside it, containing it
        assert main(["datasets", "bundle-sweep", str(sweep), str(dst), "--overwrite"]) == 2
        _one_line(capsys, str(dst), prefix="granalytics datasets bundle-sweep: error:")
    assert _digest(sweep) == before
    copy = tmp_path / "copy.h5"
    shutil.copy(run_file, copy)
    digest = hashlib.sha256(copy.read_bytes()).hexdigest()
    with pytest.raises(ga.ParameterError, match="the subset is the input"):
        ga.subset_run(copy, copy, [0, 1], overwrite=True)
    assert hashlib.sha256(copy.read_bytes()).hexdigest() == digest


def test_convert_refuses_an_output_that_is_one_of_its_inputs(tmp_path, capsys):
    from pathlib import Path

    data = Path(__file__).parent / "data" / "yade_wet_drum"
    for name in ("frame_particles_000012000.csv.gz", "frame_contacts_000012000.csv.gz", "meta.toml"):
        shutil.copy(data / name, tmp_path / name)
    particles, contacts, meta = (tmp_path / n for n in ("frame_particles_000012000.csv.gz",
                                                        "frame_contacts_000012000.csv.gz", "meta.toml"))
    before = particles.read_bytes()
    assert main(["convert", str(particles), "--from", "yade", "--contacts", str(contacts), "--mapping", str(meta),
                 "--out", str(particles), "--overwrite", "--quiet"]) == 2
    _one_line(capsys, "is the input")
    assert particles.read_bytes() == before


# 3 ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", [["stats", "--window", "0:2"], ["identify", "--out", "labels.h5"],
                                     ["compare-methods", "--methods", "gna,dbscan"], ["track", "--out", "kin"],
                                     ["sensitivity", "--window", "0:2"], ["export-vtk", "--out", "vtk"]])
def test_ctrl_c_is_one_line_and_exit_130(run_file, tmp_path, capsys, monkeypatch, command):
    def interrupted(self, snapshot):
        raise KeyboardInterrupt

    monkeypatch.setattr(ga.GraphNetworkAnalysis, "identify", interrupted)
    import sys

    monkeypatch.setattr(sys.modules["granalytics.analysis.sensitivity"], "sensitivity",
                        lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt()))
    argv = [command[0], run_file, *(str(tmp_path / a) if a in ("labels.h5", "kin", "vtk") else a for a in command[1:]),
            "--quiet"]
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 130
    _one_line(capsys, "interrupted", prefix=f"granalytics: {command[0]}:")
    assert not (tmp_path / "kin").exists() and not (tmp_path / "labels.h5").exists()  # no empty folder, no half file
    left = [p for p in os.listdir(tmp_path) if p not in ("vtk",)]
    assert left == [], left
    if (tmp_path / "vtk").exists():
        assert os.listdir(tmp_path / "vtk") == []


def test_an_interrupted_export_vtk_leaves_the_earlier_export_whole(run_file, tmp_path, monkeypatch, capsys):
    out = tmp_path / "vtk"
    assert main(["export-vtk", run_file, "--out", str(out), "--quiet"]) == 0
    before = _digest(out)
    calls = []

    def fail_at_the_fourth_frame(self, snapshot):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return original(self, snapshot)

    original = ga.GraphNetworkAnalysis.identify
    monkeypatch.setattr(ga.GraphNetworkAnalysis, "identify", fail_at_the_fourth_frame)
    assert main(["export-vtk", run_file, "--out", str(out), "--overwrite", "--quiet", "--c-agg", "0.9"]) == 130
    assert _digest(out) == before  # no frame replaced, no truncated .vtu, run.pvd as it was


def test_an_interrupted_compare_cg_leaves_the_earlier_figures(tmp_path, monkeypatch, capsys):
    runs = [write_synthetic_run(tmp_path / f"cg{a}.h5", n_particles=n, revolutions=3.0, frames_per_revolution=4,
                                alpha=a, seed=1) for a, n in ((1.0, 400), (2.0, 50))]
    out = tmp_path / "cg"
    assert main(["compare-cg", *runs, "--window", "1:3", "--out", str(out), "--quiet"]) == 0
    before = _digest(out)
    import matplotlib.figure

    saved = []
    real = matplotlib.figure.Figure.savefig

    def interrupt_at_the_third_figure(self, *args, **kwargs):
        saved.append(1)
        if len(saved) == 3:
            raise KeyboardInterrupt
        return real(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", interrupt_at_the_third_figure)
    assert main(["compare-cg", *runs, "--window", "1:3", "--out", str(out), "--overwrite", "--quiet",
                 "--c-agg", "0.3"]) == 130
    assert _digest(out) == before


def test_stats_writes_all_its_outputs_or_none(run_file, tmp_path, monkeypatch, capsys):
    table = tmp_path / "ts.csv"
    table.write_text("precious")
    import matplotlib.figure

    def disk_full(self, *args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", disk_full)
    assert main(["stats", run_file, "--window", "0:2", "--out", str(table), "--plot", str(tmp_path / "p.png"),
                 "--overwrite", "--quiet"]) == 2
    assert table.read_text() == "precious" and not (tmp_path / "p.png").exists()
    assert sorted(os.listdir(tmp_path)) == ["ts.csv"]


def test_a_numba_kernel_interrupted_by_ctrl_c_counts_as_an_interrupt():
    from sim.cli import _interrupted

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("build_csr returned a result with an exception set")
    except SystemError as exc:
        assert _interrupted(exc)
    assert not _interrupted(SystemError("a real one"))


# 4 ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command, out", [(["identify"], "labels.h5"), (["stats", "--window", "0:2"], "ts.csv")])
def test_identify_and_stats_lock_their_outputs(run_file, tmp_path, capsys, command, out):
    target = tmp_path / out
    with ga.WriterLock(target):  # what a running command holds
        assert main([command[0], run_file, *command[1:], "--out", str(target), "--quiet"]) == 2
    _one_line(capsys, "lock")
    assert not target.exists()


# 5 ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", [["info"], ["stats", "--window", "0:1", "--quiet"]])
def test_a_fifo_is_refused_at_once(tmp_path, capsys, command):
    fifo = tmp_path / "f.h5"
    os.mkfifo(fifo)
    assert main([command[0], str(fifo), *command[1:]]) == 2
    _one_line(capsys, "not a regular file")


def test_convert_refuses_a_fifo(tmp_path, capsys):
    fifo = tmp_path / "atoms.dump"
    os.mkfifo(fifo)
    mapping = tmp_path / "m.toml"
    mapping.write_text('units = "si"\n')
    assert main(["convert", str(fifo), "--contacts", str(fifo), "--mapping", str(mapping), "--dt-s", "1e-5",
                 "--out", str(tmp_path / "o.h5")]) == 2
    _one_line(capsys, "not a regular file")


# 7 ------------------------------------------------------------------------------------------
def test_deeply_nested_toml_is_one_line(tmp_path, capsys):
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    from granalytics.convert._text import load_toml

    with pytest.raises(ga.GranalyticsError, match="nested too deeply"):
        load_toml(deep)
    from sim.cli import sweep_main

    assert sweep_main([str(deep), "--out", str(tmp_path / "s")]) == 2
    _one_line(capsys, "nested too deeply", prefix="sim: error:")


# 8 ------------------------------------------------------------------------------------------
def test_a_killed_writers_temporary_is_removed_by_the_next_write(run_file, tmp_path, capsys):
    out = tmp_path / "labels.h5"
    stale = tmp_path / "labels.h5.999999999.tmp"  # pid 999999999 runs nowhere
    stale.write_bytes(b"left by kill -9")
    assert main(["identify", run_file, "--out", str(out), "--quiet"]) == 0
    assert not stale.exists() and out.exists()


def test_a_failed_track_leaves_no_empty_folder(run_file, tmp_path, capsys):
    out = tmp_path / "kinetics"
    assert main(["track", run_file, "--out", str(out), "--window", "50:60", "--quiet"]) == 2
    assert not out.exists()


# 9, 12 --------------------------------------------------------------------------------------
def test_silent_wrong_answers_are_refused_or_warned(run_file):
    with ga.open_run(run_file) as run:
        with pytest.raises(ga.ParameterError, match="another frame"):
            ga.frame_stats(run[6], ga.identify(run[5]))
        with pytest.raises(ga.ParameterError, match="revolutions must be a finite number, got nan"):
            run.nearest(revolutions=float("nan"))
        with pytest.warns(UserWarning, match="no frame near revolutions=100"):
            assert run.nearest(revolutions=100).time == run.times[-1]
    with pytest.raises(ga.ParameterError, match="bins_per_decade must be a whole number >= 1, got 0"):
        ga.size_distribution([2, 3, 4], bins_per_decade=0)
    with pytest.raises(ga.ParameterError, match="min_size must be a whole number >= 1, got 0"):
        ga.size_distribution([2, 3, 4], min_size=0)
    with pytest.raises(ga.ValidationError, match="whole frame indices, got 1.7"):
        ga.subset_run(run_file, os.path.join(os.path.dirname(run_file), "s.h5"), [0, 1.7])


@pytest.mark.parametrize("call, words", [
    (lambda: ga.identify(None), "snapshot must be a granalytics Snapshot, got NoneType"),
    (lambda: ga.identify("run.h5"), "open the run with granalytics.open_run"),
    (lambda: ga.open_run(123), "path must be a file name"),
    (lambda: ga.steady_state(pd.DataFrame({"revolutions": [0.0, 1.0]}), window="3:6"), "window must be a pair"),
    (lambda: ga.steady_state(pd.DataFrame({"revolutions": [0.0, 1.0]}), columns=("nope",)), "no column 'nope'"),
    (lambda: ga.sensitivity_summary(pd.DataFrame()), "sensitivity_summary: table must be"),
    (lambda: ga.compare_methods([], ["gna", "dbscan"]), "methods must be a dict"),
])
def test_the_public_api_names_the_argument(call, words):
    with pytest.raises(ga.ParameterError, match=words):
        call()


# 10, 11 -------------------------------------------------------------------------------------
@pytest.mark.parametrize("argv, words", [
    (["stats", "RUN", "--window", "3:6", "--window-time", "1:5"], "give one steady-state window"),
    (["track", "RUN", "--out", "OUT", "--method", "dbscan", "--c-agg", "0.9"], "--c-agg 0.9: method 'dbscan'"),
    (["compare-cg", "RUN", "RUN", "--out", "OUT", "--method", "dbscan", "--a-agg-deg", "30"],
     "--a-agg-deg 30: method 'dbscan'"),
    (["stats", "RUN", "--window=-1e308:1e308"], "--window"),
    (["subset", "RUN", "--out", "OUT", "--every", str(10**23)], "--every"),
    (["compare-methods", "RUN", "--set", "sieve.apertures_m=abc"], "apertures_m must be a sequence"),
])
def test_conflicting_or_impossible_options_are_refused_naming_the_option(run_file, tmp_path, capsys, argv, words):
    argv = [run_file if a == "RUN" else str(tmp_path / "out") if a == "OUT" else a for a in argv]
    try:
        code = main([*argv, "--quiet"])
    except SystemExit as exc:  # argparse's refusal of an option value
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_subset_refuses_a_full_window_outside_the_run(run_file, tmp_path, capsys):
    assert main(["subset", run_file, "--out", str(tmp_path / "s.h5"), "--full-window", "50:60", "--every", "2",
                 "--quiet"]) == 2
    _one_line(capsys, "no frame in the window [50, 60] revolutions; the run covers [0, 2]")
    assert not (tmp_path / "s.h5").exists()


# 13, 15 -------------------------------------------------------------------------------------
def test_info_into_a_closed_pipe_exits_quietly(run_file):
    import subprocess
    import sys

    proc = subprocess.run(f"{sys.executable} -m granalytics info {run_file} | head -1", shell=True,
                          capture_output=True, text=True, timeout=120)
    assert proc.stdout.strip() == "file" and proc.stderr == ""


def test_python_m_granalytics_datasets_gives_no_runpy_warning():
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "granalytics.datasets", "list"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "RuntimeWarning" not in proc.stderr and "lab-cg3" in proc.stdout


def test_a_sweep_workers_warning_is_one_line(capsys, tmp_path):
    import warnings

    from granalytics.core.files import warnings_as_lines

    with warnings_as_lines("sim sweep: p.h5"):
        warnings.warn("took over the stale lock file\nof a dead writer", UserWarning)
    err = capsys.readouterr().err
    assert err == "sim sweep: p.h5: warning: took over the stale lock file of a dead writer\n"
    import inspect

    from sim.sweep import run_point

    assert "warnings_as_lines" in inspect.getsource(run_point)


def test_the_readme_says_how_to_reach_the_commands():
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    assert readme.split("```")[1].strip().splitlines() == [
        "make demo    # identify granules and print granulation statistics on the demo run",
        "make test    # create .venv, install the project with its test extras, run the test suite"]
    assert ". .venv/bin/activate" in readme and ".venv/bin/granalytics" in readme
