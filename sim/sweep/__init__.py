"""Parameter sweeps on dask: ``python -m sim sweep SPEC.toml --out DIR [--workers N] [--scheduler ADDR]``
(the command line is in :mod:`sim.cli`).

A sweep is a TOML file::

    preset = "lab-cg3"          # any of sim.params.PRESETS (default lab-cg3)
    revolutions = 6.0           # drum revolutions after settling (required)
    frame_every_rev = 0.05      # output interval [revolutions] (default 0.05)
    checkpoint_every = 20       # checkpoint every N frames (default 20; resume needs checkpoints)
    threads = 1                 # numba threads per point (default 1)

    [grid]                      # every key a list; the points are the cartesian product
    gamma = [0.05, 0.1, 0.2]    # surface tension of the ORIGINAL system [N/m] (scaled by alpha)
    omega = [2.0, 3.0]          # drum angular velocity [rad/s]
    alpha = [2.0]               # CG factor (default: the preset's)
    seed = [0, 1]               # filling seed
    particles = [3000]          # particle count of the ORIGINAL system (scaled by 1/alpha^3)
    drum_ratio = [11.0, 17.0]   # or: the preset's drum sized for this D/d of the simulated particles
    drum_particles = [375]      # or: the preset's drum sized for this many simulated particles

``gamma``, ``omega``, ``seed`` and ``particles`` apply to the original (α = 1) system, exactly
like the options of ``python -m sim run``; the point is then coarse-grained by ``alpha``.
``drum_ratio`` and ``drum_particles`` are ``--drum-ratio`` and ``--drum-particles``: the preset's
drum geometry rule (fill, L/R_d, r_s/R_d, baffles) sized for a confinement D/d or a particle count
at the point's α (:func:`sim.params.sized_drum`); neither goes with ``particles``. Any
other scalar field of :class:`sim.params.SimParams` of the original system (``viscosity``,
``friction``, ``spray_dose``, ``settle_time``, …) may also be swept under its own name.

Each point runs as one dask task and writes ``DIR/points/<point>.h5``; the client records it in
``DIR/manifest.csv`` (rewritten atomically after every finished point). A point whose manifest row
says ``done`` and whose file still has the recorded sha256 is skipped; any other point is run,
resuming from its checkpoint ``<point>.h5.ckpt.npz`` when there is one. A failing point is
recorded with its one-line error and the others go on. See docs/parameter_studies.md.
"""

from granalytics.core.manifest import MANIFEST_COLUMNS, read_manifest

from .runner import PointTask, run_point, run_sweep
from .spec import GRID_ALIASES, MAX_POINTS, SweepPoint, SweepSpec, load_spec, parse_spec, point_name

__all__ = [
    "SweepSpec", "SweepPoint", "PointTask", "load_spec", "parse_spec", "point_name", "run_point", "run_sweep",
    "read_manifest", "GRID_ALIASES", "MANIFEST_COLUMNS", "MAX_POINTS",
]
