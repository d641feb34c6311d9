"""What each result is saved as and drawn as: :func:`save` and :func:`draw` dispatch on the
result's type (:func:`functools.singledispatch`; a new result type registers its writer with
``@save.register`` and its figure with ``@draw.register``), and :func:`output_paths` names the
files a result type is saved to, for checking them before the work that computes it.

- a table (DataFrame): saved as .csv or .parquet by the path's suffix; no figure (a table's own
  figure function in :mod:`granalytics.report.figures` draws it);
- :class:`CGComparison`: saved into a folder as ``cg_table.csv``, ``cg_timeseries.csv``,
  ``cg_sizes.csv`` and the paper's Figs 3–6 as PNG and PDF; drawn as those figures (a dict);
- :class:`CGThresholdComparison`: saved into a folder as ``cg_thresholds.csv`` and one heatmap
  ``cg_thresholds_<metric>.png`` per headline statistic; drawn as those heatmaps (a dict);
- :class:`Calibration`: saved into a folder as ``calibration_grid.csv``,
  ``calibration_distributions.csv``, ``calibration.json`` and its two figures; drawn as those;
- :class:`GranuleTracks`: saved into a folder as ``events.csv``, ``tracks.csv``, ``rates.csv``,
  ``kernel.csv``, ``breakage.csv`` (the rates of :mod:`granalytics.analysis.tracking.rates`) and
  ``tracking.png``; drawn as that figure;
- :class:`PBMPrediction`: saved into a folder as ``kernel.csv``, ``rates.csv``,
  ``distributions.csv``, ``summary.csv``, ``settings.json`` (:meth:`PBMPrediction.to_json`) and
  ``pbm.png``; drawn as the prediction beside its DEM;
- :class:`MeasuredDistribution`: saved as the CSV of its classes that :func:`read_sieve_csv` reads;
- :class:`RunStatistics`: saved into a folder as ``frames.csv``, ``sizes.csv`` and ``meta.json``,
  which :meth:`RunStatistics.read` reads;
- :class:`IdentificationResult`: drawn as the frame in 3-D (``granalytics identify`` writes the
  labels of every frame).

Outputs are checked before they are written (none exists unless ``overwrite``; a folder is made
if missing) and a folder's files are written as one (all of them change, or none:
:func:`~granalytics.report.files.staged_outputs`).
"""

from __future__ import annotations

import contextlib
import functools
import os

import pandas as pd

from granalytics.analysis.calibration import Calibration, MeasuredDistribution
from granalytics.analysis.cg import CGComparison, CGThresholdComparison
from granalytics.analysis.metrics import BY_FIGURE
from granalytics.analysis.population_balance import PBMPrediction
from granalytics.analysis.run_statistics import RUN_STATISTICS_FILES, RunStatistics
from granalytics.analysis.tracking import GranuleTracks, breakage_rate, coalescence_kernel, event_rates
from granalytics.base.errors import GranalyticsError, ParameterError
from granalytics.base.files import write_atomically
from granalytics.base.validation import Path, validate
from granalytics.identification.result import IdentificationResult
from granalytics.report.files import (check_outputs, new_output_paths, output_folder, save_figure, staged_outputs,
                                      write_json, write_table)

__all__ = ["save", "draw", "output_paths", "output_names", "CG_TABLES", "CG_FORMATS", "CALIBRATION_TABLES",
           "TRACKING_FILES", "PBM_FILES"]

#: the tables :func:`save` writes of a :class:`CGComparison`, in this order
CG_TABLES = ("cg_table.csv", "cg_timeseries.csv", "cg_sizes.csv")
#: the formats of a :class:`CGComparison`'s figures
CG_FORMATS = ("png", "pdf")
#: the tables (and the JSON summary) :func:`save` writes of a :class:`Calibration`, in this order
CALIBRATION_TABLES = ("calibration_grid.csv", "calibration_distributions.csv", "calibration.json")
#: the figures of a :class:`Calibration` (the keys of :func:`~granalytics.report.figures.calibration_figures`)
CALIBRATION_FIGURES = ("calibration_objective", "calibration_distributions")
#: the files :func:`save` writes of a :class:`GranuleTracks`, in this order
TRACKING_FILES = ("events.csv", "tracks.csv", "rates.csv", "kernel.csv", "breakage.csv", "tracking.png")
#: the files :func:`save` writes of a :class:`PBMPrediction`, in this order
PBM_FILES = ("kernel.csv", "rates.csv", "distributions.csv", "summary.csv", "settings.json", "pbm.png")


def output_names(kind) -> list:
    """The names of the files :func:`save` writes of a result of type ``kind`` (a result class
    saved to a folder: :class:`CGComparison`, :class:`CGThresholdComparison`, :class:`Calibration`,
    :class:`GranuleTracks`, :class:`PBMPrediction`) into its folder."""
    if kind is CGComparison:
        from granalytics.report.figures import cg_figure_names

        return [*CG_TABLES, *(f"{name}.{ext}" for name in cg_figure_names() for ext in CG_FORMATS)]
    if kind is CGThresholdComparison:
        return ["cg_thresholds.csv", *(f"cg_thresholds_{metric}.png" for metric in BY_FIGURE)]
    if kind is Calibration:
        return [*CALIBRATION_TABLES, *(f"{name}.png" for name in CALIBRATION_FIGURES)]
    if kind is GranuleTracks:
        return list(TRACKING_FILES)
    if kind is PBMPrediction:
        return list(PBM_FILES)
    if kind is RunStatistics:
        return list(RUN_STATISTICS_FILES)
    raise ParameterError(f"output_paths: a {getattr(kind, '__name__', kind)} is not saved to a folder "
                         "(CGComparison, CGThresholdComparison, Calibration, GranuleTracks, PBMPrediction and "
                         "RunStatistics are)")


def output_paths(kind, folder, *, overwrite=False) -> list:
    """The paths of the files :func:`save` writes of a result of type ``kind`` (a result class
    saved to a folder, :func:`output_names`) into ``folder``; refuses (``ParameterError``)
    a ``folder`` that is a file and files that exist unless ``overwrite``. For checking the
    outputs before the work that computes the result."""
    return new_output_paths(_output_path(folder), output_names(kind), overwrite=overwrite)


def _output_path(path) -> str:
    """``path`` as a str, refused in one line (``ParameterError``) when it is not a file or folder name."""
    validate("save", {"path": [Path("a file or folder name")]}, {"path": path})
    return os.fspath(path)


def _types(generic) -> str:
    return ", ".join(sorted(t.__name__ for t in generic.registry if t is not object))


@functools.singledispatch
def save(result, path, *, overwrite=False, **options) -> list:
    """Write ``result`` to ``path`` (a file, or a folder for results of several files), as the
    command line that computes it does; the writer is that of the result's type (the table of
    :mod:`granalytics.report.registry`).

    Parameters
    ----------
    result
        A table (DataFrame), :class:`~granalytics.CGComparison`,
        :class:`~granalytics.CGThresholdComparison`, :class:`~granalytics.Calibration`,
        :class:`~granalytics.GranuleTracks`, :class:`~granalytics.PBMPrediction`,
        :class:`~granalytics.RunStatistics` or :class:`~granalytics.MeasuredDistribution`.
    path : path
        The file of a table (.csv or .parquet) or of a measured distribution, the folder of a
        comparison, calibration, tracking, prediction or run statistics (made if missing).
    overwrite : bool, default False
        Replace existing files (otherwise ``ParameterError`` naming the first, before anything is
        written).
    **options
        Options of the result type's writer (a :class:`CGComparison`: ``size_unit`` of Fig 5; a
        :class:`GranuleTracks`: ``revolution_period_s``, ``size_unit``, ``alpha`` and the figure's
        ``title``).

    Returns
    -------
    list of str
        The paths written.
    """
    raise ParameterError(f"save: no writer for a {type(result).__name__} (granalytics.save writes a {_types(save)})")


@save.register
def _save_table(table: pd.DataFrame, path, *, overwrite=False, stage=None) -> list:
    """A table, .csv or .parquet by ``path``'s suffix; a named index is written as the first
    columns. With ``stage`` (:func:`~granalytics.report.files.staged_outputs`'s) the caller has
    checked ``path`` and writes it together with its other outputs."""
    path = _output_path(path)
    if stage is None:
        check_outputs(tables=(path,), overwrite=overwrite)
    if any(name is not None for name in table.index.names):
        table = table.reset_index()
    write_table(table, path, stage)
    return [path]


@contextlib.contextmanager
def _written_as_one(folder, figures=()):
    """The ``stage`` of ``folder``'s outputs (made if missing; all its files change, or none:
    :func:`~granalytics.report.files.staged_outputs`); ``figures`` are closed afterwards."""
    try:
        with output_folder(folder), staged_outputs(folder) as stage:
            yield stage
    finally:
        if figures:
            import matplotlib.pyplot as plt

            for fig in figures:
                plt.close(fig)


@save.register
def _save_cg(comparison: CGComparison, folder, *, overwrite=False, size_unit="particles") -> list:
    """The comparison's tables (sizes in particles of each run, with its α) and its Figs 3–6
    (Fig 5's sizes in ``size_unit``) as PNG and PDF, written into ``folder`` as one."""
    from granalytics.report.figures import cg_figures

    folder = _output_path(folder)
    paths = output_paths(CGComparison, folder, overwrite=overwrite)
    figures = cg_figures(comparison, size_unit=size_unit)
    written = []
    try:
        with _written_as_one(folder, figures.values()) as stage:
            for table, path in zip((comparison.table, comparison.timeseries, comparison.distributions), paths):
                write_table(table, path, stage)
                written.append(path)
            for name, fig in figures.items():
                for ext in CG_FORMATS:
                    path = os.path.join(folder, f"{name}.{ext}")
                    fig.savefig(stage(path), dpi=150, format=ext)
                    written.append(path)
    except OSError as exc:
        raise ParameterError(f"{folder}: cannot write the comparison ({exc})") from None
    return written


@save.register
def _save_cg_thresholds(comparison: CGThresholdComparison, folder, *, overwrite=False) -> list:
    """The deviation table and one heatmap per headline statistic, written into ``folder`` as one."""
    from granalytics.report.figures import cg_threshold_figures

    folder = _output_path(folder)
    paths = output_paths(CGThresholdComparison, folder, overwrite=overwrite)
    figures = cg_threshold_figures(comparison.table)
    with _written_as_one(folder, figures.values()) as stage:
        write_table(comparison.table, paths[0], stage)
        for metric, path in zip(BY_FIGURE, paths[1:]):
            figures[f"cg_thresholds_{metric}"].savefig(stage(path), dpi=120)
    return paths


@save.register
def _save_calibration(calibration: Calibration, folder, *, overwrite=False) -> list:
    """The calibration's grid and distributions, ``calibration.json`` (:meth:`Calibration.to_json`)
    and its two figures, written into ``folder`` as one."""
    from granalytics.report.figures import calibration_figures

    folder = _output_path(folder)
    paths = output_paths(Calibration, folder, overwrite=overwrite)
    figures = calibration_figures(calibration)
    with _written_as_one(folder, figures.values()) as stage:
        write_table(calibration.grid, paths[0], stage)
        write_table(calibration.distributions, paths[1], stage)
        write_json(calibration.to_json(), paths[2], stage)
        for name, path in zip(CALIBRATION_FIGURES, paths[3:]):
            figures[name].savefig(stage(path), dpi=120, bbox_inches="tight")
    return paths


@save.register
def _save_run_statistics(statistics: RunStatistics, folder, *, overwrite=False) -> list:
    """The kept statistics' ``frames.csv``, ``sizes.csv`` and ``meta.json``
    (:meth:`RunStatistics.tables`), written into ``folder`` as one, ``frames.csv`` renamed in last:
    a process killed between the renames leaves sizes of frames that ``frames.csv`` does not list
    yet (which reading ignores), never frames without their sizes."""
    folder = _output_path(folder)
    paths = output_paths(RunStatistics, folder, overwrite=overwrite)
    tables = statistics.tables()
    with _written_as_one(folder) as stage:
        for name, path in sorted(zip(RUN_STATISTICS_FILES, paths), key=lambda item: item[0] == "frames.csv"):
            (write_json if name.endswith(".json") else write_table)(tables[name], path, stage)
    return paths


def _tracking_tables(tracks, revolution_period_s, size_unit, alpha) -> tuple:
    """The event rates, coalescence kernel and breakage rate of ``tracks``, as saved and drawn."""
    return (event_rates(tracks, revolution_period_s), coalescence_kernel(tracks, size_unit=size_unit, alpha=alpha),
            breakage_rate(tracks, size_unit=size_unit, alpha=alpha))


@save.register
def _save_tracks(tracks: GranuleTracks, folder, *, overwrite=False, revolution_period_s=None, size_unit="particles",
                 alpha=None, title=None) -> list:
    """The events and tracks, the event rates (per revolution with ``revolution_period_s``, 2π/|Ω|
    [s]), the coalescence kernel and breakage rate (sizes in ``size_unit``, with the CG factor
    ``alpha``, a float or a run or its metadata, for ``"original"``) and the tracking figure
    (titled ``title``), written into ``folder`` as one."""
    from granalytics.report.figures import tracking_figure

    folder = _output_path(folder)
    paths = output_paths(GranuleTracks, folder, overwrite=overwrite)
    rates, kernel, breakage = _tracking_tables(tracks, revolution_period_s, size_unit, alpha)
    fig = tracking_figure(tracks, rates, kernel, size_unit=size_unit, alpha=alpha, title=title)
    with _written_as_one(folder, [fig]) as stage:
        for table, path in zip((tracks.events, tracks.tracks, rates, kernel, breakage), paths):
            write_table(table, path, stage)
        save_figure(fig, paths[-1], stage)
    return paths


@save.register
def _save_pbm(prediction: PBMPrediction, folder, *, overwrite=False) -> list:
    """The measured rates (``kernel.csv``, ``rates.csv``), both distributions and their summary,
    ``settings.json`` (:meth:`PBMPrediction.to_json`) and the prediction's figure, written into
    ``folder`` as one."""
    from granalytics.report.figures import pbm_figure

    folder = _output_path(folder)
    paths = output_paths(PBMPrediction, folder, overwrite=overwrite)
    fig = pbm_figure(prediction)  # a matplotlib Figure outside pyplot: nothing to close
    with _written_as_one(folder) as stage:
        for table, path in zip((prediction.rates.kernel, prediction.rates.classes, prediction.distributions(),
                                prediction.summary()), paths):
            write_table(table, path, stage)
        write_json(prediction.to_json(), paths[4], stage, indent=1)
        save_figure(fig, paths[5], stage)
    return paths


@save.register
def _save_measured(distribution: MeasuredDistribution, path, *, overwrite=False) -> list:
    """The classes form (``lower_m,upper_m,mass_fraction``, 6 significant digits) that
    :func:`~granalytics.read_sieve_csv` reads."""
    path = _output_path(path)
    check_outputs(others=(path,), overwrite=overwrite)
    table = distribution.table()[["lower_m", "upper_m", "mass_fraction"]]
    try:
        write_atomically(path, lambda tmp: table.to_csv(tmp, index=False, float_format="%.6g"))
    except OSError as exc:
        raise GranalyticsError(f"{path}: cannot write ({exc})") from None
    return [path]


@functools.singledispatch
def draw(result, **options):
    """The figure(s) of ``result``, drawn by its type's figure function
    (:mod:`granalytics.report.figures`; the table of :mod:`granalytics.report.registry`).

    Parameters
    ----------
    result
        :class:`~granalytics.CGComparison`, :class:`~granalytics.CGThresholdComparison`,
        :class:`~granalytics.Calibration`, :class:`~granalytics.GranuleTracks`,
        :class:`~granalytics.IdentificationResult` or
        :class:`~granalytics.PBMPrediction`.
    **options
        Options of the figure function (e.g. ``size_unit`` of a comparison's Fig 5; those of
        :func:`save` for a :class:`GranuleTracks`).

    Returns
    -------
    Figure or dict of Figure
        One figure, or several by name.
    """
    raise ParameterError(f"draw: no figure for a {type(result).__name__} (granalytics.draw draws a {_types(draw)}; "
                         "a table's figure is drawn by its function in granalytics.report.figures)")


@draw.register
def _draw_cg(comparison: CGComparison, *, size_unit="particles") -> dict:
    from granalytics.report.figures import cg_figures

    return cg_figures(comparison, size_unit=size_unit)


@draw.register
def _draw_cg_thresholds(comparison: CGThresholdComparison) -> dict:
    from granalytics.report.figures import cg_threshold_figures

    return cg_threshold_figures(comparison.table)


@draw.register
def _draw_calibration(calibration: Calibration) -> dict:
    from granalytics.report.figures import calibration_figures

    return calibration_figures(calibration)


@draw.register
def _draw_tracks(tracks: GranuleTracks, *, revolution_period_s=None, size_unit="particles", alpha=None, title=None):
    from granalytics.report.figures import tracking_figure

    rates, kernel, _ = _tracking_tables(tracks, revolution_period_s, size_unit, alpha)
    return tracking_figure(tracks, rates, kernel, size_unit=size_unit, alpha=alpha, title=title)


@draw.register
def _draw_frame(result: IdentificationResult, *, ax=None, max_colours=20):
    from granalytics.report.figures import frame_figure

    return frame_figure(result, ax=ax, max_colours=max_colours)


@draw.register
def _draw_pbm(prediction: PBMPrediction, *, times=None, title=None):
    from granalytics.report.figures import pbm_figure

    return pbm_figure(prediction, times=times, title=title)
