"""Calibration of the thresholds against a measured size distribution (docs/calibration.md)."""

import json
import re

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics import ParameterError
from granalytics.analysis.calibration import grid_measurement
from granalytics.datasets import DATASET_DIR

EDGES = np.r_[0.0, 1e-3 * np.array([1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.2]), np.inf]
C_GRID = np.linspace(0.25, 0.65, 9)  # step 0.05
A_GRID = np.linspace(10, 50, 9)  # step 5°
WINDOW = (3, 4.5)


@pytest.fixture(scope="module")
def cg1_frames():
    with ga.open_run(DATASET_DIR / "lab-cg1.h5") as run:
        return list(run.select(revolutions=WINDOW))


@pytest.fixture(scope="module")
def cg1_grid(cg1_frames):
    return ga.size_class_grid(cg1_frames, EDGES, C_GRID, A_GRID)


@pytest.mark.parametrize("measure", ["volume", "width"])
def test_one_pass_distributions_equal_per_threshold_identification(cg1_frames, measure):
    frames = cg1_frames[::8]
    c_grid, a_grid = [0.2, 0.45, 0.6, 0.84], [10.0, 30.0, 90.0]
    grid = ga.size_class_grid(frames, EDGES, c_grid, a_grid, measure=measure)
    for f, snapshot in enumerate(frames):
        for a_i, a in enumerate(grid.comotion_values):
            for c_i, c in enumerate(grid.c_agg):
                labels = ga.identify(snapshot, c_agg=c, a_agg_deg=a).labels
                expected = ga.size_class_fractions(snapshot, labels, EDGES, measure)
                assert np.array_equal(grid.fractions[f, a_i, c_i], expected), (f, a, c)


def test_one_pass_equals_identification_with_the_rigid_test_and_a_size_floor(cg1_frames):
    snapshot = cg1_frames[0]
    grid = ga.size_class_grid([snapshot], EDGES, [0.3, 0.6], comotion="rigid", rigid_tol=[0.1, 0.4], min_size=3)
    for a_i, tol in enumerate(grid.comotion_values):
        for c_i, c in enumerate(grid.c_agg):
            labels = ga.identify(snapshot, c_agg=c, comotion="rigid", rigid_tol=tol, min_size=3).labels
            assert np.array_equal(grid.fractions[0, a_i, c_i], ga.size_class_fractions(snapshot, labels, EDGES))


def test_width_is_the_virtual_sieves_second_principal_extent(cg1_frames):
    snapshot = cg1_frames[0]
    result = ga.identify(snapshot, method="sieve", c_agg=0.45, a_agg_deg=30)
    widths, membership = result.extra["widths_m"], result.extra["membership"]
    volume = snapshot.particle_volume
    size = np.where(np.bincount(membership)[membership] >= 2, widths[membership], 2 * snapshot.radius)
    expected = np.bincount(np.searchsorted(EDGES, size, side="right"), weights=volume, minlength=EDGES.size + 1)
    got = ga.size_class_fractions(snapshot, ga.identify(snapshot, c_agg=0.45, a_agg_deg=30).labels, EDGES, "width")
    np.testing.assert_allclose(got, expected / volume.sum(), rtol=1e-9, atol=1e-15)


def test_cg_particles_are_sieved_in_original_system_sizes():
    with ga.open_run(DATASET_DIR / "lab-cg3.h5") as run:
        snapshot = run[-1]
    alpha = snapshot.meta.alpha
    assert alpha == 3
    free = ga.size_class_fractions(snapshot, np.full(snapshot.n_particles, -1), EDGES)  # every particle free
    d_original = 2 * snapshot.radius / alpha
    expected = np.bincount(np.searchsorted(EDGES, d_original, side="right"), weights=snapshot.radius**3,
                           minlength=EDGES.size + 1)
    np.testing.assert_allclose(free, expected / expected.sum())
    pair = np.full(snapshot.n_particles, -1)
    pair[:2] = 0  # a granule of two CG particles: the diameter of the sphere of their solid volume
    d_v = 2 * ((snapshot.radius[:2] ** 3).sum()) ** (1 / 3)  # (6V/π)^(1/3), V = 4π/3 Σ R³
    got = ga.size_class_fractions(snapshot, pair, EDGES)
    assert got[np.searchsorted(EDGES, d_v, side="right")] >= (snapshot.radius[:2] ** 3).sum() / (snapshot.radius**3).sum()


def test_recovery_of_known_thresholds(cg1_grid):
    """A "measured" distribution made at C_agg 0.45, A_agg 30° with a normal error of 0.01 on its
    cumulative mass passing is recovered within a grid step and inside the confidence region."""
    measured = grid_measurement(cg1_grid, 0.45, 30.0, noise=0.01, seed=1)
    cal = ga.calibrate_thresholds(cg1_grid, measured, C_GRID, A_GRID, window=WINDOW, n_boot=100)
    assert abs(cal.best["c_agg"] - 0.45) <= 0.05 + 1e-9
    assert abs(cal.best["a_agg_deg"] - 30.0) <= 5 + 1e-9
    truth = cal.grid[np.isclose(cal.grid.c_agg, 0.45) & np.isclose(cal.grid.a_agg_deg, 30.0)]
    assert truth.in_region.item()
    assert not cal.poor_fit
    assert set(cal.constraint) == {"c_agg", "a_agg_deg"}
    assert "best: C_agg" in cal.summary()
    d = cal.distributions
    assert np.isclose(d.measured_fraction.sum(), 1) and np.isclose(d.simulated_fraction.sum(), 1, atol=1e-9)
    assert (d.simulated_fraction_error >= 0).all()


def test_a_distribution_no_threshold_can_produce_is_a_poor_fit(cg1_grid):
    impossible = ga.MeasuredDistribution.from_classes(EDGES[:-1], EDGES[1:], [0, 0.05, 0.05, 0.1, 0.6, 0.1, 0.05, 0.05, 0])
    cal = ga.calibrate_thresholds(cg1_grid, impossible, C_GRID, A_GRID, window=WINDOW, n_boot=50)
    assert cal.poor_fit
    assert "POOR FIT" in cal.summary()


def test_an_axis_the_data_cannot_constrain_is_said_to_be_unconstrained(cg1_grid):
    # at C_agg above the largest strength (0.8546) nothing is a granule, whatever A_agg
    with ga.open_run(DATASET_DIR / "lab-cg1.h5") as run:
        frames = list(run.select(revolutions=(3, 3.5)))
    g = ga.size_class_grid(frames, EDGES, [0.86, 0.9], [10.0, 30.0, 60.0])
    measured = grid_measurement(g, 0.9, 30.0, noise=0.01, seed=0)
    cal = ga.calibrate_thresholds(g, measured, [0.86, 0.9], [10.0, 30.0, 60.0], window=(3, 3.5), n_boot=50,
                                  block_rev=0.1)
    assert cal.constraint["a_agg_deg"] == "unconstrained"
    assert cal.constraint["c_agg"] == "unconstrained"


def test_replicas_and_the_rigid_test():
    grids = []
    for name in ("lab-cg3", "lab-cg3-seed1"):
        with ga.open_run(DATASET_DIR / f"{name}.h5") as run:
            grids.append(ga.size_class_grid(run.select(revolutions=(3, 4)), EDGES, [0.3, 0.6], comotion="rigid",
                                       rigid_tol=[0.1, 0.4]))
    measured = grid_measurement(grids[0], 0.6, 0.4, noise=0.01)
    cal = ga.calibrate_thresholds(grids, measured, [0.3, 0.6], comotion="rigid", rigid_tol=[0.1, 0.4], window=(3, 4),
                                  n_boot=20)
    assert cal.threshold_column == "rigid_tol"
    assert set(cal.grid.columns) >= {"c_agg", "rigid_tol", "chi2", "in_region"}
    assert cal.settings["n_frames"] == [g.volumes.shape[0] for g in grids]


def test_a_window_takes_the_same_frames_from_a_run_and_from_a_list_of_its_snapshots(cg1_grid):
    # lab-cg1's frame meant for revolution 3.5 is stamped 3.5000082: inside the window [3, 3.5] by
    # the one rule of core.windows, whether the frames come as a run or as snapshots
    measured = grid_measurement(cg1_grid, 0.6, 20.0, noise=0.01, seed=0)
    fit = dict(c_agg=[0.3, 0.6], a_agg_deg=[20.0, 40.0], window=(3, 3.5), n_boot=20, block_rev=0.2)
    with ga.open_run(DATASET_DIR / "lab-cg1.h5") as run:
        by_run = ga.calibrate_thresholds(run, measured, **fit)
        snapshots = list(run.select(revolutions=(2.5, 4)))
    by_list = ga.calibrate_thresholds(snapshots, measured, **fit)
    assert by_run.settings["n_frames"] == by_list.settings["n_frames"] == [11]
    pd.testing.assert_frame_equal(by_list.grid, by_run.grid)
    pd.testing.assert_frame_equal(by_list.distributions, by_run.distributions)


def _write(tmp_path, text, name="m.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_both_file_forms_and_the_example_file(tmp_path):
    classes = ga.read_sieve_csv(_write(tmp_path, "lower_m,upper_m,mass_fraction\n0,0.001,0.2\n0.001,0.002,0.5\n"
                                                 "0.002,inf,0.3\n"))
    passing = ga.read_sieve_csv(_write(tmp_path, "# a comment\naperture_m,passing_fraction\n0.001,0.2\n0.002,0.7\n",
                                       "p.csv"))
    np.testing.assert_array_equal(classes.edges_m, passing.edges_m)
    np.testing.assert_allclose(classes.fractions, passing.fractions)
    example = ga.read_sieve_csv(DATASET_DIR / "sieve" / "example-sieve.csv")
    assert example.n_classes == EDGES.size - 1 and example.sigma is not None
    np.testing.assert_allclose(example.edges_m, EDGES)


@pytest.mark.parametrize("text, words", [
    ("lower_m,upper_m,mass_fraction\n0,0.001,0.5\n0.001,0.002,0.4\n", "sum to 0.9"),
    ("lower_m,upper_m,mass_fraction\n0.001,0.002,0.5\n0,0.001,0.5\n", "row 2, field lower_m: classes not sorted"),
    ("lower_m,upper_m,mass_fraction\n0,0.002,0.5\n0.001,0.003,0.5\n", "row 2, field lower_m: overlaps"),
    ("lower_m,upper_m,mass_fraction\n0,0.001,0.5\n0.0015,0.003,0.5\n", "row 2, field lower_m: a gap"),
    ("lower_m,upper_m,mass_fraction\n0,0.001,-0.5\n0.001,0.003,1.5\n", "row 1, field mass_fraction: must not be negative"),
    ("lower_m,upper_m,mass_fraction\n0,0.001,abc\n0.001,0.003,1\n", "row 1, field mass_fraction: not a number"),
    ("lower_m,upper_m,mass_fraction\n0,0.001,nan\n0.001,0.003,1\n", "row 1, field mass_fraction: must be a finite"),
    ("lower_m,upper_m,mass_fraction\n0,inf,0.5\n0.001,0.003,0.5\n", "row 1, field upper_m: must be a finite"),
    ("lower_m,upper_m,mass_fraction\n0.002,0.001,0.5\n0.001,0.003,0.5\n", "row 1, field upper_m: must be above"),
    ("lower_m,upper_m,mass_fraction\n0,0.001,1\n", "1 class(es)"),
    ("lower_m,upper_m,mass_fraction\n0,0.001\n0.001,0.002,1\n", "row 1: expected 3 fields"),
    ("size,fraction\n0.001,1\n", "header"),
    ("", "empty"),
    ("aperture_m,passing_fraction\n0.002,0.5\n0.001,0.9\n", "row 2, field aperture_m: apertures not sorted"),
    ("aperture_m,passing_fraction\n0.001,0.5\n0.002,0.4\n", "row 2, field passing_fraction: decreases"),
    ("aperture_m,passing_fraction\n0.001,0.5\n0.002,1.2\n", "row 2, field passing_fraction: above 1"),
    ("aperture_m,passing_fraction,sigma\n0.001,0.5,-0.01\n0.002,1,0.01\n", "row 1, field sigma: must not be negative"),
    ("aperture_m,passing_fraction,sigma\n0.001,0.5,0\n0.002,1,0.01\n", "row 1, field sigma: a standard error of a "
                                                                          "fraction must be >= 1e-06"),
    ("aperture_m,passing_fraction,sigma\n0.001,0.5,0.01\n0.002,1,1e-300\n", "row 2, field sigma: a standard error"),
    ("aperture_m,passing_fraction,sigma,sigma\n0.001,0.5,0.01,0.01\n0.002,1,0.01,0.01\n", "names a column twice"),
    ("aperture_m,passing_fraction\n" + "0.001,0.5\n" * 100_000, "is not a sieve analysis"),
    ("aperture_m,passing_fraction\n1.0,0.5\n2.0,1\n", "column aperture_m: an aperture of 2 m is larger than any "
                                                     "granulator's granule (at most 0.1 m is read as metres): the file "
                                                     "is likely in millimetres"),
    ("lower_m,upper_m,mass_fraction\n0,500,0.5\n500,1000,0.5\n", "column upper_m: an aperture of 1000 m is larger "
                                                                 "than any granulator's granule (at most 0.1 m is read "
                                                                 "as metres): the file is likely in micrometres"),
])
def test_every_malformed_measured_file_is_refused_in_one_line(tmp_path, text, words):
    path = _write(tmp_path, text)
    with pytest.raises(ParameterError) as info:
        ga.read_sieve_csv(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and words in message, message


def test_the_command_line(tmp_path, capsys):
    from granalytics.cli import main

    run = str(DATASET_DIR / "lab-cg3.h5")
    measured = str(DATASET_DIR / "sieve" / "example-sieve.csv")
    out = tmp_path / "cal"
    argv = ["calibrate", run, "--measured", measured, "--c-agg", "0.3,0.6", "--a-agg-deg", "20,40", "--window", "3:4",
            "--bootstrap", "20", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "best: C_agg" in printed
    names = {p.name for p in out.iterdir()}
    assert names == {"calibration_grid.csv", "calibration_distributions.csv", "calibration.json",
                     "calibration_objective.png", "calibration_distributions.png"}
    saved = json.loads((out / "calibration.json").read_text())
    assert saved["settings"]["measure"] == "volume" and "region" in saved
    assert main(argv) == 2  # not replaced without --overwrite
    assert "exists" in capsys.readouterr().err
    assert main(argv + ["--overwrite"]) == 0
    bad = _write(tmp_path, "lower_m,upper_m,mass_fraction\n0,0.001,0.5\n0.001,0.002,0.4\n")
    assert main(["calibrate", run, "--measured", str(bad), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sum to 0.9" in err[0]
    assert not (tmp_path / "x").exists()


def test_arguments_are_refused_at_the_function_the_user_called_naming_parameter_and_value():
    with ga.open_run(DATASET_DIR / "lab-cg3.h5") as run:
        snapshot = run[-1]
    free = np.full(snapshot.n_particles, -1)
    edges = "edges_m must be a sequence of two or more ascending sizes >= 0 [m] or a MeasuredDistribution, got list"
    for bad in ([2e-3, 1e-3], [0, np.nan, 1e-3], [-1e-3, 1e-3], [1e-3]):
        with pytest.raises(ParameterError, match=rf"^size_class_fractions: {re.escape(edges)} \["):
            ga.size_class_fractions(snapshot, free, bad)
    with pytest.raises(ParameterError, match=r"^MeasuredDistribution: fractions must be a pair of numbers in \[0, 1\], "
                                             r"got list \[1.0\]$"):
        ga.MeasuredDistribution(edges_m=[0, 1e-3, 2e-3], fractions=[1.0])
    with pytest.raises(ParameterError, match="^MeasuredDistribution.from_classes: lower_m, upper_m, mass_fraction and "
                                             "sigma must hold one value per class, got 2, 2, 1 values$"):
        ga.MeasuredDistribution.from_classes([0, 1e-3], [1e-3, 2e-3], [1.0])
    measured = ga.read_sieve_csv(DATASET_DIR / "sieve" / "example-sieve.csv")
    with pytest.raises(ParameterError, match="^calibrate_thresholds: measure must be one of 'volume', 'width', got str "
                                             "'diameter'$"):
        ga.calibrate_thresholds([], measured, [0.5], [20.0], measure="diameter")
    with pytest.raises(ParameterError, match=r"^calibrate_thresholds: c_agg must be a number >= 0 or a sequence of "
                                             r"numbers >= 0, got list \[-0.5\]$"):
        ga.calibrate_thresholds([], measured, [-0.5], [20.0])


def test_a_measured_file_that_is_a_fifo_is_refused_not_waited_on(tmp_path):
    import os

    fifo = tmp_path / "sieve.csv"
    os.mkfifo(fifo)
    with pytest.raises(ParameterError, match="sieve.csv"):
        ga.read_sieve_csv(fifo)


def test_statistics_that_would_mean_nothing_and_grids_that_cannot_fit_are_refused_before_the_work(cg1_grid, cg1_frames):
    measured = grid_measurement(cg1_grid, 0.6, 20.0, noise=0.01, seed=0)
    with pytest.raises(ParameterError, match="block_rev = 1e\\+300 revolutions: the bootstrap needs blocks shorter"):
        ga.calibrate_thresholds(cg1_grid, measured, C_GRID, A_GRID, block_rev=1e300, n_boot=20)
    with pytest.raises(ParameterError, match="would need .* of memory"):
        ga.calibrate_thresholds(cg1_grid, measured, np.linspace(0.1, 0.9, 10_000), np.linspace(5, 60, 10_000), n_boot=20)
    with pytest.raises(ParameterError, match="would need .* of memory"):
        ga.calibrate_thresholds(cg1_grid, measured, C_GRID, A_GRID, n_boot=10**12)
    edges = np.array([0, 2e-3, 4e-3])
    two = ga.MeasuredDistribution(edges_m=edges, fractions=np.array([0.5, 0.5]), source="two edges")
    grid = ga.size_class_grid(cg1_frames[::8], edges, C_GRID, A_GRID)
    with pytest.raises(ParameterError, match="gives 2 class edge\\(s\\) to compare at and the fit has 2 free"):
        ga.calibrate_thresholds(grid, two, C_GRID, A_GRID, n_boot=20)
