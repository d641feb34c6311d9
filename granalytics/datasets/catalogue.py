"""The catalogue of bundled runs and sweeps: what each file is, its sha256, the exact commands that
made it, the code version and the wall time, and the functions that hand a checked file out
(:func:`dataset_path`, :func:`open_dataset`, :func:`replica_paths`, :func:`sweep_path`,
:func:`foreign_path`, :func:`confinement_groups`). Remaking files from these recipes is
:mod:`granalytics.datasets.build`'s job."""

from __future__ import annotations

from pathlib import Path

from granalytics.base.errors import GranalyticsError
from granalytics.core.manifest import file_sha256

__all__ = ["SIMULATOR_PHYSICS_VERSION", "PHYSICS_RECHECKS", "physics_note", "DATASETS", "REPLICAS", "replica_paths", "CONFINEMENT", "confinement_groups", "NOT_BUNDLED", "FOREIGN",
           "foreign_path", "SWEEPS", "dataset_path", "open_dataset", "sweep_path", "file_sha256", "DATASET_DIR"]


DATASET_DIR = Path(__file__).resolve().parents[2] / "datasets"


_RAW_DIR = "build/runs"  # full-resolution simulator output (not bundled), relative to the repository root


def _recipe(preset, revolutions, full_window=None, *, seed=0, every=None, threads=1, window_every=1):
    name = preset if seed == 0 else f"{preset}-seed{seed}"
    raw = f"{_RAW_DIR}/{name}.h5"
    sim = (f"python -m sim run --preset {preset} --revolutions {revolutions:g} --seed {seed} --threads {threads} "
           f"--checkpoint-every 2 --quiet --out {raw}")
    subset = f"granalytics subset {raw} --out datasets/{name}.h5 --float32 --overwrite"
    if full_window is not None:
        subset += f" --full-window {full_window} --every {every or 4}"
        if window_every != 1:
            subset += f" --window-every {window_every}"
    elif every is not None:
        subset += f" --every {every}"
    return [sim, subset]


#: the commit whose simulator (physics version 3, the 3-D packing) made the datasets and sweeps of 2026-12-02
_SIM_V3 = "733e5744cb9a46aae3bdb1334874dffa436e9345"


#: the commit whose simulator made paper-cg2: physics version 3 with the two-thread force loop repaired
#: (sim/ unchanged from there to c81f4a7, which resumed the run); bit-reproducible on 2 threads
_SIM_V3_PAPER_CG2 = "37454f848582e8c4653def71b64d8197ae5ddb88"


#: name -> file, sha256, the commands that made it (from the repository root, in order), the
#: code version (git commit) and simulator wall time, description
DATASETS = {
    "lab-cg1": {
        "file": "lab-cg1.h5",
        "sha256": "f5066547f234e74f204d76d45cd65845f68158b9790869523238aedeef2a9054",
        "commands": _recipe("lab-cg1", 6, full_window="3:6"),
        "code_version": _SIM_V3,
        "wall_time": "1 h 44 min 55 s (1 thread, beside the paper-cg3 run, a sweep and test runs on the other core)",
        "description": "lab drum, CG1: the 3 000 original particles of 1.5 mm, 6 revolutions; every frame in [3, 6], "
                       "every fourth before (76 of 121 frames)",
    },
    "lab-cg2": {
        "file": "lab-cg2.h5",
        "sha256": "b943991c85a8553246786366f3cb7d2978c6630b3314632a1324586371e45654",
        "commands": _recipe("lab-cg2", 6),
        "code_version": _SIM_V3,
        "wall_time": "3 min 58 s (1 thread, beside the lab-cg1 run on the other core)",
        "description": "lab drum, CG2: 375 particles of 3 mm standing for 3 000 of 1.5 mm, 6 revolutions, every "
                       "frame (0.05 revolution, 121 frames)",
    },
    "lab-cg3": {
        "file": "lab-cg3.h5",
        "sha256": "2e74f902a6ce671484f434244215c6c1fdb7f9e90c3915b06bbfe01074fad646",
        "commands": _recipe("lab-cg3", 6),
        "code_version": _SIM_V3,
        "wall_time": "39 s (1 thread, beside the lab-cg1 run on the other core)",
        "description": "lab drum, CG3: 111 particles of 4.5 mm standing for 3 000 of 1.5 mm, 6 revolutions, "
                       "every frame (0.05 revolution, 121 frames)",
    },
    "paper-cg2": {
        "file": "paper-cg2.h5",
        "sha256": "fb2c9b950cc7320380ca9528a7691f51880b3a60df716639ee54a90c06c4c262",
        "commands": _recipe("paper-cg2", 3, full_window="2:3", threads=2, every=12, window_every=4),
        "code_version": _SIM_V3_PAPER_CG2,
        "wall_time": "1 h 25 min on 2 threads (5 093 s recorded in its provenance; 74 min in one sitting beside light "
                     "work, the last 18 % resumed from its checkpoint in the next, 17 min; the raw file, 153 MB, has "
                     "sha256 74d077cfcd9945b238319fbc69486a2f71b78a6943bb8803a2bd6690276f515b)",
        "description": "the paper's drum, CG2: 15 000 particles of 3 mm standing for 120 000 of 1.5 mm, 3 revolutions; "
                       "every fourth frame in [2, 3] (0.2 revolution, as paper-cg3 there), every twelfth before "
                       "(0.6 revolution): 10 of 61 frames",
    },
    "paper-cg3": {
        "file": "paper-cg3.h5",
        "sha256": "c71f05f2aeba939a8fbda44cc29628b1959dd10b0b330fac374d1ba607e0719b",
        "commands": _recipe("paper-cg3", 6, full_window="3:6"),
        "code_version": _SIM_V3,
        "wall_time": "57 min 4 s (1 thread, beside the lab-cg1 run on the other core and test runs)",
        "description": "the paper's drum, CG3: 4 444 particles of 4.5 mm standing for 120 000 of 1.5 mm, "
                       "6 revolutions; every frame in [3, 6], every fourth before (76 of 121 frames)",
    },
}


#: the commit whose simulator (physics version 3, unchanged since :data:`_SIM_V3`) made the replicas
_SIM_V3_REPLICAS = "26c578892af9126f8c24468ddcaaab0c85dd2ab2"


#: replica -> (sha256, simulator wall time)
_REPLICA_RUNS = {
    "lab-cg3-seed1": ("508acaafa50f60b066e94c8b55247f750944599ec72f720fa85f4f98f174689f", "2 min 16 s (numba compiling)"),
    "lab-cg3-seed2": ("3f1751de45a70bdf66927a5adb8d49697faecf98e22ca2d341e1cd0b5cd22b8e", "59 s"),
    "lab-cg2-seed1": ("048e5a6b7963e12cbf1c07492011bea02067ecc31dc18afe7bff56a30d7dc9f4", "4 min 24 s"),
    "lab-cg2-seed2": ("99c02d50db38aa924592782950999d46eb86659d2da4d81d1d6b691e09902dc3", "4 min 30 s"),
}


for _preset, _n in (("lab-cg3", 111), ("lab-cg2", 375)):
    for _seed in (1, 2):
        _sha, _wall = _REPLICA_RUNS[f"{_preset}-seed{_seed}"]
        DATASETS[f"{_preset}-seed{_seed}"] = {
            "file": f"{_preset}-seed{_seed}.h5",
            "sha256": _sha,
            "commands": _recipe(_preset, 6, seed=_seed, every=4),
            "code_version": _SIM_V3_REPLICAS,
            "wall_time": f"{_wall} (1 thread, beside another run on the other core)",
            "description": f"replica of {_preset} (seed {_seed} instead of 0: another random filling), "
                           f"{_n} particles, 6 revolutions; every fourth frame (0.2 revolution, 31 of 121 frames)",
        }


#: replica sets: name -> the datasets that are runs of one system differing only in their seed
#: (seed 0 first), for ``compare_cg`` groups and :func:`~granalytics.replica_steady_state`
REPLICAS = {preset: (preset, f"{preset}-seed1", f"{preset}-seed2") for preset in ("lab-cg2", "lab-cg3")}


def replica_paths(name: str) -> list:
    """Paths of a replica set (:data:`REPLICAS`), each checked as :func:`dataset_path` does."""
    try:
        names = REPLICAS[name]
    except KeyError:
        raise GranalyticsError(f"unknown replica set {name!r}; available: {', '.join(REPLICAS)}") from None
    return [dataset_path(n) for n in names]


#: the commit whose simulator (physics version 3, unchanged since :data:`_SIM_V3`; the drum sized by
#: --drum-particles / --drum-ratio) made the confinement runs of 2026-12-03
_SIM_V3_CONFINEMENT = "69c6860a6f22f7180e1a4e4daabd5032b3844d5a"


#: the Froude-matched Ω of the α = 1 twins of lab-cg3 and lab-cg2: Ω·√(R_lab/R) = 2·√3, 2·√2 rad/s
_FROUDE_OMEGA = {111: 3.4641016151377544, 375: 2.8284271247461903}


def _confinement_recipe(name, size_option, revolutions, seed, *, omega=None, full_window="1:6", threads=1,
                        checkpoint_every=20):
    """Commands of a confinement run: the lab drum's rule sized by ``size_option`` at α = 1, then
    a float32 subset keeping frame 0 and every fourth frame (0.2 revolution) of ``full_window``."""
    raw = f"{_RAW_DIR}/confinement/{name}.h5"
    sim = (f"python -m sim run --preset lab-cg1 {size_option} --revolutions {revolutions:g} --seed {seed} "
           f"{f'--omega {omega!r} ' if omega else ''}--threads {threads} --checkpoint-every {checkpoint_every} "
           f"--quiet --out {raw}")
    subset = (f"granalytics subset {raw} --out datasets/confinement/{name}.h5 --float32 --overwrite "
              f"--full-window {full_window} --every 20 --window-every 4")
    return [sim, subset]


#: the α = 1 runs of the confinement curve (docs/results.md, "Confinement"): the lab drum's geometry
#: rule sized for 111 and 375 particles (the D/d of lab-cg3 and lab-cg2), at Ω = 2 rad/s and at the
#: Froude-matched Ω, seeds 0-2, and for D/d = 50 (9 844 particles, 2 revolutions, seed 0):
#: name -> sha256, simulator wall time
_CONFINEMENT_RUNS = {
    "cg1-n111-seed0": ("bb5b70a9fcdcba1ab4c065148522d479c1ca822cf00bec267707c8210f10a843", "3 min 14 s"),
    "cg1-n111-seed1": ("3c8a3dbea584045e22227ad10812f4bef1e1a1a4294a2c7da0bb3b3e68f56ba5", "3 min 57 s"),
    "cg1-n111-seed2": ("87d7177c03caf045fcc10373004e3c9a05c7fb6b4e1f384bba7afd4c4de04973", "3 min 47 s"),
    "cg1-n375-seed0": ("d09ab44fb03582d466788a702a5e7d24879761072a2eb5b5de799f66cffb0cf2", "14 min 50 s"),
    "cg1-n375-seed1": ("8cc6d50c857f9decdd64ff2d7405b07cf30cc9b07d2fdca9e6d57897abf7e32e", "11 min 27 s"),
    "cg1-n375-seed2": ("e0fe5322dfbc3020a0f1788a07f8e95832397557392c5457844e4296f3651055", "11 min 12 s"),
    "cg1-n111-fr-seed0": ("e8ac07f29b1e5a5e198b727514fe2db2d604862f08abea363e79aedca60b7291", "1 min 46 s"),
    "cg1-n111-fr-seed1": ("2fd421c9b44eb55c06a4cbdb1ee6af47c0898c45cee63fe4fdde58020baa5edf", "1 min 55 s"),
    "cg1-n111-fr-seed2": ("c7e1d668a18761bc84ace2ee05c9b61644861c42beb348731c3aef97ca4e97b0", "2 min 2 s"),
    "cg1-dd50-seed0": ("4470f73502b8625d8daab0ec705d4eeb10521ece7d178bcc43d0c3507ef2249d",
                       "2 h 0 min (7 220 s in its provenance): frames 0-16 on 1 thread beside the other runs (started "
                       "with --revolutions 4 --threads 1, stopped after the checkpoint of frame 16), the rest resumed on 2 "
                       "threads with the recipe's options (bit-identical for any thread count)"),
}


CONFINEMENT = {}


for _name, (_sha, _wall) in _CONFINEMENT_RUNS.items():
    _base, _, _seed = _name.rpartition("-seed")
    _froude = _base.endswith("-fr")
    if _base.startswith("cg1-dd"):
        _size, _revs, _window, _threads, _every = f"--drum-ratio {_base.removeprefix('cg1-dd')}", 2, "1:2", 2, 4
        _what = f"the lab drum's rule at D/d = {_base.removeprefix('cg1-dd')} (9 844 particles of 1.5 mm), 2 revolutions"
    else:
        _n = int(_base.removeprefix("cg1-n").removesuffix("-fr"))
        _size, _revs, _window, _threads, _every = f"--drum-particles {_n}", 6, "1:6", 1, 20
        _what = (f"the lab drum's rule sized for {_n} particles of 1.5 mm (the D/d of "
                 f"{'lab-cg3' if _n == 111 else 'lab-cg2'}), 6 revolutions"
                 + (f", Ω = {_FROUDE_OMEGA[_n]:.4g} rad/s (the Froude number of the lab drum at 2 rad/s)" if _froude else ""))
    CONFINEMENT[_name] = {  # not bundled (the 100 MB budget): the raw runs, made by the recipe's first command
        "file": f"{_RAW_DIR}/confinement/{_name}.h5",
        "subset_sha256": _sha,
        "commands": _confinement_recipe(_name, _size, _revs, int(_seed), omega=_FROUDE_OMEGA[_n] if _froude else None,
                                        full_window=_window, threads=_threads, checkpoint_every=_every),
        "code_version": _SIM_V3_CONFINEMENT,
        "wall_time": _wall if _base.startswith("cg1-dd") else f"{_wall} (1 thread, beside another run on the other core)",
        "description": f"α = 1 confinement run, seed {_seed}: {_what}; frame 0 and every fourth frame of [{_window.replace(':', ', ')}]",
    }


def confinement_groups(root=None) -> dict:
    """The confinement runs as replica groups: label (``cg1-n111``, ``cg1-n111-fr``, ``cg1-n375``,
    ``cg1-dd50``) -> paths of the raw runs under ``root`` (default: the repository root), seeds in
    order. They are not bundled (the 100 MB budget of datasets/); each is made by the first
    command of its recipe (about 4 h on one core in all; ``subset_sha256`` is the sum of the
    float32 subset its second command writes).

    Raises
    ------
    GranalyticsError
        A run is missing, naming the command that makes it.
    """
    root = Path(root) if root is not None else DATASET_DIR.parent
    groups: dict = {}
    for name, entry in CONFINEMENT.items():
        path = root / entry["file"]
        if not path.exists():
            raise GranalyticsError(f"{path}: confinement run missing (not bundled; made by: {entry['commands'][0]})")
        groups.setdefault(name.rpartition("-seed")[0], []).append(path)
    return groups


#: runs whose recipe is kept but which are not bundled (not remade with the current simulator yet):
#: name -> {"commands", "cost", "why"}; empty since paper-cg2 was remade in 3-D (2026-12-02)
NOT_BUNDLED: dict = {}


#: runs of the DEM codes our users come from, made by the real programs (their input scripts and raw
#: output in ``folder``), converted by granalytics: name -> file, sha256, program, the program's
#: commands (run in ``folder`` where the program is installed; the raw output kept otherwise), the
#: conversion commands (from the repository root), description
FOREIGN = {
    "liggghts-wet-drum": {
        "file": "liggghts-wet-drum.h5",
        "sha256": "eb30661a848f38769ce58ffa0c27588147909441eb4855f1d2b8f64270506abb",
        "program": "liggghts",
        "folder": "tests/data/liggghts_wet_drum",
        "program_commands": ["python3 make_drum_stl.py", "liggghts -in in.wetdrum -echo none -log none",
                             "gzip -9f atoms.*.dump pairs.*.dump"],
        "commands": ["granalytics convert tests/data/liggghts_wet_drum/atoms.5000.dump.gz tests/data/liggghts_wet_drum/atoms.10000.dump.gz tests/data/liggghts_wet_drum/atoms.15000.dump.gz tests/data/liggghts_wet_drum/atoms.20000.dump.gz --contacts tests/data/liggghts_wet_drum/pairs.5000.dump.gz tests/data/liggghts_wet_drum/pairs.10000.dump.gz tests/data/liggghts_wet_drum/pairs.15000.dump.gz tests/data/liggghts_wet_drum/pairs.20000.dump.gz --mapping tests/data/liggghts_wet_drum/mapping.toml --dt-s 2e-6 "
                     "--out datasets/liggghts-wet-drum.h5 --overwrite --quiet"],
        "description": "LIGGGHTS 3.8.0 wet drum: 300 spheres of 1.5 mm, Hertz contacts, cohesion easo/capillary/viscous, "
                       "R = 20 mm, 4 baffles, 2 rad/s; 4 frames (tests/data/liggghts_wet_drum/README.md)",
    },
    "yade-wet-drum": {
        "file": "yade-wet-drum.h5",
        "sha256": "808e1ed839b5e7abe2eda4b6d6d7f12aaccc0ef234af47d3098f20559d547399",
        "program": "yade",
        "folder": "tests/data/yade_wet_drum",
        "program_commands": ["yade -n -x wetdrum_yade.py", "cp out/frame_particles_000012000.csv out/"
                             "frame_particles_000016000.csv out/frame_contacts_000012000.csv "
                             "out/frame_contacts_000016000.csv . && gzip -9f frame_*.csv && rm -r out"],
        "commands": ["granalytics convert tests/data/yade_wet_drum/frame_particles_000012000.csv.gz tests/data/yade_wet_drum/frame_particles_000016000.csv.gz --from yade --contacts tests/data/yade_wet_drum/frame_contacts_000012000.csv.gz tests/data/yade_wet_drum/frame_contacts_000016000.csv.gz --mapping tests/data/yade_wet_drum/meta.toml "
                     "--out datasets/yade-wet-drum.h5 --overwrite --quiet"],
        "description": "YADE 2023.02a ViscElCapMat wet drum exported with scripts/yade_export.py: about 250 spheres, "
                       "Willett bridges, R = 20 mm, 2 rad/s; 2 frames (tests/data/yade_wet_drum/README.md). YADE's "
                       "output differs in its last digits from run to run (checked 2026-12-02: LIGGGHTS remade its "
                       "dumps byte for byte, YADE not), so a remake gives a new sum. Remade 2026-12-02 on the 3-D lattice of "
                       "benchmarks/_bench.py (246 spheres; 90 % of touching contacts cross axial layers, 35 % before); "
                       "re-converted 2026-12-03: the reader fills in Willett's F_cap(0+) of touching wet pairs",
    },
}


#: name -> folder under datasets/, sha256 of its manifest.csv, spec, commands, code version, wall
#: time, description (the point files' sums are in the manifest; :func:`sweep_path` checks both)
SWEEPS = {
    "gamma-omega-lab-cg3": {
        "dir": "sweeps/gamma-omega-lab-cg3",
        "manifest_sha256": "2ce1a2a2b21358af287695247280777daa671041a2126e69bd5f26c1e9f6b949",
        "spec": "sweeps/gamma-omega-lab-cg3.toml",
        "commands": [
            "python -m sim sweep datasets/sweeps/gamma-omega-lab-cg3.toml --out build/sweeps/gamma-omega-lab-cg3 "
            "--workers 2",
            "python -m granalytics.datasets bundle-sweep build/sweeps/gamma-omega-lab-cg3 "
            "datasets/sweeps/gamma-omega-lab-cg3 --every 8 --full-window 3:6 --window-every 2 --overwrite",
        ],
        "code_version": _SIM_V3,
        "wall_time": "16 min on 1 worker (about 46 s per point), beside the CG2 sweep on the other core",
        "description": "lab drum at CG3 (111 particles), γ = 0.01, 0.03, 0.06, 0.1095, 0.2, 0.3, 0.444 N/m (original "
                       "system) × Ω = 1.5, 2, 3 rad/s, 6 revolutions, every second frame in [3, 6] (0.1 revolution), every "
                       "eighth before (0.4 revolution), as float32 (thinned before the window on 2026-12-02 from the "
                       "bundled copy of every second frame, to make room for paper-cg2: the same frames and values as "
                       "the command from the raw sweep, which was not kept; source_sha256 is the raw points' sum)",
    },
    "gamma-omega-lab-cg2": {
        "dir": "sweeps/gamma-omega-lab-cg2",
        "manifest_sha256": "d09f31784b0ab2935be3ad8546283287c444f9cbfe51ddbab8ac3608fab05d21",
        "spec": "sweeps/gamma-omega-lab-cg2.toml",
        "commands": [
            "python -m sim sweep datasets/sweeps/gamma-omega-lab-cg2.toml --out build/sweeps/gamma-omega-lab-cg2 "
            "--workers 2",
            "python -m granalytics.datasets bundle-sweep build/sweeps/gamma-omega-lab-cg2 "
            "datasets/sweeps/gamma-omega-lab-cg2 --every 12 --full-window 3:6 --window-every 3 --overwrite",
        ],
        "code_version": _SIM_V3,
        "wall_time": "about 1 h 15 min: 15 points on one worker beside other runs (3.5-7 min a point), the last six as "
                     "two single-worker sweeps of gamma = 0.3 and 0.444 side by side (12 min), merged into the folder",
        "description": "lab drum at CG2 (375 particles), the same γ × Ω grid as gamma-omega-lab-cg3, 6 revolutions, "
                       "every third frame in [3, 6] (0.15 revolution), every twelfth before (0.6 revolution), as float32 "
                       "(thinned before the window from the bundled copy on 2026-12-02, as gamma-omega-lab-cg3)",
    },
}


#: the simulator's physics version today (``sim.params.PHYSICS_VERSION``: granalytics does not
#: import the simulator; tests/test_datasets.py keeps the two equal)
SIMULATOR_PHYSICS_VERSION = 4

#: the physics version that made each registered run or sweep (its files record it too)
for _entry in (*DATASETS.values(), *CONFINEMENT.values(), *SWEEPS.values()):
    _entry.setdefault("physics_version", 3)

#: bundled sets of an older physics version remade with today's simulator (their recipes' own
#: commands) and compared: set -> what the comparison found
#: (``python benchmarks/dataset_recheck.py table``; window [3, 6], three seeds each)
PHYSICS_RECHECKS: dict = {
    "lab-cg3": "rechecked with physics version 4 (seeds 0-2): yield 0.349 ± 0.005 against 0.345 ± 0.018, "
               "⟨V_g⟩/V_p 3.02 ± 0.04 against 2.99 ± 0.05, N_g/N 0.119 ± 0.003 against 0.118 ± 0.006 (window [3, 6]): "
               "the same within 0.4 replica s.e.",
    "lab-cg2": "rechecked with physics version 4 (seeds 0-2): yield 0.423 ± 0.001 against 0.432 ± 0.010, "
               "⟨V_g⟩/V_p 3.58 ± 0.05 against 3.57 ± 0.06, N_g/N 0.123 ± 0.001 against 0.125 ± 0.002 (window [3, 6]): "
               "the same within 1.1 replica s.e.",
}


def physics_note(name: str, entry: dict) -> str:
    """One line on the physics version that made a registered run, and, where it is older than
    today's, whether its statistics still hold (:data:`PHYSICS_RECHECKS`)."""
    version = entry["physics_version"]
    if version == SIMULATOR_PHYSICS_VERSION:
        return f"physics version {version} (today's)"
    replica_set = next((s for s, names in REPLICAS.items() if name in names), name)
    found = PHYSICS_RECHECKS.get(replica_set, "not rechecked with today's simulator")
    return f"physics version {version} (today's is {SIMULATOR_PHYSICS_VERSION}; a rerun differs in its trajectory): {found}"


def _checked_file(entry, missing) -> Path:
    """The registry ``entry``'s file under ``datasets/`` after checking that it exists (else
    ``missing``, formatted with the entry's commands) and that its sha256 is the registry's
    (read once)."""
    path = DATASET_DIR / entry["file"]
    if not path.exists():
        raise GranalyticsError(f"{path}: " + missing.format(" && ".join(entry["commands"])))
    digest = file_sha256(path)
    if digest != entry["sha256"]:
        raise GranalyticsError(f"{path}: sha256 {digest} does not match the registry ({entry['sha256']})")
    return path


def dataset_path(name: str) -> Path:
    """Path of a bundled dataset after checking its sha256 sum.

    Raises
    ------
    GranalyticsError
        Unknown name, missing file (e.g. an installed package without the source tree), or a
        checksum mismatch.
    """
    try:
        entry = DATASETS[name]
    except KeyError:
        raise GranalyticsError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}") from None
    return _checked_file(entry, "dataset file missing (datasets live in the source tree; made by: {})")


def open_dataset(name: str):
    """Open a bundled dataset as a :class:`~granalytics.Run`."""
    from granalytics.core import open_run

    return open_run(dataset_path(name))


def foreign_path(name: str) -> Path:
    """Path of a converted run of another code (:data:`FOREIGN`) after checking its sha256."""
    try:
        entry = FOREIGN[name]
    except KeyError:
        raise GranalyticsError(f"unknown run {name!r}; available: {', '.join(FOREIGN)}") from None
    return _checked_file(entry, "missing (made by: {})")


def sweep_path(name: str) -> Path:
    """Folder of a bundled sweep after checking the sha256 of its manifest and of every point
    file the manifest lists (``granalytics.study_table(sweep_path(name))`` analyses it).

    Raises
    ------
    GranalyticsError
        Unknown name, missing folder or file, or a checksum mismatch.
    """
    import pandas as pd

    try:
        entry = SWEEPS[name]
    except KeyError:
        raise GranalyticsError(f"unknown sweep {name!r}; available: {', '.join(SWEEPS)}") from None
    folder = DATASET_DIR / entry["dir"]
    manifest = folder / "manifest.csv"
    if not manifest.exists():
        raise GranalyticsError(f"{manifest}: sweep manifest missing (made by: {' && '.join(entry['commands'])})")
    digest = file_sha256(manifest)
    if digest != entry["manifest_sha256"]:
        raise GranalyticsError(f"{manifest}: sha256 {digest} does not match the registry ({entry['manifest_sha256']})")
    table = pd.read_csv(manifest, dtype={"file": str, "sha256": str})
    for rel, expected in zip(table.file, table.sha256):
        path = folder / rel
        if not path.exists():
            raise GranalyticsError(f"{path}: point file of sweep {name} missing")
        if file_sha256(path) != expected:
            raise GranalyticsError(f"{path}: sha256 does not match {manifest}")
    return folder

