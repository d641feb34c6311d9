"""Figures of the results (matplotlib), one module per subject: one run's statistics
(:mod:`.timeseries`), a threshold sensitivity pass (:mod:`.sensitivity`), a method comparison
(:mod:`.methods`), an identified frame (:mod:`.frames`), a CG comparison (:mod:`.cg`), granule
kinetics and population balance (:mod:`.kinetics`), a parameter study (:mod:`.study`) and a
threshold calibration (:mod:`.calibration`).

The figures draw what :mod:`granalytics.analysis` computes (a figure given a result calls the
analysis function that derives what it shows, e.g. :meth:`~granalytics.CGComparison.size_distributions`);
no statistic is computed here, and no analysis module draws. Functions take an optional ``ax``
and return the axes/figure, so they compose in notebooks. They never change matplotlib's backend
(the command line selects Agg itself). :func:`granalytics.draw` draws any result with the figure
of its type.
"""

from granalytics.report.figures.calibration import calibration_figures
from granalytics.report.figures.cg import cg_figure_names, cg_figures, cg_threshold_figures
from granalytics.report.figures.frames import frame_figure
from granalytics.report.figures.kinetics import pbm_figure, tracking_figure
from granalytics.report.figures.methods import comparison_figure
from granalytics.report.figures.sensitivity import sensitivity_figure
from granalytics.report.figures.study import growth_figure
from granalytics.report.figures.timeseries import plot_size_distribution, plot_timeseries, stats_figure

__all__ = ["plot_timeseries", "plot_size_distribution", "stats_figure", "sensitivity_figure", "comparison_figure",
           "frame_figure", "cg_figures", "cg_figure_names", "tracking_figure", "growth_figure", "cg_threshold_figures",
           "pbm_figure", "calibration_figures"]
