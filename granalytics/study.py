"""Parameter studies: analysis of a sweep folder (``python -m sim sweep``), the paper's Fig 7 law
and a Gaussian-process surrogate.

A sweep folder holds ``manifest.csv`` (one row per point: parameters, status, file, …) and the
run files ``points/<point>.h5``. This module reads only those files; it does not need :mod:`sim`.

- :func:`study_table`: steady-state yield, mean granule volume and granule number of every
  finished point, for each cohesion convention, with γ and Ω of the *original* (α = 1) system
  taken from the run's metadata (the paper's Fig 7 plots CG2 runs, simulated with γ₂ = 2γ,
  against the original γ).
- :func:`fit_granule_growth`: ⟨V_g⟩/V_p = β(γ − γ₁) above the onset γ₁ (paper §3.2: β ≈ 70,
  γ₁ ≈ 0.027 N/m), with 95 % confidence intervals.
- :func:`fit_surrogate`: a Gaussian-process regression of the steady-state metrics on the swept
  inputs, with leave-one-out errors.
- :func:`growth_figure`: Fig 7.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .metrics import HEADLINE
from .cohesion import check_cohesion
from .errors import ParameterError
from .manifest import MANIFEST_COLUMNS, read_manifest
from .stats import DEFAULT_WINDOW_REV

__all__ = [
    "study_table", "read_manifest", "fit_granule_growth", "GrowthFit", "fit_surrogate", "Surrogate",
    "PAPER_BETA", "PAPER_GAMMA_1",
    "STUDY_METRICS",
]

#: the paper's Fig 7 law ⟨V_g⟩/V_p = β(γ − γ₁): slope and onset [N/m]
PAPER_BETA = 70.0
PAPER_GAMMA_1 = 0.027

#: steady-state metrics of the study table
STUDY_METRICS = HEADLINE

#: manifest columns that are bookkeeping, not point parameters (the schema's, and the bundled copy's
#: ``source_sha256``, :func:`granalytics.datasets.bundle_sweep`)
_BOOKKEEPING = ("status", *MANIFEST_COLUMNS, "source_sha256")

_DEFAULT_OUTPUTS = ("yield_fraction_mean", "mean_volume_norm_mean", "n_granules_norm_mean")


# ----------------------------------------------------------------------------- the table
def _original_values(meta):
    """(γ, Ω) of the original system: ``meta.sim_config["original"]`` when the run came from
    ``sim``, else γ/α (Weber scaling γ_CG = α·γ) and the run's Ω."""
    original = (meta.sim_config or {}).get("original") or {}
    gamma = original.get("surface_tension", meta.surface_tension / meta.alpha)
    omega = original.get("drum_omega", meta.drum_omega)
    return float(gamma), float(omega)


def study_table(sweep_dir, window=DEFAULT_WINDOW_REV, method="gna", cohesion=("acting", "bridge"), *,
                replicas=None, progress=False, **params) -> pd.DataFrame:
    """Steady-state statistics of every finished point of a sweep.

    Parameters
    ----------
    sweep_dir : path, or list of paths
        Folder with ``manifest.csv`` and the run files it names (relative to the folder); several
        folders are analysed as one table (e.g. a sweep and its replicas at other seeds, run later).
    window : (float, float), default (3, 6)
        Steady-state window [revolutions] (:func:`~granalytics.steady_state`; block s.e.m. over
        revolutions).
    method : str, default "gna"
        Identification method; ``params`` go to it (e.g. ``c_agg=0.6, a_agg_deg=20``).
    cohesion : str or sequence of str, default ("acting", "bridge")
        Cohesion conventions (:mod:`granalytics.cohesion`); one row per point and convention.
        Ignored (one row per point, ``cohesion`` None) for methods without a convention.
    replicas : str, optional
        A grid column that tells replicas apart (``"seed"``): points equal in every other
        parameter are combined into one row (:func:`~granalytics.stats.combine_replicas`):
        ``<metric>_mean`` over the replicas, ``_sem`` their block s.e.m. combined (√(Σ sem²)/n),
        ``_replica_sem`` (standard deviation of the replica means / √n), ``_replica_std``,
        ``n_replicas``; ``point`` and ``file`` list the replicas joined by ``"; "``, the
        ``replicas`` column their values.
    progress : bool
        A progress bar over points.

    Returns
    -------
    DataFrame
        One row per finished (``status == done``) point and convention: ``point``, the point
        parameters of the manifest, then ``gamma`` and ``omega`` of the ORIGINAL system and
        ``alpha`` read from the run's metadata (``meta.sim_config["original"]``; runs without it:
        γ = γ_run/α), ``gamma_run`` (γ of the simulated system), ``n_particles``, ``cohesion``,
        ``<metric>_mean``, ``_std``, ``_sem`` for ``yield_fraction``, ``mean_volume_norm``,
        ``n_granules_norm`` (``mean_volume_norm_mean`` is NaN when no frame in the window has a
        granule), ``n_frames``, ``method``, ``window``, ``file``.
    """
    from tqdm.auto import tqdm

    from .identify import METHODS, method_parameters
    from .io import open_run
    from .stats import run_stats, steady_state

    if isinstance(sweep_dir, (list, tuple)):  # several folders analysed as one (e.g. replicas run later)
        if not sweep_dir:
            raise ParameterError("study_table: no sweep folder given")
        table = pd.concat([study_table(d, window, method, cohesion, progress=progress, **params) for d in sweep_dir],
                          ignore_index=True)
        return table if replicas is None else _combine_replica_rows(table, replicas, sweep_dir[0])

    if method not in METHODS:
        raise ParameterError(f"unknown method {method!r}; available: {sorted(METHODS)}")
    conventions = [cohesion] if isinstance(cohesion, str) else list(cohesion)
    if not conventions:
        raise ParameterError("cohesion: give at least one convention")
    for c in conventions:
        check_cohesion(c)
    if "cohesion" not in method_parameters(method):
        conventions = [None]
    lo, hi = (float(w) for w in window)
    manifest = read_manifest(sweep_dir)
    done = manifest[manifest["status"] == "done"]
    if done.empty:
        raise ParameterError(f"{os.path.join(os.fspath(sweep_dir), 'manifest.csv')}: no finished point "
                             f"({len(manifest)} in the manifest)")
    param_cols = [c for c in manifest.columns if c not in ("point", *_BOOKKEEPING)]
    rows = []
    for record in tqdm(done.to_dict("records"), disable=not progress, unit="point", desc="study"):
        if not isinstance(record.get("file"), str) or not record["file"]:
            raise ParameterError(f"{os.path.join(os.fspath(sweep_dir), 'manifest.csv')}: point {record['point']} is "
                                 f"done but its file field is empty ({record.get('file')!r})")
        path = os.path.join(os.fspath(sweep_dir), record["file"])
        with open_run(path) as run:
            meta = run.meta
            frames = run.select(revolutions=(lo, hi))
            if not len(frames):
                revs = run.revolutions
                span = f"[{revs.min():.3g}, {revs.max():.3g}]" if len(revs) else "no frames"
                raise ParameterError(f"{path}: no frame in the window [{lo:g}, {hi:g}] revolutions (the run covers {span})")
            gamma, omega = _original_values(meta)
            for conv in conventions:
                kwargs = dict(params) if conv is None else {**params, "cohesion": conv}
                ts = run_stats(frames, method, **kwargs)
                steady = steady_state(ts, window=(lo, hi), columns=STUDY_METRICS, source=path)
                row = {"point": record["point"], **{c: record[c] for c in param_cols}}
                row.update({"gamma": gamma, "omega": omega, "alpha": float(meta.alpha),
                            "gamma_run": float(meta.surface_tension), "n_particles": int(meta.n_particles),
                            "cohesion": conv})
                for metric in STUDY_METRICS:
                    for stat in ("mean", "std", "sem"):
                        row[f"{metric}_{stat}"] = float(steady.loc[metric, stat])
                row["n_frames"] = int(steady.loc["yield_fraction", "n_frames"])
                row["method"] = method
                row["window"] = f"{lo:g}:{hi:g}"
                row["file"] = record["file"]
                rows.append(row)
    table = pd.DataFrame(rows)
    return table if replicas is None else _combine_replica_rows(table, replicas, sweep_dir)


def _combine_replica_rows(table, replicas, sweep_dir) -> pd.DataFrame:
    """Rows of :func:`study_table` that differ only in the ``replicas`` column, combined."""
    from .stats import combine_replicas

    if replicas not in table:
        raise ParameterError(f"{os.path.join(os.fspath(sweep_dir), 'manifest.csv')}: no grid column {replicas!r} "
                             f"to tell replicas apart (it has {', '.join(map(str, table.columns))})")
    stats = [f"{m}_{s}" for m in STUDY_METRICS for s in ("mean", "std", "sem")]
    joined = ("point", "file", replicas)
    keys = [c for c in table.columns if c not in (*stats, *joined, "n_frames")]
    rows = []
    for _, group in table.groupby(keys, sort=False, dropna=False):
        row = group.iloc[0][keys].to_dict()
        for col in joined:
            row[col] = "; ".join(str(v) for v in group[col])
        means = group[[f"{m}_mean" for m in STUDY_METRICS]].T.set_axis(STUDY_METRICS)
        sems = group[[f"{m}_sem" for m in STUDY_METRICS]].T.set_axis(STUDY_METRICS)
        combined = combine_replicas(means, sems)
        for metric in STUDY_METRICS:
            row[f"{metric}_mean"] = combined.loc[metric, "mean"]
            row[f"{metric}_std"] = float(group[f"{metric}_std"].mean())
            row[f"{metric}_sem"] = combined.loc[metric, "block_sem"]
            row[f"{metric}_replica_sem"] = combined.loc[metric, "replica_sem"]
            row[f"{metric}_replica_std"] = combined.loc[metric, "replica_std"]
        row["n_replicas"] = len(group)
        row["n_frames"] = int(group["n_frames"].sum())
        rows.append(row)
    return pd.DataFrame(rows)[[*table.columns, *(f"{m}_{s}" for m in STUDY_METRICS
                                                  for s in ("replica_sem", "replica_std")), "n_replicas"]]


def _select_cohesion(table, cohesion):
    if cohesion is None or "cohesion" not in table:
        return table
    if table["cohesion"].isna().all():  # a method without conventions
        return table
    part = table[table["cohesion"] == cohesion]
    if part.empty:
        raise ParameterError(f"the table has no rows with cohesion={cohesion!r} "
                             f"(it has {sorted(table['cohesion'].dropna().unique())})")
    return part


# ----------------------------------------------------------------------------- the Fig 7 law
@dataclass
class GrowthFit:
    """Fit of ⟨V_g⟩/V_p = β·max(0, γ − γ₁) (:func:`fit_granule_growth`).

    Attributes
    ----------
    beta, gamma_1 : float
        Slope and onset [N/m].
    beta_ci, gamma_1_ci : (float, float)
        Confidence intervals (``confidence``, default 95 %): estimate ± t(dof)·standard error.
    beta_se, gamma_1_se : float
        Standard errors (curve_fit covariance scaled by the residual variance).
    cov : (2, 2) array
        Covariance of (β, γ₁).
    confidence : float
    dof : int
        Degrees of freedom of the t quantile: points used − 2.
    n_points : int
        Points given.
    n_used : int
        Points that carry information (all but points without granules at or below the onset).
    n_no_granules : int
        Points without granules (mean volume NaN or 0), taken as ⟨V_g⟩/V_p = 0.
    weighted : bool
        Whether the fit was weighted by 1/sem².
    model : str
        ``"hinge"`` or ``"linear"``.
    rss : float
        (Weighted) residual sum of squares over the used points.
    gamma_range : (float, float)
        The smallest and largest γ given [N/m].

    One rule decides whether the data show growth (:attr:`shows_growth`): the slope's interval
    lies above zero and, for the hinge, the onset γ₁ lies within the γ given. A fit that fails it
    is reported as "no growth law" (:meth:`summary`, the ``study`` command) and never drawn as a law
    (:func:`granalytics.plot.growth_figure`); its numbers stay available for inspection.
    """

    beta: float
    gamma_1: float
    beta_ci: tuple
    gamma_1_ci: tuple
    beta_se: float
    gamma_1_se: float
    cov: np.ndarray
    confidence: float
    dof: int
    n_points: int
    n_used: int
    n_no_granules: int
    weighted: bool
    model: str
    rss: float
    gamma_range: tuple = (-math.inf, math.inf)
    paper_beta: float = PAPER_BETA
    paper_gamma_1: float = PAPER_GAMMA_1
    extra: dict = field(default_factory=dict)

    @property
    def shows_growth(self) -> bool:
        """β's interval above 0 and (hinge) γ₁ within the γ given: see the class docstring."""
        slope = self.beta_ci[0] > 0
        onset = self.model != "hinge" or self.gamma_range[0] <= self.gamma_1 <= self.gamma_range[1]
        return bool(slope and onset)

    def no_growth_reason(self) -> str:
        """Why :attr:`shows_growth` is False ("" when it is True)."""
        reasons = []
        if not self.beta_ci[0] > 0:
            reasons.append(f"β's interval [{self.beta_ci[0]:.3g}, {self.beta_ci[1]:.3g}] includes 0")
        if self.model == "hinge" and not self.gamma_range[0] <= self.gamma_1 <= self.gamma_range[1]:
            reasons.append(f"the onset γ₁ = {self.gamma_1:.3g} N/m lies outside the γ given "
                           f"[{self.gamma_range[0]:g}, {self.gamma_range[1]:g}] N/m")
        return "; ".join(reasons)

    def predict(self, gamma):
        """β·max(0, γ − γ₁) at ``gamma`` (array-like)."""
        return self.beta * np.maximum(0.0, np.asarray(gamma, dtype=float) - self.gamma_1)

    def summary(self) -> str:
        """One line: β and γ₁ with their intervals beside the paper's values ("no growth law: …" first
        when the data show none, :attr:`shows_growth`)."""
        pct = f"{100 * self.confidence:g} %"
        verdict = "" if self.shows_growth else f"no growth law ({self.no_growth_reason()}); the fit, not a law: "
        return (f"{verdict}⟨V_g⟩/V_p = β(γ − γ₁), {self.model} model: β = {self.beta:.4g} "
                f"[{self.beta_ci[0]:.4g}, {self.beta_ci[1]:.4g}] (paper ≈ {self.paper_beta:g}), "
                f"γ₁ = {self.gamma_1:.4g} [{self.gamma_1_ci[0]:.4g}, {self.gamma_1_ci[1]:.4g}] N/m "
                f"(paper ≈ {self.paper_gamma_1:g} N/m); {pct} intervals, {self.n_points} points "
                f"({self.n_no_granules} without granules, {self.n_used} used, "
                f"{'weighted by 1/sem²' if self.weighted else 'unweighted'})")

    def to_dict(self) -> dict:
        """The fit as flat scalars (β and γ₁ [N/m] with their interval bounds and standard
        errors, and the fit's settings), e.g. for a row of a table or JSON."""
        return {"beta": self.beta, "beta_ci_low": self.beta_ci[0], "beta_ci_high": self.beta_ci[1],
                "gamma_1": self.gamma_1, "gamma_1_ci_low": self.gamma_1_ci[0], "gamma_1_ci_high": self.gamma_1_ci[1],
                "beta_se": self.beta_se, "gamma_1_se": self.gamma_1_se, "confidence": self.confidence,
                "dof": self.dof, "n_points": self.n_points, "n_used": self.n_used,
                "n_no_granules": self.n_no_granules, "weighted": self.weighted, "model": self.model, "rss": self.rss,
                "shows_growth": self.shows_growth}


def _hinge(g, beta, gamma_1):
    return beta * np.maximum(0.0, g - gamma_1)


def fit_granule_growth(gamma, mean_volume_norm, sem=None, *, model="hinge", confidence=0.95) -> GrowthFit:
    """Fit the paper's Fig 7 law ⟨V_g⟩/V_p = β(γ − γ₁) for γ > γ₁, the onset γ₁ fitted.

    How points at or below the onset enter: a point without granules (``mean_volume_norm`` NaN,
    as :func:`study_table` reports it, or 0) is taken as ⟨V_g⟩/V_p = 0. With ``model="hinge"``
    (default) every point is fitted by β·max(0, γ − γ₁) — no baseline: below the onset the model
    is 0, so points without granules below γ₁ are fitted exactly and points without granules
    above γ₁ pull the onset up. With ``model="linear"`` only points with granules are fitted by
    the straight line β(γ − γ₁) (the paper's reading: the line through the data, γ₁ its zero).

    The fit minimises the weighted residual sum of squares: the hinge by profiling γ₁ (a grid,
    then a bounded scalar minimisation, β in closed form for each γ₁), then polished by
    :func:`scipy.optimize.curve_fit` on the points that carry information — every point except
    those without granules at or below the onset (which are fitted exactly and have no gradient).
    Its covariance, scaled by the residual variance (``absolute_sigma=False``: the sems weight
    the points relative to each other), gives standard errors and intervals estimate ±
    t_{(1+confidence)/2, n_used − 2}·se.

    Parameters
    ----------
    gamma : array-like
        γ of the ORIGINAL system [N/m] (paper Fig 7 convention).
    mean_volume_norm : array-like
        Steady-state ⟨V_g⟩/V_p per point (NaN: no granules).
    sem : array-like, optional
        Standard errors of ``mean_volume_norm``; weights 1/sem². Missing or non-positive sems (a
        point without granules, a single block) take the smallest positive sem given.
    model : {"hinge", "linear"}
    confidence : float, default 0.95

    Raises
    ------
    ParameterError
        Mismatched lengths, non-finite γ or volumes (other than NaN), fewer than three points with granules
        at two or more γ, no growth (slope ≤ 0), or too few points for an interval.
    """
    from scipy.optimize import curve_fit, minimize_scalar
    from scipy.stats import t as student_t

    if model not in ("hinge", "linear"):
        raise ParameterError(f"model must be 'hinge' or 'linear', got {model!r}")
    if not 0 < confidence < 1:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    g = np.asarray(gamma, dtype=float).ravel()
    v = np.asarray(mean_volume_norm, dtype=float).ravel()
    if g.shape != v.shape:
        raise ParameterError(f"{g.size} γ values for {v.size} volumes")
    if not np.isfinite(g).all():
        raise ParameterError("γ values must be finite")
    no_granules = np.isnan(v) | (v == 0)
    v = np.where(np.isnan(v), 0.0, v)
    if not np.isfinite(v).all():
        raise ParameterError("mean volumes must be finite numbers (NaN: no granules)")
    weighted = False
    s = np.ones_like(g)
    if sem is not None:
        s_in = np.asarray(sem, dtype=float).ravel()
        if s_in.shape != g.shape:
            raise ParameterError(f"{s_in.size} sems for {g.size} points")
        if (s_in < 0).any():
            k = int(np.flatnonzero(s_in < 0)[0])
            raise ParameterError(f"sem must be >= 0, got {float(s_in[k])!r} at γ = {g[k]:g} N/m")
        ok = np.isfinite(s_in) & (s_in > 0)
        odd = ~ok & ~no_granules  # a point without granules has no sem; one with granules should
        if ok.any() and odd.any():
            import warnings

            warnings.warn(f"{int(odd.sum())} sem(s) zero or NaN at points with granules (γ = "
                          f"{', '.join(f'{x:g}' for x in g[odd])} N/m; a single block?) take the smallest positive "
                          f"sem given, {s_in[ok].min():.3g}", stacklevel=2)
        if ok.any():
            s = np.where(ok, s_in, s_in[ok].min())
            weighted = True
    w = 1.0 / s**2
    pos = ~no_granules
    if pos.sum() < 3 or np.unique(g[pos]).size < 2:
        raise ParameterError(f"the growth fit needs at least three points with granules at two or more γ "
                             f"(got {int(pos.sum())} with granules)")
    # weighted straight line through the points with granules: the start (and the linear model)
    A = np.column_stack([np.ones(pos.sum()), g[pos]])
    sw = np.sqrt(w[pos])
    (a0, b0), *_ = np.linalg.lstsq(A * sw[:, None], v[pos] * sw, rcond=None)
    if not b0 > 0:
        raise ParameterError(f"no growth of the mean granule volume with γ (fitted slope {b0:.3g} <= 0)")
    g1_start = -a0 / b0

    if model == "linear":
        used = pos
        func = lambda x, beta, gamma_1: beta * (x - gamma_1)  # noqa: E731
        p0 = (b0, g1_start)
    else:
        def profile(g1):
            """(weighted RSS, β) of the hinge with onset(s) ``g1`` (scalar or array), β in closed form."""
            g1 = np.atleast_1d(np.asarray(g1, dtype=float))
            x = np.maximum(0.0, g[None, :] - g1[:, None])
            den = (w * x * x).sum(axis=1)
            beta = np.divide((w * x * v).sum(axis=1), den, out=np.zeros_like(den), where=den > 0)
            return (w * (v - beta[:, None] * x) ** 2).sum(axis=1), beta

        top = g[pos].max()
        span = max(g.max() - g.min(), abs(top) * 1e-3, 1e-12)
        low = min(g1_start, g.min()) - span
        grid = np.unique(np.concatenate([np.linspace(low, top, 801), [g1_start] if low <= g1_start < top else []]))
        rss = profile(grid)[0]
        k = int(np.argmin(rss))
        lo_b, hi_b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
        best = float(grid[k])
        if hi_b > lo_b:
            res = minimize_scalar(lambda x: profile(x)[0][0], bounds=(lo_b, hi_b), method="bounded",
                                  options={"xatol": 1e-12 * max(1.0, abs(best))})
            if res.fun <= rss[k]:
                best = float(res.x)
        beta_best = float(profile(best)[1][0])
        if not beta_best > 0:
            raise ParameterError("no growth of the mean granule volume with γ above the onset")
        used = pos | (g > best)
        func = _hinge
        p0 = (beta_best, best)
    n_used = int(used.sum())
    dof = n_used - 2
    if dof < 1:
        raise ParameterError(f"the growth fit needs at least three informative points, got {n_used}")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            popt, pcov = curve_fit(func, g[used], v[used], p0=p0, sigma=s[used], absolute_sigma=False, maxfev=20000)
        except (RuntimeError, ValueError) as exc:
            raise ParameterError(f"the growth fit did not converge ({exc})") from None
    residual = lambda p: float(np.sum(w[used] * (v[used] - func(g[used], *p)) ** 2))  # noqa: E731
    if model == "hinge" and residual(popt) > residual(p0) * (1 + 1e-9):  # keep the profile optimum
        popt = np.asarray(p0, dtype=float)
        x = np.maximum(0.0, g[used] - popt[1])
        J = np.column_stack([x, np.where(g[used] > popt[1], -popt[0], 0.0)]) / s[used][:, None]
        pcov = np.linalg.pinv(J.T @ J) * residual(popt) / dof
    beta, gamma_1 = (float(x) for x in popt)
    se = np.sqrt(np.clip(np.diag(pcov), 0, None))
    q = float(student_t.ppf(0.5 + confidence / 2, dof))
    return GrowthFit(
        beta=beta, gamma_1=gamma_1, beta_ci=(beta - q * se[0], beta + q * se[0]),
        gamma_1_ci=(gamma_1 - q * se[1], gamma_1 + q * se[1]), beta_se=float(se[0]), gamma_1_se=float(se[1]),
        cov=np.asarray(pcov), confidence=float(confidence), dof=int(dof), n_points=int(g.size), n_used=n_used,
        n_no_granules=int(no_granules.sum()), weighted=weighted, model=model, rss=residual(popt),
        gamma_range=(float(g.min()), float(g.max())),
    )


def _fit_from_table(table, cohesion="acting", **kwargs) -> GrowthFit:
    part = _select_cohesion(table, cohesion)
    for col in ("gamma", "mean_volume_norm_mean"):
        if col not in part:
            raise ParameterError(f"the table has no column {col!r} (use study_table)")
    sem = part["mean_volume_norm_sem"] if "mean_volume_norm_sem" in part else None
    if "mean_volume_norm_replica_sem" in part:  # rows over replicas: the run-to-run error where it exists
        sem = part["mean_volume_norm_replica_sem"].fillna(sem if sem is not None else np.nan)
    return fit_granule_growth(part["gamma"], part["mean_volume_norm_mean"], sem, **kwargs)


# ----------------------------------------------------------------------------- the surrogate
class Surrogate:
    """Gaussian-process surrogate of steady-state metrics (:func:`fit_surrogate`).

    Attributes
    ----------
    inputs, outputs : list of str
    models : dict
        Output -> fitted ``GaussianProcessRegressor`` (on standardised inputs; ``normalize_y``).
    data : DataFrame
        The training rows (inputs and outputs).
    """

    def __init__(self, inputs, outputs, models, scaler, data, n_restarts):
        self.inputs = list(inputs)
        self.outputs = list(outputs)
        self.models = models
        self._mean, self._scale = scaler
        self.data = data
        self._n_restarts = n_restarts
        self._loo = None
        self._loo_predictions = None

    def _x(self, frame):
        return (frame[self.inputs].to_numpy(dtype=float) - self._mean) / self._scale

    def predict(self, points) -> pd.DataFrame:
        """Predicted mean and standard deviation of every output.

        Parameters
        ----------
        points : dict or DataFrame
            Values of exactly the surrogate's inputs (scalars or equal-length lists), e.g.
            ``{"gamma": 0.2, "omega": 3.0}``.

        Returns
        -------
        DataFrame
            The inputs, then ``<output>`` (mean) and ``<output>_std`` (predictive standard
            deviation, including the fitted white-noise level: the scatter expected of a new run).
        """
        if isinstance(points, dict):
            unknown = sorted(set(points) - set(self.inputs))
            if unknown:
                raise ParameterError(f"unknown input {unknown[0]!r}; the surrogate's inputs are {self.inputs}")
            try:
                frame = pd.DataFrame({k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in points.items()})
            except (TypeError, ValueError) as exc:
                raise ParameterError(f"prediction inputs must be numbers ({exc})") from None
        elif isinstance(points, pd.DataFrame):
            frame = points
        else:
            raise ParameterError("points must be a dict or a DataFrame")
        missing = [k for k in self.inputs if k not in frame]
        if missing:
            raise ParameterError(f"missing input {missing[0]!r}; the surrogate's inputs are {self.inputs}")
        try:
            values = frame[self.inputs].to_numpy(dtype=float)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"prediction inputs must be numbers ({exc})") from None
        if not np.isfinite(values).all():
            raise ParameterError("prediction inputs must be finite numbers")
        trained = self.data[self.inputs].to_numpy(dtype=float)
        low, high = trained.min(axis=0), trained.max(axis=0)
        outside = [f"{name} = {v:g} (trained on [{lo:g}, {hi:g}])" for row in values
                   for name, v, lo, hi in zip(self.inputs, row, low, high) if not lo <= v <= hi]
        if outside:
            warnings.warn("surrogate: extrapolating outside the sweep, where a Gaussian process returns to its "
                          "mean: " + "; ".join(outside), stacklevel=2)
        out = pd.DataFrame(values, columns=self.inputs)
        x = (values - self._mean) / self._scale
        for name in self.outputs:
            mean, std = self.models[name].predict(x, return_std=True)
            out[name] = mean
            out[f"{name}_std"] = std
        return out

    def _compute_loo(self):
        import warnings

        from sklearn.base import clone

        errors, preds = {}, []
        for name in self.outputs:
            rows = self.data[np.isfinite(self.data[name].to_numpy(dtype=float))]
            x, y = self._x(rows), rows[name].to_numpy(dtype=float)
            fitted = self.models[name]
            predicted = np.empty_like(y)
            for i in range(len(y)):
                keep = np.arange(len(y)) != i
                model = clone(fitted)
                model.set_params(kernel=fitted.kernel_, n_restarts_optimizer=0)  # start from the full fit
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model.fit(x[keep], y[keep])
                predicted[i] = model.predict(x[i:i + 1])[0]
            err = predicted - y
            errors[name] = {"rmse": float(np.sqrt(np.mean(err**2))), "mae": float(np.mean(np.abs(err))),
                            "output_std": float(np.std(y, ddof=1)) if len(y) > 1 else math.nan,
                            "n_points": int(len(y))}
            part = rows[self.inputs].copy()
            part["output"] = name
            part["observed"] = y
            part["predicted"] = predicted
            preds.append(part)
        table = pd.DataFrame(errors).T
        table.index.name = "output"
        self._loo = table.astype({"n_points": int})
        self._loo_predictions = pd.concat(preds, ignore_index=True)

    @property
    def loo(self) -> pd.DataFrame:
        """Leave-one-out error per output (index): ``rmse``, ``mae`` (of the prediction of each
        point by a GP refitted without it, hyperparameters re-optimised from the full fit's),
        ``output_std`` (scale of the output, for comparison) and ``n_points``. Computed on first
        access."""
        if self._loo is None:
            self._compute_loo()
        return self._loo

    @property
    def loo_predictions(self) -> pd.DataFrame:
        """The leave-one-out predictions behind :attr:`loo`: inputs, ``output``, ``observed``,
        ``predicted``."""
        if self._loo_predictions is None:
            self._compute_loo()
        return self._loo_predictions


def fit_surrogate(table, inputs=("gamma", "omega"), outputs=_DEFAULT_OUTPUTS, *, cohesion="acting",
                  n_restarts=3, random_state=0) -> Surrogate:
    """Gaussian-process regression of each output on the inputs.

    One ``sklearn.gaussian_process.GaussianProcessRegressor`` per output, on inputs standardised
    to zero mean and unit variance, ``normalize_y=True``, kernel
    ``ConstantKernel · RBF(one length scale per input) + WhiteKernel`` (the white term absorbs
    the run-to-run scatter, e.g. between seeds). Rows with a NaN output (e.g. the mean granule
    volume of a point without granules) are left out of that output's model.

    Parameters
    ----------
    table : DataFrame
        :func:`study_table` output (or any table with the input and output columns).
    inputs, outputs : sequence of str
    cohesion : str, default "acting"
        When the table has several cohesion conventions, fit this one's rows.
    n_restarts : int, default 3
        Restarts of the kernel hyperparameter optimiser.
    random_state : int, default 0

    Returns
    -------
    Surrogate
    """
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    inputs, outputs = list(inputs), list(outputs)
    if not inputs or not outputs:
        raise ParameterError("give at least one input and one output")
    part = _select_cohesion(table, cohesion)
    missing = [c for c in inputs + outputs if c not in part]
    if missing:
        raise ParameterError(f"the table has no column {missing[0]!r}; columns: {list(part.columns)}")
    data = part[inputs + outputs].reset_index(drop=True)
    try:
        x_all = data[inputs].to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"inputs {inputs} must be numeric columns") from None
    if not np.isfinite(x_all).all():
        raise ParameterError("the inputs have missing or non-finite values")
    mean = x_all.mean(axis=0)
    scale = x_all.std(axis=0)
    scale[scale == 0] = 1.0
    models = {}
    for name in outputs:
        y = data[name].to_numpy(dtype=float)
        ok = np.isfinite(y)
        if ok.sum() < 3:
            raise ParameterError(f"output {name!r}: the surrogate needs at least three points, got {int(ok.sum())}")
        kernel = (ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(len(inputs)), (1e-2, 1e2))
                  + WhiteKernel(1e-2, (1e-8, 1e1)))
        gp = GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=n_restarts,
                                      random_state=random_state)
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # convergence warnings at the bounds
            gp.fit((x_all[ok] - mean) / scale, y[ok])
        models[name] = gp
    return Surrogate(inputs, outputs, models, (mean, scale), data, n_restarts)


# ----------------------------------------------------------------------------- Fig 7
