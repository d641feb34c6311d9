"""A sweep spec (TOML) read and checked into its points (:func:`load_spec`, :func:`parse_spec`):
every grid value checked against the simulator's parameters and every point's frame plan
checked before anything runs; a point's name from its grid values (:func:`point_name`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import math
from dataclasses import dataclass, field

from granalytics.base.errors import ParameterError
from granalytics.base.files import regular_input
from granalytics.core.manifest import NAMED_PARAMETERS

from ..params import (PRESETS, SimParams, cg_scale, check_cg_particle_count, frame_interval_steps, preset_original,
                      sized_drum, with_step_factor)


#: grid keys that are the ``python -m sim run`` overrides -> SimParams field of the original system
GRID_ALIASES = {"gamma": "surface_tension", "omega": "drum_omega", "seed": "seed", "particles": "n_particles"}


#: canonical order of the named keys in point names and manifest columns (others follow, sorted)
_NAMED = NAMED_PARAMETERS


#: SimParams fields that cannot be grid keys under their own name
_NOT_FIELDS = {"alpha", "surface_tension", "drum_omega", "n_particles", "seed", "gravity"}


#: grid keys that size the preset's drum (sim.params.sized_drum) -> python type
_SIZING = {"drum_ratio": float, "drum_particles": int}


#: grid keys applied to the simulated system after the CG rule (sim.params.with_step_factor), not to the original
_AFTER_CG = {"dt_factor"}


_TOP_LEVEL = {"preset", "revolutions", "frame_every_rev", "checkpoint_every", "threads", "grid"}


_SIM_FIELDS = {f.name: f for f in dataclasses.fields(SimParams)}


# ----------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep: its name, the grid values (``grid``, spec names) and the five named
    parameters of the original system resolved from the preset where the grid does not set them
    (``resolved``: gamma, omega, alpha, seed, particles, then the other grid keys)."""

    name: str
    grid: dict
    resolved: dict


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep: fixed settings and the points (cartesian product of ``grid``)."""

    path: str
    preset: str
    revolutions: float
    frame_every_rev: float
    checkpoint_every: int
    threads: int
    grid: dict
    points: tuple = field(default_factory=tuple)


def build_params(preset, overrides):
    """(original, params) of a point, refusing the particle counts ``python -m sim run`` refuses."""
    original, alpha = preset_original(preset)
    changes = {k: v for k, v in overrides.items() if k != "alpha" and k not in _SIZING and k not in _AFTER_CG}
    original = dataclasses.replace(original, **changes)
    alpha = float(overrides.get("alpha", alpha))
    sizing = {k: overrides[k] for k in _SIZING if k in overrides}
    if sizing and "n_particles" in overrides:
        raise ValueError("grid key 'particles' keeps the preset's drum; drum_ratio and drum_particles size the drum "
                         "and set the count: give one of them")
    original = sized_drum(preset, original, alpha, **sizing)
    check_cg_particle_count(original.n_particles, alpha)
    params = original if alpha == 1 else cg_scale(original, alpha)
    return original, with_step_factor(params, overrides.get("dt_factor", 1.0))


def _fmt_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = repr(value)
        return text[:-2] if text.endswith(".0") else text
    return str(value)


def point_name(grid_values: dict) -> str:
    """Deterministic file-system-safe name of a point from its grid values, e.g.
    ``gamma=0.1_omega=2_seed=0``: the named keys (gamma, omega, alpha, seed, particles) in that
    order, then the other keys alphabetically; floats in their shortest exact form."""
    keys = [k for k in _NAMED if k in grid_values] + sorted(k for k in grid_values if k not in _NAMED)
    name = "_".join(f"{k}={_fmt_value(grid_values[k])}" for k in keys)
    if len(name) > 150:  # keep file names short; the hash keeps them unique
        digest = hashlib.sha256(name.encode()).hexdigest()[:12]
        name = f"{name[:130]}_{digest}"
    return name


def _expected_type(key):
    """(python types, description) a grid value of ``key`` must have."""
    if key in ("gamma", "omega", "alpha"):
        return float, "a number"
    if key in ("seed", "particles"):
        return int, "an integer"
    if key in _SIZING:
        return (float, "a number") if _SIZING[key] is float else (int, "an integer")
    default = _SIM_FIELDS[key].default
    if isinstance(default, bool):
        return bool, "true or false"
    if isinstance(default, int):
        return int, "an integer"
    if isinstance(default, float):
        return float, "a number"
    return str, "a string"


def _check_value(where, key, value):
    kind, what = _expected_type(key)
    if kind is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        value = float(value) if ok else value
    elif kind is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    else:
        ok = isinstance(value, kind)
    if not ok:
        raise ParameterError(f"{where}: grid key {key!r}: every value must be {what}, got {value!r}")
    if key == "omega" and value == 0:
        raise ParameterError(f"{where}: grid key 'omega': a sweep needs a rotating drum, got 0")
    if key == "alpha" and value < 1:
        raise ParameterError(f"{where}: grid key 'alpha': the CG factor must be >= 1, got {value!r}")
    return value


def _number(where, spec, key, default, kind, positive=True):
    value = spec.get(key, default)
    if value is None:
        raise ParameterError(f"{where}: {key} is required")
    good = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind is int:
        good = good and isinstance(value, int)
    if not good or not math.isfinite(value) or (positive and value <= 0):
        raise ParameterError(f"{where}: {key} must be {'an integer' if kind is int else 'a number'} > 0, got {value!r}")
    return kind(value)


#: the most points one sweep spec may hold (each point is a simulation of minutes to hours)
MAX_POINTS = 10_000


def parse_spec(spec: dict, path="<spec>") -> SweepSpec:
    """Validate a sweep spec (the TOML file as a dict) and expand its grid.

    Raises
    ------
    ParameterError
        One line naming the file and the problem: an unknown key, a grid value that is not a
        list, an empty grid or list, a duplicate or invalid value, a point the simulator refuses.
    """
    where = str(path)
    unknown = sorted(set(spec) - _TOP_LEVEL)
    if unknown:
        raise ParameterError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(_TOP_LEVEL))})")
    preset = spec.get("preset", "lab-cg3")
    if preset not in PRESETS:
        raise ParameterError(f"{where}: unknown preset {preset!r}; available: {', '.join(PRESETS)}")
    revolutions = _number(where, spec, "revolutions", None, float)
    frame_every_rev = _number(where, spec, "frame_every_rev", 0.05, float)
    checkpoint_every = _number(where, spec, "checkpoint_every", 20, int)
    threads = _number(where, spec, "threads", 1, int)
    grid = spec.get("grid")
    if not isinstance(grid, dict):
        raise ParameterError(f"{where}: a [grid] table is required (keys: parameters, values: lists)")
    if not grid:
        raise ParameterError(f"{where}: the [grid] table is empty")
    known = set(_NAMED) | set(_SIZING) | (set(_SIM_FIELDS) - _NOT_FIELDS)
    values = {}
    for key, items in grid.items():
        if key not in known:
            hint = f" (use {next(k for k, v in GRID_ALIASES.items() if v == key)!r})" if key in GRID_ALIASES.values() else ""
            raise ParameterError(f"{where}: unknown grid key {key!r}{hint}; known: {', '.join(_NAMED)} "
                                 f"or a field of sim.params.SimParams")
        if not isinstance(items, list):
            raise ParameterError(f"{where}: grid key {key!r} must be a list of values, got {items!r}")
        if not items:
            raise ParameterError(f"{where}: grid key {key!r} has an empty list")
        checked = [_check_value(where, key, v) for v in items]
        if len({_fmt_value(v) for v in checked}) != len(checked):
            raise ParameterError(f"{where}: grid key {key!r} lists a value twice: {items!r}")
        values[key] = checked
    keys = [k for k in _NAMED if k in values] + sorted(k for k in values if k not in _NAMED)
    n_points = math.prod(len(values[k]) for k in keys)
    if n_points > MAX_POINTS:  # refused before a million parameter sets are built and checked
        raise ParameterError(f"{where}: the grid has {n_points:,} points ({' × '.join(str(len(values[k])) for k in keys)}), "
                             f"more than the {MAX_POINTS:,} a sweep may run (each is a simulation); split it")
    points = []
    for combo in itertools.product(*(values[k] for k in keys)):
        grid_values = dict(zip(keys, combo))
        name = point_name(grid_values)
        overrides = {GRID_ALIASES.get(k, k): v for k, v in grid_values.items()}
        try:
            original, params = build_params(preset, overrides)
            frame_interval_steps(revolutions, frame_every_rev, params)  # the frame plan of `sim run`
        except ValueError as exc:
            raise ParameterError(f"{where}: point {name}: {exc}") from None
        resolved = {"gamma": original.surface_tension, "omega": original.drum_omega, "alpha": params.alpha,
                    "seed": original.seed, "particles": original.n_particles}
        resolved.update({k: v for k, v in grid_values.items() if k not in resolved})
        points.append(SweepPoint(name, grid_values, resolved))
    return SweepSpec(where, preset, revolutions, frame_every_rev, checkpoint_every, threads,
                     {k: values[k] for k in keys}, tuple(points))


def load_spec(path) -> SweepSpec:
    """Read and validate a sweep spec TOML file (see the module docstring)."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    regular_input(path)  # a FIFO would block for ever
    try:
        with open(path, "rb") as f:
            spec = tomllib.load(f)
    except RecursionError:
        raise ParameterError(f"{path}: not a sweep spec: its tables or arrays are nested too deeply") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the sweep spec ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({' '.join(str(exc).split())})") from None
    except UnicodeDecodeError as exc:
        raise ParameterError(f"{path}: not UTF-8 text, as TOML must be (byte {exc.start}: {exc.reason})") from None
    return parse_spec(spec, path)

