"""The figures of a threshold calibration (:class:`granalytics.Calibration`): the objective
over the grid and the measured beside the simulated size distribution."""

from __future__ import annotations

import math
import os

import numpy as np

from granalytics.report.figures._axes import cell_edges

__all__ = ["calibration_figures"]


def calibration_figures(calibration) -> dict:
    """The two figures of a threshold calibration (:func:`granalytics.calibrate_thresholds`).

    Returns
    -------
    dict
        ``"calibration_objective"``: χ² over the grid (log colour scale) with the best point, the
        bootstrap confidence region (outlined cells) and the Δχ² region (dots);
        ``"calibration_distributions"``: the measured and best-fit simulated distributions,
        cumulative mass fraction passing against aperture and mass fraction per class, with errors
        (measured σ; simulated block-bootstrap s.e.).
    """
    s = calibration.settings
    caption = (f"{', '.join(os.path.basename(str(r)) for r in s['runs'])}; window [{s['window_rev'][0]:g}, "
               f"{s['window_rev'][1]:g}] rev; size = {'volume-equivalent diameter' if s['measure'] == 'volume' else 'second principal extent'}; "
               f"cohesion={s['cohesion']}")
    return {"calibration_objective": _calibration_objective_figure(calibration, caption),
            "calibration_distributions": _calibration_distributions_figure(calibration, caption)}


def _threshold_names(calibration):
    """The calibration's co-motion threshold: (axis label, short name)."""
    if calibration.threshold_column == "a_agg_deg":
        return "A_agg [deg]", "A_agg"
    return "rigid tolerance", "rigid_tol"


def _calibration_objective_figure(cal, caption):
    """χ² over the threshold grid with the best point and the two confidence regions."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Rectangle

    col = cal.threshold_column
    name, short = _threshold_names(cal)
    grid, s = cal.grid, cal.settings
    c_vals, a_vals = np.unique(grid.c_agg), np.unique(grid[col])
    table = grid.pivot(index=col, columns="c_agg", values="chi2").reindex(index=a_vals, columns=c_vals)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    values = np.clip(table.to_numpy(), max(1e-3, np.nanmin(table.to_numpy()[table.to_numpy() > 0], initial=1.0) / 2), None)
    c_edges, a_edges = cell_edges(c_vals), cell_edges(a_vals)
    mesh = ax.pcolormesh(c_edges, a_edges, values, norm=LogNorm(), cmap="viridis_r", shading="flat")
    fig.colorbar(mesh, ax=ax, label="χ² (cumulative passing, weighted by errors)")
    cw, aw = np.diff(c_edges), np.diff(a_edges)
    for _, row in grid[grid.in_region].iterrows():
        i, j = np.searchsorted(c_vals, row.c_agg), np.searchsorted(a_vals, row[col])
        ax.add_patch(Rectangle((c_edges[i], a_edges[j]), cw[i], aw[j], fill=False, ec="white", lw=1.5))
    chi = grid[grid.in_chi2_region]
    ax.plot(chi.c_agg, chi[col], ".", color="orange", ms=4,
            label=f"Δχ² region ({100 * s['level']:g} %, Gaussian approximation; for comparison only)")
    ax.plot([cal.best["c_agg"]], [cal.best[col]], "*", color="red", ms=14, mec="white",
            label=f"best: C_agg = {cal.best['c_agg']:g}, {short} = {cal.best[col]:g}")
    ax.plot([], [], "s", mfc="none", mec="grey",
            label=f"confidence region ({100 * s['level']:g} %, bootstrap): the one the summary reports")
    ax.set_xlabel("C_agg")
    ax.set_ylabel(name)
    ax.legend(loc="lower right", fontsize=7, framealpha=0.8)
    title = f"calibration against {os.path.basename(str(s['measured']))}"
    if cal.poor_fit:
        title += "\nPOOR FIT: no grid point reproduces it"
    ax.set_title(title, fontsize=10)
    fig.text(0.01, 0.005, caption + f"\nC_agg: {cal.constraint['c_agg']}; {short}: {cal.constraint[col]}",
             fontsize=7, va="bottom")
    fig.subplots_adjust(bottom=0.2)
    return fig


def _calibration_distributions_figure(cal, caption):
    """The measured and the best pair's simulated distributions: cumulative mass fraction passing
    against aperture, and mass fraction per sieve class, with their errors."""
    import matplotlib.pyplot as plt

    _, short = _threshold_names(cal)
    d = cal.distributions
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    upper_mm = d.upper_m.to_numpy() * 1e3
    finite = np.isfinite(upper_mm)
    ax1.errorbar(upper_mm[finite], d.measured_passing[finite], yerr=d.measured_sigma[finite], fmt="o", color="k",
                 capsize=3, label="measured (σ)")
    ax1.errorbar(upper_mm[finite], d.simulated_passing[finite], yerr=d.simulated_passing_error[finite].fillna(0),
                 fmt="s-", color="tab:blue", ms=4, capsize=3, label="simulated, best pair (bootstrap s.e.)")
    ax1.set_xscale("log")
    ax1.set_xticks(upper_mm[finite])  # the apertures themselves: a decade's ticks would be 10⁰ and 10¹ only
    ax1.set_xticklabels([f"{a:.3g}" for a in upper_mm[finite]], rotation=45, ha="right", fontsize=7)
    ax1.minorticks_off()
    ax1.set_xlabel("aperture [mm] (original-system sizes)")
    ax1.set_ylabel("cumulative mass fraction passing")
    ax1.set_ylim(-0.02, 1.02)
    ax1.legend(fontsize=8)
    k = np.arange(len(d))
    labels = [f"{lo * 1e3:.3g}–{hi * 1e3:.3g}" if math.isfinite(hi) else f"≥ {lo * 1e3:.3g}"
              for lo, hi in zip(d.lower_m, d.upper_m)]
    ax2.bar(k - 0.2, d.measured_fraction, width=0.4, color="0.6", label="measured")
    ax2.bar(k + 0.2, d.simulated_fraction, width=0.4, yerr=d.simulated_fraction_error, color="tab:blue", capsize=2,
            label="simulated, best pair")
    ax2.set_xticks(k)
    ax2.set_xticklabels(labels, rotation=45, ha="right", fontsize=7)
    ax2.set_xlabel("sieve class [mm]")
    ax2.set_ylabel("mass fraction per class")
    ax2.legend(fontsize=8)
    fig.suptitle(f"best pair C_agg = {cal.best['c_agg']:g}, {short} = {cal.best[cal.threshold_column]:g}: χ² = "
                 f"{cal.chi2_min:.3g} on {cal.dof} degrees of freedom (p = {cal.p_value:.2g})", fontsize=10)
    fig.text(0.01, 0.005, caption, fontsize=7, va="bottom")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig
