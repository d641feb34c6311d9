"""The paper's CG1 goes on across machines (benchmarks/paper_drum_runs.py): ``keep`` keeps a compacted
checkpoint, every covered frame's statistics and chosen float32 frames in the repository; on a machine
that lost the run, ``cg1`` starts a part from the kept checkpoint, and the statistics kept over both
machines are those of the uninterrupted run."""

import dataclasses
import importlib.util
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.analysis.confinement import confinement_timeseries
from sim.checkpoint import resume_run
from sim.params import cg_scale
from sim.run import Simulation

from conftest import former_lab_original

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
ORIGINAL = former_lab_original(5400)
PARAMS = dataclasses.replace(cg_scale(ORIGINAL, 3.0), settle_time=0.01, spray_interval=0.01, initial_film=0.004)
FRAME_EVERY = 400


@pytest.fixture
def driver(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("paper_drum_runs", os.path.join(BENCH, "paper_drum_runs.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    kept = tmp_path / "kept"
    monkeypatch.setattr(module, "CG1_KEPT", str(kept))
    monkeypatch.setattr(module, "CG1_KEPT_CHECKPOINT", str(kept / "paper-cg1.ckpt.npz"))
    monkeypatch.setattr(module, "CG1_KEPT_FRAMES", (0, 5, 11))
    # nothing of the real runs: their folders, the repository's kept files, the processes
    for name, folder in (("HOME_RUNS", "home"), ("SERIES_DIR", "home/paper-family"), ("CG1_DIR", "home/paper-cg1"),
                         ("SUBSETS", "subsets"), ("SERIES_KEPT", "subsets/unfinished")):
        monkeypatch.setattr(module, name, str(tmp_path / folder))
    os.makedirs(tmp_path / "subsets")
    monkeypatch.setattr(module, "_queue", lambda: [("dd44-seed1.h5", [], 3)])
    monkeypatch.setattr(module, "_series_done", lambda: False)
    monkeypatch.setattr(module, "_simulations", lambda folder: {})
    monkeypatch.setattr(module, "_processes", lambda *words: [])
    real = [os.path.join(BENCH, "paper_cg1_run"), os.path.join(BENCH, "paper_family_runs")]
    before = _listing(real)
    yield module
    assert _listing(real) == before, "a test wrote into the repository's kept runs"


def _listing(folders) -> dict:
    """{path: modification time} of everything under ``folders``."""
    return {os.path.join(root, name): os.path.getmtime(os.path.join(root, name))
            for folder in folders for root, _, names in os.walk(folder) for name in names}


def stopped_after(out, frames, monkeypatch, resume=False):
    """A run of 10 frames after the first stopped (killed) right after its checkpoint at ``frames``
    (``resume``: the run in ``out`` resumed from its checkpoint, then stopped)."""
    import sim.run as sim_run

    real_write = sim_run.write_checkpoint

    class Stop(Exception):
        pass

    def write_then_stop(sim, path, extra):
        real_write(sim, path, extra)
        if extra["frames"] == frames:
            raise Stop

    monkeypatch.setattr(sim_run, "write_checkpoint", write_then_stop)
    with pytest.raises(Stop):
        (resume_run(out) if resume else Simulation(PARAMS, ORIGINAL)).run(
            out, revolutions(10), frame_every=FRAME_EVERY, checkpoint_every=3, progress=False, resume=resume)
    monkeypatch.setattr(sim_run, "write_checkpoint", real_write)


def revolutions(frames):
    return frames * FRAME_EVERY * PARAMS.dt / PARAMS.revolution_period


def test_cg1_goes_on_from_what_the_repository_kept_when_a_machine_lost_the_run(driver, tmp_path, monkeypatch, capsys):
    full = Simulation(PARAMS, ORIGINAL).run(tmp_path / "full.h5", revolutions(10), frame_every=FRAME_EVERY,
                                            checkpoint_every=None, progress=False)
    machine_a = tmp_path / "a"
    machine_a.mkdir()
    # machine A: the run from its start, stopped after frame 7 (its last checkpoint after 6 frames)
    Simulation(PARAMS, ORIGINAL).run(machine_a / "paper-cg1.h5", revolutions(7), frame_every=FRAME_EVERY,
                                     checkpoint_every=3, progress=False)
    args = type("Args", (), {"dir": str(machine_a), "series_dir": str(tmp_path / "no-series"), "dt_factor": 1.5})
    driver.keep(args)
    kept = tmp_path / "kept"
    table = pd.read_csv(kept / "frames.csv")
    assert table["frame"].tolist() == list(range(6))  # the frames the kept checkpoint covers, not frame 6
    assert {"frame-000.h5", "frame-005.h5", "meta.json", "sizes.csv", "paper-cg1.ckpt.npz"} <= set(os.listdir(kept))
    assert not (kept / "frame-011.h5").exists()
    driver.keep(args)  # kept again: nothing added twice
    assert pd.read_csv(kept / "frames.csv")["frame"].tolist() == list(range(6))

    # machine B has nothing: cg1 starts a part from the kept checkpoint
    machine_b = tmp_path / "b"
    commands = []
    monkeypatch.setattr(driver.subprocess, "run", lambda cmd, check: commands.append(cmd))
    driver.cg1(type("Args", (), {"dir": str(machine_b), "dt_factor": 1.5}))
    cmd = commands[-1]
    assert cmd[cmd.index("--out") + 1] == str(machine_b / "paper-cg1-from006.h5")
    assert cmd[cmd.index("--resume-from") + 1] == str(kept / "paper-cg1.ckpt.npz") and "--resume" not in cmd
    # made here with the tiny system's options: the part from frame 6 to the end
    part = machine_b / "paper-cg1-from006.h5"
    resume_run(part, from_checkpoint=kept / "paper-cg1.ckpt.npz").run(
        part, revolutions(10), frame_every=FRAME_EVERY, checkpoint_every=1, progress=False, new_part=True)
    driver.cg1(type("Args", (), {"dir": str(machine_b), "dt_factor": 1.5}))  # its own checkpoint now
    assert "--resume" in commands[-1] and commands[-1][commands[-1].index("--out") + 1] == str(part)
    driver.keep(type("Args", (), {"dir": str(machine_b), "series_dir": str(tmp_path / "no-series")}))
    table = pd.read_csv(kept / "frames.csv")
    sizes = pd.read_csv(kept / "sizes.csv")
    assert table["frame"].tolist() == list(range(11))
    assert (kept / "frame-005.h5").exists() and (kept / "frame-011.h5").exists() is False
    # the kept statistics are the uninterrupted run's, frame by frame
    with ga.open_run(full) as run:
        expected, expected_sizes = confinement_timeseries(run, run.meta, return_sizes=True)
        frame5 = run[5].position
    assert np.allclose(table.drop(columns=["frame"]).select_dtypes("number").to_numpy(),
                       expected.drop(columns=["frame"]).select_dtypes("number").to_numpy(), equal_nan=True)
    for k, granules in enumerate(expected_sizes):
        mine = sizes[sizes["frame"] == k]
        assert np.array_equal(np.repeat(mine["size"], mine["count"]), np.sort(granules))
    with ga.open_run(kept / "frame-005.h5") as run:
        assert len(run) == 1 and np.allclose(run[0].position, frame5, rtol=1e-6)
    # the progress line reads machine B's part, or the kept checkpoint once B has lost it too
    capsys.readouterr()
    driver.progress(type("Args", (), {"dir": str(machine_b)}))
    assert "11 frames" in capsys.readouterr().out.split("|")[2]
    shutil.rmtree(machine_b)
    driver.progress(type("Args", (), {"dir": str(machine_b)}))
    line = capsys.readouterr().out
    assert "11 frames" in line and "the kept one: this machine has none newer" in line
    # the machine column names the cores and, where Linux tells it, the CPU model (paces differ by host)
    machine = line.split("|")[4]
    assert f"{os.cpu_count()} cores" in machine
    model = [row.split(":", 1)[1].strip() for row in Path("/proc/cpuinfo").read_text().splitlines()
             if row.startswith("model name")][:1] if Path("/proc/cpuinfo").exists() else []
    assert all(name in machine for name in model)


def test_a_series_run_made_on_two_machines_gets_the_subset_of_the_uninterrupted_run(driver, tmp_path, monkeypatch):
    per_frame = revolutions(1)
    monkeypatch.setattr(driver, "REVOLUTIONS", 10 * per_frame)
    monkeypatch.setattr(driver, "FRAME_EVERY_REV", per_frame)
    monkeypatch.setattr(driver, "WINDOW", (5 * per_frame, 10 * per_frame))
    monkeypatch.setattr(driver, "_thinning", lambda name: (3, 2))  # frames 0, 3, 6, 9 and 6, 8, 10 in the window
    monkeypatch.setattr(driver, "_queue", lambda: [("paper-cg3-weber-seed1.h5", [], 3)])
    full = Simulation(PARAMS, ORIGINAL).run(tmp_path / "full.h5", revolutions(10), frame_every=FRAME_EVERY,
                                            checkpoint_every=None, progress=False)
    machine_a, machine_b = tmp_path / "a", tmp_path / "b"
    machine_a.mkdir()
    stopped_after(machine_a / "paper-cg3-weber-seed1.h5", 6, monkeypatch)
    driver.keep(type("Args", (), {"dir": str(tmp_path / "no-cg1"), "series_dir": str(machine_a)}))
    kept = sorted(os.listdir(tmp_path / "subsets" / "unfinished"))
    assert kept == ["paper-cg3-weber-seed1.ckpt.npz", "paper-cg3-weber-seed1.f000-003.h5"]  # frames 0 and 3: those below 6
    commands = []
    monkeypatch.setattr(driver.subprocess, "run", lambda cmd, check: commands.append(cmd))
    monkeypatch.setattr(driver, "_hand_the_core_to_cg1", lambda args: None)
    driver.series(type("Args", (), {"dir": str(machine_b), "dt_factor": 1.5}))
    cmd = commands[-1]
    part = machine_b / "paper-cg3-weber-seed1-from006.h5"
    assert cmd[cmd.index("--out") + 1] == str(part) and "--resume-from" in cmd
    resume_run(part, from_checkpoint=tmp_path / "subsets" / "unfinished" / "paper-cg3-weber-seed1.ckpt.npz").run(
        part, revolutions(10), frame_every=FRAME_EVERY, checkpoint_every=3, progress=False, new_part=True)
    driver.series(type("Args", (), {"dir": str(machine_b), "dt_factor": 1.5}))  # finished: joined
    assert os.listdir(tmp_path / "subsets" / "unfinished") == []
    with ga.open_run(tmp_path / "subsets" / "paper-cg3-weber-seed1.h5") as joined, ga.open_run(full) as run:
        assert joined.unfinished is None and "first_frame" not in joined.meta.provenance
        # the settling, which only the run's first machine recorded (a part begun from a checkpoint does not)
        assert {"settle_wall_time_s", "settle_cpu_time_s"} <= set(joined.meta.provenance)
        assert joined.meta.provenance["subset_of"]["frames_kept"] == [0, 3, 6, 8, 9, 10]
        assert [int(s) for s in joined.steps] == [k * FRAME_EVERY for k in (0, 3, 6, 8, 9, 10)]
        for frame, k in zip(joined, (0, 3, 6, 8, 9, 10)):
            assert np.allclose(frame.position, run[k].position, rtol=1e-6, atol=0)
    with ga.open_run(part) as made_on_b:
        assert "settle_wall_time_s" not in made_on_b.meta.provenance
    subset = tmp_path / "subsets" / "paper-cg3-weber-seed1.h5"
    assert driver._finished_run(str(machine_b / "paper-cg3-weber-seed1.h5")) == str(subset)
    # a finished paper-drum CG run: its last checkpoint is kept for the load-free speed-ups
    driver.keep(type("Args", (), {"dir": str(tmp_path / "no-cg1"), "series_dir": str(machine_b)}))
    final = tmp_path / "subsets" / "checkpoints" / "paper-cg3-weber-seed1.ckpt.npz"
    assert resume_run(final, from_checkpoint=final).resume_point.frames == 9
    assert os.listdir(tmp_path / "subsets" / "unfinished") == []


def test_a_stop_between_keeping_the_frames_and_the_checkpoint_loses_nothing(driver, tmp_path, monkeypatch):
    """keep keeps the frames' statistics before the checkpoint: a stop between the two leaves
    statistics of frames a later part makes again, which are skipped, not counted twice."""
    full = Simulation(PARAMS, ORIGINAL).run(tmp_path / "full.h5", revolutions(10), frame_every=FRAME_EVERY,
                                            checkpoint_every=None, progress=False)
    machine_a, machine_b = tmp_path / "a", tmp_path / "b"
    machine_a.mkdir()
    args_a = type("Args", (), {"dir": str(machine_a), "series_dir": str(tmp_path / "no-series")})
    stopped_after(machine_a / "paper-cg1.h5", 3, monkeypatch)
    driver.keep(args_a)  # frames 0-2 and the checkpoint at 3
    stopped_after(machine_a / "paper-cg1.h5", 6, monkeypatch, resume=True)

    def stop(*args):
        raise KeyboardInterrupt

    with monkeypatch.context() as patch, pytest.raises(KeyboardInterrupt):
        patch.setattr("sim.checkpoint.compact_checkpoint", stop)
        driver.keep(args_a)  # frames 3-5 kept, the checkpoint at 6 not
    kept = tmp_path / "kept"
    assert pd.read_csv(kept / "frames.csv")["frame"].tolist() == list(range(6))
    assert resume_run(kept / "paper-cg1.ckpt.npz", from_checkpoint=kept / "paper-cg1.ckpt.npz").resume_point.frames == 3
    part = machine_b / "paper-cg1-from003.h5"
    machine_b.mkdir()
    resume_run(part, from_checkpoint=kept / "paper-cg1.ckpt.npz").run(
        part, revolutions(10), frame_every=FRAME_EVERY, checkpoint_every=1, progress=False, new_part=True)
    driver.keep(type("Args", (), {"dir": str(machine_b), "series_dir": str(tmp_path / "no-series")}))
    table = pd.read_csv(kept / "frames.csv")
    assert table["frame"].tolist() == list(range(11))
    with ga.open_run(full) as run:
        expected = confinement_timeseries(run, run.meta)
    assert np.allclose(table["yield_fraction"], expected["yield_fraction"])


def test_a_series_run_finished_in_one_piece_has_its_subset_written_before_what_was_kept_is_removed(
        driver, tmp_path, monkeypatch):
    per_frame = revolutions(1)
    monkeypatch.setattr(driver, "REVOLUTIONS", 10 * per_frame)
    monkeypatch.setattr(driver, "FRAME_EVERY_REV", per_frame)
    monkeypatch.setattr(driver, "WINDOW", (5 * per_frame, 10 * per_frame))
    monkeypatch.setattr(driver, "_thinning", lambda name: (3, 2))  # frames 0, 3, 6, 9 and 6, 8, 10 in the window
    machine = tmp_path / "a"
    machine.mkdir()
    stopped_after(machine / "dd44-seed1.h5", 6, monkeypatch)
    driver.keep(type("Args", (), {"dir": str(tmp_path / "no-cg1"), "series_dir": str(machine)}))
    kept = tmp_path / "subsets" / "unfinished"
    assert sorted(os.listdir(kept)) == ["dd44-seed1.ckpt.npz", "dd44-seed1.f000-003.h5"]
    driver._join_parts(str(machine), "dd44-seed1")  # unfinished: nothing changes
    assert len(os.listdir(kept)) == 2 and not (tmp_path / "subsets" / "dd44-seed1.h5").exists()
    resume_run(machine / "dd44-seed1.h5").run(machine / "dd44-seed1.h5", revolutions(10), frame_every=FRAME_EVERY,
                                              checkpoint_every=3, progress=False, resume=True)
    driver._join_parts(str(machine), "dd44-seed1")  # finished here in one piece: its subset, then forget
    assert os.listdir(kept) == []
    with ga.open_run(tmp_path / "subsets" / "dd44-seed1.h5") as subset, ga.open_run(machine / "dd44-seed1.h5") as run:
        assert subset.meta.provenance["subset_of"]["frames_kept"] == [0, 3, 6, 8, 9, 10]
        assert np.allclose(subset[2].position, run[6].position, rtol=1e-6, atol=0)


def test_keep_reads_and_compacts_one_snapshot_while_the_simulator_writes_a_newer_checkpoint(driver, tmp_path,
                                                                                            monkeypatch):
    """A checkpoint written while ``keep`` computes the frames' statistics does not become the kept
    one: the kept checkpoint never lies past the frames kept."""
    from sim.checkpoint import checkpoint_path

    machine = tmp_path / "a"
    machine.mkdir()
    out = machine / "paper-cg1.h5"
    stopped_after(out, 3, monkeypatch)
    real = driver._keep_statistics

    def statistics_while_the_run_goes_on(folder, covered):
        real(folder, covered)
        stopped_after(out, 6, monkeypatch, resume=True)  # the simulator's next checkpoint, meanwhile

    monkeypatch.setattr(driver, "_keep_statistics", statistics_while_the_run_goes_on)
    driver.keep(type("Args", (), {"dir": str(machine), "series_dir": str(tmp_path / "no-series")}))
    kept = tmp_path / "kept"
    assert pd.read_csv(kept / "frames.csv")["frame"].tolist() == [0, 1, 2]
    assert resume_run(kept / "paper-cg1.ckpt.npz", from_checkpoint=kept / "paper-cg1.ckpt.npz").resume_point.frames == 3
    assert driver._checkpoint_point(checkpoint_path(out))[0] == 6 and not os.path.exists(f"{checkpoint_path(out)}.keeping")


def test_the_core_is_not_handed_to_a_cg1_that_is_settling(driver, tmp_path, monkeypatch):
    out = tmp_path / "home" / "paper-cg1" / "paper-cg1.h5"
    monkeypatch.setattr(driver, "_simulations", lambda folder: {1: ["sim", "run", "--threads", "1", "--out", str(out)]})
    stopped = []
    monkeypatch.setattr(driver, "_stop", stopped.append)
    monkeypatch.setattr("time.sleep", lambda s: pytest.fail("waited for a checkpoint that settling will not write soon"))
    driver._hand_the_core_to_cg1(type("Args", (), {"dt_factor": 1.5}))
    assert stopped == []


def test_the_law_weighs_each_point_by_the_larger_of_its_replica_and_block_errors(driver):
    t = pd.DataFrame({"yield_fraction_err": [0.0003, 0.004], "yield_fraction_block_sem": [0.004, 0.002]})
    assert driver._law_errors(t, "yield_fraction").tolist() == [0.004, 0.004]


def test_the_cost_table_gives_cg1s_cpu_rate_over_each_runs(driver, tmp_path, monkeypatch, capsys):
    from sim.checkpoint import checkpoint_path

    cg1 = tmp_path / "home" / "paper-cg1" / "paper-cg1.h5"
    cg1.parent.mkdir(parents=True, exist_ok=True)
    Simulation(PARAMS, ORIGINAL).run(cg1, revolutions(3), frame_every=FRAME_EVERY, checkpoint_every=3, progress=False)
    other = tmp_path / "cg3.h5"
    Simulation(PARAMS, ORIGINAL).run(other, revolutions(2), frame_every=FRAME_EVERY, checkpoint_every=None, progress=False)
    capsys.readouterr()
    driver._cost_table({"paper-cg3 weber": [str(other)]})
    rows = {line.split("|")[1].strip(): line.split("|")[2:-1] for line in capsys.readouterr().out.splitlines()
            if line.startswith("| paper-cg")}
    _, step, info = driver._checkpoint_point(checkpoint_path(cg1))
    cg1_rate = info["cpu_s"] / (step * info["params"]["dt"])
    with ga.open_run(other) as run:
        rate = run.meta.provenance["cpu_time_per_simulated_s"]
    assert rows["paper-cg1 (so far)"][2].strip() == f"{cg1_rate:.0f}" and rows["paper-cg3 weber"][2].strip() == f"{rate:.0f}"
    assert rows["paper-cg3 weber"][4].strip() == f"{cg1_rate / rate:.1f}×"


def test_the_law_is_fitted_over_every_drum_and_without_the_most_confined_and_drawn(driver, tmp_path):
    """The CG1 prediction rests on two fits of the law (every D/d; from D/d 33 on): `table` prints
    both and the range of their values with the widest band, and draws them with the CG runs."""
    ratios = np.array([22.0, 33.0, 44.0, 66.0])
    law = {"yield_fraction": (0.7, 8.0), "mean_volume_norm": (8.0, 12.0), "n_granules_norm": (0.086, -10.0)}
    columns = {"drum_ratio": ratios, "label": [f"D/d {r:g}" for r in ratios], "n_replicas": [3, 3, 3, 1]}
    for metric, (y_inf, b) in law.items():
        values = y_inf * (1 - b / ratios)
        values[0] *= 1.1  # the most confined drum off the curve
        columns.update({metric: values, f"{metric}_err": 0.01 * values, f"{metric}_block_sem": 0.005 * values})
    t = pd.DataFrame(columns)
    laws = driver._fit_laws(t)
    assert list(laws) == ["all", "from 33"]
    for metric, (y_inf, b) in law.items():
        exact = laws["from 33"][metric]
        assert exact.y_inf == pytest.approx(y_inf) and exact.b == pytest.approx(b) and exact.chi2 < 1e-12
        assert laws["all"][metric].chi2 > 1  # D/d 22 pulls the fit over every drum off the law
        low, high, band = driver._prediction(laws, metric)
        values = [float(fits[metric](133.3)) for fits in laws.values()]
        assert (low, high) == (min(values), max(values))
        assert band == max(float(fits[metric].error(133.3)) for fits in laws.values()) and band > 0
    assert list(driver._fit_laws(t.iloc[1:])) == ["all"]  # three D/d from 33 on: one fit; fewer: none
    assert driver._fit_laws(t.iloc[2:]) == {}
    cg = t.iloc[[2]].assign(label="paper-cg3 bond", drum_ratio=44.4, alpha=3.0)  # a confinement_table row
    steady = pd.DataFrame({"mean": [0.66, 7.0, 0.093], "sem": [0.01, 0.2, 0.002]}, index=list(law))
    path = tmp_path / "law.png"
    logs = driver._fit_logs(t)
    for metric in law:  # the weighted regression on ln(D/d) by hand, with the errors the law weighs by
        weight = 1 / driver._law_errors(t, metric).to_numpy() ** 2
        design = np.column_stack([np.ones(4), np.log(ratios)])
        a, c = np.linalg.solve(design.T @ (design * weight[:, None]), design.T @ (weight * t[metric].to_numpy()))
        assert (logs[metric].a, logs[metric].c) == (pytest.approx(a, rel=1e-9), pytest.approx(c, rel=1e-9))
        assert logs[metric].dof == 2 and logs[metric].chi2 > 0  # the law's points: not a line in ln(D/d)
    driver._law_figure(t, laws, logs, cg, (133.3, steady), str(path))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_table_checks_the_paper_drum_rule_against_the_law_it_prints(driver, capsys, monkeypatch):
    import granalytics as ga

    fit = ga.ConfinementFit(y_inf=0.7, b=7.0, covariance=np.diag([0.0, 1.1**2]), chi2=0.0, dof=2)
    monkeypatch.setitem(ga.CONFINEMENT_RULE, "paper drum", {"within_5pc": (140.0, 22.0), "within_10pc": (70.0, 11.0)})
    driver._check_rule(fit)
    out = capsys.readouterr().out
    assert "within 10 % above D/d 70 ± 11 (CONFINEMENT_RULE['paper drum'] 70 ± 11: agrees)" in out
    assert "within 5 % above D/d 140 ± 22 (CONFINEMENT_RULE['paper drum'] 140 ± 22: agrees)" in out
    monkeypatch.setitem(ga.CONFINEMENT_RULE, "paper drum", {"within_5pc": (139.0, 21.0), "within_10pc": (70.0, 11.0)})
    driver._check_rule(fit)
    assert "within 5 % above D/d 140 ± 22 (CONFINEMENT_RULE['paper drum'] 139 ± 21: DIFFERS)" in capsys.readouterr().out


def test_cg1s_verdict_waits_for_the_window_then_sets_it_beside_both_curves(driver, monkeypatch, capsys):
    """`table`'s CG1 verdict: nothing until the kept statistics reach the window's end, then CG1's
    steady state (block s.e.m.) beside the law and the curve without saturation at its D/d."""
    import types

    from granalytics.datasets import dataset_path

    with ga.open_run(dataset_path("paper-cg3")) as run:
        meta = run.meta  # any run's metadata: its drum gives the D/d the curves are read at
    revolutions = np.arange(0, 81) * 0.05
    rng = np.random.default_rng(3)
    series = {"revolutions": revolutions, "yield_fraction": 0.68 + 0.01 * rng.standard_normal(81),
              "mean_volume_norm": 7.5 + 0.1 * rng.standard_normal(81), "n_granules_norm": np.full(81, 0.09),
              "wall_share": np.full(81, 0.05), "coordination": np.full(81, 4.6), "bed_angle_deg": np.full(81, 45.0),
              "kinetic_energy_norm": np.full(81, 0.5)}
    ratios = np.array([22.0, 33.0, 44.0, 66.0])
    t = pd.DataFrame({"drum_ratio": ratios, **{m: y * (1 - b / ratios) for m, (y, b) in
                                               {"yield_fraction": (0.7, 7.0), "mean_volume_norm": (7.9, 12.0),
                                                "n_granules_norm": (0.086, -10.0)}.items()}})
    for metric in ("yield_fraction", "mean_volume_norm", "n_granules_norm"):
        t[f"{metric}_err"] = t[f"{metric}_block_sem"] = 0.01 * t[metric]
    fits, logs = driver._fit_laws(t)["all"], driver._fit_logs(t)
    partial = types.SimpleNamespace(timeseries=pd.DataFrame(series).iloc[:40], meta=meta)
    monkeypatch.setattr(driver, "_kept_statistics", lambda: partial)
    assert driver._cg1_against_law((2.0, 4.0), fits, logs) is None
    assert "paper-cg1 has 1.95 revolutions kept" in capsys.readouterr().out
    monkeypatch.setattr(driver, "_kept_statistics", lambda: types.SimpleNamespace(timeseries=pd.DataFrame(series),
                                                                                   meta=meta))
    drum_ratio, steady = driver._cg1_against_law((2.0, 4.0), fits, logs)
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| yield"))
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    mean = steady.loc["yield_fraction", "mean"]
    assert mean == pytest.approx(series["yield_fraction"][40:].mean())  # the window [2, 4]: frames 40-80
    law, log = float(fits["yield_fraction"](drum_ratio)), float(logs["yield_fraction"](drum_ratio))
    assert cells[2].startswith(f"{law:.4g} ±") and cells[4].startswith(f"{log:.4g} ±")
    assert cells[3].startswith(f"{100 * (mean / law - 1):+.0f} %") and cells[5].startswith(f"{100 * (mean / log - 1):+.0f} %")
    assert cells[6] == "slightly above 0.55" and "45.0°" in out


def test_the_series_leaves_the_second_core_to_cg1_until_cg1_is_done(monkeypatch):
    """D/d 66 seed 1 joins the series' queue only once CG1's newest checkpoint covers all its
    frames; before that the series is done after the paper-cg2 runs (and CG1 gets its core)."""
    spec = importlib.util.spec_from_file_location("paper_drum_runs_queue", os.path.join(BENCH, "paper_drum_runs.py"))
    fresh = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fresh)
    frames = round(fresh.REVOLUTIONS / fresh.FRAME_EVERY_REV) + 1  # revolutions 0, 0.05, ..., 4
    for covered, expected in ((frames - 1, False), (frames, True)):
        monkeypatch.setattr(fresh, "_newest", lambda folder, stem, kept, c=covered: ("ckpt", (c, 1, {}), None))
        names = [name for name, _, _ in fresh._queue()]
        assert ("dd66-seed1.h5" in names) is expected
        assert names[-1 - expected] == "paper-cg2-bond-seed0.h5"
    monkeypatch.setattr(fresh, "_newest", lambda folder, stem, kept: None)  # no CG1 at all
    assert "dd66-seed1.h5" not in [name for name, _, _ in fresh._queue()]
