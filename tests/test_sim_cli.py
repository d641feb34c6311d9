import re

import pytest

from conftest import swallow_an_interrupt_in_import
from sim.cli import main
from sim.params import PRESETS


@pytest.mark.parametrize(
    "args, words",
    [
        (["--gamma", "-1"], "--gamma"),
        (["--alpha", "0.5"], "alpha"),
        (["--threads", "99"], "--threads"),
        (["--revolutions", "0"], "--revolutions"),
        (["--resume"], "no checkpoint"),
    ],
)
def test_bad_parameters_give_one_line_and_exit_2(tmp_path, capsys, args, words):
    argv = ["run", "--preset", "lab-cg3", "--revolutions", "1", "--out", str(tmp_path / "r.h5"), "--quiet"] + args
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sim: error:") and words in err[0]


def test_threads_is_auto_or_a_count(tmp_path, capsys):
    from sim.cli import build_parser

    args = ["run", "--revolutions", "1", "--out", str(tmp_path / "r.h5")]
    assert build_parser().parse_args(args).threads == "auto"
    assert build_parser().parse_args(args + ["--threads", "1"]).threads == 1
    with pytest.raises(SystemExit) as exit_:
        main(args + ["--threads", "all"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--threads" in err[0] and "'auto' or a whole number" in err[0]


def test_presets_are_listed(capsys):
    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    assert "paper-cg1" in out and "120000 particles" in out and "lab-cg3" in out


def test_unknown_preset_is_an_argparse_error():
    with pytest.raises(SystemExit) as exit_:
        main(["run", "--preset", "lab-cg9", "--revolutions", "1", "--out", "x.h5"])
    assert exit_.value.code == 2


@pytest.mark.slow
def test_a_killed_run_resumes_from_its_checkpoint_bit_identically(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    import numpy as np

    import granalytics as ga

    args = [sys.executable, "-m", "sim", "run", "--preset", "lab-cg3", "--revolutions", "0.1",
            "--frame-every-rev", "0.01", "--checkpoint-every", "3", "--quiet"]
    full, part = tmp_path / "full.h5", tmp_path / "part.h5"
    subprocess.run(args + ["--out", str(full)], check=True, capture_output=True)
    proc = subprocess.Popen(args + ["--out", str(part)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    marker = f"{part}.ckpt.npz"  # one file, renamed into place when complete
    deadline = time.time() + 120
    while not os.path.exists(marker) and time.time() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, "the run ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    subprocess.run(args + ["--out", str(part), "--resume"], check=True, capture_output=True)
    with ga.open_run(full) as a, ga.open_run(part) as b:
        assert len(a) == len(b) == 11  # 0.1 revolution, a frame every 3 491 steps: 10 intervals
        for fa, fb in zip(a, b):
            for name in ("time", "ids", "position", "velocity", "angular_velocity", "film_volume",
                         "contact_i", "contact_j", "f_cap", "f_normal", "gap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name


# --- refusals, overwrite, resume checks (a tiny drum: 200 particles, settled in 0.01 s) ---------

import dataclasses  # noqa: E402
import hashlib  # noqa: E402
import shutil  # noqa: E402

import numpy as np  # noqa: E402

import granalytics as ga  # noqa: E402
import sim.cli  # noqa: E402
import sim.run  # noqa: E402

from conftest import former_lab_original  # noqa: E402

TINY = dataclasses.replace(former_lab_original(5400), settle_time=0.01, spray_interval=0.01, initial_film=0.004)
# a frame every 0.001 revolution (349 steps), 4 frames after the first, a checkpoint every 2 frames
BASE = ["--revolutions", "0.004", "--frame-every-rev", "0.001", "--checkpoint-every", "2", "--quiet"]


@pytest.fixture
def cli(monkeypatch, capsys, tmp_path):
    """``cli(out, *args)`` runs ``python -m sim run`` on the tiny preset (CG3 of TINY); returns
    (exit status, stderr lines)."""
    monkeypatch.setattr(sim.cli, "preset_original", lambda name: (TINY, 3.0))

    def run(out, *args):
        capsys.readouterr()
        try:
            code = main(["run", "--out", str(tmp_path / out), *BASE, *args])
        except SystemExit as exc:  # argparse's own errors
            code = exc.code
        return code, capsys.readouterr().err.strip().splitlines()

    return run


def files(directory):
    """Name -> sha256 of every file in ``directory``: what 'nothing changed on disk' compares."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(directory.iterdir())}


def refused(result, *words):
    code, err = result
    assert code == 2 and len(err) == 1 and err[0].startswith("sim: error:"), err
    for word in words:
        assert word in err[0], err[0]
    return err[0]


@pytest.mark.parametrize("args, words", [
    (["--seed", "abc"], ["--seed"]),
    (["--seed", "-1"], ["--seed"]),
    (["--particles", "10"], ["--particles 10", "0 particles"]),
    (["--checkpoint-every", "0"], ["--checkpoint-every"]),
    (["--checkpoint-minutes", "0"], ["--checkpoint-minutes", "> 0"]),
    (["--checkpoint-minutes", "nan"], ["--checkpoint-minutes"]),
    (["--revolutions", "inf"], ["--revolutions"]),
    (["--revolutions", "nan"], ["--revolutions"]),
    (["--omega", "0"], ["--omega"]),
    (["--frame-every-rev", "inf"], ["--frame-every-rev"]),
    (["--revolutions", "0.006", "--frame-every-rev", "0.0025"], ["--revolutions", "--frame-every-rev", "whole number"]),
    (["--alpha", "inf"], ["alpha"]),
    (["--alpha", "1e300"], ["0 particles after coarse-graining", "at least 2"]),
    (["--omega", "1e-300"], ["--revolutions", "time steps", "1e-300 rad/s"]),
    (["--revolutions", "1e308"], ["--revolutions", "time steps"]),
    (["--law-parameter", "youngs_modulus=1e7"], ["--law-parameter youngs_modulus", "'linear_coulomb'", "k_n"]),
    (["--contact-law", "hertz_mindlin", "--law-parameter", "k_n=200"], ["'hertz_mindlin' has no parameter 'k_n'"]),
    (["--law-parameter", "k_n"], ["--law-parameter", "NAME=NUMBER"]),
    (["--contact-law", "hertz_mindlin", "--law-parameter", "restitution=1.5"], ["restitution", "(0, 1]"]),
    (["--contact-law", "hooke"], ["--contact-law", "hooke"]),
])
def test_bad_option_values_are_refused_in_one_line_before_anything_is_written(cli, tmp_path, args, words):
    refused(cli("r.h5", *args), *words)
    assert files(tmp_path) == {}


def test_dt_factor_multiplies_the_cg_rules_step_is_recorded_and_shown_by_info(cli, tmp_path, capsys):
    from sim.cli import _params, build_parser

    def step(*flags):
        args = build_parser().parse_args(["run", "--preset", "lab-cg3", "--revolutions", "1", "--out", "x.h5", *flags])
        return _params(args)

    original, paper = step()
    _, coarse = step("--dt-factor", "2.5")
    assert original.dt == 3e-6 and original.dt_factor == 1 and paper.dt == pytest.approx(9e-6)
    assert coarse.dt == pytest.approx(2.5 * paper.dt) and coarse.dt_factor == 2.5  # after the rule
    _, twin = step("--cg-rule", "bond", "--twin", "--dt-factor", "2")
    _, twin_paper = step("--cg-rule", "bond", "--twin")
    assert twin.dt == pytest.approx(2 * twin_paper.dt) and twin.dt_factor == 2
    refused(cli("r.h5", "--dt-factor", "3"), "k_t", "fewer than 20")
    refused(cli("r.h5", "--dt-factor", "nan"), "--dt-factor", "(0, 100]")
    assert cli("r.h5", "--dt-factor", "2", "--threads", "1")[0] == 0  # the cost line names the count
    with ga.open_run(tmp_path / "r.h5") as run:
        params, config = run.meta.sim_config["params"], run.meta.sim_config
        assert params["dt_factor"] == 2 and run.steps[1] * params["dt"] == pytest.approx(run.times[1], rel=1e-12)
        assert config["steps_per_contact"] == pytest.approx(127.1 / 2, rel=2e-3)
    capsys.readouterr()
    from granalytics.cli import main as granalytics_main

    assert granalytics_main(["info", str(tmp_path / "r.h5")]) == 0
    assert "time step" in (out := capsys.readouterr().out) and "2 × the CG rule's step, t_c/Δt = 63.5" in out
    cost = next(line for line in out.splitlines() if line.strip().startswith("cost"))
    assert re.search(r"wall [\d.]+ s, CPU [\d.]+ s, 1 thread\(s\) at the end, [\d.]+ M particle-steps/s "
                     r"\(last sitting\); the settling before it: wall [\d.]+ s, CPU [\d.]+ s$", cost), cost


def test_a_time_step_too_long_for_the_contacts_is_refused():
    from sim.params import SimParams, preset

    with pytest.raises(ValueError, match=r"dt = 0\.0001 s is above t_c/20 = 1\.37e-05 s.*t_c = 0\.000273 s"):
        SimParams(dt=1e-4)
    for name in PRESETS:  # every preset resolves the contact of its smallest particles with > 20 steps
        p = preset(name)
        assert p.dt <= p.contact_time(p.r_mean * (1 - p.d_spread)) / 20


def test_an_existing_out_is_replaced_only_with_overwrite(cli, tmp_path):
    out = tmp_path / "r.h5"
    out.write_bytes(b"a precious file")
    refused(cli("r.h5"), "exists", "--overwrite")
    assert files(tmp_path) == {"r.h5": hashlib.sha256(b"a precious file").hexdigest()}
    assert cli("r.h5", "--overwrite")[0] == 0
    with ga.open_run(out) as run:
        assert len(run) == 5
    refused(cli("r.h5", "--overwrite", "--resume"), "--resume", "--overwrite")


def test_resume_from_a_kept_checkpoint_starts_a_part_and_refuses_what_does_not_match(cli, tmp_path):
    assert cli("a.h5")[0] == 0  # its last checkpoint after 4 frames
    kept = tmp_path / "kept.ckpt.npz"
    shutil.copyfile(tmp_path / "a.h5.ckpt.npz", kept)
    refused(cli("p.h5", "--resume", "--resume-from", str(kept)), "--resume", "--resume-from", "one of them")
    refused(cli("p.h5", "--resume-from", str(kept), "--seed", "1"), "kept.ckpt.npz", "other parameters", "seed")
    refused(cli("p.h5", "--resume-from", str(kept), "--revolutions", "0.003"), "after 4 frames, the requested run has 4")
    refused(cli("a.h5", "--resume-from", str(kept), "--revolutions", "0.006"), "a.h5 exists", "--overwrite")
    refused(cli("a.h5", "--resume-from", str(tmp_path / "a.h5.ckpt.npz"), "--overwrite", "--revolutions", "0.006"),
            "a.h5's own checkpoint", "--resume")
    refused(cli("p.h5", "--resume-from", str(tmp_path / "none.npz"), "--revolutions", "0.006"), "no checkpoint")
    assert not (tmp_path / "p.h5").exists()
    # the part holds the run's frames 4-6 of a run extended to 0.006 revolution, as a run made at once
    assert cli("p.h5", "--resume-from", str(kept), "--revolutions", "0.006")[0] == 0
    assert cli("once.h5", "--revolutions", "0.006")[0] == 0
    with ga.open_run(tmp_path / "p.h5") as part, ga.open_run(tmp_path / "once.h5") as once:
        assert len(part) == 3 and part.meta.provenance["first_frame"] == 4 and part.unfinished is None
        for fa, fb in zip(once[4:], part):
            assert fa.step == fb.step and np.array_equal(fa.position, fb.position)


def test_the_last_frame_is_at_the_requested_revolutions(cli, tmp_path):
    # 0.0015 revolution is 523.6 steps, rounded up to 524: 4 intervals reach 0.006 revolution
    assert cli("r.h5", "--revolutions", "0.006", "--frame-every-rev", "0.0015")[0] == 0
    p = sim.cli.cg_scale(TINY, 3.0)
    with ga.open_run(tmp_path / "r.h5") as run:
        assert len(run) == 5 and np.array_equal(run.steps, np.arange(5) * 524)
        assert abs(run.times[-1] - 0.006 * p.revolution_period) <= 2 * p.dt


def test_resume_refuses_a_checkpoint_that_is_not_the_run_files_and_changes_nothing(cli, tmp_path):
    assert cli("a.h5")[0] == 0
    assert cli("b.h5", "--seed", "1")[0] == 0
    assert cli("short.h5", "--revolutions", "0.002")[0] == 0  # 3 frames
    assert cli("fine.h5", "--frame-every-rev", "0.0005")[0] == 0  # frames every 175 steps
    for name in ("b", "short", "fine"):
        shutil.copyfile(tmp_path / "a.h5.ckpt.npz", tmp_path / f"{name}.h5.ckpt.npz")  # a.h5 after 4 frames
    before = files(tmp_path)
    refused(cli("b.h5", "--resume"), "different parameters", "seed")  # a seed-1 file, a seed-0 checkpoint
    refused(cli("b.h5", "--resume", "--seed", "1"), "other parameters", "seed")
    refused(cli("a.h5", "--resume", "--frame-every-rev", "0.0005", "--revolutions", "0.004"), "frame every 349 steps")
    refused(cli("short.h5", "--resume"), "holds 3 frames", "comes after 4")
    refused(cli("fine.h5", "--resume"), "not every 349 steps")
    refused(cli("a.h5", "--resume", "--revolutions", "0.001"), "past the end")
    assert files(tmp_path) == before
    # a deleted run file, a damaged checkpoint: one line each
    (tmp_path / "b.h5").unlink()
    refused(cli("b.h5", "--resume"), "run file missing")
    damaged = tmp_path / "short.h5.ckpt.npz"
    damaged.write_bytes(damaged.read_bytes()[: damaged.stat().st_size // 2])
    refused(cli("short.h5", "--resume"), "damaged checkpoint")
    (tmp_path / "fine.h5.ckpt.npz").write_bytes(b"not a checkpoint")
    refused(cli("fine.h5", "--resume"), "damaged checkpoint")
    # and the matching pair resumes: a.h5 extended to 0.006 revolution equals a run made at once
    assert cli("a.h5", "--resume", "--revolutions", "0.006")[0] == 0
    assert cli("once.h5", "--revolutions", "0.006")[0] == 0
    with ga.open_run(tmp_path / "a.h5") as a, ga.open_run(tmp_path / "once.h5") as b:
        assert len(a) == len(b) == 7
        for fa, fb in zip(a, b):
            for name in ("time", "step", "position", "velocity", "angular_velocity", "film_volume", "contact_i",
                         "contact_j", "f_cap", "f_normal", "gap", "bridge_volume"):
                assert np.array_equal(getattr(fa, name), getattr(fb, name)), name


def test_an_out_in_a_missing_folder_is_refused_before_the_settling(cli, tmp_path, monkeypatch):
    def no_settling(*args, **kwargs):
        raise AssertionError("settled before checking --out")

    monkeypatch.setattr(sim.run.Simulation, "_fill", no_settling)
    refused(cli("missing/r.h5"), "missing", "does not exist")
    assert files(tmp_path) == {}


def test_the_settling_shows_a_progress_bar_and_the_end_says_what_was_written(cli, tmp_path, capsys):
    code = main(["run", "--out", str(tmp_path / "r.h5"), *[a for a in BASE if a != "--quiet"]])
    captured = capsys.readouterr()
    assert code == 0
    assert "settling" in captured.err and "frame" in captured.err
    assert f"{tmp_path / 'r.h5'}: 5 frames" in captured.out and "0.004 revolutions" in captured.out
    # resuming the finished run writes nothing and does not claim it did
    assert main(["run", "--out", str(tmp_path / "r.h5"), *BASE, "--resume"]) == 0
    captured = capsys.readouterr()
    assert "finished already" in captured.err and "wrote" not in captured.out
    # and says what the file holds: 5 frames, 0.004 revolutions (it said "4 frames" of the checkpoint's state)
    assert f"{tmp_path / 'r.h5'}: 5 frames" in captured.out and "0.004 revolutions" in captured.out


def test_an_interrupted_run_says_how_to_go_on(cli, tmp_path, monkeypatch):
    calls = {"n": 0}
    advance = sim.run.Simulation.advance

    def interrupt_after_three_frames(self, n_steps):
        calls["n"] += 1
        if calls["n"] > 3:
            raise KeyboardInterrupt
        advance(self, n_steps)

    monkeypatch.setattr(sim.run.Simulation, "advance", interrupt_after_three_frames)
    code, err = cli("r.h5")
    assert code == 130 and len(err) == 1
    assert "interrupted" in err[0] and "--resume continues" in err[0] and "r.h5.ckpt.npz" in err[0]
    monkeypatch.setattr(sim.run.Simulation, "advance", advance)
    assert cli("r.h5", "--resume")[0] == 0
    with ga.open_run(tmp_path / "r.h5") as run:
        assert len(run) == 5


def test_an_interruption_while_settling_does_not_describe_an_earlier_run(cli, tmp_path, monkeypatch):
    assert cli("r.h5")[0] == 0  # an earlier run and its checkpoint
    before = files(tmp_path)

    def interrupted(self, progress=False):
        raise KeyboardInterrupt

    monkeypatch.setattr(sim.run.Simulation, "_fill", interrupted)
    code, err = cli("r.h5", "--overwrite")
    assert code == 130 and err == ["sim: interrupted while settling; nothing was written"]
    assert files(tmp_path) == before


@pytest.mark.parametrize("flag, viscous", [([], True), (["--no-viscous"], False)])
def test_no_viscous_switches_off_the_bridges_lubrication_force(flag, viscous):
    from sim.cli import _params, build_parser

    args = build_parser().parse_args(["run", "--preset", "lab-cg2", "--revolutions", "1", "--out", "x.h5", *flag])
    original, scaled = _params(args)
    assert original.viscous is viscous and scaled.viscous is viscous


def test_contact_law_and_its_parameters_are_set_in_the_original_system_and_scaled_by_the_laws_rule():
    from sim.cli import _params, build_parser

    def params(*flags):
        args = build_parser().parse_args(["run", "--preset", "lab-cg2", "--revolutions", "1", "--out", "x.h5", *flags])
        return _params(args)

    original, scaled = params("--law-parameter", "k_n=200", "--law-parameter", "friction=0.3")
    assert (original.contact_law, original.k_n, original.friction) == ("linear_coulomb", 200.0, 0.3)
    assert (scaled.k_n, scaled.friction) == (400.0, 0.3)  # the linear law: k_n ×α
    original, scaled = params("--contact-law", "hertz_mindlin", "--law-parameter", "youngs_modulus=1e7")
    assert scaled.contact_law == original.contact_law == "hertz_mindlin"
    assert scaled.youngs_modulus == original.youngs_modulus == 1e7  # Hertz: E unchanged under CG


def test_a_run_file_another_process_has_open_is_neither_truncated_nor_replaced(cli, tmp_path):
    """Hostile round four, B1: --overwrite of a run file that another process reads truncated it
    to 0 bytes before HDF5 refused to lock it. Now it is refused before the settling, whole."""
    import subprocess
    import sys

    target = tmp_path / "held.h5"
    assert cli("held.h5")[0] == 0
    before = target.read_bytes()
    reader = subprocess.Popen([sys.executable, "-c", "import h5py, sys, time; f = h5py.File(sys.argv[1], 'r'); "
                               "print('open', flush=True); time.sleep(60)", str(target)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert reader.stdout.readline().strip() == "open"
        refused(cli("held.h5", "--overwrite"), "another process has the file open")
        assert target.read_bytes() == before
    finally:
        reader.kill()
        reader.wait()
    assert not [p.name for p in tmp_path.iterdir() if ".new-" in p.name]


@pytest.mark.parametrize("args, words", [
    (["--revolutions", "1e12", "--frame-every-rev", "0.05"], ["frames of", "of disk", "refused before starting"]),
    (["--particles", "100000000"], ["a simulation of", "of memory", "refused before starting"]),
])
def test_a_run_that_cannot_fit_is_refused_before_the_settling(cli, tmp_path, monkeypatch, args, words):
    import sim.run

    monkeypatch.setattr(sim.run.Simulation, "_fill", lambda *a, **k: pytest.fail("settled before refusing"))
    refused(cli("big.h5", *args), *words)


def test_an_out_name_too_long_for_the_file_system_is_refused_before_the_settling(cli, monkeypatch):
    import sim.run

    monkeypatch.setattr(sim.run.Simulation, "_fill", lambda *a, **k: pytest.fail("settled before refusing"))
    refused(cli("a" * 250 + ".h5"), "file name is too long")


@pytest.mark.parametrize("args, words", [
    (["--law-parameter", "c_t=0.3"], ["parameter c_t = 0.3", "explicit dashpot is unstable"]),
    (["--law-parameter", "c_t=10"], ["parameter c_t = 10", "explicit dashpot is unstable"]),
    (["--law-parameter", "k_t=1e5"], ["parameter k_t", "fewer than 20"]),
    (["--gamma", "1e6"], ["parameter surface_tension = 1e+06", "10 % overlap"]),
    (["--bridge-volume", "1000"], ["parameter bridge_volume = 1e+03", "Willett"]),
])
def test_physics_that_cannot_run_is_refused_naming_the_parameter(cli, monkeypatch, args, words):
    """Hostile round four, B6: these ran until "particle 53 left the drum" or "increase the skin",
    or silently (a bridge volume of 1000 m³)."""
    import sim.run

    monkeypatch.setattr(sim.run.Simulation, "_fill", lambda *a, **k: pytest.fail("settled before refusing"))
    refused(cli("x.h5", *args), *words)


def test_the_stability_checks_pass_every_preset_under_both_rules_and_fail_just_beyond_their_limit():
    import math

    from sim.params import PRESETS, SimParams, cg_scale, preset_original

    for name in PRESETS:
        for rule in ("weber", "bond"):
            original, alpha = preset_original(name)
            original = dataclasses.replace(original, cg_rule=rule)
            if alpha > 1:
                cg_scale(original, alpha)
    p = SimParams()
    r_min = p.r_mean * (1 - p.d_spread)
    m_t = 2 / 7 * p.density * 4 / 3 * math.pi * r_min**3 / 2
    dataclasses.replace(p, c_t=0.99 * m_t / p.dt)
    with pytest.raises(ValueError, match="parameter c_t"):
        dataclasses.replace(p, c_t=1.01 * m_t / p.dt)
    dataclasses.replace(p, bridge_volume=0.099 * r_min**3)
    with pytest.raises(ValueError, match="parameter bridge_volume"):
        dataclasses.replace(p, bridge_volume=0.101 * r_min**3)


def test_the_first_run_says_it_compiles_and_the_bar_does_not_count_the_compilation(monkeypatch, capsys):
    """Round four, C9: a first run compiled for ~70 s under a bar whose ETA read 660:06:18. Now the
    first step (the compilation) runs before the bar, and a cold cache is said in one line."""
    import sim.run

    calls = []
    original_advance = sim.run.Simulation._advance

    def advance(self, n, settling=False, on_steps=None):
        calls.append((n, on_steps is None))
        return original_advance(self, n, settling, on_steps)

    monkeypatch.setattr(sim.run.Simulation, "_advance", advance)
    monkeypatch.setattr(sim.run, "_kernels_cached", lambda: False)
    sim.run.Simulation(sim.cli.cg_scale(TINY, 3.0), TINY, progress=True, threads=1)
    assert calls[0] == (1, True) and calls[1][1] is False  # one step outside the bar, then the bar's steps
    assert "compiling the simulator's kernels (the first run of this installation" in capsys.readouterr().err


def _rewrite_checkpoint(path, change):
    """Apply ``change(arrays)`` to the arrays of the checkpoint ``path`` (kept in its format)."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    change(arrays)
    with open(path, "wb") as f:
        np.savez(f, **arrays)


@pytest.mark.parametrize("change, words", [
    (lambda a: a["pair_j"].__setitem__(-1, 10**6), ["state field pair_j", "is outside [0,"]),
    (lambda a: a["part_slots"].__setitem__(0, 10**7), ["state field part_slots[0]", "is outside"]),
    (lambda a: a["pos"].__setitem__((3, 1), np.nan), ["state field pos[3, 1] is nan", "not a finite number"]),
])
def test_a_checkpoint_that_points_past_its_arrays_or_holds_nan_is_refused_naming_the_file(cli, tmp_path, change,
                                                                                           words):
    """Hostile round four, B5: a checkpoint whose contacts pointed past the particles crashed the
    simulator (SIGSEGV) and NaN in one was reported without naming the file."""
    assert cli("a.h5")[0] == 0
    _rewrite_checkpoint(tmp_path / "a.h5.ckpt.npz", change)
    before = files(tmp_path)
    message = refused(cli("a.h5", "--resume", "--revolutions", "0.006"), *words)
    assert "a.h5.ckpt.npz" in message
    assert files(tmp_path) == before


def test_a_simulation_that_becomes_unstable_stops_naming_the_particle(cli, tmp_path, monkeypatch, capsys):
    import sim.run

    original = sim.run.Simulation._advance

    def advance(self, n, settling=False, on_steps=None):
        original(self, n, settling, on_steps)
        if not settling and self.state.step > 700:
            self.state.vel[5, 0] = np.inf  # what an unstable integration ends in

    monkeypatch.setattr(sim.run.Simulation, "_advance", advance)
    code, err = cli("unstable.h5")
    assert code == 1 and len(err) == 1 and "became unstable at step" in err[0] and "not finite" in err[0], err


def test_a_ctrl_c_while_the_simulator_loads_is_one_line_and_exit_130(monkeypatch, capsys):
    """``python -m sim`` loads numba for a fraction of a second; a Ctrl-C then printed a traceback
    and the process died by SIGINT, or was swallowed inside a library's import and the command ran
    on. Here the Ctrl-C comes inside an import that swallows it, as such a library does."""
    import signal

    import sim.__main__ as entry

    swallow_an_interrupt_in_import(monkeypatch, "sim.cli")
    assert entry.main(["--help"]) == 130
    assert capsys.readouterr().err.strip() == "sim: interrupted before any work; nothing was written"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.parametrize("args, words", [
    (["--cylinder-facets", str(10**20)], ["--cylinder-facets", "[3, 10000]"]),
    (["--particles", str(10**12)], ["--particles", "at most"]),
    (["--drum-particles", str(10**12)], ["--drum-particles"]),
    (["--checkpoint-every", str(10**12)], ["--checkpoint-every"]),
    (["--seed", str(2**64)], ["--seed", "2⁶³"]),
])
def test_every_integer_switch_has_an_upper_bound(cli, tmp_path, args, words):
    refused(cli("r.h5", *args), *words)
    assert files(tmp_path) == {}


def test_a_checkpoint_of_an_unknown_format_or_a_text_physics_version_is_refused(cli, tmp_path):
    import json
    import zipfile

    assert cli("a.h5")[0] == 0
    ckpt = tmp_path / "a.h5.ckpt.npz"
    with np.load(ckpt) as data:
        arrays = {name: data[name] for name in data.files}
    info = json.loads(str(arrays["checkpoint_info"]))
    for change, words in (({"format": 99}, ["checkpoint format 99"]),
                          ({"physics_version": "4"}, ["physics version as str '4'", "not a whole number"])):
        np.savez(ckpt, **{**arrays, "checkpoint_info": np.array(json.dumps({**info, **change}))})
        refused(cli("a.h5", "--resume"), *words)
    assert zipfile.is_zipfile(ckpt)


def test_the_settled_bed_is_checkpointed_before_the_first_frame_is_simulated(cli, tmp_path, monkeypatch):
    """Settling 10⁵ particles takes hours: a run stopped before its first frame resumes from the
    settled bed instead of settling again."""
    from sim.run import Simulation

    advance = Simulation.advance

    def stopped(self, n_steps):
        raise KeyboardInterrupt

    monkeypatch.setattr(Simulation, "advance", stopped)
    code, _ = cli("r.h5", "--checkpoint-every", "5")
    assert code == 130 and (tmp_path / "r.h5.ckpt.npz").exists()
    monkeypatch.setattr(Simulation, "advance", advance)
    monkeypatch.setattr(Simulation, "_fill", lambda *a, **k: pytest.fail("settled again"))
    assert cli("r.h5", "--checkpoint-every", "5", "--resume")[0] == 0
    with ga.open_run(tmp_path / "r.h5") as run:
        assert len(run) == 5 and run.unfinished is None
