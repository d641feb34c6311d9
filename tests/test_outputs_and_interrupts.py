"""Nothing written outside its place, nothing destroyed by Ctrl-C or by --overwrite, every error one
line (found by the second hostile round). Each test failed on the code before the fix it names."""

import hashlib
import os
import shutil

import pandas as pd
import pytest

from conftest import swallow_an_interrupt_in_import
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
    import granalytics.analysis.sensitivity

    monkeypatch.setattr(granalytics.analysis.sensitivity, "sensitivity",
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
    """The simulator's command line and granalytics' share one test (granalytics.base.interrupts.interrupted)."""
    import sim.cli
    from granalytics.base.interrupts import interrupted

    assert sim.cli.interrupted is interrupted
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("build_csr returned a result with an exception set")
    except SystemError as exc:
        assert interrupted(exc)
    assert not interrupted(SystemError("a real one"))


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
    assert main(["track", run_file, "--out", str(out), "--window-rev", "50:60", "--quiet"]) == 2
    assert not out.exists()


# 9, 12 --------------------------------------------------------------------------------------
def test_silent_wrong_answers_are_refused_or_warned(run_file):
    with ga.open_run(run_file) as run:
        with pytest.raises(ga.ParameterError, match="another frame"):
            ga.frame_stats(run[6], ga.identify(run[5]))
        with pytest.raises(ga.ParameterError, match="^nearest: revolutions must be a finite number or None, got float nan$"):
            run.nearest(revolutions=float("nan"))
        with pytest.warns(UserWarning, match="no frame near revolutions=100"):
            assert run.nearest(revolutions=100).time == run.times[-1]
    with pytest.raises(ga.ParameterError, match="size_distribution: bins_per_decade must be a whole number >= 1, got int 0"):
        ga.size_distribution([2, 3, 4], bins_per_decade=0)
    with pytest.raises(ga.ParameterError, match="size_distribution: min_size must be a whole number >= 1, got int 0"):
        ga.size_distribution([2, 3, 4], min_size=0)
    with pytest.raises(ga.ValidationError, match="whole frame indices, got 1.7"):
        ga.subset_run(run_file, os.path.join(os.path.dirname(run_file), "s.h5"), [0, 1.7])


@pytest.mark.parametrize("call, words", [
    (lambda: ga.identify(None), r"^identify: snapshot must be a granalytics Snapshot \(.*\), got NoneType None$"),
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
    (["stats", "RUN", "--window", "3:6", "--window-time", "1:5"], "--window-time: not allowed with argument --window"),
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

    from granalytics.base.errors import warnings_as_lines

    with warnings_as_lines("sim sweep: p.h5"):
        warnings.warn("took over the stale lock file\nof a dead writer", UserWarning)
    err = capsys.readouterr().err
    assert err == "sim sweep: p.h5: warning: took over the stale lock file of a dead writer\n"


def test_the_readmes_first_commands_set_up_the_environment_the_readme_names():
    """The README opens with make commands; each is a target of the Makefile, every one installs the
    project into .venv, and the commands run from .venv/bin, where the README says they are."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    readme = (root / "README.md").read_text()
    commands = [line.split("#")[0].split() for line in readme.split("```")[1].strip().splitlines()]
    assert commands and all(command[0] == "make" for command in commands), commands
    plans = {" ".join(command): subprocess.run(["make", "-nB", *command[1:]], cwd=root, capture_output=True, text=True,
                                               check=True).stdout for command in commands}
    for command, plan in plans.items():
        assert "-m venv .venv" in plan and "pip install --quiet -e" in plan, command
    assert "make test" in plans and ".venv/bin/python -m pytest" in plans["make test"]
    assert any(".venv/bin/granalytics " in plan for plan in plans.values())
    assert ". .venv/bin/activate" in readme and ".venv/bin/granalytics" in readme


# ------------------------------------------------------------ round three (issue 33): Ctrl-C (A2)
def test_ctrl_c_while_the_commands_load_is_one_line_and_exit_130(run_file, tmp_path):
    """The commands' imports take seconds; a Ctrl-C then printed a KeyboardInterrupt traceback
    and the process died of SIGINT (exit -2). A real SIGINT, 0.3 s after the start."""
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "granalytics", "identify", run_file, "--out",
                             str(tmp_path / "labels.h5"), "--quiet"], stderr=subprocess.PIPE, text=True)
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().startswith("granalytics:") and "\n" not in err.strip() and "interrupted" in err
    assert not (tmp_path / "labels.h5").exists()


def test_the_console_script_handles_ctrl_c_before_the_commands_are_imported(monkeypatch, capsys):
    import builtins

    import granalytics.__main__ as entry

    real = builtins.__import__

    def interrupted_import(name, *args, **kwargs):
        if name == "granalytics.cli":
            raise KeyboardInterrupt
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted_import)
    assert entry.main(["info", "run.h5"]) == 130
    assert capsys.readouterr().err.strip() == "granalytics: interrupted before any work; nothing was written"


def test_a_ctrl_c_while_the_commands_load_is_held_not_lost_in_a_library(monkeypatch, capsys):
    """A library that swallows exceptions around an optional import (a bare ``except:``) lost a
    Ctrl-C that was raised inside it, and the command ran to its end with status 0 (seen in 1 of 40
    interrupts under load); one raised inside a nested PyRun call left CPython to end the process
    by SIGINT after the message. While the commands load, the Ctrl-C is held and then acted on."""
    import signal

    import granalytics.__main__ as entry

    swallow_an_interrupt_in_import(monkeypatch, "granalytics.cli")
    assert entry.main(["--version"]) == 130
    assert capsys.readouterr().err.strip() == "granalytics: interrupted before any work; nothing was written"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_sigint_that_the_process_ignores_stays_ignored_while_the_commands_load():
    """A script's background job (``cmd &``) is started with SIGINT ignored and must survive a
    Ctrl-C; holding the interrupt while the commands load turned it into exit 130."""
    import signal
    import time

    from granalytics.base.interrupts import interrupts_held

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with interrupts_held() as held:
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            signal.raise_signal(signal.SIGINT)
            time.sleep(0.05)
        assert held == [] and signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_ctrl_c_inside_a_numba_kernel_is_an_interrupt_too(run_file, tmp_path, monkeypatch, capsys):
    """A Ctrl-C while a numba kernel runs surfaces as SystemError ('... returned a result with an
    exception set'), which export-vtk printed as a traceback with exit 1."""
    def kernel_interrupted(self, snapshot):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("CPUDispatcher(<function gna_fused>) returned a result with an exception set")

    monkeypatch.setattr(ga.GraphNetworkAnalysis, "identify", kernel_interrupted)
    assert main(["export-vtk", run_file, "--out", str(tmp_path / "vtk"), "--quiet"]) == 130
    _one_line(capsys, "interrupted", prefix="granalytics: export-vtk:")


def _interrupt_the_swap_at(monkeypatch, call):
    """Ctrl-C at the ``call``-th rename or link of the swap that puts staged outputs in place."""
    import granalytics.report.files as files

    seen = []

    def interrupting(real):
        def step(src, dst, **kwargs):
            if ".staging-" in os.fspath(src) or ".staging-" in os.fspath(dst):
                seen.append(dst)
                if len(seen) == call:
                    raise KeyboardInterrupt
            return real(src, dst, **kwargs)
        return step

    monkeypatch.setattr(files.os, "replace", interrupting(os.replace))
    monkeypatch.setattr(files.os, "link", interrupting(os.link))
    return seen


@pytest.mark.parametrize("call", [2, 3, 5, 7])
@pytest.mark.parametrize("command", ["stats", "track", "compare-cg"])
def test_ctrl_c_inside_the_final_renames_changes_no_output(run_file, tmp_path, monkeypatch, capsys, command, call):
    """A Ctrl-C during the renames of a multi-file output left 2 new and 3 old files: now the
    earlier outputs are put back (all old), exit 130."""
    out = tmp_path / "out"
    runs = [run_file]
    if command == "compare-cg":
        runs.append(write_synthetic_run(tmp_path / "cg2.h5", n_particles=60, revolutions=2.0, frames_per_revolution=4,
                                        alpha=2.0, seed=7))
    argv = {"stats": ["stats", run_file, "--window", "0:2", "--out", str(out / "ts.csv"), "--steady-out",
                      str(out / "steady.csv"), "--sizes-out", str(out / "sizes.csv"), "--plot", str(out / "p.png")],
            "track": ["track", run_file, "--out", str(out)],
            "compare-cg": ["compare-cg", *runs, "--window", "1:2", "--mixed-systems", "--out", str(out)]}[command]
    out.mkdir()
    assert main([*argv, "--quiet"]) == 0
    before = _digest(out)
    seen = _interrupt_the_swap_at(monkeypatch, call)
    assert main([*argv, "--quiet", "--overwrite", "--c-agg", "0.3"]) == 130
    assert len(seen) >= call  # the interrupt came inside the swap (then the renames that undo it)
    assert _digest(out) == before
    assert not [p for p in os.listdir(out) if p.startswith(".staging")]
    capsys.readouterr()


def test_a_real_sigint_during_the_swap_is_held_and_undoes_it(tmp_path, monkeypatch):
    import signal

    import granalytics.report.files as files

    targets = [tmp_path / f"t{k}.csv" for k in range(4)]
    for target in targets:
        target.write_text("old")
    real = os.replace

    def replace(src, dst):
        if dst == os.fspath(targets[1]):
            signal.raise_signal(signal.SIGINT)  # to this thread, at once: held until the swap is done
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        with files.staged_outputs() as stage:
            for target in targets:
                with open(stage(target), "w") as f:
                    f.write("new")
    assert [t.read_text() for t in targets] == ["old"] * 4
    assert sorted(os.listdir(tmp_path)) == sorted(t.name for t in targets)


def test_ctrl_c_while_bundle_sweep_replaces_a_bundle_keeps_the_old_one(sweep, tmp_path, monkeypatch, capsys):
    """Ctrl-C during the replacement deleted the new bundle and part of the old one."""
    import shutil as shutil_module

    dst = tmp_path / "bundle"
    assert main(["datasets", "bundle-sweep", str(sweep), str(dst)]) == 0
    before = _digest(dst)
    real = shutil_module.rmtree

    def interrupted_rmtree(path, *args, **kwargs):  # the old code deleted dst before the rename
        if os.fspath(path) == os.fspath(dst):
            real(os.path.join(path, "points"), *args, **kwargs)
            raise KeyboardInterrupt
        return real(path, *args, **kwargs)

    monkeypatch.setattr(shutil_module, "rmtree", interrupted_rmtree)
    import granalytics.report.files as files

    real_replace, interrupts = os.replace, []

    def replace(src, dst_path):  # Ctrl-C as the new bundle is renamed into place (once)
        if os.fspath(dst_path) == os.fspath(dst) and not interrupts:
            interrupts.append(src)
            raise KeyboardInterrupt
        return real_replace(src, dst_path)

    monkeypatch.setattr(files.os, "replace", replace)
    assert main(["datasets", "bundle-sweep", str(sweep), str(dst), "--overwrite"]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err == f"granalytics datasets bundle-sweep: interrupted; {dst} was left as it was"
    assert _digest(dst) == before
    assert sorted(os.listdir(tmp_path)) == ["bundle", "sweep"]


# ------------------------------------------------- writes where they should not (A6, A7)
@pytest.mark.parametrize("command", ["identify", "subset", "table", "synthetic"])
def test_an_output_that_is_a_device_is_refused_even_with_overwrite(run_file, tmp_path, capsys, command):
    """--out /dev/null --overwrite replaced the device with a file (as root); a table through a
    link to it (its name needs a table extension) the same."""
    out = "/dev/null"
    if command == "table":
        out = tmp_path / "t.parquet"
        out.symlink_to("/dev/null")
    argv = (["synthetic", "--out", str(out), "--particles", "50"] if command == "synthetic"
            else [command, run_file, "--out", str(out), "--quiet"])
    before = os.stat("/dev/null")
    assert main([*argv, "--overwrite"]) == 2
    _one_line(capsys, str(out), "not a regular file")
    after = os.stat("/dev/null")
    assert (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)
    assert not os.path.exists("/dev/null.lock")


def test_synthetic_replaces_a_run_only_with_overwrite_and_never_through_a_link(run_file, tmp_path, capsys):
    """synthetic --out replaced an existing run without --overwrite, wrote through a symlink into
    another run, and a Ctrl-C truncated the run it was replacing."""
    precious = tmp_path / "precious.h5"
    shutil.copy(run_file, precious)
    digest = hashlib.sha256(precious.read_bytes()).hexdigest()
    link = tmp_path / "link.h5"
    link.symlink_to(precious)
    for out in (precious, link):
        assert main(["synthetic", "--out", str(out), "--particles", "50", "--revolutions", "0.5"]) == 2
        _one_line(capsys, "exists", "--overwrite")
    assert main(["synthetic", "--out", str(link), "--particles", "50", "--revolutions", "0.5", "--overwrite"]) == 0
    assert not link.is_symlink() and ga.open_run(link).n_particles == 50
    assert hashlib.sha256(precious.read_bytes()).hexdigest() == digest
    capsys.readouterr()


def test_an_interrupted_synthetic_leaves_the_run_it_replaces_whole(run_file, tmp_path, monkeypatch, capsys):
    precious = tmp_path / "precious.h5"
    shutil.copy(run_file, precious)
    digest = hashlib.sha256(precious.read_bytes()).hexdigest()
    import granalytics.datasets.synthetic as synthetic

    real, calls = synthetic.synthetic_snapshot, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(synthetic, "synthetic_snapshot", interrupted)
    assert main(["synthetic", "--out", str(precious), "--particles", "50", "--overwrite"]) == 130
    _one_line(capsys, "interrupted", prefix="granalytics: synthetic:")
    assert hashlib.sha256(precious.read_bytes()).hexdigest() == digest
    assert sorted(os.listdir(tmp_path)) == ["precious.h5"]


def test_an_output_linked_to_the_input_is_the_input(run_file, tmp_path, capsys):
    """identify --out LINK, LINK a symlink to its own input, replaced the input run."""
    source = tmp_path / "run.h5"
    shutil.copy(run_file, source)
    digest = hashlib.sha256(source.read_bytes()).hexdigest()
    link = tmp_path / "labels.h5"
    link.symlink_to(source)
    for command in ("identify", "subset", "table"):
        out = link if command != "table" else tmp_path / "t.parquet"
        if command == "table":
            out.symlink_to(source)
        assert main([command, str(source), "--out", str(out), "--overwrite", "--quiet"]) == 2
        _one_line(capsys, "input run")
    assert hashlib.sha256(source.read_bytes()).hexdigest() == digest


def test_study_refuses_an_output_that_reaches_the_sweep_through_a_link(sweep, tmp_path, capsys):
    """study --out through a symlinked sweep folder overwrote the sweep's manifest.csv."""
    (tmp_path / "alias").symlink_to(sweep)
    before = _digest(sweep)
    for out in (tmp_path / "alias" / "manifest.csv", tmp_path / "alias" / "points" / "t.csv"):
        assert main(["study", str(sweep), "--out", str(out), "--overwrite", "--quiet"]) == 2
        _one_line(capsys, "inside the sweep folder")
    (tmp_path / "table.csv").symlink_to(sweep / "manifest.csv")
    assert main(["study", str(sweep), "--out", str(tmp_path / "table.csv"), "--overwrite", "--quiet"]) == 2
    _one_line(capsys, "inside the sweep folder")
    assert _digest(sweep) == before


# ------------------------------------------------- round three (issue 33): Ctrl-C never dropped (A2)
class _DroppedInterrupt:
    """An object whose ``__del__`` raises KeyboardInterrupt: what a real SIGINT does when it lands
    while an llvmlite object is freed or a WeakValueDictionary entry is removed. Python cannot
    propagate it ("Exception ignored in ...") and drops it."""

    def __del__(self):
        raise KeyboardInterrupt


def test_a_ctrl_c_that_python_drops_in_a_del_method_is_raised_at_the_next_frame(run_file, tmp_path, monkeypatch,
                                                                                 capsys):
    """About one real SIGINT in 15 landed in a __del__ or weakref callback: 'Exception ignored in
    ...', and stats went on to write its outputs and exit 0."""
    real, seen = ga.GraphNetworkAnalysis.identify, []

    def identify(self, snapshot):
        seen.append(snapshot.time)
        if len(seen) == 2:
            _DroppedInterrupt()  # freed at once: the interrupt is raised in its __del__ and dropped
        return real(self, snapshot)

    monkeypatch.setattr(ga.GraphNetworkAnalysis, "identify", identify)
    out = tmp_path / "ts.csv"
    out.write_text("precious")
    assert main(["stats", run_file, "--window", "0:2", "--out", str(out), "--overwrite", "--quiet"]) == 130
    _one_line(capsys, "no output was replaced", prefix="granalytics: stats: interrupted")
    assert out.read_text() == "precious" and len(seen) == 2  # stopped after the frame it came in
    assert sorted(os.listdir(tmp_path)) == ["ts.csv"]


def test_a_dropped_ctrl_c_replaces_no_output_and_is_not_lost_at_the_end(run_file, tmp_path, monkeypatch, capsys):
    from granalytics.base.files import write_atomically
    from granalytics.base.interrupts import interrupts_not_lost, raise_dropped_interrupt

    target = tmp_path / "t.txt"
    target.write_text("precious")

    def write(tmp):
        open(tmp, "w").write("new")
        _DroppedInterrupt()

    with interrupts_not_lost():
        with pytest.raises(KeyboardInterrupt):
            write_atomically(target, write)
        raise_dropped_interrupt()  # raised once, then gone
    assert target.read_text() == "precious" and os.listdir(tmp_path) == ["t.txt"]
    # dropped while the table is printed, after the outputs were written: exit 130 all the same
    import granalytics.cli.stats as stats

    real = stats.format_steady_table

    def notes(*args, **kwargs):
        _DroppedInterrupt()
        return real(*args, **kwargs)

    monkeypatch.setattr(stats, "format_steady_table", notes)
    assert main(["stats", run_file, "--window", "0:2", "--out", str(tmp_path / "ts.csv"), "--quiet"]) == 130
    assert pd.read_csv(tmp_path / "ts.csv").shape[0] > 0
    err = capsys.readouterr().err.strip().splitlines()  # (the growing synthetic run also gets the drift warning)
    assert err[-1] == "granalytics: stats: interrupted as it finished; the outputs it wrote are whole", err
    assert all("warning" in line for line in err[:-1]), err
    # outside the command line nothing changes: Python's own hook gets it (prints and drops it)
    import sys

    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: seen.append(unraisable.exc_type))
    _DroppedInterrupt()
    raise_dropped_interrupt()  # nothing was recorded: nothing raised
    assert seen == [KeyboardInterrupt]


def test_ctrl_c_inside_numbas_unpickling_is_an_interrupt_too():
    """A Ctrl-C while numba loaded a cached kernel came as a SystemError caused by a SystemError
    caused by the KeyboardInterrupt: a traceback and exit 1."""
    from granalytics.base.interrupts import interrupted

    def chained(depth):
        try:
            if depth == 0:
                raise KeyboardInterrupt
            chained(depth - 1)
        except BaseException as exc:
            raise SystemError("<function _numba_unpickle> returned a result with an exception set") from exc

    for depth in (0, 1, 3):
        with pytest.raises(SystemError) as exc:
            chained(depth)
        assert interrupted(exc.value)
    assert not interrupted(SystemError("a real one"))
    wrapped = SystemError("a real one, raised while handling another error")
    wrapped.__cause__ = ValueError("not an interrupt")
    wrapped.__cause__.__context__ = KeyboardInterrupt()  # only a chain of SystemErrors leads to one
    assert not interrupted(wrapped)


def test_a_ctrl_c_after_the_command_finished_is_ignored_while_the_process_exits(run_file, monkeypatch, capsys):
    """A Ctrl-C in the half second that the process takes to shut down after the command printed
    its table was raised in an atexit or __del__ ('Exception ignored', exit 0) or killed the process
    without a word (exit -2); one just as the command returned was reported as 'interrupted
    before any work; nothing was written'."""
    import subprocess
    import sys

    import granalytics.__main__ as entry
    import granalytics.cli as cli

    def finished_then_interrupted(argv):
        cli._done(0)
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_main", finished_then_interrupted)
    assert entry.main(["info", run_file]) == 0
    assert capsys.readouterr().err == ""
    code = ("import signal, sys; from granalytics.__main__ import main; sys.argv = ['granalytics', 'info', sys.argv[1]]; "
            "status = main(); print(status, signal.getsignal(signal.SIGINT) is signal.SIG_IGN)")
    done = subprocess.run([sys.executable, "-c", code, run_file], capture_output=True, text=True, timeout=120)
    assert done.stdout.strip().splitlines()[-1] == "0 True", done.stderr


def test_bundle_sweep_overwrite_never_deletes_other_files_in_the_folder(sweep, tmp_path, capsys):
    """Round three and four, B8: --overwrite of a folder that held the user's other files (a
    bundle made into an existing folder, notes beside it) deleted them with the old bundle."""
    dst = tmp_path / "bundle"
    assert main(["datasets", "bundle-sweep", str(sweep), str(dst)]) == 0
    (dst / "notes.txt").write_text("mine")
    before = _digest(dst)
    assert main(["datasets", "bundle-sweep", str(sweep), str(dst), "--overwrite"]) == 2
    assert "holds files that are not a bundle's (notes.txt)" in capsys.readouterr().err
    assert _digest(dst) == before
    (dst / "notes.txt").unlink()
    assert main(["datasets", "bundle-sweep", str(sweep), str(dst), "--overwrite"]) == 0


def test_sigterm_is_cleaned_up_as_a_ctrl_c(tmp_path, capsys):
    """Round four, B7: SIGTERM left .staging-* folders and *.lock files that nothing cleaned. The
    command lines now raise it as a KeyboardInterrupt, so the clean-up of a Ctrl-C runs."""
    import signal

    from granalytics.base.interrupts import terminate_as_interrupt
    from granalytics.report.files import staged_outputs

    target = tmp_path / "out.csv"
    with pytest.raises(KeyboardInterrupt):
        with terminate_as_interrupt(), staged_outputs() as stage:
            with open(stage(str(target)), "w") as f:
                f.write("half")
            signal.raise_signal(signal.SIGTERM)
    assert not list(tmp_path.iterdir())  # no staging folder, no output
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # restored


def test_a_disk_that_fills_during_subset_is_one_line_not_a_crash(tmp_path):
    """Round four, B5: a file-size limit (or a full disk) during subset ended in 11 tracebacks and
    a segmentation fault (exit 139) as the interpreter closed the broken HDF5 file."""
    import resource
    import subprocess
    import sys

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (200 * 1024, 200 * 1024))

    out = tmp_path / "sub.h5"
    done = subprocess.run([sys.executable, "-m", "granalytics", "subset", "datasets/lab-cg3.h5", "--out", str(out),
                           "--quiet"], capture_output=True, text=True, preexec_fn=limit)
    err = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(err) == 1, (done.returncode, err)
    assert "the disk is full or a file-size limit was reached" in err[0]
    assert not list(tmp_path.iterdir())  # nothing left: no partial file, no lock
