"""Runs combined as replicas or CG levels must be one system (hostile round four, B2): replicas one
system at different seeds, CG levels one original system at different α; a copy of a run is not a
replica; runs of another system are refused unless the user says they mean it."""

import math

import pytest

import granalytics as ga
from granalytics.core import RunMeta, RunWriter
from granalytics.datasets.synthetic import synthetic_snapshot
from granalytics.analysis.run_systems import check_replicas, system_of
from conftest import expects_small_run_warnings

ORIGINAL = {"n_particles": 8100, "d_mean": 1.5e-3, "surface_tension": 0.1095, "drum_omega": 2.0, "seed": 0,
            "alpha": 1.0, "cg_rule": "weber", "bridge_volume": 0.0}


def simulator_run(path, alpha=1.0, seed=0, **changes):
    """A physics-free run whose metadata is a simulator run's: its original parameters recorded."""
    original = {**ORIGINAL, "seed": seed, **changes}
    n = round(original["n_particles"] / alpha**3)
    meta = RunMeta(surface_tension=original["surface_tension"] * alpha, density=2500.0,
                   drum_omega=original["drum_omega"], n_particles=n, mean_radius=0.75e-3 * alpha, alpha=alpha,
                   sim_config={"original": original, "params": {**original, "alpha": alpha, "n_particles": n,
                                                                "surface_tension": original["surface_tension"] * alpha}},
                   provenance={"code": "sim"})
    period = 2 * math.pi / meta.drum_omega
    with RunWriter(path, meta) as writer:
        for k in range(21):
            writer.append(synthetic_snapshot(n, granulated_fraction=0.4, time=k / 10 * period, step=k * 100,
                                             alpha=alpha, seed=seed * 1000 + k, meta=meta))
    return str(path)


def test_the_system_leaves_out_seed_alpha_and_rule():
    meta = RunMeta(surface_tension=0.1, density=2500.0, drum_omega=2.0, n_particles=10, mean_radius=1e-3,
                   sim_config={"original": {**ORIGINAL, "seed": 7, "cg_rule": "bond"}})
    assert system_of(meta) == {k: v for k, v in ORIGINAL.items() if k not in ("seed", "alpha", "cg_rule")}
    assert system_of(RunMeta(surface_tension=0.1, density=2500.0, drum_omega=2.0, n_particles=10,
                             mean_radius=1e-3)) is None


@expects_small_run_warnings
def test_replicas_of_another_system_or_copies_are_refused(tmp_path):
    cg1 = simulator_run(tmp_path / "cg1.h5")
    a = simulator_run(tmp_path / "a.h5", 3.0, seed=0)
    b = simulator_run(tmp_path / "b.h5", 3.0, seed=1)
    other_gamma = simulator_run(tmp_path / "g.h5", 3.0, seed=2, surface_tension=0.03)
    copy = tmp_path / "copy.h5"
    copy.write_bytes((tmp_path / "a.h5").read_bytes())
    ga.compare_cg([cg1, [a, b]], ["cg1", "cg3"], window=(0, 2))
    with pytest.raises(ga.ParameterError, match="g.h5: not a replica of .*a.h5: its system differs in "
                                                "surface_tension: 0.1095 vs 0.03"):
        ga.compare_cg([cg1, [a, b, other_gamma]], ["cg1", "cg3"], window=(0, 2))
    with pytest.raises(ga.ParameterError, match="copy.h5: the same seed 0 as .*a.h5: a copy of one run, not a replica"):
        ga.compare_cg([cg1, [a, b, str(copy)]], ["cg1", "cg3"], window=(0, 2))


@expects_small_run_warnings
def test_cg_levels_of_another_original_system_are_refused_unless_mixed_systems(tmp_path):
    cg1 = simulator_run(tmp_path / "cg1.h5")
    drum = simulator_run(tmp_path / "drum.h5", 3.0, drum_omega=3.0)
    with pytest.raises(ga.ParameterError, match="not coarse-grained from one system: cg3 differs from cg1 in "
                                                "drum_omega: 2.0 vs 3.0"):
        ga.compare_cg([cg1, drum], ["cg1", "cg3"], window=(0, 2))
    with pytest.warns(UserWarning, match="drum_omega: 2.0 vs 3.0"):
        ga.compare_cg([cg1, drum], ["cg1", "cg3"], window=(0, 2), mixed_systems=True)
    # seed, α and the CG rule may differ
    rule = simulator_run(tmp_path / "rule.h5", 3.0, seed=4, cg_rule="bond")
    ga.compare_cg([cg1, rule], ["cg1", "cg3"], window=(0, 2))


def test_foreign_runs_are_checked_by_their_seed_or_frames():
    members = [{"path": p, "alpha": 1.0, "n_particles": 10, "seed": None, "system": None, "content": c}
               for p, c in (("x.h5", "aa"), ("y.h5", "bb"))]
    check_replicas(members)
    with pytest.raises(ga.ParameterError, match="y.h5: the same frames as x.h5"):
        check_replicas([members[0], {**members[1], "content": "aa"}])


def test_the_command_line_refuses_a_copy_as_a_replica_and_takes_mixed_systems(tmp_path, capsys):
    from granalytics.cli import main

    a = simulator_run(tmp_path / "a.h5", 3.0, seed=0)
    copy = tmp_path / "copy.h5"
    copy.write_bytes((tmp_path / "a.h5").read_bytes())
    assert main(["stats", a, "--replica", str(copy), "--window", "0:2"]) == 2
    assert "a copy of one run, not a replica" in capsys.readouterr().err
    cg1 = simulator_run(tmp_path / "cg1.h5", surface_tension=0.2)
    assert main(["compare-cg", cg1, a, "--window", "0:2", "--out", str(tmp_path / "cg"), "--quiet"]) == 2
    assert "surface_tension: 0.2 vs 0.1095" in capsys.readouterr().err
    assert main(["compare-cg", cg1, a, "--window", "0:2", "--out", str(tmp_path / "cg"), "--quiet",
                 "--mixed-systems"]) == 0
