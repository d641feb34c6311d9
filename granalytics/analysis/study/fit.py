"""The paper's Fig 7 law: ⟨V_g⟩/V_p = β(γ − γ₁) above the onset γ₁ (paper §3.2: β ≈ 70,
γ₁ ≈ 0.027 N/m), fitted with 95 % confidence intervals (:func:`fit_granule_growth`,
:class:`GrowthFit`), on arrays or on a study table (:func:`fit_growth_of_table`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from numbers import Real

import numpy as np

from granalytics.analysis.study.sweep_table import growth_rows
from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.base.validation import Array, Interval, Options, validate_params


#: the paper's Fig 7 law ⟨V_g⟩/V_p = β(γ − γ₁): slope and onset [N/m]
PAPER_BETA = 70.0


PAPER_GAMMA_1 = 0.027


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
    (:func:`granalytics.report.figures.growth_figure`); its numbers stay available for inspection.
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
        """β·max(0, γ − γ₁) at ``gamma`` [N/m] (array-like)."""
        return _hinge(np.asarray(gamma, dtype=float), self.beta, self.gamma_1)

    def summary(self) -> str:
        """One line: β and γ₁ with their intervals beside the paper's values ("no growth law: …" first
        when the data show none, :attr:`shows_growth`)."""
        pct = f"{100 * self.confidence:g} %"
        verdict = "" if self.shows_growth else f"no growth law ({self.no_growth_reason()}); the fit, not a law: "
        return (f"{verdict}⟨V_g⟩/V_p = β(γ − γ₁), {self.model} model: β = {self.beta:.4g} "
                f"[{self.beta_ci[0]:.4g}, {self.beta_ci[1]:.4g}] m/N (paper ≈ {self.paper_beta:g} m/N), "
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


def paper_growth_law(gamma):
    """The paper's Fig 7 law, ⟨V_g⟩/V_p = :data:`PAPER_BETA`·max(0, γ − :data:`PAPER_GAMMA_1`), at
    ``gamma`` [N/m] (array-like)."""
    return _hinge(np.asarray(gamma, dtype=float), PAPER_BETA, PAPER_GAMMA_1)


def _hinge(g, beta, gamma_1):
    return beta * np.maximum(0.0, g - gamma_1)


def _line(g, beta, gamma_1):
    return beta * (g - gamma_1)


@validate_params({"gamma": [Array()], "mean_volume_norm": [Array()], "sem": [Array(), None],
                  "model": [Options(("hinge", "linear"))], "confidence": [Interval(Real, 0, 1, closed="neither")]})
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
        at two or more γ, or no growth (slope ≤ 0).
    """
    from scipy.stats import t as student_t

    g, v, no_granules, s, weighted = _growth_points(gamma, mean_volume_norm, sem)
    w = 1.0 / s**2
    pos = ~no_granules
    b0, g1_start = _line_start(g, v, w, pos)
    if model == "linear":
        used, func, p0 = pos, _line, (b0, g1_start)
    else:
        best, beta_best = _hinge_onset(g, v, w, pos, g1_start)
        used, func, p0 = pos | (g > best), _hinge, (beta_best, best)
    popt, pcov, dof, rss = _polish(func, g, v, s, w, used, p0, hinge=model == "hinge")
    beta, gamma_1 = (float(x) for x in popt)
    se = np.sqrt(np.clip(np.diag(pcov), 0, None))
    q = float(student_t.ppf(0.5 + confidence / 2, dof))
    return GrowthFit(
        beta=beta, gamma_1=gamma_1, beta_ci=(beta - q * se[0], beta + q * se[0]),
        gamma_1_ci=(gamma_1 - q * se[1], gamma_1 + q * se[1]), beta_se=float(se[0]), gamma_1_se=float(se[1]),
        cov=np.asarray(pcov), confidence=float(confidence), dof=int(dof), n_points=int(g.size), n_used=int(used.sum()),
        n_no_granules=int(no_granules.sum()), weighted=weighted, model=model, rss=rss,
        gamma_range=(float(g.min()), float(g.max())),
    )


def _growth_points(gamma, mean_volume_norm, sem):
    """The checked points of :func:`fit_granule_growth`: γ [N/m], ⟨V_g⟩/V_p (NaN read as 0), which
    points have no granules, the sems (ones when none are given; missing or zero ones the smallest
    positive sem) and whether they weight the fit."""
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
            warnings.warn(f"{int(odd.sum())} sem(s) zero or NaN at points with granules (γ = "
                          f"{', '.join(f'{x:g}' for x in g[odd])} N/m; a single block?) take the smallest positive "
                          f"sem given, {s_in[ok].min():.3g}", stacklevel=user_stacklevel())
        if ok.any():
            s = np.where(ok, s_in, s_in[ok].min())
            weighted = True
    return g, v, no_granules, s, weighted


def _line_start(g, v, w, pos):
    """Slope β and zero γ₁ [N/m] of the straight line fitted (weights ``w``) through the points
    with granules (``pos``): the linear model's start and the hinge's first onset."""
    if pos.sum() < 3 or np.unique(g[pos]).size < 2:
        raise ParameterError(f"the growth fit needs at least three points with granules at two or more γ "
                             f"(got {int(pos.sum())} with granules)")
    A = np.column_stack([np.ones(pos.sum()), g[pos]])
    sw = np.sqrt(w[pos])
    (a0, b0), *_ = np.linalg.lstsq(A * sw[:, None], v[pos] * sw, rcond=None)
    if not b0 > 0:
        raise ParameterError(f"no growth of the mean granule volume with γ (fitted slope {b0:.3g} <= 0)")
    return b0, -a0 / b0


def _hinge_onset(g, v, w, pos, g1_start):
    """Onset γ₁ [N/m] and slope β minimising the weighted RSS of the hinge over all points, γ₁
    profiled on a grid then by a bounded scalar minimisation, β in closed form for each γ₁."""
    from scipy.optimize import minimize_scalar

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
    return best, beta_best


def _polish(func, g, v, s, w, used, p0, hinge):
    """:func:`scipy.optimize.curve_fit` of ``func`` on the ``used`` points from ``p0``: the
    parameters, their covariance (scaled by the residual variance), the degrees of freedom and the
    weighted RSS. For the ``hinge``, a start (the profile optimum) better than the polished fit is
    kept, its covariance from the hinge's Jacobian there."""
    from scipy.optimize import curve_fit

    dof = int(used.sum()) - 2  # >= 1: the used points hold the three with granules of _line_start
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            popt, pcov = curve_fit(func, g[used], v[used], p0=p0, sigma=s[used], absolute_sigma=False, maxfev=20000)
        except (RuntimeError, ValueError) as exc:
            raise ParameterError(f"the growth fit did not converge ({exc})") from None
    residual = lambda p: float(np.sum(w[used] * (v[used] - func(g[used], *p)) ** 2))  # noqa: E731
    if hinge and residual(popt) > residual(p0) * (1 + 1e-9):
        popt = np.asarray(p0, dtype=float)
        x = np.maximum(0.0, g[used] - popt[1])
        J = np.column_stack([x, np.where(g[used] > popt[1], -popt[0], 0.0)]) / s[used][:, None]
        pcov = np.linalg.pinv(J.T @ J) * residual(popt) / dof
    return popt, pcov, dof, residual(popt)


def fit_growth_of_table(table, cohesion="acting", **kwargs) -> GrowthFit:
    part = growth_rows(table, cohesion)
    sem = part["mean_volume_norm_sem"] if "mean_volume_norm_sem" in part else None
    if "mean_volume_norm_replica_sem" in part:  # rows over replicas: the run-to-run error where it exists
        sem = part["mean_volume_norm_replica_sem"].fillna(sem if sem is not None else np.nan)
    return fit_granule_growth(part["gamma"], part["mean_volume_norm_mean"], sem, **kwargs)

