"""Population balance over granule size, fed by the rates measured on tracked DEM granules.

The state is the number of granules N(x) of each size x (primary particles per granule) in the
whole system (the drum), free primary particles included as the size x = 1. The mechanisms are
those the tracking measures (``docs/tracking.md``), each a binary or fragmenting event:

- **coalescence** of two granules of sizes x and y at the rate β(x, y)·N(x)·N(y) (½β·N(x)² for
  x = y) [1/s]: β as in :func:`granalytics.coalescence_kernel` [1/s per pair of granules];
- **layering**: a free particle joins a granule of size x at the rate λ(x)·N(1)·N(x) [1/s] (a
  coalescence with x = 1); λ(1) is **nucleation**, two free particles forming a pair, at the rate
  ½λ(1)·N(1)²;
- **breakage** of a granule of size x at the rate S(x)·N(x) [1/s] into ν fragments of at least
  ``min_fragment`` particles each, every composition of x into ν such parts equally likely (for
  ν = 2 and ``min_fragment`` 1: a cut at a uniformly random bond, random scission); S and ν as in
  :func:`granalytics.breakage_rate`;
- **erosion**: a granule of size x loses one particle to the free state at the rate E(x)·N(x)
  [1/s] (a pair that erodes becomes two free particles).

The equations are discretised on a grid of integer pivots (every integer up to where the
geometric grid's spacing exceeds one, geometric with the given ratio beyond; :func:`pbm_grid`)
with the **fixed pivot technique** of Kumar & Ramkrishna (1996): a granule of size v between the
pivots x_k ≤ v < x_{k+1} is counted as a fraction (x_{k+1} − v)/(x_{k+1} − x_k) at x_k and the rest
at x_{k+1}, which keeps both its number and its mass. Every event therefore changes the number of
granules by exactly what it should (−1 for a coalescence, ν − 1 for a breakage) and conserves the
primary particles exactly; on a grid of all integers the scheme is the discrete equation itself.
Coalescences whose product would be larger than the grid's top pivot (the system's particle
count, for a DEM) are not allowed. The equations are integrated with
:func:`scipy.integrate.solve_ivp` (BDF with the exact Jacobian by default).

:func:`fit_pbm_rates` measures every rate from a :class:`granalytics.GranuleTracks`;
:func:`size_counts` and :func:`project_counts` put a DEM frame's granules on the grid;
:func:`ks_distance` compares two distributions on it. ``docs/population_balance.md`` has the
model, the tests against closed forms and the prediction of the bundled DEM runs.

Units: time in seconds; granule sizes in primary particles (of the run: CG particles in a CG run);
numbers of granules in the whole system (not per volume).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.analysis.population_balance.grid import (GRID, RATIO, check_grid, distribution_summary, pbm_grid,
                                                          pivot_weights, project_counts)
from granalytics.base.errors import ParameterError
from granalytics.base.validation import POSITIVE, Array, Callable, Instance, Interval, Options, validate_params


#: the value columns of a per-class rate table that each mechanism reads
_TABLE_COLUMNS = {"breakage": "selection_rate_per_s", "layering": "layering_per_s", "erosion": "erosion_per_s"}


def _class_lookup(table, name, extrapolate):
    """Pivot sizes -> class index of a table with size_min/size_max columns (-1: no class)."""
    for col in ("size_min", "size_max"):
        if col not in table.columns:
            raise ParameterError(f"{name}: the table has no column {col!r} (expected the output of "
                                 f"{'breakage_rate' if name == 'breakage' else 'fit_pbm_rates'})")
    lo = table["size_min"].to_numpy(dtype=np.int64)
    hi = table["size_max"].to_numpy(dtype=np.int64)
    order = np.argsort(lo)
    lo, hi = lo[order], hi[order]
    if (lo[1:] <= hi[:-1]).any():
        raise ParameterError(f"{name}: the table's size classes overlap")

    def classify(x):
        x = np.asarray(x, dtype=np.int64)
        c = np.searchsorted(lo, x, side="right") - 1
        inside = (c >= 0) & (x <= hi[np.clip(c, 0, None)])
        if extrapolate == "nearest":
            inside |= x > hi[-1]
            c = np.where(x > hi[-1], lo.size - 1, c)
        return np.where(inside & (c >= 0), order[np.clip(c, 0, None)], -1)

    return classify


def _values(spec, name, column, grid, extrapolate):
    """A per-size rate at the pivots from a table, a callable or a number (None: zeros)."""
    if spec is None:
        return np.zeros(grid.size)
    if isinstance(spec, pd.DataFrame):
        if column not in spec.columns:
            raise ParameterError(f"{name}: the table has no column {column!r}")
        classify = _class_lookup(spec, name, extrapolate)
        values = spec[column].to_numpy(dtype=float)
        c = classify(grid)
        out = np.where(c >= 0, values[np.clip(c, 0, None)], 0.0)
        return np.nan_to_num(out, nan=0.0)
    if not callable(spec):
        return np.full(grid.size, float(spec))  # a number >= 0 (population_balance's constraints)
    out = np.broadcast_to(np.asarray(spec(grid.astype(float)), dtype=float), grid.shape).copy()
    if not np.isfinite(out).all() or (out < 0).any():
        bad = int(np.nonzero(~np.isfinite(out) | (out < 0))[0][0])
        raise ParameterError(f"{name} must be finite and >= 0, got {out[bad]!r} at size {grid[bad]}")
    return out


def _kernel_matrix(kernel, grid, extrapolate):
    """β at every pair of pivots [1/s per pair]; a table gives zero below its smallest class."""
    g = grid.size
    if kernel is None:
        return np.zeros((g, g))
    if isinstance(kernel, pd.DataFrame):
        need = ("size_min_i", "size_max_i", "size_min_j", "size_max_j", "beta_per_s")
        missing = [c for c in need if c not in kernel.columns]
        if missing:
            raise ParameterError(f"kernel: the table has no column {missing[0]!r} (expected the output of "
                                 "coalescence_kernel)")
        classes = (pd.concat([kernel[["size_min_i", "size_max_i"]].set_axis(["size_min", "size_max"], axis=1),
                              kernel[["size_min_j", "size_max_j"]].set_axis(["size_min", "size_max"], axis=1)])
                   .drop_duplicates().sort_values("size_min").reset_index(drop=True))
        classify = _class_lookup(classes, "kernel", extrapolate)
        nc = len(classes)
        index = {lo: i for i, lo in enumerate(classes["size_min"])}
        table = np.zeros((nc, nc))
        ci = kernel["size_min_i"].map(index).to_numpy()
        cj = kernel["size_min_j"].map(index).to_numpy()
        beta = np.nan_to_num(kernel["beta_per_s"].to_numpy(dtype=float), nan=0.0)
        table[ci, cj] = beta
        table[cj, ci] = beta
        c = classify(grid)
        ok = c >= 0
        out = np.zeros((g, g))
        out[np.ix_(ok, ok)] = table[np.ix_(c[ok], c[ok])]
        return out
    if not callable(kernel):
        return np.full((g, g), float(kernel))  # a number >= 0 (population_balance's constraints)
    x = grid.astype(float)
    out = np.broadcast_to(np.asarray(kernel(x[:, None], x[None, :]), dtype=float), (g, g)).copy()
    if not np.isfinite(out).all() or (out < 0).any():
        i, j = (int(v[0]) for v in np.nonzero(~np.isfinite(out) | (out < 0)))
        raise ParameterError(f"kernel must be finite and >= 0, got {out[i, j]!r} at sizes ({grid[i]}, {grid[j]})")
    if not np.allclose(out, out.T, rtol=1e-12, atol=0):
        raise ParameterError("kernel must be symmetric: β(x, y) = β(y, x)")
    return out


def _composition_fragments(x, nu, m):
    """Expected fragments of each size s = 1..x when a granule of x breaks into nu parts of >= m
    particles, every such composition equally likely."""
    from scipy.special import gammaln

    out = np.zeros(x)
    xp = x - nu * (m - 1)  # compositions of xp into nu parts >= 1, then m - 1 added to each part
    if nu < 2 or xp < nu:
        return None
    sp = np.arange(1, xp - nu + 2)  # part sizes in the shifted problem
    if nu == 2:
        p = np.full(sp.size, 1.0 / (xp - 1))
    else:
        def log_comb(n, k):
            return gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)

        p = np.exp(log_comb(xp - sp - 1, nu - 2) - log_comb(xp - 1, nu - 1))
    out[sp + m - 2] = nu * p
    return out


def _fragments_at(fragments, x, nu, m, name="fragments"):
    if fragments == "uniform":
        lo, hi = math.floor(nu), math.ceil(nu)
        f_lo = _composition_fragments(x, lo, m)
        f_hi = _composition_fragments(x, hi, m)
        if f_hi is None:
            return f_lo
        if f_lo is None or hi == lo:
            return f_hi
        w = nu - lo
        return (1 - w) * f_lo + w * f_hi
    out = np.asarray(fragments(int(x)), dtype=float)
    if out.shape != (x,) or not np.isfinite(out).all() or (out < 0).any():
        raise ParameterError(f"{name}({x}) must return {x} non-negative expected fragment counts (sizes 1..{x})")
    mass = float(np.dot(np.arange(1, x + 1), out))
    if abs(mass - x) > 1e-9 * x or out[-1] > 0:
        raise ParameterError(f"{name}({x}): the fragments must hold the granule's {x} particles in pieces "
                             f"smaller than it, they hold {mass:g}")
    return out


@dataclass(eq=False)
class PopulationBalance:
    """Solution of :func:`population_balance`.

    Attributes
    ----------
    grid : (G,) int64 array
        Pivots [particles per granule]; ``grid[0] == 1`` (free particles).
    t_s : (T,) float array
        Output times [s].
    numbers : (T, G) float array
        Number of granules at each pivot and time (whole system).
    success : bool
        The integrator reached the last time.
    message : str
        The integrator's message.
    nfev : int
        Evaluations of the right-hand side.
    info : dict
        The rates at the pivots (``beta`` (G, G) [1/s per pair, layering included in row and
        column 0], ``selection``, ``n_fragments``, ``erosion``), ``unbreakable_sizes`` (pivots with
        S > 0 too small for two fragments of ``min_fragment``) and the right-hand side ``rhs(t, N)``
        and its Jacobian ``jac(t, N)``.
    """

    grid: np.ndarray
    t_s: np.ndarray
    numbers: np.ndarray
    success: bool = True
    message: str = ""
    nfev: int = 0
    info: dict = field(default_factory=dict, repr=False)

    def moment(self, k) -> np.ndarray:
        """Σ x^k N(x) over all pivots (free particles included) at each time; k = 1: primary particles."""
        return self.numbers @ self.grid.astype(float) ** k

    @property
    def mass_error(self) -> float:
        """Largest relative change of the primary particles Σ x N(x) from the first time."""
        m1 = self.moment(1)
        return float(np.max(np.abs(m1 - m1[0])) / m1[0]) if m1[0] > 0 else 0.0

    def granules(self, min_size=2) -> np.ndarray:
        """Numbers of granules of at least ``min_size`` particles at each pivot and time (smaller pivots zero)."""
        return np.where(self.grid >= min_size, self.numbers, 0.0)

    def summary(self, min_size=2) -> pd.DataFrame:
        """Per time: ``t_s``, ``n_granules`` (granules of >= ``min_size`` particles), ``mean_size``
        (their mean size [particles]), ``yield_fraction`` (fraction of the primary particles in
        them), ``free`` (free particles) and ``mass`` (Σ x N(x))."""
        return distribution_summary(self.numbers, self.grid, self.t_s, min_size=min_size)


def _initial_counts(initial):
    """``initial`` as numbers of granules by size (``counts[s - 1]``: granules of s particles) and
    the primary particles they hold."""
    if isinstance(initial, dict):
        try:
            top = max(int(s) for s in initial) if initial else 0
            counts = np.zeros(max(top, 1))
            for s, v in initial.items():
                if int(s) != s or s < 1:
                    raise ValueError
                counts[int(s) - 1] += float(v)
        except (TypeError, ValueError):
            raise ParameterError("initial: the keys must be granule sizes >= 1 (particles) and the values numbers") from None
        if not np.isfinite(counts).all() or (counts < 0).any():
            raise ParameterError(f"initial: the numbers of granules must be finite and >= 0, got {initial!r}")
    else:
        counts = np.asarray(initial, dtype=float)
    mass0 = float(np.dot(np.arange(1, counts.size + 1), counts))
    if mass0 <= 0:
        raise ParameterError("initial holds no particle")
    return counts, mass0


def _pivots(grid, counts, mass0, n_max, ratio):
    """``grid`` checked, or (None) :func:`pbm_grid` up to ``n_max``, by default the ``mass0``
    primary particles of the initial ``counts``."""
    if grid is not None:
        return check_grid(grid)
    top = int(np.nonzero(counts)[0][-1]) + 1
    n_max = int(round(mass0)) if n_max is None else n_max
    if n_max < top:
        raise ParameterError(f"n_max must be >= the largest initial granule ({top}), got {n_max!r}")
    return pbm_grid(int(n_max), ratio)


def _coalescence_events(kernel, layering, grid, extrapolate):
    """Coalescence, layering and nucleation as pair events i <= j of pivots whose product fits on
    the grid: β at every pair of pivots (λ added in row and column 0) [1/s per pair], the pairs'
    pivot indices ``iu``, ``ju``, their rate coefficients (β, ½β for i = j) and the (G, P)
    stoichiometry of each event on the pivots (fixed pivot split of the product)."""
    x = grid.astype(float)
    beta = _kernel_matrix(kernel, grid, extrapolate)
    lam = _values(layering, "layering", _TABLE_COLUMNS["layering"], grid, extrapolate)
    beta[0, :] += lam
    beta[:, 0] += lam
    beta[0, 0] -= lam[0]  # added twice on the diagonal
    iu, ju = np.triu_indices(grid.size)
    product = x[iu] + x[ju]
    allowed = (product <= x[-1]) & (beta[iu, ju] > 0)
    iu, ju, product = iu[allowed], ju[allowed], product[allowed]
    coef = beta[iu, ju] * np.where(iu == ju, 0.5, 1.0)
    k, a, upper = pivot_weights(grid, product)
    p = iu.size
    stoich = np.zeros((grid.size, p))
    cols = np.arange(p)
    np.add.at(stoich, (iu, cols), -1.0)
    np.add.at(stoich, (ju, cols), -1.0)
    np.add.at(stoich, (k, cols), a)
    np.add.at(stoich, (upper, cols), 1 - a)
    return beta, iu, ju, coef, stoich


def _fragment_numbers(breakage, n_fragments, grid, extrapolate):
    """ν at the pivots: the breakage table's ``fragments_mean`` where it is >= 2, else
    ``n_fragments`` (a number or a function of size, >= 2)."""
    if callable(n_fragments):
        default_nu = _values(n_fragments, "n_fragments", None, grid, extrapolate)
        if (default_nu < 2).any():
            raise ParameterError(f"n_fragments must be >= 2, got {default_nu.min()!r}")
    else:
        default_nu = np.full(grid.size, float(n_fragments))
    if isinstance(breakage, pd.DataFrame) and "fragments_mean" in breakage.columns:
        measured = _values(breakage.assign(_nu=breakage["fragments_mean"]), "breakage", "_nu", grid, extrapolate)
        return np.where(measured >= 2, measured, default_nu)  # NaN (no breakage seen) reads as 0: the default
    return default_nu


def _breakage_operator(sel, nu, ero, fragments, min_fragment, grid):
    """Breakage (selection rate ``sel``, ν fragments) and erosion (rate ``ero``) as the (G, G)
    linear operator on the pivot numbers, and the pivots with S > 0 too small to break."""
    g = grid.size
    linear = np.zeros((g, g))
    unbreakable = []
    for i in range(1, g):
        xi = int(grid[i])
        if sel[i] > 0:
            frag = _fragments_at(fragments, xi, float(min(nu[i], xi // min_fragment)), min_fragment) \
                if fragments == "uniform" else _fragments_at(fragments, xi, None, min_fragment)
            if frag is None or not frag.any():
                unbreakable.append(xi)
            else:
                col = project_counts(frag, grid)
                linear[:, i] += sel[i] * col
                linear[i, i] -= sel[i]
        if ero[i] > 0:
            col = project_counts(np.bincount([xi - 1, 1], minlength=xi + 1)[1:].astype(float), grid)
            linear[:, i] += ero[i] * col
            linear[i, i] -= ero[i]
    return linear, unbreakable


def _rate_functions(stoich, coef, iu, ju, linear):
    """The right-hand side dN/dt(t, N) (pair events ``stoich``, ``coef``, ``iu``, ``ju`` and the
    ``linear`` operator) and its exact Jacobian."""

    def rhs(_t, n):
        return stoich @ (coef * n[iu] * n[ju]) + linear @ n

    def jac(_t, n):
        j = linear.copy()
        w_i = stoich * (coef * n[ju])  # d rate / d n_i
        w_j = stoich * (coef * n[iu])
        np.add.at(j.T, iu, w_i.T)
        np.add.at(j.T, ju, w_j.T)
        return j

    return rhs, jac


#: the constraints of a rate: a per-class table, a function of size or a number (None: no such events)
_RATE = [Instance(pd.DataFrame, "a table"), Callable(), Interval(Real, 0, None), None]


@validate_params({
    "kernel": _RATE, "breakage": _RATE, "layering": _RATE, "erosion": _RATE,
    "n_fragments": [Interval(Real, 2, None), Callable()],
    "initial": [Array(ndim=1, within=Interval(Real, 0, None)), Instance(dict, "a dict {size: number}")],
    "t": [Array(ndim=1, finite=True)], "fragments": [Options(("uniform",)), Callable()],
    "min_fragment": [Interval(Integral, 1, None)], "grid": [GRID, None], "ratio": [RATIO],
    "n_max": [Interval(Integral, 1, None), None], "extrapolate": [Options(("nearest", "zero"))], "rtol": [POSITIVE],
    "atol": [POSITIVE, None]})
def population_balance(kernel, breakage, initial, t, *, layering=None, erosion=None, fragments="uniform",
                       n_fragments=2.0, min_fragment=1, grid=None, ratio=2 ** 0.25, n_max=None,
                       extrapolate="nearest", method="BDF", rtol=1e-8, atol=None) -> PopulationBalance:
    """Integrate the population balance of granule sizes (coalescence, breakage, layering, erosion).

    dN_k/dt = ½ Σ_{i,j} η_k(x_i + x_j) β_ij N_i N_j − N_k Σ_j β_kj N_j
              + Σ_i n_{k,i} S_i N_i − S_k N_k + (erosion, as a breakage into {x − 1, 1} at E(x))

    on the pivots x_k of ``grid``, where η_k splits a product between its two neighbouring pivots
    and n_{k,i} collects the fragments of a pivot-i granule at pivot k, both by the fixed pivot
    technique (Kumar & Ramkrishna 1996), so that number and mass are kept event by event. Layering
    is the coalescence of a free particle (x = 1) with a granule: λ(x) is added to β(1, x).

    Parameters
    ----------
    kernel : DataFrame, callable, float or None
        Coalescence kernel β [1/s per pair of granules]. A table from
        :func:`granalytics.coalescence_kernel` (``beta_per_s`` of each class pair; zero for
        sizes below its smallest class, i.e. free particles, and for NaN cells), a function
        ``beta(x, y)`` of two broadcastable float arrays of sizes [particles], or a constant.
        None: no coalescence (layering aside).
    breakage : DataFrame, callable, float or None
        Selection rate S(x) [1/s per granule]. A table from :func:`granalytics.breakage_rate`
        (``selection_rate_per_s``; its ``fragments_mean``, where given, sets ν of each class) or
        from :func:`fit_pbm_rates`, a function ``S(x)`` or a constant. None: no breakage.
    initial : (S,) array or dict
        Numbers of granules by size at ``t[0]``: ``initial[s - 1]`` granules of s particles
        (s = 1: free particles), or ``{size: number}``. See :func:`size_counts`.
    t : (T,) array
        Output times [s], increasing; ``t[0]`` is the time of ``initial``. With kernels measured
        per second (:func:`granalytics.coalescence_kernel` and :func:`granalytics.breakage_rate`
        are per second), times are seconds; with rates per revolution, revolutions.
    layering : DataFrame, callable, float or None
        λ(x) [1/s per (free particle, granule of size x) pair]; λ(1) is nucleation (two free
        particles forming a pair). Table: column ``layering_per_s`` (:func:`fit_pbm_rates`).
    erosion : DataFrame, callable, float or None
        E(x) [1/s per granule]: rate at which a granule of size x loses one particle to the free
        state (zero at x = 1 whatever is given). Table: column ``erosion_per_s``.
    fragments : "uniform" or callable, default "uniform"
        Fragments of a breakage: ``"uniform"``, ν parts of at least ``min_fragment`` particles,
        every composition equally likely (ν non-integer: the two neighbouring integers mixed;
        ν = 2 with ``min_fragment`` 1 is a cut at a random bond); or a function ``b(x)``
        returning the expected number of fragments of each size 1..x of a granule of x
        particles (they must hold x particles).
    n_fragments : float or callable, default 2
        ν(x) for ``"uniform"`` fragments where the breakage table gives none (>= 2).
    min_fragment : int, default 1
        Smallest fragment of a ``"uniform"`` breakage [particles]; granules smaller than twice this
        do not break. Use the tracking's ``min_fragment`` with rates from it.
    grid : (G,) int array, optional
        Pivots, increasing integers from 1. Default :func:`pbm_grid` (``n_max``, ``ratio``).
    ratio : float, default 2**0.25
        Pivot ratio of the default grid.
    n_max : int, optional
        Top pivot of the default grid [particles]; default the total number of primary particles
        in ``initial`` (no granule can be larger).
    extrapolate : {"nearest", "zero"}, default "nearest"
        Rates of tables for sizes above their largest class: that class's, or zero.
    method : str, default "BDF"
        :func:`scipy.integrate.solve_ivp` method; the implicit ones get the exact Jacobian.
    rtol : float, default 1e-8
    atol : float, optional
        Absolute tolerance [granules]; default ``1e-10`` × the total number of primary particles.

    Returns
    -------
    PopulationBalance
        Numbers at the pivots at each time of ``t``, with moments, a summary (mean size, yield)
        and the relative change of the primary particles (``mass_error``).

    Raises
    ------
    ParameterError
        For an invalid argument, naming it and its value.
    """
    from scipy.integrate import solve_ivp

    t = np.asarray(t, dtype=float)
    if t.size < 2 or (np.diff(t) <= 0).any():
        raise ParameterError(f"population_balance: t must be at least two increasing times [s], got {t.tolist()[:6]}")
    counts, mass0 = _initial_counts(initial)
    grid = _pivots(grid, counts, mass0, n_max, ratio)
    n0 = project_counts(counts, grid)
    beta, iu, ju, coef, stoich = _coalescence_events(kernel, layering, grid, extrapolate)
    sel = _values(breakage, "breakage", _TABLE_COLUMNS["breakage"], grid, extrapolate)
    nu = _fragment_numbers(breakage, n_fragments, grid, extrapolate)
    ero = _values(erosion, "erosion", _TABLE_COLUMNS["erosion"], grid, extrapolate)
    ero[0] = 0.0
    linear, unbreakable = _breakage_operator(sel, nu, ero, fragments, min_fragment, grid)
    rhs, jac = _rate_functions(stoich, coef, iu, ju, linear)

    atol = 1e-10 * mass0 if atol is None else float(atol)
    kwargs = {"jac": jac} if method in ("BDF", "Radau", "LSODA") else {}
    sol = solve_ivp(rhs, (t[0], t[-1]), n0, method=method, t_eval=t, rtol=rtol, atol=atol, **kwargs)
    numbers = sol.y.T if sol.y.shape[1] == t.size else np.full((t.size, grid.size), np.nan)
    return PopulationBalance(grid=grid, t_s=t, numbers=numbers, success=bool(sol.success), message=str(sol.message),
                             nfev=int(sol.nfev), info={"unbreakable_sizes": unbreakable, "beta": beta,
                                                       "selection": sel, "n_fragments": nu, "erosion": ero,
                                                       "rhs": rhs, "jac": jac})

