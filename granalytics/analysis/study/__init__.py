"""Parameter studies: analysis of a sweep folder (``python -m sim sweep``), the paper's Fig 7 law
and a Gaussian-process surrogate.

- :mod:`.table`: :func:`study_table`, steady-state yield, mean granule volume and granule number of
  every finished point, for each cohesion convention, at the *original* (α = 1) γ and Ω; the
  points of Fig 7 (:func:`growth_points`, seeds of one point combined);
- :mod:`.fit`: :func:`fit_granule_growth`, ⟨V_g⟩/V_p = β(γ − γ₁) above the onset γ₁ (paper §3.2:
  β ≈ 70, γ₁ ≈ 0.027 N/m), with 95 % confidence intervals;
- :mod:`.surrogate`: :func:`fit_surrogate`, a Gaussian-process regression of the steady-state
  metrics on the swept inputs, with leave-one-out errors.

Fig 7 is drawn by :func:`granalytics.report.figures.growth_figure`.
"""

from granalytics.analysis.study.fit import (PAPER_BETA, PAPER_GAMMA_1, GrowthFit, fit_granule_growth,
                                            fit_growth_of_table, paper_growth_law)
from granalytics.analysis.study.surrogate import Surrogate, fit_surrogate
from granalytics.analysis.study.sweep_table import STUDY_METRICS, growth_points, select_cohesion, study_table
from granalytics.core.manifest import read_manifest


__all__ = ["study_table", "read_manifest", "fit_granule_growth", "GrowthFit", "fit_surrogate", "Surrogate",
           "PAPER_BETA", "PAPER_GAMMA_1", "STUDY_METRICS", "fit_growth_of_table", "select_cohesion",
           "growth_points", "paper_growth_law"]
