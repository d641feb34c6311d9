"""What each result is saved as and drawn as: :func:`save` and :func:`draw` dispatch on the
result's type (:func:`functools.singledispatch`; a new result type registers its writer with
``@save.register`` and its figure with ``@draw.register``), and :func:`output_paths` names the
files a result type is saved to, for checking them before the work that computes it.

- a table (DataFrame): saved as .csv or .parquet by the path's suffix; no figure (a table's own
  figure function in :mod:`granalytics.report.figures` draws it);
- :class:`CGComparison`: saved into a folder as ``cg_table.csv``, ``cg_timeseries.csv``,
  ``cg_sizes.csv`` and the paper's Figs 3–6 as PNG and PDF; drawn as those figures (a dict);
- :class:`Calibration`: saved into a folder as ``calibration_grid.csv``,
  ``calibration_distributions.csv``, ``calibration.json`` and its two figures; drawn as those;
- :class:`MeasuredDistribution`: saved as the CSV of its classes that :func:`read_sieve_csv` reads;
- :class:`IdentificationResult`: drawn as the frame in 3-D (``granalytics identify`` writes the
  labels of every frame);
- :class:`PBMPrediction`: drawn as the prediction beside its DEM.

Outputs are checked before they are written (none exists unless ``overwrite``; a folder is made
if missing) and a folder's files are written as one (all of them change, or none:
:func:`~granalytics.report.files.staged_outputs`).
"""

from __future__ import annotations

import functools
import os

import pandas as pd

from granalytics.analysis.calibration import Calibration, MeasuredDistribution
from granalytics.analysis.cg import CGComparison
from granalytics.analysis.population_balance import PBMPrediction
from granalytics.base.errors import GranalyticsError, ParameterError
from granalytics.base.files import write_atomically
from granalytics.identification.result import IdentificationResult
from granalytics.report.files import (check_outputs, new_output_paths, output_folder, staged_outputs, write_json,
                                      write_table)

__all__ = ["save", "draw", "output_paths", "output_names", "CG_TABLES", "CG_FORMATS", "CALIBRATION_TABLES"]

#: the tables :func:`save` writes of a :class:`CGComparison`, in this order
CG_TABLES = ("cg_table.csv", "cg_timeseries.csv", "cg_sizes.csv")
#: the formats of a :class:`CGComparison`'s figures
CG_FORMATS = ("png", "pdf")
#: the tables (and the JSON summary) :func:`save` writes of a :class:`Calibration`, in this order
CALIBRATION_TABLES = ("calibration_grid.csv", "calibration_distributions.csv", "calibration.json")
#: the figures of a :class:`Calibration` (the keys of :func:`~granalytics.report.figures.calibration_figures`)
CALIBRATION_FIGURES = ("calibration_objective", "calibration_distributions")


def output_names(kind) -> list:
    """The names of the files :func:`save` writes of a result of type ``kind`` (a result class,
    :class:`CGComparison` or :class:`Calibration`) into its folder."""
    if kind is CGComparison:
        from granalytics.report.figures import cg_figure_names

        return [*CG_TABLES, *(f"{name}.{ext}" for name in cg_figure_names() for ext in CG_FORMATS)]
    if kind is Calibration:
        return [*CALIBRATION_TABLES, *(f"{name}.png" for name in CALIBRATION_FIGURES)]
    raise ParameterError(f"output_paths: a {getattr(kind, '__name__', kind)} is not saved to a folder "
                         "(CGComparison and Calibration are)")


def output_paths(kind, folder, *, overwrite=False) -> list:
    """The paths of the files :func:`save` writes of a result of type ``kind`` (a result class,
    :class:`CGComparison` or :class:`Calibration`) into ``folder``; refuses (``ParameterError``)
    a ``folder`` that is a file and files that exist unless ``overwrite``. For checking the
    outputs before the work that computes the result."""
    return new_output_paths(folder, output_names(kind), overwrite=overwrite)


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
        A table (DataFrame), :class:`~granalytics.CGComparison` or :class:`~granalytics.Calibration`.
    path : path
        The file of a table (.csv or .parquet), the folder of a comparison or calibration (made if
        missing).
    overwrite : bool, default False
        Replace existing files (otherwise ``ParameterError`` naming the first, before anything is
        written).
    **options
        Options of the result type's writer (a :class:`CGComparison`: ``size_unit`` of Fig 5).

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
    path = os.fspath(path)
    if stage is None:
        check_outputs(tables=(path,), overwrite=overwrite)
    if any(name is not None for name in table.index.names):
        table = table.reset_index()
    write_table(table, path, stage)
    return [path]


@save.register
def _save_cg(comparison: CGComparison, folder, *, overwrite=False, size_unit="particles") -> list:
    """The comparison's tables (sizes in particles of each run, with its α) and its Figs 3–6
    (Fig 5's sizes in ``size_unit``) as PNG and PDF, written into ``folder`` as one."""
    import matplotlib.pyplot as plt

    from granalytics.report.figures import cg_figures

    folder = os.fspath(folder)
    paths = output_paths(CGComparison, folder, overwrite=overwrite)
    figures = cg_figures(comparison, size_unit=size_unit)
    written = []
    try:
        with output_folder(folder), staged_outputs(folder) as stage:
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
    finally:
        for fig in figures.values():
            plt.close(fig)
    return written


@save.register
def _save_calibration(calibration: Calibration, folder, *, overwrite=False) -> list:
    """The calibration's grid and distributions, ``calibration.json`` (:meth:`Calibration.to_json`)
    and its two figures, written into ``folder`` as one."""
    import matplotlib.pyplot as plt

    from granalytics.report.figures import calibration_figures

    folder = os.fspath(folder)
    paths = output_paths(Calibration, folder, overwrite=overwrite)
    figures = calibration_figures(calibration)
    try:
        with output_folder(folder), staged_outputs(folder) as stage:
            write_table(calibration.grid, paths[0], stage)
            write_table(calibration.distributions, paths[1], stage)
            write_json(calibration.to_json(), paths[2], stage)
            for name, path in zip(CALIBRATION_FIGURES, paths[3:]):
                figures[name].savefig(stage(path), dpi=120, bbox_inches="tight")
    finally:
        for fig in figures.values():
            plt.close(fig)
    return paths


@save.register
def _save_measured(distribution: MeasuredDistribution, path, *, overwrite=False) -> list:
    """The classes form (``lower_m,upper_m,mass_fraction``, 6 significant digits) that
    :func:`~granalytics.read_sieve_csv` reads."""
    path = os.fspath(path)
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
        :class:`~granalytics.CGComparison`, :class:`~granalytics.Calibration`,
        :class:`~granalytics.IdentificationResult` or :class:`~granalytics.PBMPrediction`.
    **options
        Options of the figure function (e.g. ``size_unit`` of a comparison's Fig 5).

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
def _draw_calibration(calibration: Calibration) -> dict:
    from granalytics.report.figures import calibration_figures

    return calibration_figures(calibration)


@draw.register
def _draw_frame(result: IdentificationResult, *, ax=None, max_colours=20):
    from granalytics.report.figures import frame_figure

    return frame_figure(result, ax=ax, max_colours=max_colours)


@draw.register
def _draw_pbm(prediction: PBMPrediction, *, times=None, title=None):
    from granalytics.report.figures import pbm_figure

    return pbm_figure(prediction, times=times, title=title)
