"""Population balance over granule size, fed by the rates measured on tracked DEM granules
(``docs/population_balance.md``).

- :mod:`.grid`: the size grid (:func:`pbm_grid`), a DEM frame's granules on it
  (:func:`size_counts`, :func:`project_counts`), :func:`distribution_summary`, :func:`ks_distance`;
- :mod:`.model`: the equations (coalescence, layering and nucleation, breakage, erosion) on the
  fixed pivot technique of Kumar & Ramkrishna (1996), integrated with ``solve_ivp``
  (:func:`population_balance`, :class:`PopulationBalance`);
- :mod:`.dem`: the rates measured on tracked granules (:func:`fit_pbm_rates`, :class:`PBMRates`)
  and the prediction of a run's later distribution (:func:`pbm_from_run`, :class:`PBMPrediction`).

Units: time in seconds; granule sizes in primary particles; numbers of granules in the whole system.
"""

from granalytics.analysis.population_balance.dem import PBMPrediction, PBMRates, fit_pbm_rates, pbm_from_run
from granalytics.analysis.population_balance.grid import (distribution_summary, ks_distance, pbm_grid, project_counts,
                                                          size_counts)
from granalytics.analysis.population_balance.model import PopulationBalance, population_balance

__all__ = ["population_balance", "PopulationBalance", "pbm_grid", "fit_pbm_rates", "PBMRates", "size_counts",
           "project_counts", "ks_distance", "distribution_summary", "pbm_from_run", "PBMPrediction"]
