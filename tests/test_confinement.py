"""The drum family by confinement (sim.params.sized_drum, the command line and sweep specs), the
confinement of a run (D/d, L/d, bed depth, wall contacts), the rigid co-motion test, the granule
size floor and the confinement curve's fit and rule."""

import math
import os

import numpy as np
import pytest

import granalytics as ga
from granalytics import ParameterError
from granalytics.identification import BACKENDS
from granalytics.analysis.confinement import (ConfinementFit, confinement_warning, decompose_cg, fit_confinement_curve,
                                              fit_logarithmic_curve)
from granalytics.identification.contacts import co_moving, co_moving_rigid, contact_strength, rigid_residual
from granalytics.datasets.synthetic import synthetic_meta, synthetic_snapshot
from sim.params import DrumRule, preset, preset_original, sized_drum

from conftest import expects_small_run_warnings, make_meta, make_snapshot


# ----------------------------------------------------------------------------- the drum family
def test_the_lab_rule_sized_for_3000_particles_is_the_lab_preset_exactly():
    original, _ = preset_original("lab-cg1")
    assert sized_drum("lab-cg1", original, 1.0, drum_particles=3000) == preset("lab-cg1")
    paper, _ = preset_original("paper-cg1")
    assert sized_drum("paper-cg1", paper, 1.0, drum_particles=120_000).drum_radius == pytest.approx(0.1, rel=1e-12)


@pytest.mark.parametrize("alpha", [1.0, 2.0, 3.0])
@pytest.mark.parametrize("ratio", [11.0, 33.65, 50.0])
def test_drum_ratio_sets_the_simulated_d_over_d_exactly_and_keeps_the_geometry_rule(alpha, ratio):
    original, _ = preset_original("lab-cg1")
    sized = sized_drum("lab-cg1", original, alpha, drum_ratio=ratio)
    assert 2 * sized.drum_radius / (alpha * original.d_mean) == pytest.approx(ratio, rel=1e-12)
    assert sized.drum_length / sized.drum_radius == pytest.approx(0.7, rel=1e-12)
    assert sized.spray_radius / sized.drum_radius == pytest.approx(0.63, rel=1e-12)
    assert (sized.n_baffles, sized.baffle_height, sized.drum_omega) == (original.n_baffles, original.baffle_height,
                                                                        original.drum_omega)
    # the count fills the drum to the rule's 25 % at packing 0.6, to one simulated particle
    fill = DrumRule(0.7).particles_for(sized.drum_radius, alpha * original.d_mean)
    assert abs(sized.n_particles / alpha**3 - fill) <= 0.5 + 1e-9


def test_a_cg_drum_sized_for_a_particle_count_holds_alpha_cubed_originals():
    original, _ = preset_original("lab-cg2")
    sized = sized_drum("lab-cg2", original, 2.0, drum_particles=375)
    assert sized.n_particles == 3000 and sized.drum_radius == pytest.approx(preset("lab-cg1").drum_radius, rel=1e-12)


@pytest.mark.parametrize("kw, words", [
    (dict(drum_ratio=20.0, drum_particles=100), "not both"),
    (dict(drum_ratio=2.0), "drum_ratio"),
    (dict(drum_ratio=float("nan")), "drum_ratio"),
    (dict(drum_particles=1), "drum_particles"),
    (dict(drum_particles=True), "drum_particles"),
])
def test_bad_drum_sizes_are_refused(kw, words):
    original, _ = preset_original("lab-cg1")
    with pytest.raises(ValueError, match=words):
        sized_drum("lab-cg1", original, 1.0, **kw)


def test_the_command_line_refuses_particles_with_a_drum_size(tmp_path, capsys):
    from sim.cli import main

    out = tmp_path / "r.h5"
    assert main(["run", "--preset", "lab-cg1", "--drum-ratio", "20", "--particles", "100", "--revolutions", "1",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--particles" in err and "--drum-ratio" in err and err.count("\n") == 1
    assert not out.exists()


def test_a_sweep_spec_sizes_the_drum_per_point_and_refuses_particles_beside_it(tmp_path):
    from sim.sweep import parse_spec

    spec = parse_spec({"preset": "lab-cg1", "revolutions": 1.0, "grid": {"drum_ratio": [11.2, 16.8], "seed": [0]}})
    counts = [p.resolved["particles"] for p in spec.points]
    assert counts == [sized_drum("lab-cg1", preset("lab-cg1"), 1.0, drum_ratio=x).n_particles for x in (11.2, 16.8)]
    with pytest.raises(ParameterError, match="particles"):
        parse_spec({"preset": "lab-cg1", "revolutions": 1.0, "grid": {"drum_ratio": [20.0], "particles": [100]}})
    with pytest.raises(ParameterError, match="drum_particles"):
        parse_spec({"preset": "lab-cg1", "revolutions": 1.0, "grid": {"drum_particles": [2.5]}})


# ----------------------------------------------------------------------------- a run's confinement
def test_confinement_closed_forms():
    # a bed filling half the cross-section is as deep as the drum's radius
    d, radius, length = 1e-3, 0.02, 0.01
    n_half = round(0.5 * math.pi * radius**2 * length * 0.6 / (math.pi * d**3 / 6))
    c = ga.confinement_of_drum(radius, length, d, n_half)
    assert (c.drum_ratio, c.length_ratio) == (pytest.approx(40.0), pytest.approx(10.0))
    assert c.fill_fraction == pytest.approx(0.5, rel=1e-4)
    assert c.bed_depth_ratio == pytest.approx(radius / d, rel=1e-3)
    # the lab rule's fill of 25 %: segment of central angle θ with θ − sin θ = π/2
    lab = preset("lab-cg1")
    c = ga.confinement_of_drum(lab.drum_radius, lab.drum_length, lab.d_mean, lab.n_particles)
    assert c.fill_fraction == pytest.approx(0.25, rel=1e-12)
    theta = 2.309881460010057  # solves θ − sin θ = π/2
    assert c.bed_depth_ratio == pytest.approx((1 - math.cos(theta / 2)) * lab.drum_radius / lab.d_mean, rel=1e-9)
    with pytest.raises(ParameterError, match="drum_length"):
        ga.confinement_of_drum(0.1, -1.0, 1e-3, 10)


def test_confinement_of_run_reads_the_recorded_values_or_the_parameters():
    params = {"drum_radius": 0.03, "drum_length": 0.021, "d_mean": 1.5e-3}
    meta = make_meta(500, sim_config={"params": params})
    assert ga.confinement_of_run(meta) == ga.confinement_of_drum(0.03, 0.021, 1.5e-3, 500)
    recorded = ga.confinement_of_drum(0.05, 0.02, 1e-3, 100)
    meta = make_meta(500, sim_config={"params": params, "confinement": recorded.to_dict()})
    assert ga.confinement_of_run(meta) == recorded
    assert ga.confinement_of_run(make_meta(10)) is None
    with pytest.raises(ga.ValidationError, match="confinement"):
        ga.confinement_of_run(make_meta(10, sim_config={"confinement": {"drum_ratio": "big"}}))


def test_wall_touching_finds_the_cylinder_the_end_plates_and_a_turned_baffle():
    radius_drum, length, r = 0.05, 0.03, 1e-3
    omega, t = 2.0, 0.3  # the baffles have turned by 0.6 rad
    phi = omega * t
    baffle_point = 0.048 * np.array([math.cos(phi), math.sin(phi)])
    across = np.array([-math.sin(phi), math.cos(phi)])
    position = np.array([
        [0.0, -(radius_drum - 0.9 * r), 0.015],   # overlaps the cylinder
        [0.0, -(radius_drum - 1.1 * r), 0.015],   # just clear of it
        [0.0, 0.0, 0.9 * r],                      # overlaps the plate z = 0
        [0.0, 0.0, length - 0.9 * r],             # overlaps the plate z = L
        [*(baffle_point + 0.9 * r * across), 0.015],  # beside the first baffle, at its turned angle
        [*(0.048 * np.array([1.0, 0.0]) + 0.9 * r * np.array([0.0, 1.0])), 0.015],  # where it was at t = 0
        [0.0, 0.0, 0.015],                        # the middle
    ])
    meta = make_meta(7, drum_omega=omega, sim_config={"params": {
        "drum_radius": radius_drum, "drum_length": length, "n_baffles": 4, "baffle_height": 0.15,
        "drum_omega": omega}})
    snap = make_snapshot(7, radius=np.full(7, r), position=position, time=t, meta=meta)
    assert ga.wall_touching(snap, meta).tolist() == [True, False, True, True, True, False, False]
    assert ga.wall_touching(snap, meta, overlap_tolerance=0.2)[1]
    with pytest.raises(ParameterError, match="drum geometry"):
        ga.wall_touching(snap, make_meta(7))


# ----------------------------------------------------------------------------- the rigid co-motion test
def _rigid_cluster(d, n=6, omega=(0.3, -0.2, 2.0), v0=(0.05, -0.1, 0.0), centre=(0.02, -0.03, 0.01), seed=0):
    """A chain of n touching particles of diameter d moving as one rigid body."""
    rng = np.random.default_rng(seed)
    position = np.cumsum(np.vstack([centre, rng.normal(size=(n - 1, 3))]), axis=0)
    position[1:] = position[0] + np.cumsum([v / np.linalg.norm(v) * d for v in rng.normal(size=(n - 1, 3))], axis=0)
    omega = np.asarray(omega)
    velocity = np.asarray(v0) + np.cross(omega, position - position[0])
    pairs = [(k, k + 1) for k in range(n - 1)]
    meta = make_meta(n, gravity=(0.0, -9.81, 0.0), drum_omega=2.0,
                     sim_config={"params": {"drum_radius": 0.05}})
    return make_snapshot(n, pairs, radius=np.full(n, d / 2), position=position, velocity=velocity,
                         angular_velocity=np.tile(omega, (n, 1)), meta=meta)


@pytest.mark.parametrize("d", [1e-3, 3e-3, 1e-2])
def test_a_rigid_granule_passes_the_rigid_test_at_any_particle_size(d):
    snap = _rigid_cluster(d)
    assert np.all(rigid_residual(snap) < 1e-12)
    assert co_moving_rigid(snap, rigid_tol=1e-6).all()
    assert co_moving_rigid(snap, rigid_tol=1e-6, rigid_scale="drum").all()


def test_solid_body_rotation_passes_the_rigid_test_where_the_angle_test_fails():
    # neighbours near the axis of a drum turning at Ω: their velocity directions differ by about d/r
    omega = 2.0
    d = 4.5e-3
    position = np.array([[0.004, 0.0, 0.01], [0.004, d, 0.01], [-0.02, -0.02, 0.01], [-0.02 + d, -0.02, 0.01]])
    velocity = np.cross([0.0, 0.0, omega], position)
    meta = make_meta(4, gravity=(0.0, -9.81, 0.0), drum_omega=omega)
    snap = make_snapshot(4, [(0, 1), (2, 3)], radius=np.full(4, d / 2), position=position, velocity=velocity,
                         angular_velocity=np.zeros((4, 3)), meta=meta)
    assert not co_moving(snap, 20.0)[0]  # r = 4 mm, d = 4.5 mm: the velocities differ by ~48°
    # with ω = 0 the pair is not rigid (the drum turns, the particles do not spin) ...
    assert not co_moving_rigid(snap, rigid_tol=0.01)[0]
    # ... and with the particles turning with the drum it is
    spun = make_snapshot(4, [(0, 1), (2, 3)], radius=np.full(4, d / 2), position=position, velocity=velocity,
                         angular_velocity=np.tile([0.0, 0.0, omega], (4, 1)), meta=meta)
    assert co_moving_rigid(spun, rigid_tol=1e-9).all()


def test_a_sheared_pair_fails_the_rigid_test_by_its_relative_velocity_over_sqrt_g_d():
    d = 2e-3
    meta = make_meta(2, gravity=(0.0, 0.0, -9.81))
    u = 0.3 * math.sqrt(9.81 * d)  # relative sliding velocity, no spin
    snap = make_snapshot(2, [(0, 1)], radius=np.full(2, d / 2), position=[[0, 0, 0], [d, 0, 0]],
                         velocity=[[0.1, 0, 0], [0.1, u, 0]], angular_velocity=np.zeros((2, 3)), meta=meta)
    assert rigid_residual(snap)[0] == pytest.approx(u, rel=1e-12)
    assert co_moving_rigid(snap, rigid_tol=0.31)[0] and not co_moving_rigid(snap, rigid_tol=0.29)[0]
    with pytest.raises(ParameterError, match="rim speed"):
        co_moving_rigid(snap, rigid_scale="drum")  # no drum radius in the metadata
    assert co_moving_rigid(snap, rigid_tol=1.0, speed_scale=1.01 * u)[0]


@pytest.fixture(scope="module")
def frames():
    meta = synthetic_meta(1200)
    return [synthetic_snapshot(1200, time=0.5 * k, granulated_fraction=0.25 * (k + 1), seed=50 + k, meta=meta)
            for k in range(3)]


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_rigid_gna_is_the_same_on_every_backend_and_equals_its_definition(frames, backend):
    s = frames[1]
    result = ga.identify(s, comotion="rigid", rigid_tol=0.3, backend=backend)
    expected = (contact_strength(s) >= 0.6) & co_moving_rigid(s, rigid_tol=0.3)
    assert np.array_equal(result.kept, expected)
    reference = ga.identify(s, comotion="rigid", rigid_tol=0.3, backend="networkx")
    assert result.partition() == reference.partition()
    assert result.n_granules > 0


def test_the_sensitivity_pass_with_the_rigid_test_equals_independent_identifications(frames):
    tols = [0.05, 0.3, 2.0]
    table = ga.sensitivity(frames, c_agg=[0.2, 0.6], comotion="rigid", rigid_tol=tols)
    assert "rigid_tol" in table and "a_agg_deg" not in table
    for (frame, c, tol), row in table.set_index(["frame", "c_agg", "rigid_tol"]).iterrows():
        s = frames[frame]
        expected = ga.frame_stats(s, ga.identify(s, c_agg=c, comotion="rigid", rigid_tol=tol)).iloc[0]
        assert (row.n_granules, row.yield_fraction) == (expected.n_granules, expected.yield_fraction)
    summary = ga.sensitivity_summary(table)
    assert sorted(summary["rigid_tol"].unique()) == tols
    with pytest.raises(ParameterError, match="rigid_tol"):
        ga.sensitivity(frames, c_agg=[0.6], comotion="rigid")
    with pytest.raises(ParameterError, match="a_agg_deg"):
        ga.sensitivity(frames, c_agg=[0.6], a_agg_deg=[20], comotion="rigid", rigid_tol=[0.2])


# ----------------------------------------------------------------------------- the granule size floor
@pytest.mark.parametrize("min_size", [2, 3, 5])
def test_min_size_drops_the_small_granules_in_identify_and_in_the_sensitivity_pass(frames, min_size):
    s = frames[2]
    full, floored = ga.identify(s), ga.identify(s, min_size=min_size)
    assert np.array_equal(floored.sizes, full.sizes[full.sizes >= min_size])
    big = np.isin(full.labels, np.flatnonzero(full.sizes >= min_size))
    assert np.array_equal(floored.labels >= 0, big)
    assert np.array_equal(floored.labels[big], full.labels[big])
    table = ga.sensitivity([s], c_agg=[0.6], a_agg_deg=[20.0], min_size=min_size)
    expected = ga.frame_stats(s, floored).iloc[0]
    assert (table.n_granules[0], table.yield_fraction[0]) == (expected.n_granules, expected.yield_fraction)
    assert table.mean_volume_norm[0] == pytest.approx(expected.mean_volume_norm, rel=1e-12)


@pytest.mark.parametrize("bad", [1, 0, 2.5, True, "3"])
def test_a_bad_min_size_is_refused_naming_it(frames, bad):
    with pytest.raises(ParameterError, match="min_size"):
        ga.identify(frames[0], min_size=bad)


# ----------------------------------------------------------------------------- the curve, the rule
def test_the_fit_recovers_the_finite_size_law_and_its_thresholds():
    x = np.array([11.0, 17.0, 34.0, 50.0])
    y_inf, b = 0.62, 2.4
    fit = fit_confinement_curve(x, y_inf * (1 - b / x), np.full(4, 0.005))
    assert (fit.y_inf, fit.b) == (pytest.approx(y_inf, rel=1e-12), pytest.approx(b, rel=1e-12))
    assert fit.within(0.05)[0] == pytest.approx(b / 0.05) and fit.within(0.1)[0] == pytest.approx(b / 0.1)
    assert fit(b / 0.1) == pytest.approx(0.9 * y_inf)
    # the errors grow with the points' errors and the error of a prediction is smallest inside the data
    noisy = fit_confinement_curve(x, y_inf * (1 - b / x) + np.array([0.01, -0.01, 0.01, -0.01]), np.full(4, 0.01))
    assert noisy.within(0.05)[1] > 0 and noisy.error(30.0) < noisy.error(5.0)
    with pytest.raises(ParameterError, match="three"):
        fit_confinement_curve(x[:2], [0.5, 0.6], [0.01, 0.01])


def test_the_logarithmic_curve_recovers_its_line_and_parts_from_the_law_beyond_the_data():
    x = np.array([22.0, 33.0, 44.0, 66.0])
    fit = fit_logarithmic_curve(x, 0.13 + 0.12 * np.log(x), np.full(4, 0.005))
    assert (fit.a, fit.c) == (pytest.approx(0.13, rel=1e-10), pytest.approx(0.12, rel=1e-10))
    assert fit.chi2 == pytest.approx(0.0, abs=1e-12) and fit.dof == 2
    # unscaled covariance: the error at a point is the weighted regression's, σ/√n at the log-mean
    assert fit.error(np.exp(np.log(x).mean())) == pytest.approx(0.005 / 2, rel=1e-10)
    # a saturating curve: both fit four points closely, the law far better; they part beyond them
    y = 0.7 * (1 - 7.0 / x)
    law, log = fit_confinement_curve(x, y, np.full(4, 0.002)), fit_logarithmic_curve(x, y, np.full(4, 0.002))
    assert law.chi2 < 1e-12 < log.chi2
    assert log(133.0) - law(133.0) > 0.02 and log.error(133.0) > log.error(40.0)
    # χ²/dof above 1 scales the covariance, as the law's fit does
    scattered = y + np.array([0.01, -0.01, 0.01, -0.01])
    loose = fit_logarithmic_curve(x, scattered, np.full(4, 0.002))
    assert loose.chi2 / loose.dof > 1
    unit = fit_logarithmic_curve(x, scattered, np.full(4, 1.0))  # χ²/dof below 1: not scaled
    assert unit.chi2 / unit.dof < 1
    assert loose.error(40.0) == pytest.approx(unit.error(40.0) * 0.002 * np.sqrt(loose.chi2 / loose.dof), rel=1e-9)
    with pytest.raises(ParameterError, match="fit_logarithmic_curve: needs three"):
        fit_logarithmic_curve(x[:2], [0.5, 0.6], [0.01, 0.01])
    for fit_curve in (fit_logarithmic_curve, fit_confinement_curve):  # a singular fit, not NaN errors
        with pytest.raises(ParameterError, match="needs two different D/d or more, got only 33"):
            fit_curve([33.0] * 3, [0.5, 0.6, 0.55], [0.01] * 3)


def test_the_decomposition_splits_a_deviation_at_equal_d_over_d_from_one_at_equal_drum():
    import pandas as pd

    fit = ConfinementFit(y_inf=0.6, b=3.0, covariance=np.zeros((2, 2)), chi2=0.0, dof=2)
    rows = pd.DataFrame([{"label": "cg3", "alpha": 3.0, "drum_ratio": 10.0, "yield_fraction": 0.35,
                          "yield_fraction_err": 0.0}])
    out = decompose_cg(rows, fit, {"cg3": (0.55, 0.0)}).iloc[0]
    assert out.cg1_equal_dd == pytest.approx(0.42)
    assert out.dev_equal_dd == pytest.approx(0.35 / 0.42 - 1) and out.dev_same_drum == pytest.approx(0.35 / 0.55 - 1)


def test_the_warning_names_the_threshold_it_falls_below():
    rule = {"a drum": {"within_5pc": (50.0, 5.0), "within_10pc": (25.0, 3.0)}}
    assert "10 %" in confinement_warning(11.0, rule) and "25" in confinement_warning(11.0, rule)
    assert "5-10 %" in confinement_warning(33.0, rule)
    assert confinement_warning(60.0, rule) is None
    assert confinement_warning(11.0, {"a drum": {"within_5pc": (None, None), "within_10pc": (None, None)}}) is None


def test_the_warning_holds_a_run_to_the_strictest_family_and_names_the_others():
    rule = {"lab drum": {"within_5pc": (62.0, 9.0), "within_10pc": (31.0, 4.0)},
            "paper drum": {"within_5pc": (139.0, 21.0), "within_10pc": (70.0, 11.0)}}
    warning = confinement_warning(44.4, rule)  # above the lab family's 10 %, below the paper family's
    assert warning.startswith("D/d = 44.4 is below 70 ± 11") and "more than 10 %" in warning
    assert "paper drum's family, 31 ± 4 in the lab drum's" in warning
    warning = confinement_warning(100.0, rule)
    assert warning.startswith("D/d = 100.0 is below 139 ± 21") and "5-10 %" in warning and "62 ± 9" in warning
    assert confinement_warning(140.0, rule) is None
    rule["paper drum"]["within_10pc"] = (70.0, None)  # a threshold without its error
    assert confinement_warning(44.4, rule).startswith("D/d = 44.4 is below 70, where")


def test_the_rule_holds_the_strictest_family_at_the_paper_drums_cg_runs():
    """paper-cg3 (D/(αd) 44.4) and paper-cg2 (66.7) lie below the paper drum family's 10 % threshold:
    its measured α = 1 yields at D/d 44 and 66 are 16 % and 10 % below its y∞."""
    for drum_ratio in (44.4, 66.7):
        assert "more than 10 %" in confinement_warning(drum_ratio)
    assert confinement_warning(1000.0) is None


# ----------------------------------------------------------------------------- the command line, the warnings
def test_info_prints_the_confinement_and_warns_below_the_rule(monkeypatch, capsys):
    import granalytics.analysis.confinement as confinement
    from granalytics.cli import main
    from granalytics.datasets import dataset_path

    path = str(dataset_path("lab-cg3"))
    monkeypatch.setattr(confinement, "CONFINEMENT_RULE", {"a drum": {"within_5pc": (50.0, 5.0), "within_10pc": (25.0, 3.0)}})
    assert main(["info", path]) == 0
    captured = capsys.readouterr()
    assert "D/d = 11.2, L/d = 3.9" in captured.out
    warned = [line for line in captured.err.splitlines() if "D/d = 11.2 is below 25" in line]
    assert len(warned) == 1 and path in warned[0]


@expects_small_run_warnings
def test_compare_cg_warns_once_for_each_system_below_the_rule(monkeypatch):
    import granalytics.analysis.confinement as confinement
    from granalytics.datasets import dataset_path, replica_paths

    monkeypatch.setattr(confinement, "CONFINEMENT_RULE", {"a drum": {"within_5pc": (50.0, 5.0), "within_10pc": (25.0, 3.0)}})
    runs = [dataset_path("lab-cg1"), replica_paths("lab-cg3")]
    with pytest.warns(UserWarning, match=r"lab-cg3.h5 \(and its 2 replica\(s\)\): D/d = 11.2 is below 25") as caught:
        ga.compare_cg(runs, window=(3.0, 3.5))
    assert any("lab-cg1.h5: D/d = 33.6 is below 50" in str(w.message) for w in caught)
    assert sum("D/d = 11.2" in str(w.message) for w in caught) == 1  # not once per replica


def test_the_command_line_runs_the_rigid_test_and_the_size_floor(tmp_path, capsys):
    import pandas as pd

    from granalytics.cli import main
    from granalytics.datasets import dataset_path

    path = str(dataset_path("lab-cg3"))
    tables = {}
    for name, options in {"angle": [], "rigid": ["--comotion", "rigid", "--rigid-tol", "0.3"],
                          "floor": ["--min-size", "5"]}.items():
        out = tmp_path / f"{name}.csv"
        assert main(["stats", path, "--window", "3:3.5", "--window-rev", "3:3.5", "--out", str(out), "--quiet"]
                    + options) == 0
        tables[name] = pd.read_csv(out)
    with ga.open_run(path) as run:
        frame = run.frame(int(tables["rigid"]["frame"][0]))
    expected = ga.frame_stats(frame, ga.identify(frame, comotion="rigid", rigid_tol=0.3)).iloc[0]
    assert tables["rigid"]["yield_fraction"][0] == pytest.approx(expected.yield_fraction)
    assert (tables["floor"]["yield_fraction"] <= tables["angle"]["yield_fraction"]).all()
    assert (tables["floor"]["yield_fraction"] < tables["angle"]["yield_fraction"]).any()
    assert main(["sensitivity", path, "--window", "3:3.5", "--comotion", "rigid", "--rigid-tol", "0.1,0.4",
                 "--c-agg", "0.6", "--quiet"]) == 0
    assert "rigid_tol" in capsys.readouterr().out


def test_the_confinement_time_series_returns_each_frames_granule_sizes_on_request():
    from granalytics.analysis.confinement import confinement_timeseries

    path = os.path.join(os.path.dirname(__file__), "..", "datasets", "lab-cg3.h5")
    with ga.open_run(path) as run:
        frames = run[-4:]
        table = confinement_timeseries(frames, run.meta)
        again, sizes = confinement_timeseries(frames, run.meta, return_sizes=True)
        plain = ga.run_stats(frames, return_sizes=True)[1]
    assert again.equals(table) and len(sizes) == len(table) == 4
    for row, frame_sizes, expected in zip(table.itertuples(), sizes, plain):
        assert np.array_equal(frame_sizes, expected)  # the granules run_stats finds, frame by frame
        assert len(frame_sizes) == row.n_granules and frame_sizes.sum() == pytest.approx(
            row.yield_fraction * row.n_particles)


@expects_small_run_warnings
def test_the_confinement_table_gives_a_group_its_replica_error_and_its_block_error_beside_it():
    from granalytics.analysis.stats import combine_steady_states, steady_state
    from granalytics.analysis.confinement import confinement_timeseries
    from granalytics.datasets import replica_paths

    paths, window = replica_paths("lab-cg3"), (3.0, 6.0)
    t = ga.confinement_table([paths, paths[:1]], window, labels=["group", "one"]).set_index("label")
    singles = []
    for path in paths:
        with ga.open_run(path) as run:
            singles.append(steady_state(confinement_timeseries(run.select(revolutions=window), run.meta), window))
    combined = combine_steady_states(singles)
    group, one = t.loc["group"], t.loc["one"]
    assert group.n_replicas == len(paths) and one.n_replicas == 1
    assert group.yield_fraction == pytest.approx(combined.loc["yield_fraction", "mean"], rel=1e-12)
    assert group.yield_fraction_err == pytest.approx(combined.loc["yield_fraction", "replica_sem"], rel=1e-12)
    assert group.yield_fraction_block_sem == pytest.approx(combined.loc["yield_fraction", "block_sem"], rel=1e-12)
    # one run: its error is its block s.e.m., the same in both columns
    assert one.yield_fraction_err == one.yield_fraction_block_sem == pytest.approx(singles[0].loc["yield_fraction", "sem"])
