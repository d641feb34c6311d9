"""granalytics: granule analytics for wet-granulation DEM simulations.

Public API (SI units throughout; angles in degrees only where a name says ``_deg``):

- data model: :class:`Snapshot`, :class:`RunMeta`; is a bed three-dimensional: :func:`bed_structure`
- run files: :class:`RunWriter`, :func:`open_run`, :class:`Run`; :class:`WriterLock` (the lock
  file a writer holds on its output)
- identification: :func:`identify` with methods ``"gna"`` (:class:`GraphNetworkAnalysis`),
  ``"dbscan"`` (:class:`DBSCANClustering`), ``"sieve"`` (:class:`VirtualSieve`), ``"community"``
  (:class:`CommunityDetection`), ``"custom"`` (:class:`CustomEdges`, a user edge criterion), all
  returning :class:`IdentificationResult`; the kept contact graph as tables, NetworkX or igraph
  graphs: :mod:`granalytics.edges`
- statistics: :func:`granule_table`, :func:`frame_stats`, :func:`run_stats`,
  :func:`steady_state`, :func:`size_distribution`
- threshold sensitivity and method comparison: :func:`sensitivity`, :func:`sensitivity_summary`,
  :func:`compare_methods`
- cohesion conventions (which force is F_coh): :func:`cohesive_force`, :data:`COHESION_CONVENTIONS`
- coarse-graining comparison (paper Figs 3–6): :func:`compare_cg`, :class:`CGComparison`
- the drum's confinement (D/d, L/d, bed depth, wall contacts): :func:`drum_confinement`,
  :func:`run_confinement`, :func:`wall_touching`; the confinement curve and the split of a CG
  deviation into confinement and scaling rules: :func:`confinement_table`,
  :func:`fit_confinement_curve`, :func:`decompose_cg`, :data:`CONFINEMENT_RULE`
- run subsets (fewer frames, float32): :func:`subset_run`
- granule life histories (tracking, coalescence and breakage events, population-balance rates):
  :func:`track_granules`, :func:`track_run`, :class:`GranuleTracks`, :func:`event_rates`,
  :func:`coalescence_kernel`, :func:`breakage_rate`
- parameter studies (paper §3.2, Fig 7): :func:`study_table`, :func:`fit_granule_growth`,
  :class:`GrowthFit`, :func:`fit_surrogate`, :class:`Surrogate` (sweeps run with
  ``granalytics sweep`` / ``python -m sim sweep``)
- errors: :class:`GranalyticsError`, :class:`ValidationError`, :class:`RunFileError`,
  :class:`RunLockedError`, :class:`ParameterError`
"""

from ._version import __version__

from ._threading import configure_threading
from .errors import GranalyticsError, ParameterError, RunFileError, RunLockedError, ValidationError
from .cg import CGComparison, compare_cg, compare_cg_thresholds
from .cohesion import COHESION_CONVENTIONS, cohesive_force
from .compare import compare_methods
from .identify import (
    CommunityDetection,
    DBSCANClustering,
    DBSCANIdentifier,
    GraphNetworkAnalysis,
    IdentificationResult,
    VirtualSieve,
    identify,
)
from . import datasets  # the bundled runs and sweeps: granalytics.datasets.open_dataset(...), sweep_path(...)
from . import files  # shared file helpers: atomic writes, the writer lock, one-line errors
from . import manifest  # the sweep manifest's schema (sim.sweep writes it, study reads it)
from . import edges  # the kept contact graph as tables, NetworkX and igraph graphs: granalytics.edges.*
from .identify import CustomEdges
from .io import Run, RunSlice, RunWriter, WriterLock, open_run, subset_run
from .sensitivity import sensitivity, sensitivity_summary
from .snapshot import RunMeta, Snapshot
from .bed import (FILL_PACKING, PLANAR_FRACTION, BedStructure, DrumConfinement, bed_structure, drum_confinement, run_confinement,
                  wall_touching)
from .confinement import CONFINEMENT_RULE, ConfinementFit, confinement_table, decompose_cg, fit_confinement_curve
from . import table  # the tidy per-particle table
from .table import PARTICLE_COLUMNS, granule_track_table, particle_table
from .stats import frame_stats, granule_table, replica_steady_state, run_stats, size_distribution, steady_state
from .study import GrowthFit, Surrogate, fit_granule_growth, fit_surrogate, study_table
from .tracking import GranuleTracks, breakage_rate, coalescence_kernel, event_rates, track_granules, track_run

__all__ = [
    "__version__",
    "Snapshot", "RunMeta",
    "bed_structure", "BedStructure", "PLANAR_FRACTION", "DrumConfinement", "drum_confinement", "run_confinement",
    "wall_touching", "FILL_PACKING", "confinement_table", "fit_confinement_curve", "ConfinementFit", "decompose_cg",
    "CONFINEMENT_RULE", "particle_table", "granule_track_table", "PARTICLE_COLUMNS", "table",
    "RunWriter", "open_run", "Run", "RunSlice", "subset_run", "WriterLock",
    "identify", "IdentificationResult",
    "GraphNetworkAnalysis", "DBSCANClustering", "DBSCANIdentifier", "VirtualSieve", "CommunityDetection", "CustomEdges",
    "edges", "datasets", "files", "manifest",
    "granule_table", "frame_stats", "run_stats", "steady_state", "replica_steady_state", "size_distribution",
    "sensitivity", "sensitivity_summary", "compare_methods",
    "cohesive_force", "COHESION_CONVENTIONS", "compare_cg", "compare_cg_thresholds", "CGComparison",
    "study_table", "fit_granule_growth", "GrowthFit", "fit_surrogate", "Surrogate",
    "track_granules", "track_run", "GranuleTracks", "event_rates", "coalescence_kernel", "breakage_rate",
    "GranalyticsError", "ValidationError", "RunFileError", "RunLockedError", "ParameterError", "configure_threading",
]
