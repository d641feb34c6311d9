"""granalytics: granule analytics for wet-granulation DEM simulations.

Public API (SI units throughout; angles in degrees only where a name says ``_deg``):

- data model: :class:`Snapshot`, :class:`RunMeta`; is a bed three-dimensional: :func:`bed_structure`
- run files: :class:`RunWriter`, :func:`open_run`, :class:`Run`; :class:`WriterLock` (the lock
  file a writer holds on its output)
- identification: :func:`identify` with methods ``"gna"`` (:class:`GraphNetworkAnalysis`),
  ``"dbscan"`` (:class:`DBSCANClustering`), ``"sieve"`` (:class:`VirtualSieve`), ``"community"``
  (:class:`CommunityDetection`), ``"custom"`` (:class:`CustomEdges`, a user edge criterion), all
  returning :class:`IdentificationResult`; the kept contact graph as tables, NetworkX or igraph
  graphs: :mod:`granalytics.identification.edges`
- statistics: :func:`granule_table`, :func:`frame_stats`, :func:`run_stats`,
  :func:`steady_state`, :func:`size_distribution`; a run's statistics kept in place of its
  frames: :class:`RunStatistics`
- threshold sensitivity and method comparison: :func:`sensitivity`, :func:`sensitivity_summary`,
  :func:`compare_methods` (which methods coincide: :func:`identical_methods`)
- calibration of the thresholds against a measured sieve analysis: :func:`calibrate_thresholds`,
  :class:`Calibration`; measured distributions :func:`read_sieve_csv`, :class:`MeasuredDistribution`;
  simulated granules in its size classes :func:`size_class_fractions`, over a threshold grid in one pass
  :func:`size_class_grid` (:class:`SizeClassGrid`)
- cohesion conventions (which force is F_coh): :func:`cohesive_force`, :data:`COHESION_CONVENTIONS`
- coarse-graining comparison (paper Figs 3–6): :func:`compare_cg`, :class:`CGComparison`; at every
  threshold pair :func:`compare_cg_thresholds`, :class:`CGThresholdComparison`
- the drum's confinement (D/d, L/d, bed depth, wall contacts): :func:`confinement_of_drum`,
  :func:`confinement_of_run`, :func:`wall_touching`; the confinement curve and the split of a CG
  deviation into confinement and scaling rules: :func:`confinement_table`,
  :func:`fit_confinement_curve` (and the non-saturating :func:`fit_logarithmic_curve` to set beside
  it), :func:`decompose_cg`, :data:`CONFINEMENT_RULE`
- run subsets (fewer frames, float32): :func:`subset_run`
- granule life histories (tracking, coalescence and breakage events, population-balance rates):
  :func:`track_granules`, :func:`track_run`, :class:`GranuleTracks`, :func:`event_rates`
  (:func:`rate_errors`), :func:`coalescence_kernel` (:func:`kernel_matrix`), :func:`breakage_rate`,
  :func:`size_histories`
- parameter studies (paper §3.2, Fig 7): :func:`study_table`, :func:`growth_points`, :func:`fit_granule_growth`,
  :class:`GrowthFit`, :func:`fit_surrogate`, :class:`Surrogate` (sweeps run with
  ``python -m sim sweep``)
- results out: :func:`save` writes any result (a table, :class:`CGComparison`, :class:`Calibration`,
  ...) as the command line does, :func:`draw` draws it (:mod:`granalytics.report`; the figures
  one by one: :mod:`granalytics.report.figures`)
- errors: :class:`GranalyticsError`, :class:`ValidationError`, :class:`RunFileError`,
  :class:`RunLockedError`, :class:`ParameterError`
"""

import importlib

from granalytics._version import __version__

#: public name -> the module that defines it (imported on first use, PEP 562: ``import granalytics``
#: loads no analysis module, so that the simulator, which needs only :mod:`granalytics.core` and
#: :mod:`granalytics.base`, stays light)
_EXPORTS = {
    **dict.fromkeys(("GranalyticsError", "ParameterError", "RunFileError", "RunLockedError", "ValidationError"), ".base.errors"),
    **dict.fromkeys(("CGComparison", "CGThresholdComparison", "cg_rule_of", "compare_cg", "compare_cg_thresholds"),
                    ".analysis.cg"),
    **dict.fromkeys(("COHESION_CONVENTIONS", "cohesive_force"), ".identification.cohesion"),
    **dict.fromkeys(("compare_methods", "identical_methods"), ".analysis.method_comparison"),
    **dict.fromkeys(("CommunityDetection", "DBSCANClustering", "GraphNetworkAnalysis",
                     "IdentificationResult", "VirtualSieve", "identify", "CustomEdges"), ".identification"),
    **dict.fromkeys(("Run", "RunSlice", "RunWriter", "open_run", "subset_run"), ".core"),
    "WriterLock": ".base.files",
    **dict.fromkeys(("save", "draw"), ".report"),
    **dict.fromkeys(("sensitivity", "sensitivity_summary"), ".analysis.sensitivity"),
    **dict.fromkeys(("Calibration", "MeasuredDistribution", "SizeClassGrid", "calibrate_thresholds", "read_sieve_csv",
                     "size_class_fractions", "size_class_grid"), ".analysis.calibration"),
    **dict.fromkeys(("RunMeta", "Snapshot"), ".core.snapshot"),
    **dict.fromkeys(("FILL_PACKING", "PLANAR_FRACTION", "BedStructure", "DrumConfinement", "bed_structure",
                     "confinement_of_drum"), ".analysis.bed"),
    **dict.fromkeys(("confinement_of_run", "wall_touching", "CONFINEMENT_RULE", "ConfinementFit", "confinement_table", "decompose_cg",
                     "fit_confinement_curve", "LogarithmicFit", "fit_logarithmic_curve", "bed_flow"),
                    ".analysis.confinement"),
    **dict.fromkeys(("PARTICLE_COLUMNS", "granule_track_table", "particle_table"), ".analysis.particle_tables"),
    "RunStatistics": ".analysis.run_statistics",
    **dict.fromkeys(("frame_stats", "granule_table", "replica_steady_state", "run_stats", "size_distribution",
                     "steady_state"), ".analysis.stats"),
    **dict.fromkeys(("GrowthFit", "Surrogate", "fit_granule_growth", "fit_surrogate", "growth_points", "study_table"),
                    ".analysis.study"),
    **dict.fromkeys(("GranuleTracks", "breakage_rate", "coalescence_kernel", "event_rates", "kernel_matrix", "rate_errors",
                     "size_histories", "track_granules", "track_run"), ".analysis.tracking"),
    **dict.fromkeys(("PBMPrediction", "PBMRates", "PopulationBalance", "distribution_summary", "fit_pbm_rates",
                     "ks_distance", "pbm_from_run", "pbm_grid", "population_balance", "project_counts",
                     "size_counts"), ".analysis.population_balance"),
}
#: public submodules (``granalytics.datasets.open_dataset(...)``, ``granalytics.edges.edge_table(...)``):
#: attribute name -> module. The layers themselves (base, core, identification, analysis, convert, export, report) are
#: ordinary subpackages.
_SUBMODULES = {
    "datasets": ".datasets", "base": ".base", "core": ".core", "convert": ".convert", "export": ".export",
    "analysis": ".analysis", "report": ".report", "edges": ".identification.edges",
}


def __getattr__(name):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(_SUBMODULES[name], __name__)
    else:
        raise AttributeError(f"module 'granalytics' has no attribute {name!r}")
    globals()[name] = value  # once
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "__version__",
    "Snapshot", "RunMeta",
    "bed_structure", "BedStructure", "PLANAR_FRACTION", "DrumConfinement", "confinement_of_drum", "confinement_of_run",
    "wall_touching", "FILL_PACKING", "confinement_table", "fit_confinement_curve", "ConfinementFit", "decompose_cg",
    "fit_logarithmic_curve", "LogarithmicFit",
    "CONFINEMENT_RULE", "bed_flow", "cg_rule_of", "particle_table", "granule_track_table", "PARTICLE_COLUMNS",
    "RunWriter", "open_run", "Run", "RunSlice", "subset_run", "WriterLock",
    "identify", "IdentificationResult",
    "GraphNetworkAnalysis", "DBSCANClustering", "VirtualSieve", "CommunityDetection", "CustomEdges",
    "edges", "datasets", "base", "core", "convert", "export", "analysis", "report", "save", "draw",
    "granule_table", "frame_stats", "run_stats", "steady_state", "replica_steady_state", "size_distribution",
    "RunStatistics",
    "sensitivity", "sensitivity_summary", "compare_methods", "identical_methods",
    "calibrate_thresholds", "Calibration", "MeasuredDistribution", "SizeClassGrid", "read_sieve_csv", "size_class_fractions", "size_class_grid",
    "cohesive_force", "COHESION_CONVENTIONS", "compare_cg", "compare_cg_thresholds", "CGComparison",
    "CGThresholdComparison",
    "study_table", "growth_points", "fit_granule_growth", "GrowthFit", "fit_surrogate", "Surrogate",
    "track_granules", "track_run", "GranuleTracks", "event_rates", "rate_errors", "coalescence_kernel", "kernel_matrix",
    "breakage_rate", "size_histories",
    "PopulationBalance", "PBMRates", "PBMPrediction", "population_balance", "pbm_from_run", "pbm_grid", "fit_pbm_rates",
    "size_counts", "project_counts", "distribution_summary", "ks_distance",
    "GranalyticsError", "ValidationError", "RunFileError", "RunLockedError", "ParameterError",
]
