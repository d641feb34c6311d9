"""Parameter sweeps on dask (sim/sweep.py): spec parsing and grid expansion, the manifest,
skipping finished points, failing points, and — with a couple of tiny real simulations — a
two-worker local cluster and a point whose worker is killed with SIGKILL and that resumes from its
checkpoint bit for bit.

Most tests use a fake point runner (a tiny synthetic run file) on an in-process dask cluster.
"""

import logging
import math
import os
import signal
import textwrap
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import granalytics as ga
from granalytics import ParameterError, RunMeta, RunWriter
from granalytics.datasets.synthetic import synthetic_snapshot
from sim.cli import add_sweep_parser, cmd_sweep
from sim.cli import sweep_main as main
from sim.sweep import load_spec, parse_spec, point_name, read_manifest, run_sweep

# ----------------------------------------------------------------------------- helpers

def write_spec(path, body):
    path.write_text(textwrap.dedent(body))
    return path


FAKE_SPEC = """
    preset = "lab-cg3"
    revolutions = 1.0
    frame_every_rev = 0.5
    [grid]
    gamma = [0.05, 0.1, 0.2]
    omega = [2.0, 3.0]
"""


def _log_call(task):
    log = os.path.join(os.path.dirname(os.path.dirname(task.out)), "calls.log")
    with open(log, "a") as f:
        f.write(task.name + "\n")


def calls(out_dir):
    log = out_dir / "calls.log"
    return log.read_text().split() if log.exists() else []


def fake_runner(task):
    """A fast stand-in for the simulator: 3 frames of 30 synthetic particles whose metadata says
    what sim would record (the original γ and Ω in sim_config)."""
    _log_call(task)
    p = task.point
    meta = RunMeta(surface_tension=p["gamma"] * p["alpha"], density=2500.0, drum_omega=p["omega"], n_particles=30,
                   mean_radius=0.75e-3 * p["alpha"], alpha=p["alpha"],
                   sim_config={"original": {"surface_tension": p["gamma"], "drum_omega": p["omega"]}})
    period = 2 * math.pi / p["omega"]
    with RunWriter(task.out, meta, overwrite=True) as writer:
        for k in range(3):
            writer.append(synthetic_snapshot(30, time=k * 0.5 * period, step=k, seed=k, meta=meta, alpha=p["alpha"]))
    return {"resumed": False}


def failing_runner(task):
    if task.point["gamma"] == 0.1 and task.point["omega"] == 3.0:
        _log_call(task)
        raise ValueError("the drum overflowed\n(second line of the message)")
    return fake_runner(task)


@pytest.fixture(scope="module")
def scheduler():
    """An in-process dask cluster (threads): cheap, and the fake runner needs no pickling."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster:
        yield cluster.scheduler_address


# ----------------------------------------------------------------------------- spec and grid

def test_grid_is_the_cartesian_product_with_deterministic_names():
    spec = parse_spec({"revolutions": 2.0, "grid": {"omega": [2, 3.5], "gamma": [0.1, 0.2], "seed": [0]}})
    assert len(spec.points) == 4
    names = [p.name for p in spec.points]
    assert names == ["gamma=0.1_omega=2_seed=0", "gamma=0.1_omega=3.5_seed=0",
                     "gamma=0.2_omega=2_seed=0", "gamma=0.2_omega=3.5_seed=0"]
    # the order of the keys in the file does not matter
    again = parse_spec({"grid": {"seed": [0], "gamma": [0.1, 0.2], "omega": [2.0, 3.5]}, "revolutions": 2})
    assert [p.name for p in again.points] == names
    # parameters not in the grid come from the preset (of the original system)
    point = spec.points[1]
    assert point.resolved == {"gamma": 0.1, "omega": 3.5, "alpha": 3.0, "seed": 0, "particles": 3000}
    assert spec.preset == "lab-cg3" and spec.frame_every_rev == 0.05 and spec.checkpoint_every == 20
    assert point_name({"alpha": 2, "gamma": 1e-05, "viscosity": 0.003}) == "gamma=1e-05_alpha=2_viscosity=0.003"


def test_other_simparams_fields_can_be_swept():
    spec = parse_spec({"revolutions": 1, "grid": {"viscosity": [0.001, 0.002], "alpha": [2.0]}})
    assert [p.name for p in spec.points] == ["alpha=2_viscosity=0.001", "alpha=2_viscosity=0.002"]
    assert spec.points[0].resolved["alpha"] == 2.0 and spec.points[0].resolved["viscosity"] == 0.001


def test_dt_factor_is_swept_after_the_cg_rule():
    from sim.sweep.spec import build_params

    spec = parse_spec({"revolutions": 1, "grid": {"dt_factor": [1, 2.5], "alpha": [3.0]}})
    assert [p.name for p in spec.points] == ["alpha=3_dt_factor=1", "alpha=3_dt_factor=2.5"]
    original, params = build_params("lab-cg3", {"alpha": 3.0, "dt_factor": 2.5})
    assert original.dt == 3e-6 and original.dt_factor == 1
    assert params.dt == pytest.approx(2.5 * 3 * 3e-6) and params.dt_factor == 2.5


@pytest.mark.parametrize("body, words", [
    ('revolutions = 1\nfoo = 2\n[grid]\ngamma = [0.1]', "unknown key 'foo'"),
    ('revolutions = 1\n[grid]\nsurface = [0.1]', "unknown grid key 'surface'"),
    ('revolutions = 1\n[grid]\nsurface_tension = [0.1]', "use 'gamma'"),
    ('revolutions = 1\n[grid]\ngamma = 0.1', "must be a list"),
    ('revolutions = 1\n[grid]\n', "empty"),
    ('revolutions = 1\n', "[grid] table is required"),
    ('revolutions = 1\n[grid]\ngamma = []', "empty list"),
    ('revolutions = 1\n[grid]\ngamma = ["a"]', "must be a number"),
    ('revolutions = 1\n[grid]\ngamma = [-0.1]', "surface_tension"),
    ('revolutions = 1\n[grid]\nseed = [1.5]', "must be an integer"),
    ('revolutions = 1\n[grid]\nparticles = [true]', "must be an integer"),
    ('revolutions = 1\n[grid]\nalpha = [0.5]', "CG factor"),
    ('revolutions = 1\n[grid]\nomega = [0]', "rotating drum"),
    ('revolutions = 1\n[grid]\ngamma = [0.1, 0.1]', "twice"),
    ('[grid]\ngamma = [0.1]', "revolutions is required"),
    ('revolutions = -1\n[grid]\ngamma = [0.1]', "revolutions must be"),
    ('preset = "lab-cg9"\nrevolutions = 1\n[grid]\ngamma = [0.1]', "unknown preset"),
    ('revolutions = 1\n[grid\ngamma = [0.1]', "not valid TOML"),
    # the frame plan and particle count of `python -m sim run`, checked before anything runs
    ('revolutions = 0.33\n[grid]\ngamma = [0.1]', "not a whole number of frame_every_rev"),
    ('revolutions = 0.1\nframe_every_rev = 1e-9\n[grid]\ngamma = [0.1]', "shorter than one time step"),
    ('revolutions = 1\n[grid]\nparticles = [10]', "at least 2 are needed"),
])
def test_bad_specs_raise_one_line(tmp_path, body, words):
    spec = write_spec(tmp_path / "spec.toml", body)
    with pytest.raises(ParameterError) as err:
        load_spec(spec)
    message = str(err.value)
    assert words in message and "\n" not in message and str(spec) in message


def test_a_spec_that_is_not_utf8_is_refused_naming_the_file(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_bytes(b"revolutions = 1\n# caf\xe9\n[grid]\ngamma = [0.1]\n")
    with pytest.raises(ParameterError, match="not UTF-8") as err:
        load_spec(spec)
    assert str(spec) in str(err.value)


def test_bad_spec_on_the_command_line_is_one_line_and_exit_2(tmp_path, capsys):
    spec = write_spec(tmp_path / "spec.toml", 'revolutions = 1\n[grid]\ngamma = 0.1\n')
    assert main([str(spec), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sim: error:") and "must be a list" in err[0]
    assert not (tmp_path / "out").exists()
    good = write_spec(tmp_path / "good.toml", FAKE_SPEC)
    assert main([str(good), "--out", str(tmp_path / "out"), "--workers", "0", "--quiet"]) == 2
    assert "--workers" in capsys.readouterr().err
    assert main([str(tmp_path / "missing.toml"), "--out", str(tmp_path / "out")]) == 2
    assert "cannot read" in capsys.readouterr().err
    # an --out below a file: the file system's refusal, in one line too
    assert main([str(good), "--out", str(good / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sim: error:") and "Not a directory" in err[0]


def test_sweep_subcommand_registers_with_argparse():
    import argparse

    parser = argparse.ArgumentParser(prog="python -m sim")
    add_sweep_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sweep", "s.toml", "--out", "d", "--workers", "3"])
    assert args.func is cmd_sweep and args.workers == 3 and args.scheduler is None
    args = parser.parse_args(["sweep", "s.toml", "--out", "d", "--scheduler", "tcp://127.0.0.1:8786"])
    assert args.scheduler == "tcp://127.0.0.1:8786"


# ----------------------------------------------------------------------------- manifest, skip, failures

def test_sweep_writes_every_point_and_skips_finished_ones(tmp_path, scheduler):
    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    out = tmp_path / "sweep"
    table = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    assert len(table) == 6 and (table["status"] == "done").all()
    assert sorted(calls(out)) == sorted(table["point"])
    assert table.columns[:7].tolist() == ["point", "status", "gamma", "omega", "alpha", "seed", "particles"]
    row = table.set_index("point").loc["gamma=0.1_omega=3"]
    assert row["gamma"] == 0.1 and row["omega"] == 3.0 and row["alpha"] == 3.0 and row["particles"] == 3000
    assert row["file"] == "points/gamma=0.1_omega=3.h5" and row["error"] == ""
    assert row["preset"] == "lab-cg3" and row["revolutions"] == 1.0 and row["wall_time_s"] >= 0
    import hashlib

    assert hashlib.sha256((out / row["file"]).read_bytes()).hexdigest() == row["sha256"]
    assert read_manifest(out).equals(table)
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]

    # a second sweep runs nothing
    again = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    assert len(calls(out)) == 6
    assert again[["point", "status", "sha256"]].equals(table[["point", "status", "sha256"]])

    # a file that no longer matches its sha256 is run again, and only that one
    with open(out / row["file"], "ab") as f:
        f.write(b"x")
    run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    assert calls(out)[6:] == ["gamma=0.1_omega=3"]

    # a grown grid runs only the new points; rows of points the spec no longer lists stay
    bigger = write_spec(tmp_path / "bigger.toml", FAKE_SPEC.replace("[0.05, 0.1, 0.2]", "[0.1, 0.4]"))
    table = run_sweep(bigger, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    assert sorted(calls(out)[7:]) == ["gamma=0.4_omega=2", "gamma=0.4_omega=3"]
    assert len(table) == 8 and (table["status"] == "done").all()


def test_the_manifest_takes_the_point_runners_wall_time_when_it_reports_one(tmp_path, scheduler):
    def reporting_runner(task):
        fake_runner(task)
        return {"resumed": True, "wall_time_s": 1234.5}  # e.g. the simulator's, over earlier attempts

    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    table = run_sweep(spec, tmp_path / "sweep", scheduler=scheduler, progress=False, point_runner=reporting_runner)
    assert (table["wall_time_s"] == 1234.5).all() and table["resumed"].all()


def test_a_failing_point_is_recorded_and_the_others_finish(tmp_path, scheduler):
    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    out = tmp_path / "sweep"
    table = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=failing_runner).set_index("point")
    failed = table.loc["gamma=0.1_omega=3"]
    assert failed["status"] == "failed" and failed["sha256"] == ""
    assert failed["error"] == "ValueError: the drum overflowed (second line of the message)"
    assert (table.drop("gamma=0.1_omega=3")["status"] == "done").all()
    # the next sweep retries only the failed point
    n = len(calls(out))
    table = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner).set_index("point")
    assert calls(out)[n:] == ["gamma=0.1_omega=3"]
    assert (table["status"] == "done").all() and table.loc["gamma=0.1_omega=3", "error"] == ""


def test_a_folder_swept_with_other_settings_is_refused(tmp_path, scheduler):
    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    out = tmp_path / "sweep"
    run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    other = write_spec(tmp_path / "other.toml", FAKE_SPEC.replace("revolutions = 1.0", "revolutions = 2.0"))
    with pytest.raises(ParameterError, match="was run with revolutions=1.0"):
        run_sweep(other, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    with pytest.raises(ParameterError, match="--workers applies to the local cluster"):
        run_sweep(spec, out, workers=2, scheduler=scheduler, progress=False, point_runner=fake_runner)
    (tmp_path / "file").write_text("")
    with pytest.raises(ParameterError, match="not a folder"):
        run_sweep(spec, tmp_path / "file", scheduler=scheduler, progress=False, point_runner=fake_runner)


def test_the_command_reports_failures_with_exit_1(tmp_path, scheduler, capsys, monkeypatch):
    import sim.sweep as sweep

    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    monkeypatch.setattr(sweep.runner, "run_point", failing_runner)  # the command's default runner
    code = main([str(spec), "--out", str(tmp_path / "sweep"), "--scheduler", scheduler, "--quiet"])
    out = capsys.readouterr().out
    assert code == 1
    assert "6 points, 5 done, 1 failed" in out and "failed gamma=0.1_omega=3: ValueError" in out


# ----------------------------------------------------------------------------- real (tiny) simulations

REAL_SPEC = """
    preset = "lab-cg3"
    revolutions = 0.1
    frame_every_rev = 0.005
    checkpoint_every = 2
    [grid]
    gamma = {gammas}
    particles = [1080]     # 40 CG3 particles
    settle_time = [0.02]
"""
FIELDS = ("time", "ids", "radius", "position", "velocity", "angular_velocity", "film_volume", "contact_i",
          "contact_j", "f_cap", "f_normal", "gap", "bridge_volume")


@pytest.fixture(scope="module")
def two_point_sweep(tmp_path_factory):
    """Two tiny real points on a LocalCluster(n_workers=2, threads_per_worker=1)."""
    tmp = tmp_path_factory.mktemp("real")
    spec = write_spec(tmp / "spec.toml", REAL_SPEC.format(gammas="[0.1, 0.2]"))
    t0 = time.perf_counter()
    table = run_sweep(spec, tmp / "sweep", workers=2, progress=False)
    return tmp / "sweep", table, time.perf_counter() - t0


@pytest.mark.slow
def test_two_real_points_on_a_two_worker_local_cluster(two_point_sweep):
    out, table, _ = two_point_sweep
    assert (table["status"] == "done").all(), table["error"].tolist()
    assert (table["resumed"] == False).all()  # noqa: E712
    for row in table.itertuples():
        with ga.open_run(out / row.file) as run:
            assert len(run) == 21  # 0.1 revolution, a frame every 0.005
            meta = run.meta
            assert meta.alpha == 3.0 and meta.n_particles == 40 and meta.n_particles_original == 1080
            assert meta.sim_config["original"]["surface_tension"] == row.gamma
            assert meta.surface_tension == pytest.approx(3 * row.gamma)
            assert row.wall_time_s == meta.provenance["wall_time_s"]  # the simulator's own figure
    assert os.path.exists(out / "points" / "gamma=0.1_particles=1080_settle_time=0.02.h5.ckpt.npz")


@pytest.mark.slow
def test_a_point_whose_worker_is_killed_resumes_from_its_checkpoint_bit_identically(tmp_path, two_point_sweep):
    from distributed import Client, LocalCluster

    reference = two_point_sweep[0] / "points" / "gamma=0.1_particles=1080_settle_time=0.02.h5"
    spec = write_spec(tmp_path / "spec.toml", REAL_SPEC.format(gammas="[0.1]"))
    out = tmp_path / "sweep"
    name = "gamma=0.1_particles=1080_settle_time=0.02"
    marker = out / "points" / f"{name}.h5.ckpt.npz"  # the checkpoint: one file, renamed into place when complete
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        (pid,) = client.run(os.getpid).values()
        result = {}

        def sweep():
            try:
                result["table"] = run_sweep(spec, out, scheduler=cluster.scheduler_address, progress=False)
            except BaseException as exc:  # pragma: no cover - reported below
                result["error"] = exc

        thread = threading.Thread(target=sweep)
        thread.start()
        deadline = time.time() + 300
        while not marker.exists() and time.time() < deadline and thread.is_alive():
            time.sleep(0.01)
        assert marker.exists(), result
        assert read_manifest(out).loc[0, "status"] == "running"
        os.kill(pid, signal.SIGKILL)  # the worker dies mid-run; its nanny starts a new one
        thread.join(timeout=600)
        assert not thread.is_alive()
    assert "error" not in result, result.get("error")
    row = result["table"].iloc[0]
    assert row["status"] == "done" and bool(row["resumed"]), row["error"]
    with ga.open_run(reference) as a, ga.open_run(out / row["file"]) as b:
        assert len(a) == len(b) == 21
        for fa, fb in zip(a, b):
            for field in FIELDS:
                assert np.array_equal(getattr(fa, field), getattr(fb, field)), field


def test_points_of_another_simulator_physics_version_are_not_reused(tmp_path, scheduler):
    import pandas as pd

    from sim.params import PHYSICS_VERSION

    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    out = tmp_path / "sweep"
    table = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
    assert (table["physics_version"] == PHYSICS_VERSION).all()
    manifest = pd.read_csv(out / "manifest.csv")
    manifest["physics_version"] = PHYSICS_VERSION - 1
    manifest.to_csv(out / "manifest.csv", index=False)
    with pytest.raises(ParameterError, match=f"physics_version={PHYSICS_VERSION - 1}, this simulator has"):
        run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)


def test_a_point_runs_on_openmp_threads_in_a_fresh_worker(tmp_path):
    # numba fixes its threading layer when its threads start; a worker process that started them
    # before configure_threading ran would simulate on TBB, many times slower for small systems
    probe = f"""
import warnings
import numba
import sim.run
from sim.sweep import PointTask, run_point

warnings.simplefilter("error", RuntimeWarning)

class Started(Exception):
    pass

class Probe:
    def __init__(self, *args, **kwargs):
        raise Started(numba.threading_layer())

sim.run.Simulation = Probe
task = PointTask(name="p", point={{}}, overrides={{}}, preset="lab-cg3", revolutions=0.1, frame_every_rev=0.05,
                 checkpoint_every=2, threads=1, out={str(tmp_path / 'p.h5')!r})
try:
    run_point(task)
except Started as started:
    print("layer", started.args[0])
"""
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["layer", "omp"]


def test_a_second_sweep_into_a_busy_folder_is_refused(tmp_path, scheduler, capsys):
    from granalytics.base.errors import RunLockedError
    from granalytics.base.files import WriterLock

    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    out = tmp_path / "out"
    out.mkdir()
    with WriterLock(str(out / "manifest.csv")):  # the lock a running sweep holds
        with pytest.raises(RunLockedError, match="manifest.csv.lock"):
            run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)
        assert main([str(spec), "--out", str(out), "--quiet"]) == 2
        assert "another writer holds the lock file" in capsys.readouterr().err
    assert calls(out) == [] and not (out / "manifest.csv").exists()
    table = run_sweep(spec, out, scheduler=scheduler, progress=False, point_runner=fake_runner)  # released
    assert (table["status"] == "done").all() and not (out / "manifest.csv.lock").exists()


def test_an_unreachable_scheduler_leaves_no_manifest_of_running_points(tmp_path, monkeypatch):
    import distributed

    def unreachable(*args, **kwargs):
        raise OSError("Timed out trying to connect")

    monkeypatch.setattr(distributed, "Client", unreachable)
    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    with pytest.raises(ParameterError, match="cannot connect to the dask scheduler"):
        run_sweep(spec, tmp_path / "out", scheduler="tcp://127.0.0.1:1", progress=False, point_runner=fake_runner)
    assert not (tmp_path / "out" / "manifest.csv").exists()


def test_an_interrupted_sweep_says_how_to_go_on(tmp_path, monkeypatch, capsys):
    import sim.sweep

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sim.sweep, "run_sweep", interrupted)
    spec = write_spec(tmp_path / "spec.toml", FAKE_SPEC)
    assert main([str(spec), "--out", str(tmp_path / "out"), "--quiet"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "interrupted" in err[0] and "the same command continues" in err[0]


def test_a_spec_of_a_million_points_is_refused_before_any_is_built(tmp_path):
    seeds = ", ".join(str(k) for k in range(1000))
    gammas = ", ".join(f"{0.01 + 1e-4 * k:.6f}" for k in range(1000))
    spec = write_spec(tmp_path / "spec.toml", f"revolutions = 1\n[grid]\nseed = [{seeds}]\ngamma = [{gammas}]\n")
    with pytest.raises(ParameterError, match=r"1,000,000 points \(1000 × 1000\), more than the 10,000"):
        load_spec(spec)


def test_granalytics_has_no_sweep_command(capsys):
    """One home for the sweep command: python -m sim sweep (tests/test_architecture.py checks that
    granalytics never imports sim)."""
    from granalytics.cli import main as granalytics_main

    with pytest.raises(SystemExit):
        granalytics_main(["sweep", "--help"])
    assert "invalid choice: 'sweep'" in capsys.readouterr().err
