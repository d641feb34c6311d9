"""The drum's confinement against coarse-graining: how granule statistics depend on the drum-to-
particle size ratio D/d, and what a user can trust.

A coarse-grained (CG) run of a drum keeps the drum and makes the particles α times larger, so it
lowers D/d by α: fewer particle layers between the walls, more particles touching a wall (wall
contacts are not edges of the granule graph), a thinner bed. Whether CG "works" is then two
questions, which this module separates:

- the **confinement curve**: runs of original (α = 1) particles in drums of one geometry rule
  (fill, L/R_d, r_s/R_d, baffles: ``python -m sim run --drum-ratio``) at several D/d, their
  steady yield, ⟨V_g⟩/V_p and N_g/N against D/d (:func:`confinement_table`), fitted by the
  finite-size law y(D/d) = y∞·(1 − b/(D/d)) (:func:`fit_confinement_curve`: the share of particles
  at a wall falls as 1/(D/d));
- the **decomposition** of a CG run's deviation (:func:`decompose_cg`): against the α = 1 curve at
  its *own* D/d (the error of the scaling rules themselves) and against the α = 1 run in the same
  drum (what a user gets).

:data:`CONFINEMENT_RULE` holds, for each drum family measured, the smallest D/d at which the yield
is within 5 % and 10 % of its large-drum value (docs/results.md, "Confinement"); the families
disagree by over a factor of two, so :func:`confinement_warning`, the one-line warning `granalytics
info` and :func:`~granalytics.compare_cg` give, names the strictest and the others.
"""

from __future__ import annotations

import dataclasses
import math
from numbers import Real

import numpy as np
import pandas as pd

from granalytics.analysis.bed import DrumConfinement, bed_structure, confinement_of_drum
from granalytics.base.errors import ParameterError, ValidationError
from granalytics.base.validation import FLAG, POSITIVE, WINDOW, Array, Instance, Interval, validate_params
from granalytics.core.snapshot import META, SNAPSHOT, Snapshot
from granalytics.analysis.frames import map_frames
from granalytics.identification import make_identifier
from granalytics.core import open_run
from granalytics.analysis.metrics import HEADLINE
from granalytics.analysis.stats import DEFAULT_WINDOW_REV, frame_stats, steady_state

__all__ = ["confinement_of_run", "wall_touching", "CONFINEMENT_RULE", "confinement_warning", "confinement_timeseries", "confinement_table",
           "ConfinementFit", "fit_confinement_curve", "LogarithmicFit", "fit_logarithmic_curve", "decompose_cg", "BED_COLUMNS", "bed_flow"]

# ----------------------------------------------------------------------------- a run's drum
def _drum_params(meta):
    """The simulated system's parameters in a run's ``sim_config`` (a dict: RunMeta's schema), or None."""
    return meta.sim_config.get("params")


@validate_params({"meta": [META]})
def confinement_of_run(meta) -> DrumConfinement | None:
    """The confinement of a run's drum from its metadata (a :class:`RunMeta`): the values the
    simulator recorded in ``sim_config["confinement"]``, or computed from ``sim_config["params"]``
    (drum_radius, drum_length, d_mean [m]) for older runs; None for a run without a drum
    description (converted from another code).

    Raises
    ------
    ValidationError
        The recorded values lack one of :class:`DrumConfinement`'s fields (RunMeta's schema makes
        those it holds numbers), or the parameters are no drum.
    """
    recorded = meta.sim_config.get("confinement")
    if recorded is not None:
        try:
            return DrumConfinement(**{f.name: float(recorded[f.name]) for f in dataclasses.fields(DrumConfinement)})
        except KeyError:
            raise ValidationError("sim_config.confinement", f"must hold the numbers of DrumConfinement, got {recorded!r}") from None
    params = _drum_params(meta)
    if params is None or not all(k in params for k in ("drum_radius", "drum_length", "d_mean")):
        return None
    try:
        return confinement_of_drum(params["drum_radius"], params["drum_length"], params["d_mean"], meta.n_particles)
    except ParameterError as exc:
        raise ValidationError("sim_config.params", str(exc)) from None


@validate_params({"snapshot": [SNAPSHOT], "meta": [META], "overlap_tolerance": [Interval(Real)]})
def wall_touching(snapshot: Snapshot, meta, overlap_tolerance: float = 0.0) -> np.ndarray:
    """Which particles of ``snapshot`` touch a wall of the simulator's drum: the cylinder
    (radius R_d about z), a baffle (a radial plate of height baffle_height·R_d, turned to the
    drum angle Ω·t) or an end plate (z = 0, z = L), from the geometry in ``meta.sim_config``.

    Parameters
    ----------
    snapshot : Snapshot
    meta : RunMeta
        The run's metadata with ``sim_config["params"]`` (drum_radius, drum_length [m],
        n_baffles, baffle_height, drum_omega [rad/s]).
    overlap_tolerance : float, default 0
        A particle counts as touching when its overlap with a wall exceeds
        −overlap_tolerance·radius (0: a true overlap).

    Returns
    -------
    numpy.ndarray of bool, shape (N,)

    Raises
    ------
    ParameterError
        The run has no drum description.
    """
    params = _drum_params(meta)
    needed = ("drum_radius", "drum_length", "n_baffles", "baffle_height", "drum_omega")
    if params is None or not all(k in params for k in needed):
        raise ParameterError("wall_touching: the run's metadata has no drum geometry (sim_config.params with "
                             f"{', '.join(needed)}); only runs of the simulator have one")
    x, y, z = snapshot.position.T
    r = snapshot.radius
    slack = -overlap_tolerance * r
    radius, length = float(params["drum_radius"]), float(params["drum_length"])
    touching = (np.hypot(x, y) + r - radius > slack) | (r - z > slack) | (r - (length - z) > slack)
    n_baffles, inner = int(params["n_baffles"]), radius * (1 - float(params["baffle_height"]))
    angle = float(params["drum_omega"]) * snapshot.time
    for b in range(n_baffles):
        phi = angle + 2 * math.pi * b / n_baffles
        ex, ey = math.cos(phi), math.sin(phi)
        a, side = x * ex + y * ey, -x * ey + y * ex  # along the plate, across it
        dist = np.where(a >= inner, np.abs(side), np.hypot(x - inner * ex, y - inner * ey))
        touching |= r - dist > slack
    return touching


#: for each drum family measured, the smallest D/d (of the simulated particles: D/(α·d) for a CG
#: run) at which the acting yield at the paper's thresholds is within 5 % and within 10 % of its
#: large-drum value y∞ (``ConfinementFit.within``), with the standard error from the fit's
#: χ²-scaled covariance; measured on α = 1 runs (docs/results.md, "Confinement"): the lab drum's
#: family (D/d 11-50, window [3, 6]; ``scripts/confinement_study.py --check-rule``) and the paper
#: drum's (D/d 22-66, window [2, 4]; ``benchmarks/paper_drum_runs.py table``). The finite-size
#: law's b differs between them by more than a factor of two, so neither threshold carries to another drum.
CONFINEMENT_RULE = {
    "lab drum": {"within_5pc": (62.0, 9.0), "within_10pc": (31.0, 4.0)},
    "paper drum": {"within_5pc": (139.0, 21.0), "within_10pc": (70.0, 11.0)},
}

#: per-frame bed columns of :func:`confinement_timeseries` beside the headline metrics
BED_COLUMNS = ("wall_share", "coordination", "bed_angle_deg", "kinetic_energy_norm")


@validate_params({"snapshot": [SNAPSHOT], "meta": [META]})
def bed_flow(snapshot, meta) -> tuple[float, float]:
    """How the bed flows in one frame: its angle and its agitation, both comparable between drums.

    Returns
    -------
    bed_angle_deg : float
        How far the drum carries the bed up [degrees]: the azimuth, about the drum axis, of the
        bed's centre of mass from the drum's lowest point (gravity along −y), positive towards the
        side the wall rises on (+x for Ω > 0 about +z). 0 for a bed at rest; it grows with the
        bed's dynamic angle of repose and with what the baffles lift.
    kinetic_energy_norm : float
        The translational kinetic energy per unit mass, Σ½m v² / Σm [J/kg], over (Ω·R_d)², the
        square of the drum's rim speed: 0 at rest, independent of the units of a similar system.
    """
    params = meta.sim_config.get("params", {})
    mass = snapshot.radius**3  # one density: masses ∝ r³
    x, y = (mass @ snapshot.position[:, :2]) / mass.sum()
    angle = math.degrees(math.atan2(x, -y))
    ke = 0.5 * float(np.sum(mass * np.einsum("ij,ij->i", snapshot.velocity, snapshot.velocity))) / float(mass.sum())
    rim = abs(meta.drum_omega) * float(params.get("drum_radius", math.nan))
    return angle * (1.0 if meta.drum_omega >= 0 else -1.0), ke / rim**2 if rim > 0 else math.nan


def confinement_warning(drum_ratio, rule=None) -> str | None:
    """One line when a run's D/d is below the strictest family's :data:`CONFINEMENT_RULE`
    threshold for 10 % (or 5 %), naming the other families' thresholds; None above it (or when no
    family has the threshold measured).

    Parameters
    ----------
    drum_ratio : float
        The run's D/(α·d) (dimensionless); NaN (an unknown drum) gives None.
    rule : dict, optional
        ``{family: {"within_5pc": (D/d, error), "within_10pc": (D/d, error)}}`` (D/d dimensionless;
        a threshold of None is not measured); default :data:`CONFINEMENT_RULE`.
    """
    rule = CONFINEMENT_RULE if rule is None else rule
    if not math.isfinite(drum_ratio):
        return None
    for key, loss, consequence in (("within_10pc", "more than 10 %", "; CG deviations here mix confinement with the "
                                    "scaling rules"), ("within_5pc", "5-10 %", "")):
        measured = {family: thresholds[key] for family, thresholds in rule.items() if thresholds[key][0] is not None}
        if not measured:
            continue
        strictest = max(measured, key=lambda family: measured[family][0])
        if drum_ratio < measured[strictest][0]:
            others = "".join(f", {_threshold(measured[family])} in the {family}'s" for family in measured
                             if family != strictest)
            return (f"D/d = {drum_ratio:.1f} is below {_threshold(measured[strictest])}, where the drum's confinement "
                    f"lowers the yield by {loss} against a large drum in the {strictest}'s family{others} "
                    f"(docs/results.md, 'Confinement'){consequence}")
    return None


def _threshold(measured) -> str:
    """``70 ± 11`` for a threshold (D/d, error); the D/d alone without an error."""
    x, err = measured
    return f"{x:.0f}" if err is None else f"{x:.0f} ± {err:.0f}"


@validate_params({"meta": [META], "progress": [FLAG]})
def confinement_timeseries(frames, meta, method="gna", *, progress=False, return_sizes=False, jobs=1,
                           scheduler=None, **params) -> pd.DataFrame:
    """:func:`~granalytics.run_stats`' time series with the bed's share of particles touching a
    wall (``wall_share``, :func:`~granalytics.wall_touching`), its coordination number
    (``coordination``, touching particle contacts per particle, walls not counted), its angle
    and its kinetic energy per mass over the rim speed squared (:func:`bed_flow`) per frame.

    Parameters
    ----------
    frames : Run or RunSlice
    meta : RunMeta
        The run's metadata (its drum geometry).
    method, params :
        The identification, as for :func:`~granalytics.run_stats`.
    progress : bool, default False
        Progress bar over frames.
    return_sizes : bool, default False
        Also return the granule sizes (particles per granule) of every frame, as
        :func:`~granalytics.run_stats` does.
    jobs, scheduler :
        Where the frames are analysed: ``jobs`` threads here, or a dask cluster (a scheduler's
        address or a ``distributed.Client``); see :func:`granalytics.analysis.frames.map_frames`.
    """
    identifier = make_identifier(method, **params)

    def one_frame(snapshot):
        result = identifier.identify(snapshot)
        row = frame_stats(snapshot, result)
        row["wall_share"] = float(wall_touching(snapshot, meta).mean())
        row["coordination"] = bed_structure(snapshot).coordination
        row["bed_angle_deg"], row["kinetic_energy_norm"] = bed_flow(snapshot, meta)
        return row, result.sizes

    frame_ids, results = map_frames(frames, one_frame, progress=progress, desc="confinement", jobs=jobs,
                                    scheduler=scheduler)
    rows = [row for row, _ in results]
    for k, row in zip(frame_ids, rows):
        row.insert(0, "frame", int(k))
    table = pd.concat(rows, ignore_index=True)
    return (table, [sizes for _, sizes in results]) if return_sizes else table


def _group_paths(group):
    return [group] if isinstance(group, (str, bytes)) or hasattr(group, "__fspath__") else list(group)


@validate_params({"groups": [Instance((list, tuple), "a list of runs or of groups of replicas")],
                  "window": [WINDOW], "labels": [Array(ndim=1, dtype=str), None],
                  "progress": [FLAG]})
def confinement_table(groups, window=DEFAULT_WINDOW_REV, labels=None, method="gna", *, progress=False,
                      **params) -> pd.DataFrame:
    """The confinement and the steady granule statistics of runs, one row per run or group of
    replicas.

    Parameters
    ----------
    groups : sequence of path or of list of paths
        Runs of the simulator; a list is a group of replicas (the same system at other seeds).
    window : (float, float), default (3, 6)
        Steady-state window [revolutions].
    labels : sequence of str, optional
        Row names (default: the first file's name).
    method, params :
        The identification (default GNA at its defaults).

    Returns
    -------
    DataFrame
        ``label``, ``alpha``, ``n_particles``, ``n_replicas``, ``drum_ratio`` (D/d),
        ``length_ratio`` (L/d), ``bed_depth_ratio`` (nominal depth/d), then for every metric of
        the headline statistics and :data:`BED_COLUMNS` its mean over the window (``<metric>``,
        averaged over replicas) and its error ``<metric>_err``: the replica standard error for a
        group of two or more, the block s.e.m. of the one run otherwise; ``<metric>_block_sem`` is
        the block s.e.m. (of a group: combined over its replicas, √(Σ sem²)/n). Two or three
        replicas may agree by chance far better than their frames scatter; a fit that weighs the
        points by their errors may take the larger of the two.
    """
    groups = [_group_paths(g) for g in groups]
    if not groups:
        raise ParameterError("confinement_table: no runs")
    if labels is not None and len(labels) != len(groups):
        raise ParameterError(f"confinement_table: {len(labels)} labels for {len(groups)} runs or groups")
    columns = (*HEADLINE, *BED_COLUMNS)
    rows = []
    for k, paths in enumerate(groups):
        series, first = [], None
        for path in paths:
            with open_run(path) as run:
                drum = confinement_of_run(run.meta)
                if drum is None:
                    raise ParameterError(f"{path}: the run has no drum description (not a run of the simulator)")
                first = first or (run.meta, drum)
                series.append(confinement_timeseries(run.select(revolutions=window), run.meta, method,
                                                     progress=progress, **params))
        steady = steady_state(series if len(series) > 1 else series[0], window, columns, source=str(paths[0]))
        error, block_sem = (steady["replica_sem"], steady["block_sem"]) if len(series) > 1 else (steady["sem"],) * 2
        meta, drum = first
        row = {"label": labels[k] if labels is not None else str(paths[0]).rsplit("/", 1)[-1].removesuffix(".h5"),
               "alpha": meta.alpha, "n_particles": meta.n_particles, "n_replicas": len(series),
               "drum_ratio": drum.drum_ratio, "length_ratio": drum.length_ratio,
               "bed_depth_ratio": drum.bed_depth_ratio}
        for col in columns:
            row[col] = float(steady.loc[col, "mean"])
            row[f"{col}_err"] = float(error.loc[col])
            row[f"{col}_block_sem"] = float(block_sem.loc[col])
        rows.append(row)
    return pd.DataFrame(rows)


@dataclasses.dataclass(frozen=True)
class ConfinementFit:
    """The finite-size law y(x) = y∞·(1 − b/x), x = D/d, fitted to a confinement curve.

    Attributes
    ----------
    y_inf, b : float
        The large-drum value and the confinement length (in particle diameters).
    covariance : (2, 2) array
        Of (y∞, b), scaled by the reduced χ² when it exceeds 1.
    chi2 : float
        χ² of the fit (with the points' errors), ``dof`` its degrees of freedom.
    """

    y_inf: float
    b: float
    covariance: np.ndarray
    chi2: float
    dof: int

    def __call__(self, drum_ratio):
        """y at D/d = ``drum_ratio``."""
        return self.y_inf * (1 - self.b / np.asarray(drum_ratio, dtype=float))

    def error(self, drum_ratio):
        """Standard error of :meth:`__call__` at ``drum_ratio`` (from the covariance)."""
        x = np.asarray(drum_ratio, dtype=float)
        grad = np.stack([1 - self.b / x, -self.y_inf / x])
        return _propagated_error(grad, self.covariance)

    @validate_params({"fraction": [Interval(Real, 0, 1, closed="neither")]})
    def within(self, fraction) -> tuple[float, float]:
        """The smallest D/d at which y is within ``fraction`` of y∞ (b/fraction), with its
        standard error."""
        return self.b / fraction, math.sqrt(self.covariance[1, 1]) / fraction

    def rule(self) -> dict:
        """This fit's entry of :data:`CONFINEMENT_RULE`: ``{"within_5pc": (D/d, error),
        "within_10pc": (D/d, error)}`` from :meth:`within`, rounded to whole D/d."""
        return {key: tuple(float(round(v)) for v in self.within(fraction))
                for key, fraction in (("within_5pc", 0.05), ("within_10pc", 0.10))}


@validate_params({"drum_ratio": [Array(ndim=1, within=POSITIVE)], "values": [Array(ndim=1, finite=True)],
                  "errors": [Array(ndim=1, within=POSITIVE)]})
def fit_confinement_curve(drum_ratio, values, errors) -> ConfinementFit:
    """Weighted least-squares fit of y = y∞·(1 − b/x) to points (x = D/d, y ± error).

    The law is linear in (y∞, y∞·b): y = y∞ − (y∞·b)/x, so the fit is a weighted linear regression
    on 1/x; the covariance of (y∞, b) follows by propagation.

    Raises
    ------
    ParameterError
        Fewer than three points, points of unequal lengths, one D/d only, or a D/d or an error
        not a finite number > 0.
    """
    x, y, s = _curve_points("fit_confinement_curve", drum_ratio, values, errors)
    coef, cov_lin, chi2, dof = _weighted_linear_fit(np.column_stack([np.ones_like(x), -1 / x]), y, s)
    y_inf, c = coef  # c = y∞·b
    jac = np.array([[1.0, 0.0], [-c / y_inf**2, 1 / y_inf]])  # d(y∞, b)/d(y∞, c)
    return ConfinementFit(y_inf=float(y_inf), b=float(c / y_inf), covariance=jac @ cov_lin @ jac.T, chi2=chi2, dof=dof)


@dataclasses.dataclass(frozen=True)
class LogarithmicFit:
    """A confinement curve that does not saturate: y(x) = a + c·ln(x), x = D/d. The alternative to
    :class:`ConfinementFit`'s finite-size law when a curve is carried beyond its largest drum:
    over a few D/d the two fit alike and part far out.

    Attributes
    ----------
    a, c : float
        y at D/d = 1 and the rise per e-fold of D/d.
    covariance : (2, 2) array
        Of (a, c), scaled by the reduced χ² when it exceeds 1.
    chi2, dof : float, int
        As :class:`ConfinementFit`'s.
    """

    a: float
    c: float
    covariance: np.ndarray
    chi2: float
    dof: int

    def __call__(self, drum_ratio):
        """y at D/d = ``drum_ratio``."""
        return self.a + self.c * np.log(np.asarray(drum_ratio, dtype=float))

    def error(self, drum_ratio):
        """Standard error of :meth:`__call__` at ``drum_ratio`` (from the covariance)."""
        x = np.asarray(drum_ratio, dtype=float)
        grad = np.stack([np.ones_like(x), np.log(x)])
        return _propagated_error(grad, self.covariance)


@validate_params({"drum_ratio": [Array(ndim=1, within=POSITIVE)], "values": [Array(ndim=1, finite=True)],
                  "errors": [Array(ndim=1, within=POSITIVE)]})
def fit_logarithmic_curve(drum_ratio, values, errors) -> LogarithmicFit:
    """Weighted least-squares fit of y = a + c·ln(x) to points (x = D/d, y ± error): the curve
    that keeps rising, to set beside :func:`fit_confinement_curve`'s before extrapolating.

    Parameters
    ----------
    drum_ratio : array-like
        D/(α·d) of each point (dimensionless, > 0).
    values, errors : array-like
        The metric at each point and its standard error (the metric's units; errors > 0), e.g.
        the steady yield of :func:`confinement_table` and its replica error.

    Returns
    -------
    LogarithmicFit
        Its covariance scaled by χ²/dof where that exceeds 1, as :func:`fit_confinement_curve`'s.

    Raises
    ------
    ParameterError
        As :func:`fit_confinement_curve`.
    """
    x, y, s = _curve_points("fit_logarithmic_curve", drum_ratio, values, errors)
    (a, c), cov, chi2, dof = _weighted_linear_fit(np.column_stack([np.ones_like(x), np.log(x)]), y, s)
    return LogarithmicFit(a=float(a), c=float(c), covariance=cov, chi2=chi2, dof=dof)


def _propagated_error(grad, covariance):
    """√(gᵀ·C·g) for each column of the gradient ``grad`` (parameters first, then the points)."""
    return np.sqrt(np.einsum("i...,ij,j...->...", grad, covariance, grad))


def _curve_points(caller, drum_ratio, values, errors):
    x, y, s = (np.asarray(a, dtype=float) for a in (drum_ratio, values, errors))
    if not (x.shape == y.shape == s.shape) or x.size < 3:
        raise ParameterError(f"{caller}: needs three or more points of equal length, got {x.size} D/d, {y.size} "
                             f"values and {s.size} errors")
    if np.unique(x).size < 2:
        raise ParameterError(f"{caller}: needs two different D/d or more, got only {x[0]:g}")
    return x, y, s


def _weighted_linear_fit(design, y, s):
    """Weighted linear least squares of ``y`` ± ``s`` on the columns of ``design``: (coefficients,
    their covariance scaled by χ²/dof where it exceeds 1, χ², dof)."""
    weight = 1 / s**2
    cov = np.linalg.inv(design.T @ (design * weight[:, None]))
    coef = cov @ (design.T @ (weight * y))
    chi2 = float(np.sum(weight * (y - design @ coef) ** 2))
    dof = y.size - design.shape[1]
    if dof > 0 and chi2 / dof > 1:
        cov = cov * (chi2 / dof)
    return coef, cov, chi2, dof


@validate_params({"cg_rows": [Instance(pd.DataFrame)], "fit": [Instance(ConfinementFit)], "same_drum": [Instance(dict)]})
def decompose_cg(cg_rows: pd.DataFrame, fit: ConfinementFit, same_drum: dict, metric="yield_fraction") -> pd.DataFrame:
    """Split the deviation of CG runs into the scaling rules' error and what a user gets.

    Parameters
    ----------
    cg_rows : DataFrame
        Rows of :func:`confinement_table` for the CG runs.
    fit : ConfinementFit
        The α = 1 confinement curve of ``metric``.
    same_drum : dict
        label -> (value, error) of the α = 1 reference in the same drum (the lab drum's CG1 run;
        for a drum without one, the curve at its D/d·α).
    metric : str

    Returns
    -------
    DataFrame
        ``label``, ``alpha``, ``drum_ratio``, ``value``, ``value_err``, ``cg1_equal_dd`` (the
        curve at the run's D/d) with ``cg1_equal_dd_err``, ``dev_equal_dd`` (relative deviation
        from it: the scaling rules' error) with ``dev_equal_dd_err``, ``cg1_same_drum``,
        ``dev_same_drum`` (from the α = 1 run in the same drum) with ``dev_same_drum_err``.
    """
    rows = []
    for row in cg_rows.itertuples(index=False):
        value, err = getattr(row, metric), getattr(row, f"{metric}_err")
        ref, ref_err = float(fit(row.drum_ratio)), float(fit.error(row.drum_ratio))
        drum_ref, drum_err = same_drum[row.label]
        rows.append({
            "label": row.label, "alpha": row.alpha, "drum_ratio": row.drum_ratio, "value": value, "value_err": err,
            "cg1_equal_dd": ref, "cg1_equal_dd_err": ref_err, "dev_equal_dd": value / ref - 1,
            "dev_equal_dd_err": value / ref * math.hypot(err / value, ref_err / ref),
            "cg1_same_drum": drum_ref, "dev_same_drum": value / drum_ref - 1,
            "dev_same_drum_err": value / drum_ref * math.hypot(err / value, drum_err / drum_ref),
        })
    return pd.DataFrame(rows)
