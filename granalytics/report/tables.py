"""Results as text: numbers with their errors (:func:`plus_minus`), the CG table
(:func:`format_cg_table`), a steady-state table (:func:`format_steady_table`) and the notes that
say why an error of a printed table is n/a (:func:`steady_error_notes`), the means of a threshold
sensitivity pass (:func:`format_sensitivity_means`) and of a method comparison
(:func:`format_method_means`), a parameter study's table (:func:`format_study_table`) and its
surrogate's leave-one-out error (:func:`format_surrogate_errors`)."""

from __future__ import annotations

import math

import pandas as pd

from granalytics.analysis.metrics import HEADLINE, METRICS

__all__ = ["plus_minus", "format_cg_table", "format_steady_table", "steady_error_notes", "format_sensitivity_means",
           "format_method_means", "format_study_table", "format_surrogate_errors"]


def plus_minus(value, error, digits=2) -> str:
    """``value ± error`` with ``error`` to ``digits`` significant figures and ``value`` to the
    same decimal place (``3.000 ± 0.091``, not ``3 ± 0.0907``); an error that is NaN (too few
    blocks or replicas to estimate one) or 0 leaves ``value`` to 4 significant figures."""
    if not (math.isfinite(error) and error > 0 and math.isfinite(value)):
        shown = "n/a" if not math.isfinite(error) else f"{error:g}"
        return f"{value:.4g} ± {shown}"
    decimals = digits - 1 - math.floor(math.log10(error))
    if decimals >= 0:
        return f"{value:.{decimals}f} ± {error:.{decimals}f}"
    step = 10.0 ** -decimals
    return f"{round(value / step) * step:.0f} ± {round(error / step) * step:.0f}"


def format_cg_table(comparison) -> str:
    """The CG table as text: the runs' size-distribution distance and speed-ups, then one block
    per headline metric with each run's steady-state mean ± its error, the block s.e.m. (in its
    own column where the ± is the replica s.e.) and the deviation from the reference run ± its
    standard error. Every error column names its error; an error that cannot be estimated is
    ``n/a`` with a note saying why."""
    table = comparison.table
    replicas = bool((table["n_replicas"] > 1).any())
    width = max(26, table["run"].str.len().max())
    lines = [f"CG comparison, {comparison.description}; deviations from {comparison.reference}",
             f"{'run':<{width}} {'replicas':>8} {'KS D':>6} {'speed-up*':>9} {'paper':>6}"]
    for row in table.itertuples():
        lines.append(f"{row.run:<{width}} {row.n_replicas:>8d} {row.ks_distance:>6.3f} {row.speedup:>8.1f}× "
                     f"{row.paper_speedup:>5.1f}×")
    error = "replica s.e." if replicas else "block s.e.m."
    notes = {}  # why an error is n/a -> the runs it is n/a for
    for metric in HEADLINE:
        label = METRICS[metric].label
        header = f"{label:<{width}} {'mean ± ' + error:>21}"
        if replicas:
            header += f" {'block s.e.m.':>12}"
        lines.append(header + f" {'deviation ± s.e.':>17}")
        for row in table.itertuples():
            mean, sem, rsem, dev, dev_se = (getattr(row, f"{metric}_{x}")
                                            for x in ("mean", "sem", "replica_sem", "rel_dev", "rel_dev_se"))
            shown_error = rsem if replicas else sem
            if not math.isfinite(shown_error):
                notes.setdefault(_cg_error_note(row, metric, mean, replicas), []).append(row.run)
            shown = plus_minus(mean, shown_error)
            if replicas and row.n_replicas == 1:  # the mean to its block s.e.m.'s figures
                shown = plus_minus(mean, sem).split(" ± ")[0] + " ± n/a"
            cells = f"{row.run:<{width}} {shown:>21}"
            if replicas:
                if not math.isfinite(sem):
                    notes.setdefault(_cg_error_note(row, metric, mean, False), []).append(row.run)
                cells += f" {format(sem, '#.2g') if math.isfinite(sem) else 'n/a':>12}"
            if row.run == comparison.reference:
                deviation = "reference"
            else:
                deviation = f"{dev:+.0%} ± " + (f"{dev_se:.0%}" if math.isfinite(dev_se) else "n/a")
            lines.append(f"{cells} {deviation:>17}")
    lines.append("* speed-up: the reference's wall time per simulated second over this run's, as the simulator "
                 "recorded them (a group: the mean over its replicas). Each run's wall time depends on what else ran "
                 "on the machine then, so a single run, a replica group and another machine give other ratios; the "
                 "load-free ratio is measured side by side by benchmarks/cg_speedup.py (docs/results.md, 'Speed-up')")
    if replicas:
        lines.append("± replica s.e.: standard deviation of a group's replica means / √n (the run-to-run error); "
                     "block s.e.m.: standard error of the mean from the means of blocks of the window, combined "
                     "over the replicas as √(Σ sem²)/n; deviation ± s.e.: from each side's larger of replica s.e. "
                     "and block s.e.m. (a single run's block s.e.m.)")
    else:
        lines.append("± block s.e.m.: standard error of the mean from the means of blocks of the window; "
                     "deviation ± s.e.: from the two runs' block s.e.m.")
    for note, runs in notes.items():
        lines.append(f"n/a: {', '.join(dict.fromkeys(runs))}: {note}")
    return "\n".join(lines)


def _cg_error_note(row, metric, mean, replica) -> str:
    """Why an error of the CG table is n/a (the note's text, without the run)."""
    if replica and row.n_replicas == 1:
        return "a single run has no replica s.e. (its block s.e.m. is beside it, and its deviations use it)"
    if not math.isfinite(mean):
        return f"no granules in the window, no {METRICS[metric].label} to average"
    return ("no block s.e.m.: the window holds fewer than two blocks (quarter revolutions) of frames, too short "
            "to estimate it; widen --window")


def steady_error_notes(steady, by, *, replicas=False) -> list:
    """Why an error of a printed steady-state table is n/a, one line per reason (none when every
    error is there)."""
    error = "block_sem" if replicas else "sem"
    missing = steady[steady[error].isna()]
    if not len(missing):
        return []
    empty = missing["mean"].isna()
    notes = []
    if empty.any():
        notes.append(f"n/a: {', '.join(missing.index[empty])}: no frame of the window has a value (no granules)")
    if (~empty).any():
        blocks = "quarter revolutions" if by == "revolutions" else "blocks"
        what = "a replica's window holds" if replicas else "the window holds"
        notes.append(f"n/a: {', '.join(missing.index[~empty])}: no block s.e.m.: {what} a single block "
                     f"(fewer than two {blocks} of frames), too short to estimate it; widen the window")
    return notes


def format_steady_table(steady, by="revolutions", *, replicas=False) -> str:
    """A steady-state table (:func:`granalytics.steady_state`, of one run or of replicas) as text:
    one row per metric (5 significant digits; ``sem`` shown as ``block_sem`` for one run), a line
    that says what each error column is, and the notes of :func:`steady_error_notes`."""
    shown = steady if replicas else steady.rename(columns={"sem": "block_sem"})
    with pd.option_context("display.float_format", "{:.5g}".format, "display.width", 120):
        lines = [shown.to_string(na_rep="n/a")]
    if replicas:
        lines.append("replica_sem: standard error of the mean over the replicas (std of the replica means / √n); "
                     "replica_std: standard deviation of the replica means; block_sem: what the replicas' block s.e.m. "
                     "say of the same mean, √(Σ sem_i²)/n")
    else:
        lines.append("std: over the frames of the window; block_sem: standard error of the mean from the means of its "
                     "blocks (the sem column of --steady-out)")
    lines += steady_error_notes(steady, by, replicas=replicas)
    return "\n".join(lines)


def format_sensitivity_means(summary, window, cohesion, *, rigid=False) -> str:
    """A sensitivity summary (:func:`granalytics.sensitivity_summary`) as text: a line that says
    what is averaged, then each threshold pair's mean of every headline metric over the frames of
    ``window`` [revolutions] (4 significant digits); the pair is (A_agg, C_agg), or (rigid_tol,
    C_agg) with ``rigid``."""
    shown = summary[["rigid_tol" if rigid else "a_agg_deg", "c_agg", *(f"{name}_mean" for name in HEADLINE)]]
    lines = [f"mean over the frames of revolutions [{window[0]:g}, {window[1]:g}] at each threshold pair "
             f"(cohesion={cohesion}; F_coh >= C_agg·2πγR keeps a contact, so above the largest F_coh/(2πγR) of "
             "the run nothing is kept)"]
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120, "display.max_rows", 40):
        lines.append(shown.to_string(index=False))
    return "\n".join(lines)


def format_method_means(mean_stats, mean_pairs, n_frames, window) -> str:
    """A method comparison's means as text (4 significant digits): a line naming the ``n_frames``
    frames of ``window`` [revolutions] averaged, the headline metrics of each method
    (``mean_stats``, indexed by method) and the agreement of each pair (``mean_pairs``, indexed by
    ``method_a``, ``method_b``)."""
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120):
        return "\n".join([f"means over the {n_frames} frames in the window [{window[0]:g}, {window[1]:g}] revolutions",
                          mean_stats.to_string(), mean_pairs.to_string()])


def format_study_table(table, *, replicas=False) -> str:
    """A study table (:func:`granalytics.study_table`) as text: each point's ``point``, ``gamma``,
    ``omega``, ``alpha``, ``cohesion`` (those it has) and each headline metric's mean ± block
    s.e.m. (± replica s.e., the block s.e.m. beside it and ``n_replicas``, with ``replicas``),
    then a line that says what the errors are and why one is n/a."""
    columns = ["point", "gamma", "omega", "alpha", "cohesion"]
    cells = table[[c for c in columns if c in table]].copy()
    for metric in HEADLINE:  # the ± is the replica s.e. where there are replicas, the block s.e.m. beside it
        if replicas:
            cells[f"{metric} ± replica s.e."] = [plus_minus(m, r) for m, r in zip(table[f"{metric}_mean"],
                                                                                table[f"{metric}_replica_sem"])]
            cells[f"{metric} block s.e.m."] = [f"{e:#.2g}" if e == e else "n/a" for e in table[f"{metric}_sem"]]
        else:
            cells[f"{metric} ± block s.e.m."] = [plus_minus(m, e) for m, e in zip(table[f"{metric}_mean"],
                                                                                table[f"{metric}_sem"])]
    if replicas:
        cells.insert(1, "n_replicas", table["n_replicas"])
    with pd.option_context("display.width", 160, "display.max_rows", 200, "display.max_colwidth", 60):
        lines = [cells.to_string(index=False)]
    lines.append("block s.e.m.: standard error of the mean from the means of blocks of the window"
                 + (" (a group's combined as √(Σ sem²)/n); replica s.e.: standard deviation of a group's replica "
                    "means / √n (n/a for a point without replicas)" if replicas else "")
                 + ("; n/a: the window of a point holds fewer than two blocks (quarter revolutions) of frames, or no "
                    "granules" if table[[f"{m}_sem" for m in HEADLINE]].isna().any().any() else ""))
    return "\n".join(lines)


def format_surrogate_errors(loo) -> str:
    """A surrogate's leave-one-out error (:attr:`granalytics.Surrogate.loo`) as text, 4 significant digits."""
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120):
        return loo.to_string()
