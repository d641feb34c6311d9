"""The figure of a parameter study: growth against the dimensionless groups (the paper's Fig 7)."""

from __future__ import annotations

import numpy as np

__all__ = ["growth_figure"]


def growth_figure(table, fit=None, cohesion="acting"):
    """The paper's Fig 7: ⟨V_g⟩/V_p against γ of the original system, one curve per Ω (error
    bars: block s.e.m.; band: the replica standard error where there are replicas), the fitted law
    and the paper's β = 70, γ₁ = 0.027 N/m for reference.

    The points are :func:`~granalytics.growth_points` of the table: rows of one (Ω, γ) (e.g.
    several seeds) averaged, the replicas' spread as the band; rows that
    ``study_table(replicas=...)`` already combined bring their replica s.e.; points without
    granules are drawn at 0 with open markers.

    Parameters
    ----------
    table : DataFrame
        :func:`study_table` output.
    fit : GrowthFit, optional
        Default: :func:`~granalytics.analysis.study.fit_growth_of_table` of the table's rows (no
        fitted line if that fails).
    cohesion : str, default "acting"
        Convention whose rows are drawn (named in the title).

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib.pyplot as plt

    from granalytics.analysis.study import fit_growth_of_table, growth_points, select_cohesion
    from granalytics.base.errors import ParameterError

    points = growth_points(table, cohesion)
    if fit is None:
        try:
            fit = fit_growth_of_table(table, cohesion)
        except ParameterError:
            fit = None
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    _draw_growth_points(ax, points)
    _draw_growth_laws(ax, fit, float(points["gamma"].min()), float(points["gamma"].max()))
    ax.set_xlabel("γ of the original system [N/m] (paper Fig 7 convention)")
    ax.set_ylabel("⟨V_g⟩ / V_p")
    part = select_cohesion(table, cohesion)
    alphas = sorted(part["alpha"].dropna().unique()) if "alpha" in part else []
    cg = f", CG{'/'.join(f'{a:g}' for a in alphas)}" if alphas else ""
    ax.set_title(f"Mean granule volume in steady state vs surface tension{cg}\ncohesion convention: {cohesion}",
                 fontsize=10)
    ax.legend(fontsize=8)
    return fig


def _draw_growth_points(ax, points):
    """The points of :func:`~granalytics.growth_points`, one colour per Ω: block s.e.m. as error
    bars, the replica s.e. as a band, open markers where there are no granules; a legend key of
    the errors."""
    drew_band = False
    for k, (omega, agg) in enumerate(points.groupby("omega", sort=True)):
        colour = f"C{k}"
        gamma, v, rsem = agg["gamma"], agg["mean_volume_norm"], agg["replica_sem"]
        ax.errorbar(gamma, v, yerr=agg["block_sem"], color=colour, marker="o", ms=5, lw=1, capsize=3,
                    label=f"Ω = {omega:g} rad/s")
        band = rsem.notna()
        if band.any():
            ax.fill_between(gamma[band], (v - rsem)[band], (v + rsem)[band], color=colour, alpha=0.2, lw=0)
            drew_band = True
        none = agg["no_granules"]
        if none.any():
            ax.plot(gamma[none], v[none], ls="none", marker="o", ms=5, mfc="white", color=colour)
    if drew_band:
        ax.fill_between([], [], [], color="0.6", alpha=0.3, lw=0, label="band: replica s.e.; bars: block s.e.m.")
    else:
        ax.errorbar([], [], yerr=[], color="0.4", marker="o", ms=5, lw=1, capsize=3, label="bars: block s.e.m.")


def _draw_growth_laws(ax, fit, gmin, gmax):
    """The fitted law where the data show growth (else the reason in the legend) and the paper's,
    over γ from below the paper's onset to ``gmax`` [N/m]."""
    from granalytics.analysis.study import PAPER_BETA, PAPER_GAMMA_1, paper_growth_law

    grid = np.linspace(min(gmin, PAPER_GAMMA_1 * 0.5), gmax, 200)
    if fit is not None and fit.shows_growth:
        ax.plot(grid, fit.predict(grid), color="k", lw=1.5,
                label=f"fit: β = {fit.beta:.3g} [{fit.beta_ci[0]:.3g}, {fit.beta_ci[1]:.3g}], "
                      f"γ₁ = {fit.gamma_1:.3g} [{fit.gamma_1_ci[0]:.3g}, {fit.gamma_1_ci[1]:.3g}] N/m")
    elif fit is not None:  # the data show no growth: no law is drawn (GrowthFit.shows_growth)
        ax.plot([], [], ls="none", label=f"no growth law: {fit.no_growth_reason()}")
    ax.plot(grid, paper_growth_law(grid), color="0.5", ls="--", lw=1,
            label=f"paper: β ≈ {PAPER_BETA:g}, γ₁ ≈ {PAPER_GAMMA_1:g} N/m")
