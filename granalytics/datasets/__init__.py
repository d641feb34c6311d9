"""Bundled snapshot series (``datasets/`` in the source tree), made by ``sim``.

Each dataset is one run file registered in :mod:`.catalogue` with its sha256 sum, the exact commands that made
it (the simulation, then :func:`granalytics.core.subset_run` through ``granalytics subset``), the
code version and the wall time (also in ``datasets/README.md``). :func:`dataset_path` checks the
sum before handing the file out, so a corrupted or regenerated file is never analysed silently.
``make datasets`` (``python -m granalytics.datasets make``, :mod:`.build`) regenerates every file
from its recipe; nothing is downloaded. Physics-free synthetic runs for tests and examples:
:mod:`.synthetic`.

The big runs are bundled with fewer frames outside their steady-state window (every fourth frame,
i.e. every 0.2 revolution, which still samples every phase of the 0.25-revolution baffle period)
and all floating-point data stored as float32 (read back as float64); the small ones keep every
frame, also as float32.

Datasets
--------
lab-cg1, lab-cg2, lab-cg3
    The lab drum (3 000 original particles of 1.5 mm, R_d = 25.2 mm, L = 17.7 mm, 4 baffles,
    Ω = 2 rad/s, Table 1 physics) at CG factors 1, 2, 3 (3 000, 375, 111 particles), seed 0:
    the CG comparison with the original system, 6 revolutions each (steady window [3, 6]).
paper-cg3
    The paper's drum (R_d = 0.1 m, L = 0.045 m, 120 000 original particles) at CG3 (4 444
    particles, 6 revolutions), seed 0.
lab-cg2-seed1, lab-cg2-seed2, lab-cg3-seed1, lab-cg3-seed2
    Replicas of lab-cg2 and lab-cg3 (seeds 1 and 2: other random fillings), every fourth frame:
    with seed 0 the replica sets :data:`REPLICAS` (:func:`replica_paths`) for the run-to-run error.

paper-cg2
    The paper's drum at CG2 (15 000 particles, 3 revolutions, 2 threads), seed 0; every fourth
    frame of the window [2, 3] (the paper-drum CG comparison with paper-cg3).

Every dataset is of physics version 3 (the 3-D initial packing; docs/simulator.md, "Physics
versions"), recorded in each run's provenance with the settled bed's structure; the sweeps too.

Sweeps
------
gamma-omega-lab-cg3
    Surface tension × drum speed on the lab drum at CG3 (the paper's Fig 7 study): 7 values of γ
    from 0.01 to 0.444 N/m × Ω = 1.5, 2, 3 rad/s, 6 revolutions each, made by ``python -m sim
    sweep`` and bundled by :func:`bundle_sweep` (float32; every second frame of the steady window
    [3, 6], every eighth before). :func:`sweep_path`
    returns its folder (manifest and point files checked), for ``granalytics study``.
"""

from granalytics.datasets.build import bundle_sweep, make_dataset, make_foreign, make_sweep
from granalytics.datasets.catalogue import (PHYSICS_RECHECKS, SIMULATOR_PHYSICS_VERSION, physics_note, CONFINEMENT, DATASET_DIR, DATASETS, FOREIGN, NOT_BUNDLED, REPLICAS,
                                            SWEEPS, confinement_groups, dataset_path, file_sha256, foreign_path,
                                            open_dataset, replica_paths, sweep_path)

__all__ = ["SIMULATOR_PHYSICS_VERSION", "PHYSICS_RECHECKS", "physics_note", "DATASETS", "REPLICAS", "replica_paths", "CONFINEMENT", "confinement_groups", "NOT_BUNDLED", "FOREIGN",
           "foreign_path", "make_foreign", "SWEEPS", "dataset_path", "open_dataset", "make_dataset", "sweep_path",
           "bundle_sweep", "make_sweep", "file_sha256", "DATASET_DIR"]
