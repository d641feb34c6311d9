"""Coarse-graining comparison: do runs of one system at CG factors α = 1, 2, 3 give the same
granulation? The analogues of the paper's Figs 3–6 (mean granule volume, granule number, size
distribution and yield) and a table of steady-state values, their deviations from the finest run,
size-distribution distances and the measured CG speed-up.

Every statistic is normalised by the run's own particle count and mean particle volume and the
identification thresholds by the run's own γ and R, so runs at different α are comparable as they
are (§3.1 of the paper: F_agg,CG = α²·F_agg,o, A_agg unchanged).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from granalytics.analysis.confinement import confinement_warning, confinement_of_run
from granalytics.analysis.run_systems import check_one_system, check_replicas, run_identity
from granalytics.analysis.metrics import BY_FIGURE
from granalytics.base.validation import FLAG, WINDOW, Array, validate_params
from granalytics.core.windows import window_mask
from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION
from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.core import open_run
from granalytics.analysis.stats import DEFAULT_WINDOW_REV, run_stats, size_distribution, steady_state

__all__ = ["compare_cg", "compare_cg_thresholds", "cg_rule_of", "cg_rule_warning", "CG_RULE_DEVIATION", "group_replicas", "CGComparison", "CGThresholdComparison", "PAPER_SPEEDUP", "CG_METRICS"]

#: speed-up over CG1 reported by the paper for CG2 and CG3 (its conclusion)
PAPER_SPEEDUP = {2.0: 12.0, 3.0: 32.0}

#: steady-state metrics compared: the headline metrics of the registry, in the order of the paper's
#: figures (a live list, :mod:`granalytics.analysis.metrics`)
CG_METRICS = BY_FIGURE


@dataclass
class CGComparison:
    """Result of :func:`compare_cg`.

    Attributes
    ----------
    runs : DataFrame
        One row per run or group of replicas: ``run`` (label), ``path`` (a group's paths joined by
        ``"; "``), ``alpha``, ``n_particles``, ``n_particles_original``, ``revolutions_last``,
        ``wall_time_s`` and ``wall_time_per_simulated_s`` (from the run's provenance, a group's
        mean; NaN when it does not say), ``n_replicas``, ``seeds``.
    timeseries : DataFrame
        :func:`~granalytics.run_stats` rows of every run, with ``run``, ``alpha`` and ``replica``
        (0, 1, … within a group).
    distributions : DataFrame
        :func:`~granalytics.size_distribution` of the granule sizes pooled over the window, per
        run, with ``run`` and ``alpha``.
    table : DataFrame
        One row per run or group: for each metric of :data:`CG_METRICS` ``<metric>_mean``,
        ``_std`` (over frames), ``_sem`` (blocking), ``_replica_sem`` (a group's run-to-run
        error; NaN for one run), ``_rel_dev`` (relative deviation of the mean from the reference
        run's) and ``_rel_dev_se`` (its standard error); ``n_replicas``; ``ks_distance`` (Kolmogorov–Smirnov D between the
        pooled granule sizes of the run and of the reference) and ``w1_log10_size``
        (Wasserstein-1 distance of log10 sizes); ``n_frames``, ``n_granules_pooled``;
        ``speedup`` (reference wall time per simulated second over this run's) and
        ``paper_speedup`` (the paper's figure for the same pair of CG factors: 12× for CG2 and
        32× over CG1, so 32/12 for CG3 over CG2); ``method``, ``cohesion``, ``window``.
    sizes : dict
        Run label -> pooled granule sizes in the window (int array).
    reference : str
        Label of the reference run (the smallest α).
    window : (float, float)
        Steady-state window [revolutions].
    method, cohesion : str
    params : dict
        Identification parameters.
    """

    runs: pd.DataFrame
    timeseries: pd.DataFrame
    distributions: pd.DataFrame
    table: pd.DataFrame
    sizes: dict
    reference: str
    window: tuple
    method: str
    cohesion: str
    params: dict = field(default_factory=dict)

    @property
    def description(self) -> str:
        """One line naming the identification: method, its thresholds (the defaults it used
        included: C_agg and A_agg, or the rigid tolerance, and the size floor), cohesion
        convention, window."""
        from granalytics.identification import make_identifier

        identifier = make_identifier(self.method, **self.params)
        rigid = getattr(identifier, "comotion", None) == "rigid"
        names = ("c_agg", "rigid_tol" if rigid else "a_agg_deg", "comotion" if rigid else None, "min_size")
        effective = {k: getattr(identifier, k) for k in names if k and getattr(identifier, k, None) is not None}
        effective.update({k: v for k, v in self.params.items() if v is not None})
        shown = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in effective.items())
        shown = shown or "its default parameters"
        return (f"{self.method} ({shown}), cohesion={self.cohesion}, "
                f"window [{self.window[0]:g}, {self.window[1]:g}] rev")

    def replica_spread(self, run, column) -> pd.DataFrame:
        """Mean, min and max of ``column`` (a :func:`~granalytics.run_stats` column) over the
        replicas of ``run`` (a label of :attr:`runs`) at the frames every replica has, their
        revolutions matched to 1e-6; a frame where a replica's value is NaN is left out.

        Returns
        -------
        DataFrame
            Indexed by revolutions: ``mean``, ``min``, ``max``.
        """
        part = self.timeseries[self.timeseries["run"] == run]
        if part.empty:
            raise ParameterError(f"run must be one of {', '.join(map(repr, self.runs['run']))}, got {run!r}")
        keyed = part.assign(_rev=part["revolutions"].round(6))
        wide = keyed.pivot_table(index="_rev", columns="replica", values=column, aggfunc="first").dropna()
        return pd.DataFrame({"mean": wide.mean(axis=1), "min": wide.min(axis=1), "max": wide.max(axis=1)})

    def size_distributions(self, size_unit="particles", *, ci=0.95) -> dict:
        """The size distribution of each run's granules pooled over the window (and its replicas)
        with a bootstrap ``ci`` band over the granules (:func:`~granalytics.size_distribution`),
        sizes in ``size_unit``: ``"particles"`` of the run, or ``"original"``-particle equivalents
        α³·n. Bins from the identification's size floor (``min_size``, default 2).

        Returns
        -------
        dict
            Run label -> size distribution table, for every run with granules in the window.
        """
        floor = self.params.get("min_size") or 2  # the smallest size that can occur
        alpha = dict(zip(self.runs["run"], self.runs["alpha"]))
        return {label: size_distribution(sizes, ci=ci, size_unit=size_unit, alpha=alpha[label], min_size=floor)
                for label, sizes in self.sizes.items() if len(sizes)}


def _paper_speedup(alpha) -> float:
    """The paper's speed-up of CG factor α over CG1 (1 for α = 1, NaN where it reports none)."""
    return 1.0 if alpha == 1 else PAPER_SPEEDUP.get(float(alpha), math.nan)


def _alpha_label(alpha, n_particles, n_replicas=1):
    replicas = f", {n_replicas} replicas" if n_replicas > 1 else ""
    return f"CG{alpha:g} ({n_particles} particles{replicas})"


def _run_list(runs, where) -> list:
    """``runs`` (a list or tuple of runs) as a list; anything else is a ParameterError."""
    if not isinstance(runs, (list, tuple)):
        raise ParameterError(f"{where}: runs must be a list of run files (or open runs), got {type(runs).__name__} "
                             f"{runs!r}")
    return list(runs)


def _run_item(item, where):
    """One run of a comparison: a run file's path, an open run (anything with ``meta``) or its kept
    :class:`~granalytics.analysis.run_statistics.RunStatistics`."""
    if not isinstance(item, (str, os.PathLike)) and not hasattr(item, "meta"):
        raise ParameterError(f"{where}: a run must be a run file's path, an open run or its RunStatistics, got "
                             f"{type(item).__name__} {item!r}")
    return item


def _replica_group(item) -> list:
    """A ``runs`` entry of :func:`compare_cg` as a list of replicas (a single run: a list of one)."""
    if isinstance(item, (list, tuple)):
        if not item:
            raise ParameterError("compare_cg: an empty group of replicas")
        return [_run_item(member, "compare_cg") for member in item]
    return [_run_item(item, "compare_cg")]


def group_replicas(paths) -> list:
    """Group run files (or :class:`~granalytics.RunStatistics` kept of runs) into replicas of one
    system: runs with equal α and particle count (and original system) are replicas (they differ in
    their seed). Returns a list of groups (lists of paths) in the order of each group's first run,
    for :func:`compare_cg`."""
    groups = {}
    for path in paths:
        if hasattr(path, "meta"):
            meta = path.meta
        else:
            with open_run(path) as run:
                meta = run.meta
        key = (float(meta.alpha), int(meta.n_particles), int(meta.n_particles_original))
        groups.setdefault(key, []).append(path)
    return list(groups.values())


#: the relative deviation of the steady yield (acting cohesion, C_agg 0.6, A_agg 20°) of a CG run
#: from α = 1 at the same confinement, with its standard error, by rule, by the confinement
#: D/(αd) of the simulated particles at which it was measured, and by α:
#: D/(αd) 11.2, the lab drum: against α = 1 runs at equal D/d, angle test, window [3, 6], mean over
#: seeds 0-4 (docs/results.md, "CG rules"; benchmarks/cg_rules_study.py table);
#: D/(αd) 44.4, the paper drum: paper-cg3 (seeds 0-1 under each rule) against the α = 1 law of the
#: paper drum's family (D/d 22-66), window [2, 4], Δt factor 1.5 (benchmarks/paper_drum_runs.py table)
CG_RULE_DEVIATION = {
    "weber": {11.2: {1.0: (0.0, 0.0), 2.0: (-0.17, 0.01), 3.0: (-0.25, 0.02)},
              44.4: {1.0: (0.0, 0.0), 3.0: (-0.01, 0.01)}},
    "bond": {11.2: {1.0: (0.0, 0.0), 2.0: (-0.01, 0.02), 3.0: (-0.00, 0.02)},
             44.4: {1.0: (0.0, 0.0), 3.0: (0.04, 0.01)}},
}
#: where each confinement of :data:`CG_RULE_DEVIATION` was measured
_CG_RULE_MEASURED_IN = {11.2: "lab drum, five seeds", 44.4: "paper drum, two seeds"}
#: the largest |yield deviation| a CG rule may have before info and compare-cg warn
CG_RULE_TOLERANCE = 0.10


def _rule_deviation(measured, alpha) -> float:
    """The yield deviation of one rule at one confinement at ``alpha``, linear between the measured α."""
    alphas = sorted(measured)
    return float(np.interp(alpha, alphas, [measured[a][0] for a in alphas]))


def cg_rule_warning(rule, alpha, drum_ratio=None) -> str | None:
    """One line when a run's CG rule at its α is measured (:data:`CG_RULE_DEVIATION`, linear in α
    between the measured factors) to move the yield by more than :data:`CG_RULE_TOLERANCE`, or
    when α lies beyond the factors measured at that confinement, or when the run is more confined
    than any measurement; None otherwise (α = 1, a rule within the tolerance, or a run of another
    code, whose rule is unknown).

    The measurement used is that of the most open measured confinement D/(αd) not above the run's
    ``drum_ratio`` that measured the run's α or a larger one (the most open not above it where none
    did; the most confined one where ``drum_ratio`` is unknown or below them all): a rule's error
    shrinks as the drum opens, so a run is judged by no more open a drum than its own."""
    if rule is None or alpha is None or alpha <= 1 or rule not in CG_RULE_DEVIATION:
        return None
    if drum_ratio is not None and not math.isfinite(drum_ratio):
        drum_ratio = None  # a run without its drum's geometry
    confinements = sorted(CG_RULE_DEVIATION[rule])
    # the table's confinements are rounded to three digits
    below = [c for c in confinements if drum_ratio is not None and c <= drum_ratio * 1.001]
    covering = [c for c in below if max(CG_RULE_DEVIATION[rule][c]) >= alpha - 1e-9]
    where = covering[-1] if covering else below[-1] if below else confinements[0]
    top = max(CG_RULE_DEVIATION[rule][where])
    if alpha > top + 1e-9:
        return (f"CG rule {rule} at α = {alpha:g}: the rules are measured up to α = {top:g} only at D/(αd) {where:g} "
                f"(docs/results.md, 'CG rules'); its error on the statistics is not known here")
    deviation = _rule_deviation(CG_RULE_DEVIATION[rule][where], alpha)
    if abs(deviation) <= CG_RULE_TOLERANCE:
        if drum_ratio is not None and not below:  # more confined than measured: the error may be larger
            return (f"CG rule {rule} at α = {alpha:g}: this run's D/(αd) {drum_ratio:.1f} is more confined than any "
                    f"measured ({where:g}, {_CG_RULE_MEASURED_IN[where]}, where the rule moved the steady yield by "
                    f"{100 * deviation:+.0f} %); its error may be larger here (docs/results.md, 'CG rules')")
        return None
    better = [r for r, by_confinement in CG_RULE_DEVIATION.items() if where in by_confinement
              and abs(_rule_deviation(by_confinement[where], alpha)) <= CG_RULE_TOLERANCE]
    run_ratio = "" if drum_ratio is None else f", this run's {drum_ratio:.0f}"
    return (f"CG rule {rule} at α = {alpha:g} moved the steady yield by about {100 * deviation:+.0f} % against α = 1 "
            f"at equal confinement (D/(αd) {where:g}, {_CG_RULE_MEASURED_IN[where]}{run_ratio}; docs/results.md, "
            "'CG rules')"
            + (f"; the rule {better[0]} keeps it within {100 * CG_RULE_TOLERANCE:.0f} % there (--cg-rule {better[0]})"
               if better else ""))


def cg_rule_of(meta):
    """The CG rule a run of our simulator was coarse-grained by (``sim_config.params.cg_rule``;
    ``"weber"``, Table 2, for runs made before the rule was a choice); None for a run of another
    code, which does not say."""
    params = (meta.sim_config or {}).get("params")
    if not isinstance(params, dict) or not params:
        return None
    return str(params.get("cg_rule", "weber"))


def _recorded(value) -> float:
    """A provenance number as a float, NaN where the run does not record it."""
    return math.nan if value is None else float(value)


def _analyse_member(item, window, method, cohesion, progress, params) -> dict:
    """One run of a comparison: its time series, steady state, pooled window sizes and provenance."""
    from granalytics.analysis.confinement import BED_COLUMNS
    from granalytics.analysis.run_statistics import RunStatistics

    lo, hi = window
    if isinstance(item, RunStatistics):  # kept in place of the frames: identified as asked already
        item.check_identification(method, {**params, "cohesion": cohesion})
        if len(item) == 0:
            raise ParameterError(f"{item.path}: the run statistics hold no frames")
        if item.unfinished:
            warnings.warn(f"{item.path}: statistics of an unfinished run: {item.unfinished}; its steady state is "
                          "that of the frames kept", stacklevel=user_stacklevel())
        meta, identity, frame_sizes = item.meta, item.identity(), item.sizes
        ts = item.timeseries.drop(columns=[c for c in BED_COLUMNS if c in item.timeseries])
        ts["method"], ts["cohesion"] = method, cohesion
    else:
        run = open_run(item) if isinstance(item, (str, os.PathLike)) else item
        try:
            meta = run.meta
            if len(run) == 0:
                raise ParameterError(f"{run.path}: the run has no frames")
            if getattr(run, "unfinished", None):
                warnings.warn(f"{os.fspath(run.path)}: unfinished run: {run.unfinished}; its steady state is that of "
                              "the frames it holds", stacklevel=user_stacklevel())
            ts, frame_sizes = run_stats(run, method, progress=progress, return_sizes=True, cohesion=cohesion, **params)
            identity = {**run_identity(run), "path": os.fspath(run.path)}
        finally:
            if run is not item:
                run.close()
    drum = confinement_of_run(meta)
    steady = steady_state(ts, window=(lo, hi), source=identity["path"])
    revs = ts["revolutions"].to_numpy()
    inside = window_mask(revs, lo, hi)
    pooled = np.concatenate([s for s, keep in zip(frame_sizes, inside) if keep] or [np.zeros(0, np.int64)])
    provenance = meta.provenance
    info = {
        **identity,
        "n_particles_original": meta.n_particles_original, "mean_radius_original": meta.mean_radius_original,
        "revolutions_last": float(revs[-1]),
        # None: recorded as not measured (RunMeta checks that these are numbers or None)
        "wall_time_s": _recorded(provenance.get("wall_time_s")),
        "wall_time_per_simulated_s": _recorded(provenance.get("wall_time_per_simulated_s")),
        "physics_version": provenance.get("physics_version"),
        "cg_rule": cg_rule_of(meta),
        "drum_ratio": drum.drum_ratio if drum is not None else math.nan,
    }
    return {"info": info, "timeseries": ts, "steady": steady, "sizes": pooled}


def _relative_deviation(mean, se, ref_mean, ref_se):
    """(mean − ref)/ref and its standard error from the two standard errors (NaN where ref is 0)."""
    if not ref_mean:
        return math.nan, math.nan
    ratio = mean / ref_mean
    # first order, written so that a mean of 0 (no granule in the CG run) keeps its error se/|ref|
    se_ratio = math.hypot(se, ratio * ref_se) / abs(ref_mean)
    return ratio - 1.0, se_ratio


_COMPARE_CONSTRAINTS = {"labels": [Array(ndim=1, dtype=str), None], "window": [WINDOW], "cohesion": [COHESION],
                        "progress": [FLAG]}


@validate_params({**_COMPARE_CONSTRAINTS, "mixed_systems": [FLAG]})
def compare_cg(runs, labels=None, *, window=DEFAULT_WINDOW_REV, method="gna", cohesion=DEFAULT_COHESION,
               progress=False, mixed_systems=False, **params) -> CGComparison:
    """Compare runs of one system at several CG factors (paper §3.1, Figs 3–6).

    Parameters
    ----------
    runs : sequence of paths (or :class:`~granalytics.Run`, or :class:`~granalytics.RunStatistics`
        kept in place of a run's frames), or of groups of them
        At least two systems; their metadata give α, the particle counts and the wall time. An
        entry that is a list or tuple of runs is a group of **replicas** (runs of one system that
        differ in their seed, e.g. from :func:`group_replicas`): its statistics are the mean over
        the replicas, with the replica standard error beside the block s.e.m.
    labels : sequence of str, optional
        Display names, one per entry of ``runs``; default ``"CG<α> (<N> particles)"`` (with the
        number of replicas for a group).
    window : (float, float), default (3, 6)
        Steady-state window [revolutions]: statistics, block s.e.m., pooled size distributions.
    method : str, default "gna"
        Identification method (any of :data:`granalytics.identification.METHODS`).
    cohesion : {"acting", "bridge"}, default "acting"
        Which force is F_coh (:mod:`granalytics.identification.cohesion`).
    progress : bool
        Progress bars over frames.
    mixed_systems : bool, default False
        Compare runs that are not coarse-grained from one original system (their original
        parameters differ in more than the seed, α and the CG rule, e.g. a twin, another γ or
        drum) with a warning; refused otherwise. Replicas of a group must always be one system at
        different seeds (a copy of a run is refused).
    **params
        Method parameters, e.g. ``c_agg=0.6, a_agg_deg=20`` (the paper's, and GNA's defaults).

    Returns
    -------
    CGComparison
        Its table has, per metric, ``_mean`` (over the replicas of a group), ``_std`` (over
        frames, averaged over replicas), ``_sem`` (block s.e.m., combined over replicas as
        √(Σ sem²)/n), ``_replica_sem`` (standard deviation of the replica means / √n; NaN for a
        single run), ``_rel_dev`` and ``_rel_dev_se`` (its standard error, from each side's larger
        of replica s.e. and block s.e.m.; a single run's block s.e.m.), and ``n_replicas``.
    """
    groups = [_replica_group(item) for item in _run_list(runs, "compare_cg")]
    if len(groups) < 2:
        raise ParameterError("compare_cg needs at least two runs")
    if labels is not None and len(labels) != len(groups):
        raise ParameterError(f"{len(labels)} labels for {len(groups)} runs")
    lo, hi = map(float, window)
    infos, systems, series, dists, steady, sizes = [], [], [], [], {}, {}
    for k, group in enumerate(groups):
        members = [_analyse_member(item, (lo, hi), method, cohesion, progress, params) for item in group]
        more = f" (and its {len(members) - 1} replica(s))" if len(members) > 1 else ""
        first = members[0]["info"]
        rule_warning = cg_rule_warning(first["cg_rule"], first["alpha"], first["drum_ratio"])
        for warning in (confinement_warning(first["drum_ratio"]), rule_warning):
            if warning:  # once per system, not per replica
                warnings.warn(f"{first['path']}{more}: {warning}", stacklevel=user_stacklevel())
        label = labels[k] if labels is not None else _alpha_label(members[0]["info"]["alpha"],
                                                                  members[0]["info"]["n_particles"], len(members))
        if label in sizes:
            raise ParameterError(f"two runs are labelled {label!r}; pass distinct labels, or group replicas "
                                 "(granalytics compare-cg --replicas)")
        systems.append(members[0]["info"]["system"])
        info, group_series, dist, steady[label], sizes[label] = _combine_group(members, label,
                                                                               params.get("min_size") or 2)
        infos.append(info)
        series.extend(group_series)
        dists.append(dist)
    _warn_if_not_one_system(infos, systems, mixed_systems)
    info = pd.DataFrame(infos)
    reference = info.loc[info["alpha"].idxmin(), "run"]
    rows = [{**_comparison_row(row, steady, sizes, reference, info.set_index("run").loc[reference]),
             "method": method, "cohesion": cohesion, "window": f"{lo:g}:{hi:g}"} for row in info.itertuples()]
    return CGComparison(
        runs=info, timeseries=pd.concat(series, ignore_index=True), distributions=pd.concat(dists, ignore_index=True),
        table=pd.DataFrame(rows), sizes=sizes, reference=reference, window=(lo, hi), method=method,
        cohesion=cohesion, params=dict(params),
    )


def _combine_group(members, label, min_size=2):
    """One run or group of replicas (:func:`_analyse_member` results) as one row of the comparison:
    its info, its members' time series (tagged), its pooled size distribution, its steady state
    over the replicas and its pooled granule sizes."""
    from granalytics.analysis.stats import combine_steady_states

    first = members[0]["info"]
    check_replicas([m["info"] for m in members])
    n = len(members)
    tables = [m["steady"] for m in members]
    combined = combine_steady_states(tables)
    combined["std"] = pd.concat([t["std"] for t in tables], axis=1).mean(axis=1)
    combined["n_frames"] = sum(t["n_frames"] for t in tables)
    info = {"run": label, **first, "path": "; ".join(m["info"]["path"] for m in members), "n_replicas": n,
            "seeds": ", ".join(str(m["info"]["seed"]) for m in members)}
    for key in ("wall_time_s", "wall_time_per_simulated_s"):
        info[key] = float(np.mean([m["info"][key] for m in members]))
    info["revolutions_last"] = min(m["info"]["revolutions_last"] for m in members)
    del info["seed"], info["system"], info["content"]
    series = []
    for r, member in enumerate(members):
        ts = member["timeseries"]
        ts.insert(0, "replica", r)
        ts.insert(0, "alpha", first["alpha"])
        ts.insert(0, "run", label)
        series.append(ts)
    # every granule of every window frame counts once: a replica with more frames gives more of them
    # (its steady means, above, count each replica once)
    pooled = np.concatenate([m["sizes"] for m in members])
    dist = size_distribution(pooled, min_size=min_size)  # bins from the smallest size that can occur
    dist.insert(0, "alpha", first["alpha"])
    dist.insert(0, "run", label)
    return info, series, dist, combined, pooled


def _warn_if_not_one_system(infos, systems, mixed_systems) -> None:
    """Refuse (or warn about) runs that are not coarse-grained from one original system
    (:func:`~granalytics.analysis.run_systems.check_one_system`); warn when they were made under
    different CG rules or simulator physics versions."""
    check_one_system([{**i, "system": s} for i, s in zip(infos, systems)], mixed_systems=mixed_systems)
    rules = {i["run"]: i["cg_rule"] for i in infos if i["alpha"] > 1 and i["cg_rule"] is not None}
    if len(set(rules.values())) > 1:
        warnings.warn("compare_cg: the coarse-grained runs were made under different CG rules ("
                      + ", ".join(f"{run}: {rule}" for run, rule in rules.items())
                      + "); their deviations mix the two rules", stacklevel=user_stacklevel())
    versions = {i["run"]: i["physics_version"] for i in infos if i["physics_version"] is not None}
    if len(set(versions.values())) > 1:
        warnings.warn("compare_cg: the runs were made by different simulator physics versions ("
                      + ", ".join(f"{run}: {v}" for run, v in versions.items())
                      + "); their differences mix coarse-graining with the change of physics", stacklevel=user_stacklevel())


def _side_error(table, metric) -> float:
    """The standard error of one side of a deviation: the larger of its replica s.e. and its block
    s.e.m. (the block s.e.m. alone for a single run). Two or three replicas that agree by chance
    give a replica s.e. far below what each run's frames allow; the block s.e.m. is the floor."""
    return float(np.fmax(table.loc[metric, "replica_sem"], table.loc[metric, "block_sem"]))


def _comparison_row(row, steady, sizes, reference, ref_row) -> dict:
    """The row of the comparison table of run ``row`` against the ``reference`` run: every CG
    metric's steady state and its relative deviation (each side's error: :func:`_side_error`), the
    size distributions' distances and the speed-up."""
    from scipy.stats import ks_2samp, wasserstein_distance

    table, ref = steady[row.run], steady[reference]
    out = {"run": row.run, "alpha": row.alpha, "n_particles": row.n_particles, "n_replicas": row.n_replicas}
    for metric in CG_METRICS:
        mean = table.loc[metric, "mean"]
        out[f"{metric}_mean"] = mean
        out[f"{metric}_std"] = table.loc[metric, "std"]
        out[f"{metric}_sem"] = table.loc[metric, "block_sem"]
        out[f"{metric}_replica_sem"] = table.loc[metric, "replica_sem"]
        if row.run == reference:
            dev, dev_se = (0.0, math.nan) if ref.loc[metric, "mean"] else (math.nan, math.nan)
        else:
            dev, dev_se = _relative_deviation(mean, _side_error(table, metric), ref.loc[metric, "mean"],
                                              _side_error(ref, metric))
        out[f"{metric}_rel_dev"] = dev
        out[f"{metric}_rel_dev_se"] = dev_se
    a, b = sizes[row.run], sizes[reference]
    both = a.size and b.size
    out["ks_distance"] = ks_2samp(a, b).statistic if both else math.nan
    out["w1_log10_size"] = wasserstein_distance(np.log10(a), np.log10(b)) if both else math.nan
    out["n_frames"] = int(table.loc["yield_fraction", "n_frames"])
    out["n_granules_pooled"] = int(a.size)
    out["wall_time_per_simulated_s"] = row.wall_time_per_simulated_s
    out["speedup"] = ref_row["wall_time_per_simulated_s"] / row.wall_time_per_simulated_s
    out["paper_speedup"] = _paper_speedup(row.alpha) / _paper_speedup(ref_row["alpha"])
    return out


def _grid_block_sems(table, window) -> pd.DataFrame:
    """The block s.e.m. of each headline metric at every threshold pair of a sensitivity table over
    ``window`` [revolutions]: :func:`steady_state`'s own blocks (its window tolerance, clipping and
    closing edge), so that a pair's error is the one ``stats`` gives it. Its drift warnings are
    left out: they would repeat for every pair."""
    rows = []
    for (a_agg, c_agg), part in table.groupby(["a_agg_deg", "c_agg"]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            steady = steady_state(part, window, BY_FIGURE)
        rows.append({"a_agg_deg": a_agg, "c_agg": c_agg, **{f"{m}_sem": steady.loc[m, "sem"] for m in BY_FIGURE}})
    return pd.DataFrame(rows)


@dataclass(eq=False)
class CGThresholdComparison:
    """Result of :func:`compare_cg_thresholds`: runs at several CG factors compared at every
    threshold pair.

    Attributes
    ----------
    table : DataFrame
        One row per run and threshold pair: ``run``, ``alpha``, ``c_agg``, ``a_agg_deg``,
        ``n_frames``, and for each headline metric ``<metric>_mean`` (over the window's frames),
        ``<metric>_sem`` (its block s.e.m., quarter-revolution blocks as :func:`steady_state`),
        ``<metric>_rel_dev`` ((run − finest)/finest; 0 for the finest run, NaN where the finest
        is 0) and ``<metric>_rel_dev_se`` (its standard error from both block s.e.m.s).
    window : (float, float)
        The window of drum revolutions averaged.
    cohesion : str
        The cohesion convention.
    """

    table: pd.DataFrame
    window: tuple
    cohesion: str

    @property
    def finest(self) -> str:
        """The label of the finest run (smallest α), the reference of the deviations."""
        return self.table.loc[self.table["alpha"].idxmin(), "run"]


@validate_params(_COMPARE_CONSTRAINTS)
def compare_cg_thresholds(runs, c_agg, a_agg_deg, labels=None, *, window=DEFAULT_WINDOW_REV,
                          cohesion=DEFAULT_COHESION, radius="pair", progress=False) -> CGThresholdComparison:
    """Does the CG agreement survive other thresholds? The deviation of each headline statistic
    from the finest run (smallest α) at every (C_agg, A_agg) pair.

    GNA's criterion is normalised by each system's own γ and R (f = F_coh/(2πγR)), so one threshold
    pair means the same in every run; every run is analysed once per frame for the whole grid
    (:func:`granalytics.analysis.sensitivity`).

    Parameters
    ----------
    runs : sequence of paths
        At least two runs of one system at several CG factors.
    c_agg, a_agg_deg : sequence of float
        The threshold grid (C_agg ≥ 0; A_agg in (0, 180] degrees).
    labels, window, cohesion, radius, progress :
        As for :func:`compare_cg`.

    Returns
    -------
    CGThresholdComparison
        Its ``table``: one row per run and threshold pair, each headline metric's mean, block
        s.e.m. and deviation from the finest run ± its standard error.
    """
    from granalytics.analysis.sensitivity import sensitivity, sensitivity_summary

    from granalytics.analysis.run_statistics import RunStatistics

    runs = [_run_item(item, "compare_cg_thresholds") for item in _run_list(runs, "compare_cg_thresholds")]
    for item in runs:
        if isinstance(item, RunStatistics):
            raise ParameterError(f"compare_cg_thresholds: {item.path} holds statistics kept at one threshold pair; "
                                 "a threshold grid identifies the granules again and needs the run's frames")
    if len(runs) < 2:
        raise ParameterError("compare_cg_thresholds needs at least two runs")
    if labels is not None and len(labels) != len(runs):
        raise ParameterError(f"{len(labels)} labels for {len(runs)} runs")
    lo, hi = map(float, window)
    rows = []
    for k, path in enumerate(runs):
        with open_run(path) as run:
            label = labels[k] if labels is not None else _alpha_label(run.meta.alpha, run.meta.n_particles)
            if any(label == r["run"].iloc[0] for r in rows):
                raise ParameterError(f"two runs are labelled {label!r}; pass distinct labels")
            frames = run.select(revolutions=(lo, hi))
            if not len(frames):
                raise ParameterError(f"{run.path}: no frame in the window [{lo:g}, {hi:g}] revolutions")
            table = sensitivity(frames, c_agg, a_agg_deg, radius=radius, cohesion=cohesion, progress=progress)
            summary = sensitivity_summary(table).merge(_grid_block_sems(table, (lo, hi)), on=["a_agg_deg", "c_agg"])
            summary.insert(0, "alpha", run.meta.alpha)
            summary.insert(0, "run", label)
            rows.append(summary)
    out = pd.concat(rows, ignore_index=True)
    finest = out.loc[out["alpha"] == out["alpha"].min(), "run"].iloc[0]
    keys = ["a_agg_deg", "c_agg"]
    ref = out[out["run"] == finest].set_index(keys)
    for metric in BY_FIGURE:
        at = pd.MultiIndex.from_frame(out[keys])
        base, base_se = (ref.loc[at, f"{metric}_{s}"].to_numpy() for s in ("mean", "sem"))
        mean, se = out[f"{metric}_mean"].to_numpy(), out[f"{metric}_sem"].to_numpy()
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(base != 0, mean / base, np.nan)
            out[f"{metric}_rel_dev"] = ratio - 1
            # the finest run's own row has no error of the deviation (it is 0 by definition)
            out[f"{metric}_rel_dev_se"] = np.where(out["run"] == finest, np.nan,
                                                   np.hypot(se, ratio * base_se) / np.abs(base))
    columns = ["run", "alpha", "c_agg", "a_agg_deg", "n_frames"]
    columns += [f"{m}_{s}" for m in BY_FIGURE for s in ("mean", "sem", "rel_dev", "rel_dev_se")]
    table = out[columns].sort_values(["alpha", "a_agg_deg", "c_agg"]).reset_index(drop=True)
    return CGThresholdComparison(table=table, window=(lo, hi), cohesion=cohesion)
