"""The CG rules (sim.cg_rules): each rule's scaling of every parameter, two-particle closed forms at
α = 1 and 3 under both rules, the α = 1 twin of a CG run (sim.params.similar_system) as the same
run in other units, and the rule carried from the command line to the run file, info and
compare-cg."""

import dataclasses
import math

import numpy as np
import pytest

from sim.capillary import capillary_force_scalar, rupture_distance_scalar, viscous_force
from sim.cg_rules import CG_RULES, cg_rule
from sim.params import SimParams, cg_scale, similar_system, preset_original, sized_drum
from sim.run import Simulation

from test_sim_physics import _restitution  # noqa: E402  (the head-on impact of the closed-form tests)
from conftest import expects_small_run_warnings, small_run_warnings

R = 0.75e-3
FREE = SimParams(n_particles=2, n_baffles=0, gravity=(0.0, 0.0, 0.0), drum_omega=0.0,
                 drum_radius=0.05, drum_length=0.05, viscous=False, friction=0.0)

#: the power of α every field of SimParams takes under a rule with forces × α^f, as a function
#: of f (None: unchanged); a field missing here fails the test, so that a new field gets a rule
POWERS = {
    "d_mean": lambda f: 1, "skin": lambda f: 1, "n_particles": lambda f: -3, "bridge_volume": lambda f: 3,
    "surface_tension": lambda f: f - 1, "viscosity": lambda f: f - 1,
    "k_n": lambda f: f - 1, "k_t": lambda f: f - 1, "c_n": lambda f: (f + 2) / 2, "c_t": lambda f: (f + 2) / 2,
    "youngs_modulus": lambda f: f - 2, "dt": lambda f: (4 - f) / 2,
}
UNCHANGED = {"density", "d_spread", "friction", "poisson_ratio", "restitution", "impact_speed", "contact_angle",
             "capillary_model", "contact_law", "viscous", "capillary_in_contact", "v_max_coef", "v_min",
             "spray_interval", "spray_dose", "spray_radius", "initial_film", "drum_radius", "drum_length",
             "n_baffles", "baffle_height", "cylinder_facets", "wall_bridges", "drum_omega", "gravity", "settle_time", "seed", "cg_rule",
             "dt_factor"}


@pytest.mark.parametrize("rule", list(CG_RULES))
@pytest.mark.parametrize("law", ["linear_coulomb", "hertz_mindlin"])
def test_each_rule_scales_every_parameter_by_its_power_of_alpha(rule, law):
    f = CG_RULES[rule].force_exponent
    original = dataclasses.replace(SimParams(bridge_volume=1e-12, contact_law=law), cg_rule=rule)
    fields = {fld.name for fld in dataclasses.fields(SimParams)} - {"alpha"}
    assert fields == set(POWERS) | UNCHANGED
    for alpha in (2.0, 3.0):
        scaled = cg_scale(original, alpha)
        assert scaled.alpha == alpha and scaled.cg_rule == rule
        for name in UNCHANGED:
            assert getattr(scaled, name) == getattr(original, name), name
        for name, power in POWERS.items():
            if name == "n_particles":
                assert scaled.n_particles == round(original.n_particles / alpha**3)
            elif name in ("k_n", "k_t", "c_n", "c_t") and law != "linear_coulomb" or \
                    name == "youngs_modulus" and law != "hertz_mindlin":
                assert getattr(scaled, name) == getattr(original, name), name  # another law's parameter
            else:
                assert getattr(scaled, name) == pytest.approx(getattr(original, name) * alpha ** power(f), rel=1e-14), name
    assert {"weber": 2.0, "bond": 3.0}[rule] == f


def test_weber_is_table_2_exactly_and_unknown_rules_are_refused():
    o = SimParams()
    c = cg_scale(o, 3.0)
    assert (c.surface_tension, c.viscosity, c.k_n, c.c_n, c.dt) == (o.surface_tension * 3.0, o.viscosity * 3.0,
                                                                     o.k_n * 3.0, o.c_n * 3.0**2, o.dt * 3.0)
    with pytest.raises(ValueError, match="cg_rule must be one of"):
        SimParams(cg_rule="froude")
    with pytest.raises(ValueError, match="unknown CG rule 'froude'; the rules are weber, bond"):
        cg_rule("froude")


def test_a_law_without_the_rule_is_refused(monkeypatch):
    from sim.laws import CONTACT_LAWS

    law = CONTACT_LAWS["hertz_mindlin"]
    monkeypatch.setitem(CONTACT_LAWS, "hertz_mindlin", dataclasses.replace(law, cg_rules=("weber",)))
    with pytest.raises(ValueError, match="the contact law 'hertz_mindlin' has no CG rule 'bond' \\(it has weber\\)"):
        SimParams(contact_law="hertz_mindlin", cg_rule="bond")


@pytest.mark.parametrize("rule", list(CG_RULES))
def test_two_particle_closed_forms_at_alpha_1_and_3(rule):
    """Restitution and contact time in steps are the original's; the capillary force at any
    gap/R, the viscous force at any gap/R and the same speed scale as α^f; the rupture distance
    scales as α (it depends on V_b/R³ only)."""
    original = dataclasses.replace(FREE, cg_rule=rule)
    f = CG_RULES[rule].force_exponent
    e1, steps1 = _restitution(original, R, 0.05)
    scaled = dataclasses.replace(cg_scale(original, 3.0), drum_radius=0.05, drum_length=0.05)
    r3 = 3 * R
    e3, steps3 = _restitution(scaled, r3, 0.05)
    assert e3 == pytest.approx(e1, rel=2e-3) and 0.5 < e1 < 1
    assert abs(steps3 - steps1) <= 1  # t_c/Δt is the original's (127 steps)
    v_b, v_b3 = 0.02 * R**3, 0.02 * r3**3
    for s_over_r in (0.0, 0.01, 0.05):
        f1 = capillary_force_scalar(0, s_over_r * R, v_b, R / 2, original.surface_tension, 0.0)
        f3 = capillary_force_scalar(0, s_over_r * r3, v_b3, r3 / 2, scaled.surface_tension, 0.0)
        assert f3 == pytest.approx(3**f * f1, rel=1e-12)
        viscous1 = viscous_force(original.viscosity, R, R, 0.01, max(s_over_r, 1e-3) * R, v_b)
        viscous3 = viscous_force(scaled.viscosity, r3, r3, 0.01, max(s_over_r, 1e-3) * r3, v_b3)
        assert viscous3 == pytest.approx(3**f * viscous1, rel=1e-12)
    assert rupture_distance_scalar(v_b3, r3 / 2, 0.0) == pytest.approx(3 * rupture_distance_scalar(v_b, R / 2, 0.0),
                                                                      rel=1e-12)
    # the weight scales as α³: the Bond number F_cap/(m g) is kept by bond and falls as 1/α under weber
    bond_number_ratio = 3**f / 3**3
    assert bond_number_ratio == pytest.approx({"weber": 1 / 3, "bond": 1.0}[rule])


def test_similar_system_keeps_every_dimensionless_group():
    o = dataclasses.replace(SimParams(bridge_volume=1e-12), cg_rule="bond")
    cg = cg_scale(o, 3.0)
    twin = similar_system(cg, 1 / 3)
    # the α = 1 twin of a bond CG3 system is the original with Ω, η × √3 and times ÷ √3
    for name in ("d_mean", "surface_tension", "k_n", "k_t", "c_n", "c_t", "dt", "bridge_volume", "skin"):
        assert getattr(twin, name) == pytest.approx(getattr(o, name), rel=1e-14), name
    assert twin.drum_omega == pytest.approx(o.drum_omega * math.sqrt(3), rel=1e-14)
    assert twin.viscosity == pytest.approx(o.viscosity * math.sqrt(3), rel=1e-14)
    assert twin.spray_interval == pytest.approx(o.spray_interval / math.sqrt(3), rel=1e-14)
    assert twin.drum_radius == pytest.approx(o.drum_radius / 3, rel=1e-14)

    def groups(p):
        weight = p.density * 4 / 3 * math.pi * p.r_mean**3 * 9.81
        return (p.surface_tension * p.r_mean / weight, p.drum_omega**2 * p.drum_radius / 9.81,  # Bond, Froude
                p.contact_time() / p.dt, p.k_n * p.r_mean / weight, p.drum_radius / p.d_mean,
                p.viscosity * p.r_mean**2 * math.sqrt(9.81 / p.r_mean) / weight, p.bridge_volume / p.r_mean**3,
                p.spray_interval * p.drum_omega, p.settle_time * math.sqrt(9.81 / p.r_mean))

    assert groups(twin) == pytest.approx(groups(cg), rel=1e-12)
    with pytest.raises(ValueError, match="length_factor"):
        similar_system(cg, 0.0)


def test_the_twin_of_a_bond_cg3_run_is_the_same_run_in_other_units():
    """The reusable twin check: a bond CG3 run and its α = 1 twin, from one seed, follow one
    trajectory (positions ÷ 3, velocities ÷ √3, liquid volumes ÷ 27) to rounding until chaos
    amplifies the rounding: through the filling, a settling, the turning drum, spraying, bridge
    formation and liquid migration. A parameter that did not scale (the spray interval, here)
    breaks it at once."""
    o, _ = preset_original("lab-cg3")
    o = dataclasses.replace(sized_drum("lab-cg3", dataclasses.replace(o, cg_rule="bond"), 3.0, drum_ratio=11.2),
                            settle_time=0.03, spray_interval=0.004, initial_film=0.004)
    cg = cg_scale(o, 3.0)
    twin = dataclasses.replace(similar_system(cg, 1 / 3), alpha=1.0)
    broken = dataclasses.replace(twin, spray_interval=o.spray_interval)
    with pytest.warns(UserWarning, match="has not settled"):  # a short settling on purpose
        runs = [Simulation(cg, o, threads=1), Simulation(twin, threads=1), Simulation(broken, threads=1)]
    for sim in runs:
        sim.advance(2500)
    a, b, c = (sim.state for sim in runs)
    order = [np.argsort(s.ids) for s in (a, b, c)]
    assert a.n_sprays >= 3 and b.n_sprays == a.n_sprays and c.n_sprays < a.n_sprays
    assert a.alive.sum() == b.alive.sum() and a.v_b[a.alive.astype(bool)].sum() > 0  # bridges, wetted by sprays
    d = twin.d_mean
    assert np.abs(a.pos[order[0]] / 3 - b.pos[order[1]]).max() < 1e-9 * d
    assert np.abs(a.vel[order[0]] / math.sqrt(3) - b.vel[order[1]]).max() < 1e-7 * math.sqrt(9.81 * d)
    assert a.film[order[0]] / 27 == pytest.approx(b.film[order[1]], rel=1e-9, abs=1e-12 * d**3)
    assert a.total_liquid() / 27 == pytest.approx(b.total_liquid(), rel=1e-12)
    assert c.total_liquid() != pytest.approx(b.total_liquid(), rel=1e-3)


def _cli_params(*flags):
    from sim.cli import _params, build_parser

    args = build_parser().parse_args(["run", "--preset", "lab-cg3", "--revolutions", "1", "--out", "x.h5", *flags])
    return _params(args)


def test_the_command_line_sets_the_rule_and_the_twin():
    original, scaled = _cli_params("--cg-rule", "bond")
    assert original.cg_rule == scaled.cg_rule == "bond" and scaled.surface_tension == pytest.approx(9 * 0.1095)
    assert _cli_params()[1].cg_rule == "weber"
    twin, same = _cli_params("--cg-rule", "bond", "--drum-ratio", "11.2", "--twin")
    assert twin is same and twin.alpha == 1.0 and twin.d_mean == pytest.approx(1.5e-3, rel=1e-14)
    assert twin.drum_omega == pytest.approx(2 * math.sqrt(3), rel=1e-14)
    with pytest.raises(ValueError, match="--twin is the α = 1 twin of a coarse-grained run"):
        _cli_params("--alpha", "1", "--twin")


@expects_small_run_warnings
def test_the_rule_is_recorded_printed_by_info_and_compare_cg_warns_when_rules_differ(tmp_path, capsys):
    import granalytics as ga
    from granalytics.cli import main as ga_main
    from granalytics.core import RunWriter

    o = dataclasses.replace(SimParams(n_particles=54, drum_radius=0.02, drum_length=0.02, spray_radius=0.0126),
                            settle_time=0.005)
    paths = []
    for rule in ("weber", "bond"):
        original = dataclasses.replace(o, cg_rule=rule)
        sim = Simulation(cg_scale(original, 1.5), original, threads=1)
        path = tmp_path / f"{rule}.h5"
        with RunWriter(path, sim.run_meta()) as writer:
            for _ in range(3):
                sim.advance(50)
                writer.append(sim.snapshot())
        paths.append(str(path))
    with ga.open_run(paths[1]) as run:
        assert run.meta.sim_config["params"]["cg_rule"] == "bond"
        assert ga.cg_rule_of(run.meta) == "bond"
    capsys.readouterr()
    assert ga_main(["info", paths[1]]) == 0
    assert "CG rule                  bond (α = 1.5; forces × α³" in capsys.readouterr().out
    reference = tmp_path / "cg1.h5"
    sim1 = Simulation(o, threads=1)
    with RunWriter(reference, sim1.run_meta()) as writer:
        for _ in range(3):
            sim1.advance(50)
            writer.append(sim1.snapshot())
    with pytest.warns(UserWarning, match="made under different CG rules .*: weber, .*: bond"):
        cg = ga.compare_cg([str(reference), *paths], ["cg1", "weber", "bond"], window=(0, 1))
    assert list(cg.runs["cg_rule"]) == ["weber", "weber", "bond"]


def test_info_and_compare_cg_warn_where_a_rule_is_measured_outside_the_tolerance(capsys):
    import granalytics as ga
    from granalytics.analysis.cg import CG_RULE_DEVIATION, cg_rule_warning
    from granalytics.cli import main as ga_main
    from granalytics.datasets import dataset_path

    weber3 = CG_RULE_DEVIATION["weber"][11.2][3.0][0]
    assert abs(weber3) > 0.1 and abs(CG_RULE_DEVIATION["bond"][11.2][3.0][0]) < 0.1
    assert f"{100 * weber3:+.0f} %" in cg_rule_warning("weber", 3.0) and "--cg-rule bond" in cg_rule_warning("weber", 3.0)
    assert cg_rule_warning("bond", 3.0) is None and cg_rule_warning("weber", 1.0) is None
    # judged by the most open measured drum not above the run's: the lab drum's below D/(αd) 44.4,
    # the paper drum's from there on, where Table 2 keeps the yield (no warning)
    assert cg_rule_warning("weber", 3.0, 30.0) == cg_rule_warning("weber", 3.0, 11.2).replace("run's 11", "run's 30")
    assert "D/(αd) 11.2, lab drum" in cg_rule_warning("weber", 3.0, 5.0)
    assert abs(CG_RULE_DEVIATION["weber"][44.4][3.0][0]) < 0.1 and cg_rule_warning("weber", 3.0, 44.4) is None
    assert cg_rule_warning("weber", 2.0, 67.0) is None and cg_rule_warning("bond", 3.0, 133.0) is None
    # a drum unknown: the most confined measurement
    assert cg_rule_warning("weber", 3.0, float("nan")) == cg_rule_warning("weber", 3.0)
    assert cg_rule_warning(None, 3.0) is None  # another code's run: its rule is unknown
    assert "measured up to α = 3" in cg_rule_warning("bond", 4.0)
    # more confined than any measurement: said, even where the rule kept the yield there
    assert "D/(αd) 8.0 is more confined than any measured (11.2" in cg_rule_warning("bond", 3.0, 8.0)
    assert cg_rule_warning("bond", 3.0, 11.2) is None
    assert ga_main(["info", str(dataset_path("lab-cg3"))]) == 0
    err = capsys.readouterr().err
    assert err.count("CG rule weber at α = 3 moved the steady yield") == 1
    assert ga_main(["info", str(dataset_path("paper-cg3"))]) == 0  # D/(αd) 44.4: Table 2 measured within 10 %
    assert "CG rule" not in capsys.readouterr().err
    with small_run_warnings(), pytest.warns(UserWarning, match="lab-cg3.h5 \\(and its 2 replica\\(s\\)\\): CG rule weber at α = 3"):
        ga.compare_cg([dataset_path("lab-cg1"), ga.datasets.replica_paths("lab-cg3")], window=(3.0, 3.5))


def test_a_rule_is_judged_by_the_most_open_drum_that_measured_its_alpha(monkeypatch):
    """A more open confinement measured at smaller α only (CG2 alone) does not hide a larger α's
    measurement in a more confined drum: a Table 2 α = 3 run in a drum more open than both is
    judged by the one that measured α = 3."""
    from granalytics.analysis import cg
    from granalytics.analysis.cg import cg_rule_warning

    weber = {**cg.CG_RULE_DEVIATION["weber"], 66.7: {1.0: (0.0, 0.0), 2.0: (0.01, 0.01)}}
    monkeypatch.setitem(cg.CG_RULE_DEVIATION, "weber", weber)
    monkeypatch.setitem(cg._CG_RULE_MEASURED_IN, 66.7, "paper drum, one seed")
    assert cg_rule_warning("weber", 3.0, 80.0) is None  # 44.4's α = 3: within the tolerance
    assert cg_rule_warning("weber", 2.0, 80.0) is None
    assert "D/(αd) 11.2" in cg_rule_warning("weber", 3.0, 30.0)  # below 44.4: the lab drum's, as before
    assert "measured up to α = 2 only at D/(αd) 66.7" in cg_rule_warning("weber", 4.0, 80.0)
    monkeypatch.setitem(weber, 66.7, {1.0: (0.0, 0.0), 3.0: (-0.2, 0.01)})  # measured at α = 3 there: it rules
    assert "moved the steady yield by about -20 %" in cg_rule_warning("weber", 3.0, 80.0)
