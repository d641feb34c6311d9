"""The population balance (granalytics.analysis.population_balance): closed forms of Smoluchowski's equation
(constant and sum kernels) and of random scission, conservation of primary particles, the fixed
pivot discretisation, the rates measured on tracked granules, and the ``pbm`` command."""

from itertools import product

import numpy as np
import pandas as pd
import pytest
from scipy.special import gammaln

import granalytics as ga
from granalytics.cli import main

N0 = 1000.0


def constant_exact(k, t, kernel, n0=N0):
    """Discrete Smoluchowski, constant kernel, monodisperse start: N_k = N0 T^(k-1)/(1+T)^(k+1), T = K N0 t/2."""
    big_t = kernel * n0 * np.asarray(t)[:, None] / 2
    return n0 * np.exp((k - 1) * np.log(np.maximum(big_t, 1e-300)) - (k + 1) * np.log1p(big_t))


def sum_exact(k, t, b, n0=N0):
    """Discrete Smoluchowski, kernel b(i + j), monodisperse start: N_k = N0 (1-τ)(kτ)^(k-1) e^(-kτ)/k!, τ = 1 - e^(-b N0 t)."""
    tau = 1 - np.exp(-b * n0 * np.asarray(t))[:, None]
    return n0 * (1 - tau) * np.exp((k - 1) * np.log(np.maximum(k * tau, 1e-300)) - k * tau - gammaln(k + 1))


def scission_exact(j, t, lam, x0):
    """Random scission of x0-particle chains, every bond breaking at rate λ: N_j = q^(j-1)(2p + (x0-j-1)p²), p = 1 - q = 1 - e^(-λt)."""
    q = np.exp(-lam * np.asarray(t))[:, None]
    p = 1 - q
    out = q ** (j - 1) * (2 * p + (x0 - j - 1) * p ** 2)
    out[:, -1] = q[:, 0] ** (x0 - 1)
    return out


def test_constant_kernel_on_all_integers_is_the_discrete_closed_form():
    grid = np.arange(1, 121)
    kernel = 1.0 / N0
    t = np.linspace(0, 6 / (kernel * N0), 5)  # T = K N0 t / 2 up to 3: mean size 4
    r = ga.population_balance(kernel, None, {1: N0}, t, grid=grid)
    exact = constant_exact(grid, t, kernel)
    big = exact > 1e-6 * N0
    assert r.success
    np.testing.assert_allclose(r.numbers[big], exact[big], rtol=1e-5)
    np.testing.assert_allclose(r.moment(0), N0 / (1 + kernel * N0 * t / 2), rtol=1e-7)
    assert r.mass_error < 1e-10


def test_sum_kernel_on_all_integers_is_the_discrete_closed_form():
    grid = np.arange(1, 401)
    b = 1e-3 / N0
    t = np.array([0.0, 0.3, 0.6]) / (b * N0)  # τ up to 0.45
    r = ga.population_balance(lambda x, y: b * (x + y), None, {1: N0}, t, grid=grid)
    exact = sum_exact(grid, t, b)
    big = exact > 1e-6 * N0
    np.testing.assert_allclose(r.numbers[big], exact[big], rtol=1e-4)
    np.testing.assert_allclose(r.moment(0), N0 * np.exp(-b * N0 * t), rtol=1e-7)
    np.testing.assert_allclose(r.moment(2), N0 / (1 - (1 - np.exp(-b * N0 * t))) ** 2, rtol=1e-4)  # M2 = N0/(1-τ)²
    assert r.mass_error < 1e-10


@pytest.mark.parametrize("case", ["constant", "sum"])
def test_geometric_grid_keeps_number_and_mass_and_converges_to_the_closed_form(case):
    n0, top = 1e4, 20000
    k = np.arange(1, top + 1)
    if case == "constant":
        kernel, t_end = 1.0 / n0, 2 * 50.0   # T = 50: mean size 51
        exact = constant_exact(k, [t_end], kernel, n0)[0]
        m0 = n0 / (1 + 50.0)
    else:
        b = 1.0 / n0 ** 2
        kernel, t_end = (lambda x, y: b * (x + y)), -np.log(1 - 0.6) / (b * n0)  # τ = 0.6
        exact = sum_exact(k, [t_end], b, n0)[0]
        m0 = n0 * 0.4
    errors, ks = [], []
    for ratio in (2 ** 0.5, 2 ** 0.25, 2 ** 0.125):
        grid = ga.pbm_grid(top, ratio)
        r = ga.population_balance(kernel, None, {1: n0}, [0.0, t_end], grid=grid)
        projected = ga.project_counts(exact, grid)
        bulk = projected > 1e-3 * projected.max()
        errors.append(np.max(np.abs(r.numbers[-1] - projected)[bulk] / projected[bulk]))
        ks.append(ga.ks_distance(r.numbers[-1], projected, grid, min_size=1))
        # the fixed pivot technique keeps the number of every event: M0 is exact for these kernels
        assert r.moment(0)[-1] == pytest.approx(m0, rel=1e-6)
        assert r.mass_error < 1e-10
        if ratio == 2 ** 0.25:
            m2_exact = float(exact @ k.astype(float) ** 2)
            assert r.moment(2)[-1] == pytest.approx(m2_exact, rel=0.03 if case == "constant" else 0.06)
    assert errors[0] > errors[1] > errors[2]  # refining the grid brings the density to the closed form
    assert errors[2] < 0.15 and ks[1] < 0.005 and ks[2] < ks[1]


def test_random_scission_is_the_closed_form_of_pure_breakage():
    lam, x0 = 0.1, 200
    grid = np.arange(1, x0 + 1)
    t = np.linspace(0, 5, 6)
    selection = lambda x: lam * (x - 1)  # noqa: E731 - one bond in x - 1 breaks at the rate λ
    r = ga.population_balance(None, selection, {x0: 1.0}, t, grid=grid, rtol=1e-10, atol=1e-14)
    exact = scission_exact(grid, t, lam, x0)
    big = exact > 1e-4
    np.testing.assert_allclose(r.numbers[big], exact[big], rtol=1e-5)
    # on the geometric grid the number of fragments is exact: M0 = 1 + (x0 - 1) p
    g = ga.population_balance(None, selection, {x0: 1.0}, t, grid=ga.pbm_grid(x0), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(g.moment(0), 1 + (x0 - 1) * (1 - np.exp(-lam * t)), rtol=1e-8)
    assert r.mass_error < 1e-12 and g.mass_error < 1e-12


def test_every_mechanism_together_keeps_the_primary_particles():
    rng = np.random.default_rng(3)
    n = 3000
    grid = ga.pbm_grid(n)
    a = rng.uniform(0.5, 2, grid.size)
    beta = np.outer(a, a) * 1e-3
    table = dict(zip(grid.tolist(), range(grid.size)))

    def kernel(x, y):
        return beta[np.vectorize(table.get)(np.broadcast_to(x, np.broadcast(x, y).shape).astype(int)),
                    np.vectorize(table.get)(np.broadcast_to(y, np.broadcast(x, y).shape).astype(int))]

    initial = ga.size_counts(rng.integers(2, 40, 60), n)
    r = ga.population_balance(kernel, lambda x: 0.2 * np.log(x), initial, np.linspace(0, 20, 11),
                              layering=lambda x: 2e-4 * x ** 0.5, erosion=lambda x: 0.3 * x ** (2 / 3),
                              n_fragments=3.4, min_fragment=2)
    assert r.success
    assert r.mass_error < 1e-10
    m0 = r.moment(0)
    assert abs(m0[-1] - m0[0]) > 0.05 * m0[0]  # the population did change
    assert r.numbers.min() > -1e-6 * n
    assert r.moment(1)[0] == pytest.approx(n)
    # the explicit method, without the Jacobian, agrees: the Jacobian is the right-hand side's
    e = ga.population_balance(kernel, lambda x: 0.2 * np.log(x), initial, np.linspace(0, 20, 11),
                              layering=lambda x: 2e-4 * x ** 0.5, erosion=lambda x: 0.3 * x ** (2 / 3),
                              n_fragments=3.4, min_fragment=2, method="RK45")
    np.testing.assert_allclose(e.numbers, r.numbers, rtol=1e-4, atol=1e-6 * n)


def test_the_jacobian_is_the_derivative_of_the_right_hand_side():
    grid = ga.pbm_grid(500)
    r = ga.population_balance(lambda x, y: 1e-3 * (x * y) ** 0.3, lambda x: 0.1 * x ** 0.5,
                              ga.size_counts([3, 5, 8, 40], 500), [0, 1.0], layering=1e-3, erosion=0.2,
                              n_fragments=2.5, min_fragment=2)
    rhs, jac = r.info["rhs"], r.info["jac"]
    state = r.numbers[-1] + 0.3
    numeric = np.empty((grid.size, grid.size))
    h = 1e-6
    for m in range(grid.size):
        e = np.zeros(grid.size)
        e[m] = h
        numeric[:, m] = (rhs(0, state + e) - rhs(0, state - e)) / (2 * h)
    np.testing.assert_allclose(jac(0, state), numeric, rtol=1e-6, atol=1e-9)
    # and every column of it keeps the mass: Σ x J[:, m] = 0
    assert np.abs(grid @ jac(0, state)).max() < 1e-10 * np.abs(jac(0, state)).max() * grid.max()


@pytest.mark.parametrize("x,nu,m", [(10, 2, 1), (10, 3, 2), (12, 4, 2), (9, 3, 3), (7, 2, 2)])
def test_uniform_fragments_are_every_composition_equally_likely(x, nu, m):
    """Expected fragment counts of a breakage into ν parts of >= m particles, against enumeration."""
    from granalytics.analysis.population_balance.model import _composition_fragments

    comps = [c for c in product(range(m, x + 1), repeat=nu) if sum(c) == x]
    expected = np.zeros(x)
    for c in comps:
        for s in c:
            expected[s - 1] += 1 / len(comps)
    np.testing.assert_allclose(_composition_fragments(x, nu, m), expected, rtol=1e-12, atol=1e-14)


def test_a_pair_cannot_break_into_fragments_of_two():
    r = ga.population_balance(None, 1.0, {2: 10.0, 3: 5.0, 4: 5.0}, [0, 40.0], grid=np.arange(1, 13), min_fragment=2)
    assert r.info["unbreakable_sizes"][:2] == [2, 3]
    np.testing.assert_allclose(r.numbers[-1, 1], 10 + 2 * 5, rtol=1e-6)  # the 4s became pairs, the 2s stayed
    assert r.numbers[-1, 2] == pytest.approx(5.0, rel=1e-6)


def test_the_projection_keeps_number_and_mass():
    grid = ga.pbm_grid(1000, 2 ** 0.5)
    rng = np.random.default_rng(0)
    counts = rng.poisson(3, 1000).astype(float)
    projected = ga.project_counts(counts, grid)
    sizes = np.arange(1, 1001)
    assert projected.sum() == pytest.approx(counts.sum(), rel=1e-13)
    assert projected @ grid == pytest.approx(counts @ sizes, rel=1e-13)
    assert ga.pbm_grid(3000)[:8].tolist() == list(range(1, 9)) and ga.pbm_grid(3000)[-1] == 3000


def _toy_tracks():
    """Six particles over four frames 1 s apart: a pair layers one particle (frame 1), two free
    particles nucleate (frame 2), the triple erodes one (frame 3)."""
    ids = [np.arange(6)] * 4
    labels = [np.array([0, 0, -1, -1, -1, -1]), np.array([0, 0, 0, -1, -1, -1]),
              np.array([0, 0, 0, 1, 1, -1]), np.array([0, 0, -1, 1, 1, -1])]
    return ga.track_granules(labels, ids, [0.0, 1.0, 2.0, 3.0])


def test_rates_refuse_tracks_with_granules_of_one_particle():
    """A granule of one particle is a free particle to the population balance (its size class 1)."""
    ids = [np.arange(4)] * 2
    labels = [np.array([0, 0, 1, -1]), np.array([0, 0, 1, 1])]
    with pytest.raises(ga.ParameterError, match="fit_pbm_rates: the tracks hold granules of one particle"):
        ga.fit_pbm_rates(ga.track_granules(labels, ids, [0.0, 1.0]), 4)


def test_rates_from_tracks_are_the_hand_counted_ones():
    rates = ga.fit_pbm_rates(_toy_tracks(), 6, size_bins=[2, 3, 4])
    c = rates.classes.set_index("size_min")
    free_mean = (4 + 3 + 1) / 3
    assert rates.free_mean == pytest.approx(free_mean)
    assert c.loc[1, "n_layering"] == 1 and c.loc[1, "layering_per_s"] == pytest.approx(1 / 3 / (free_mean ** 2 / 2))
    assert c.loc[2, "n_layering"] == 1 and c.loc[2, "layering_per_s"] == pytest.approx(1 / 3 / (free_mean * 2 / 3))
    assert c.loc[3, "n_erosion"] == 1 and c.loc[3, "erosion_per_s"] == pytest.approx(1 / 3 / (2 / 3))
    assert c.loc[2, "n_erosion"] == 0 and c["n_breakage"].sum() == 0
    # the tables drive the model: the pivots read their class's rate
    r = rates.predict(ga.size_counts([2], 6), [0, 1.0], grid=np.arange(1, 7))
    assert r.info["beta"][0, 1] == pytest.approx(c.loc[2, "layering_per_s"])
    assert r.info["beta"][0, 0] == pytest.approx(c.loc[1, "layering_per_s"])
    assert r.info["erosion"][2] == pytest.approx(c.loc[3, "erosion_per_s"])
    assert r.info["erosion"][3] == pytest.approx(c.loc[3, "erosion_per_s"])  # above the table: its largest class
    assert r.mass_error < 1e-12


def test_a_kernel_table_gives_zero_to_free_particles_and_nan_cells():
    kernel = pd.DataFrame({"size_min_i": [2, 2, 4], "size_max_i": [3, 3, 7], "size_min_j": [2, 4, 4],
                           "size_max_j": [3, 7, 7], "beta_per_s": [1.0, 2.0, np.nan]})
    r = ga.population_balance(kernel, None, {2: 3.0, 5: 1.0}, [0, 1e-3], grid=np.arange(1, 21))
    beta = r.info["beta"]
    assert beta[0].max() == 0 and beta[1, 2] == 1.0 and beta[1, 4] == 2.0 and beta[4, 4] == 0 and beta[1, 10] == 2.0
    z = ga.population_balance(kernel, None, {2: 3.0, 5: 1.0}, [0, 1e-3], grid=np.arange(1, 21), extrapolate="zero")
    assert z.info["beta"][1, 10] == 0


@pytest.mark.parametrize("kwargs,match", [
    ({"kernel": -1.0}, r"^population_balance: kernel must be a table, a callable, a number >= 0 or None, got float -1.0$"),
    ({"kernel": lambda x, y: -x * y}, "kernel must be finite and >= 0"),
    ({"kernel": lambda x, y: x + 2 * y}, "symmetric"),
    ({"t": [1.0, 0.5]}, r"^population_balance: t must be at least two increasing times \[s\], got \[1.0, 0.5\]$"),
    ({"t": [0.0]}, "at least two"),
    ({"t": [0.0, float("nan")]}, "t must be a sequence of finite numbers"),
    ({"initial": [1.0, -2.0]}, "initial must be a sequence of numbers >= 0 or a dict"),
    ({"initial": {2: -1.0}}, "initial: the numbers of granules must be finite and >= 0"),
    ({"grid": [2, 3, 4]}, "starting at 1"),
    ({"grid": [1, 2]}, "above the grid's largest pivot"),
    ({"min_fragment": 0}, "min_fragment must be a whole number"),
    ({"erosion": "fast"}, "erosion must be a table"),
    ({"n_fragments": 1.5}, "n_fragments must be a number >= 2 or a callable, got float 1.5"),
    ({"n_fragments": lambda x: x / x, "breakage": 1.0}, "n_fragments must be >= 2"),
    ({"extrapolate": "linear"}, "extrapolate must be"),
])
def test_invalid_arguments_are_named(kwargs, match):
    args = {"kernel": 1.0, "breakage": None, "initial": [4.0, 2.0, 1.0], "t": [0.0, 1.0], **kwargs}
    with pytest.raises(ga.ParameterError, match=match):
        ga.population_balance(args.pop("kernel"), args.pop("breakage"), args.pop("initial"), args.pop("t"), **args)


def test_the_pbm_of_a_dem_run_keeps_its_particles_and_stays_near_it():
    """lab-cg3 (111 particles): rates on revolutions [1, 2], prediction of [2, 6]."""
    from granalytics.datasets import open_dataset

    with open_dataset("lab-cg3") as run:
        pred = ga.pbm_from_run(run, (1, 2), (2, 6))
        n = run.meta.n_particles
    assert pred.pbm.success and pred.pbm.mass_error < 1e-10
    table = pred.summary()
    assert table["dem_yield_fraction"].iloc[0] == table["pbm_yield_fraction"].iloc[0]
    assert table["ks_d"].iloc[0] == 0
    # every DEM frame holds the run's particles on the grid
    np.testing.assert_allclose(pred.dem_numbers @ pred.pbm.grid, n)
    # the prediction stays within the DEM's own frame-to-frame spread of the yield
    spread = table["dem_yield_fraction"].std()
    assert abs(table["pbm_yield_fraction"].iloc[-1] - table["dem_yield_fraction"].mean()) < 3 * spread
    long = pred.distributions()
    assert set(long["source"]) == {"dem", "pbm"} and len(long) == 2 * pred.pbm.numbers.size
    # the cumulative number distributions of granules at the frames nearest the revolutions asked
    cumulative = pred.cumulative_fractions([2.0, 4.04])
    nearest = pred.revolutions[np.argmin(np.abs(pred.revolutions - 4.04))]
    assert cumulative.groupby(["revolution", "source"], sort=False).ngroups == 4
    assert cumulative["revolution"].unique().tolist() == [pred.revolutions[0], nearest]
    assert (cumulative["size"] >= 2).all()
    for _, part in cumulative.groupby(["revolution", "source"]):
        assert (np.diff(part["fraction"]) >= -1e-12).all() and part["fraction"].iloc[-1] == pytest.approx(1.0)
    first_dem = cumulative[(cumulative["source"] == "dem") & (cumulative["revolution"] == pred.revolutions[0])]
    granules = pred.dem_numbers[0][pred.pbm.grid >= 2]
    np.testing.assert_allclose(first_dem["fraction"], np.cumsum(granules) / granules.sum())


def test_pbm_command_writes_its_outputs_and_refuses_to_replace_them(tmp_path, capsys):
    from granalytics.datasets import dataset_path

    run = str(dataset_path("lab-cg3"))
    out = tmp_path / "pbm"
    argv = ["pbm", run, "--fit-window", "1:2", "--predict", "2:4", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    names = {"kernel.csv", "rates.csv", "distributions.csv", "summary.csv", "settings.json", "pbm.png"}
    assert names <= {p.name for p in out.iterdir()}
    summary = pd.read_csv(out / "summary.csv")
    assert summary["revolution"].iloc[-1] == pytest.approx(4, abs=0.01)
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "--overwrite" in err and len(err.splitlines()) == 1
    assert main(argv + ["--overwrite"]) == 0
    assert main(["pbm", run, "--fit-window", "3:4", "--predict", "2:4", "--out", str(out), "--overwrite"]) == 2
    assert "starts before --fit-window" in capsys.readouterr().err
    assert main(["pbm", run, "--fit-window", "1:1.01", "--predict", "2:4", "--out", str(out), "--overwrite"]) == 2
    assert "at least two are needed" in capsys.readouterr().err


def test_the_dem_side_refuses_its_arguments_at_the_door(tmp_path):
    """fit_pbm_rates and pbm_from_run name the argument before any frame is identified."""
    from granalytics.datasets.synthetic import write_synthetic_run

    tracks = ga.track_granules([[0, 0, -1], [0, 0, 0]], [[1, 2, 3], [1, 2, 3]], [0.0, 1.0])
    with pytest.raises(ga.ParameterError, match=r"^fit_pbm_rates: n_particles must be a whole number >= 1, got int 0$"):
        ga.fit_pbm_rates(tracks, 0)
    with pytest.raises(ga.ParameterError, match="^pbm_from_run: run must be an open run"):
        ga.pbm_from_run("run.h5", (1, 2), (2, 6))
    with ga.open_run(write_synthetic_run(tmp_path / "r.h5", 50, revolutions=1.0, frames_per_revolution=4)) as run:
        with pytest.raises(ga.ParameterError, match=r"^pbm_from_run: predict_window must be a pair of finite numbers "
                                                    r"\(lo, hi\) with lo <= hi, got tuple \(6, 2\)$"):
            ga.pbm_from_run(run, (0, 1), (6, 2))
