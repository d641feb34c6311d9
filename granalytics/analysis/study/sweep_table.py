"""The study table of a sweep folder (``python -m sim sweep``): steady-state yield, mean granule
volume and granule number of every finished point, for each cohesion convention, with γ and Ω of
the *original* (α = 1) system taken from the run's metadata (the paper's Fig 7 plots CG2 runs,
simulated with γ₂ = 2γ, against the original γ); replicas of a point combined; the points of
Fig 7 drawn from it (:func:`growth_points`).

A sweep folder holds ``manifest.csv`` (one row per point: parameters, status, file, …) and the
run files ``points/<point>.h5``. This module reads only those files; it does not need :mod:`sim`.
"""

from __future__ import annotations

import math
import os

import pandas as pd

from granalytics.analysis.metrics import HEADLINE
from granalytics.analysis.stats import DEFAULT_WINDOW_REV, combine_replicas
from granalytics.base.errors import ParameterError
from granalytics.core.manifest import MANIFEST_COLUMNS, file_sha256, read_manifest
from granalytics.base.validation import FLAG, WINDOW, Array, Instance, Options, Path, validate_params
from granalytics.identification import METHODS
from granalytics.identification.cohesion import COHESION, check_cohesion


#: steady-state metrics of the study table
STUDY_METRICS = HEADLINE


#: manifest columns that are bookkeeping, not point parameters (the schema's, and the bundled copy's
#: ``source_sha256``, :func:`granalytics.datasets.bundle_sweep`)
_BOOKKEEPING = ("status", *MANIFEST_COLUMNS, "source_sha256")


# ----------------------------------------------------------------------------- the table
def _original_values(meta):
    """(γ, Ω) of the original system: ``meta.sim_config["original"]`` when the run came from
    ``sim``, else γ/α (Weber scaling γ_CG = α·γ) and the run's Ω."""
    original = meta.sim_config.get("original", {})
    gamma = original.get("surface_tension", meta.surface_tension / meta.alpha)
    omega = original.get("drum_omega", meta.drum_omega)
    return float(gamma), float(omega)


def _checked_point_file(sweep_dir, record) -> str:
    """The run file of a manifest row, refused (ParameterError) when it lies outside the sweep
    folder (``../outside/x.h5``) or its bytes are not those whose sha256 the manifest records (a
    point file replaced by another one)."""
    folder = os.path.realpath(os.fspath(sweep_dir))
    path = os.path.join(os.fspath(sweep_dir), record["file"])
    if os.path.commonpath([folder, os.path.realpath(path)]) != folder:
        raise ParameterError(f"{os.path.join(os.fspath(sweep_dir), 'manifest.csv')}: point {record['point']}'s file "
                             f"{record['file']!r} lies outside the sweep folder")
    recorded = record.get("sha256")
    if isinstance(recorded, str) and recorded and os.path.isfile(path) and file_sha256(path) != recorded:
        raise ParameterError(f"{path}: its sha256 is not the one the manifest records for point {record['point']} "
                             "(the file was replaced or changed after the sweep)")
    return path


def _check_point_parameters(path, record, meta) -> None:
    """Refuse a point file whose own parameters (γ and Ω of its original system, α, seed) are not
    the manifest row's: another point's file under this point's name."""
    params = meta.sim_config.get("params", {})
    gamma, omega = _original_values(meta)
    own = {"gamma": gamma, "omega": omega, "alpha": float(meta.alpha), "seed": params.get("seed")}
    for key, value in own.items():
        listed = record.get(key)
        if listed is None or value is None or (isinstance(listed, float) and math.isnan(listed)):
            continue
        if not math.isclose(float(listed), float(value), rel_tol=1e-9, abs_tol=0.0):
            raise ParameterError(f"{path}: the run's {key} is {value:g}, the manifest's point {record['point']} says "
                                 f"{float(listed):g} (another point's file?)")


@validate_params({"sweep_dir": [Path("a folder"), Instance((list, tuple), "a list of them")],
                  "window": [WINDOW], "method": [Options(METHODS)], "cohesion": [COHESION, Array(ndim=1, dtype=str)],
                  "replicas": [Instance(str), None], "progress": [FLAG]})
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
        Cohesion conventions (:mod:`granalytics.identification.cohesion`); one row per point and convention.
        Ignored (one row per point, ``cohesion`` None) for methods without a convention.
    replicas : str, optional
        A grid column that tells replicas apart (``"seed"``): points equal in every other
        parameter are combined into one row (:func:`~granalytics.analysis.stats.combine_replicas`):
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

    from granalytics.identification import method_parameters
    from granalytics.core import open_run
    from granalytics.analysis.stats import run_stats, steady_state

    if isinstance(sweep_dir, (list, tuple)):  # several folders analysed as one (e.g. replicas run later)
        if not sweep_dir:
            raise ParameterError("study_table: no sweep folder given")
        table = pd.concat([study_table(d, window, method, cohesion, progress=progress, **params) for d in sweep_dir],
                          ignore_index=True)
        return table if replicas is None else _combine_replica_rows(table, replicas, sweep_dir[0])

    conventions = [cohesion] if isinstance(cohesion, str) else list(cohesion)
    if not conventions:
        raise ParameterError("cohesion: give at least one convention")
    for c in conventions:
        check_cohesion(c, "study_table")
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
        if not record["file"]:  # read_manifest reads the column as text, "" where it is empty
            raise ParameterError(f"{os.path.join(os.fspath(sweep_dir), 'manifest.csv')}: point {record['point']} is "
                                 f"done but its file field is empty ({record.get('file')!r})")
        path = _checked_point_file(sweep_dir, record)
        with open_run(path) as run:
            meta = run.meta
            _check_point_parameters(path, record, meta)
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


def select_cohesion(table, cohesion):
    if cohesion is None or "cohesion" not in table:
        return table
    if table["cohesion"].isna().all():  # a method without conventions
        return table
    part = table[table["cohesion"] == cohesion]
    if part.empty:
        raise ParameterError(f"the table has no rows with cohesion={cohesion!r} "
                             f"(it has {sorted(table['cohesion'].dropna().unique())})")
    return part


def growth_rows(table, cohesion, columns=("gamma", "mean_volume_norm_mean")) -> pd.DataFrame:
    """The rows of ``table`` under ``cohesion`` (:func:`select_cohesion`), once it has ``columns``
    (a ParameterError naming the first missing one otherwise)."""
    part = select_cohesion(table, cohesion)
    for col in columns:
        if col not in part:
            raise ParameterError(f"the table has no column {col!r} (use study_table)")
    return part


@validate_params({"table": [Instance(pd.DataFrame, "a study table (a DataFrame, study_table's result)")],
                  "cohesion": [COHESION, None]})
def growth_points(table, cohesion="acting") -> pd.DataFrame:
    """The points of the paper's Fig 7: the steady-state ⟨V_g⟩/V_p of a :func:`study_table` at
    every (Ω, γ) of one cohesion convention, its rows of one point (several seeds) combined.

    Rows of one (Ω, γ) are averaged by :func:`~granalytics.analysis.stats.combine_replicas`
    (block sems combined as √(Σ sem²)/n, the replicas' spread as the replica standard error); a
    single row that ``study_table(replicas=...)`` already combined brings its own replica s.e.
    A point without granules (⟨V_g⟩/V_p NaN or 0 in every row) counts as 0.

    Parameters
    ----------
    table : DataFrame
        :func:`study_table` output: ``omega``, ``gamma`` [N/m], ``mean_volume_norm_mean`` and,
        where it has them, ``mean_volume_norm_sem`` and ``mean_volume_norm_replica_sem``.
    cohesion : str, default "acting"
        Convention whose rows are taken (:func:`select_cohesion`).

    Returns
    -------
    DataFrame
        One row per (Ω, γ), sorted by both: ``omega`` [rad/s], ``gamma`` [N/m],
        ``mean_volume_norm`` (0 without granules), ``block_sem``, ``replica_sem`` (NaN for a
        single run), ``no_granules`` (bool).
    """
    part = growth_rows(table, cohesion, ("omega", "gamma", "mean_volume_norm_mean"))
    nan = pd.Series(math.nan, index=part.index)
    part = pd.DataFrame({"omega": part["omega"], "gamma": part["gamma"],
                         "v": part["mean_volume_norm_mean"].fillna(0.0),
                         "none": part["mean_volume_norm_mean"].isna() | (part["mean_volume_norm_mean"] == 0),
                         "sem": part.get("mean_volume_norm_sem", nan),
                         "rsem": part.get("mean_volume_norm_replica_sem", nan)})
    rows = []
    for (omega, gamma), g in part.groupby(["omega", "gamma"], sort=True):
        c = combine_replicas(g[["v"]].T, g[["sem"]].T.fillna(0.0)).iloc[0]
        rows.append({"omega": omega, "gamma": gamma, "mean_volume_norm": c["mean"], "block_sem": c["block_sem"],
                     "replica_sem": c["replica_sem"] if len(g) > 1 else g["rsem"].iloc[0],
                     "no_granules": bool(g["none"].all())})
    return pd.DataFrame(rows, columns=["omega", "gamma", "mean_volume_norm", "block_sem", "replica_sem",
                                       "no_granules"])
