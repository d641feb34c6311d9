"""Calibration of the granule definition against a measured sieve analysis (``docs/calibration.md``).

- :mod:`.measured`: the measured distribution in sieve classes (:class:`MeasuredDistribution`) and
  its CSV file with every check of it (:func:`read_sieve_csv`);
- :mod:`.size_classes`: simulated granules sorted by size into those classes, at one
  threshold pair (:func:`size_class_fractions`) or over a threshold grid in one pass per frame
  (:func:`size_class_grid`, :class:`SizeClassGrid`); a "measured" distribution made from a grid
  (:func:`grid_measurement`);
- :mod:`.bootstrap`: the mean over a window's frames at every grid point, its moving-block
  bootstrap, and the confidence region of the replicas' best points;
- :mod:`.fit`: the fit of C_agg and A_agg (or the rigid tolerance), :func:`calibrate_thresholds`,
  and its result, :class:`Calibration`.

Each module imports only those above it in this list. Sizes in metres (original-system sizes in a
coarse-grained run); mass fractions.
"""

from granalytics.analysis.calibration.fit import DEFAULT_MEASURED_ERROR, POOR_FIT_P, Calibration, calibrate_thresholds
from granalytics.analysis.calibration.measured import SUM_TOLERANCE, MeasuredDistribution, read_sieve_csv
from granalytics.analysis.calibration.size_classes import (SIZE_MEASURES, SizeClassGrid, grid_measurement, size_class_fractions,
                                                           size_class_grid)

__all__ = ["calibrate_thresholds", "Calibration", "POOR_FIT_P", "DEFAULT_MEASURED_ERROR", "MeasuredDistribution",
           "read_sieve_csv", "SUM_TOLERANCE", "SIZE_MEASURES", "size_class_fractions", "SizeClassGrid", "size_class_grid",
           "grid_measurement"]
