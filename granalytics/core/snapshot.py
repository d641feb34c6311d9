"""Data model: one frame of a wet-particle simulation (:class:`Snapshot`) and a run's metadata
(:class:`RunMeta`).

All quantities are SI: seconds, metres, m/s, rad/s, m³, newtons, kg/m³, N/m, radians.

Contacts and liquid bridges are stored as pairs of *row indices* into the snapshot's particle
arrays (not particle ids), with ``contact_i < contact_j``. A pair appears at most once: a pair
that touches and shares a liquid bridge is one entry carrying both its forces and its bridge
volume.

:data:`SNAPSHOT` and :data:`META` are the constraints of an argument that takes a frame or a run's
metadata (:mod:`granalytics.base.validation`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from dataclasses import dataclass, field
from numbers import Integral, Real

import numpy as np

from granalytics.base.errors import ValidationError, user_stacklevel
from granalytics.base.validation import FLAG, POSITIVE, Array, Instance, Interval, violation_message, typed_repr

__all__ = ["RunMeta", "Snapshot", "SNAPSHOT", "META"]


def json_problem(value) -> str | None:
    """Why ``value`` cannot be stored as JSON and read back unchanged, or None if it can.

    Refused: objects JSON has no type for, circular references, and dict keys that are not
    strings (JSON would silently turn ``{1: x}`` into ``{"1": x}``).
    """
    try:
        json.dumps(value)
    except (TypeError, ValueError, RecursionError) as exc:
        return str(exc)
    stack = [(value, "")]
    while stack:
        item, where = stack.pop()
        if isinstance(item, dict):
            for key, sub in item.items():
                if not isinstance(key, str):
                    return f"key {key!r}{' in ' + where if where else ''} is not a string"
                stack.append((sub, f"{where}[{key!r}]"))
        elif isinstance(item, (list, tuple)):
            stack.extend((sub, f"{where}[{k}]") for k, sub in enumerate(item))
    return None


#: the largest CG factor a run may record (a CG particle standing for a million original ones)
MAX_ALPHA = 100.0


@dataclass
class RunMeta:
    """Metadata of a run: what CG-aware statistics need, plus provenance.

    Parameters
    ----------
    surface_tension : float
        Liquid surface tension γ of *this* (possibly coarse-grained) system [N/m].
    density : float
        Particle density ρ [kg/m³].
    drum_omega : float
        Drum angular velocity Ω [rad/s]; revolutions are t·Ω/2π. Use 0 when the run has no
        drum (revolution-based selections then raise).
    n_particles : int
        Number of particles of this run.
    mean_radius : float
        Mean particle radius of this run [m].
    alpha : float, default 1
        Coarse-graining factor α (1 = original system).
    contact_angle : float, default 0
        Liquid–solid contact angle θ [rad].
    gravity : tuple of 3 floats, default (0, 0, -9.81)
        Gravitational acceleration [m/s²].
    n_particles_original : int, optional
        Particle count of the original (α = 1) system; defaults to ``round(n_particles·α³)``.
    mean_radius_original : float, optional
        Mean particle radius of the original system [m]; defaults to ``mean_radius/α``.
    capillary_in_contact : bool, optional
        Whether the producing DEM code applied the capillary (bridge) force between *touching*
        particles. YADE's law does not (False); ``sim`` records its parameter of the same name.
        Default: ``sim_config["params"]["capillary_in_contact"]`` when present, else False.
        Decides the ``cohesion="acting"`` convention (:mod:`granalytics.identification.cohesion`).
    sim_config : dict
        Full simulator configuration when the run came from ``sim`` (JSON-serialisable).
    provenance : dict
        Free-form provenance: code, version, command line, source files (JSON-serialisable).
    """

    surface_tension: float
    density: float
    drum_omega: float
    n_particles: int
    mean_radius: float
    alpha: float = 1.0
    contact_angle: float = 0.0
    gravity: tuple = (0.0, 0.0, -9.81)
    n_particles_original: int | None = None
    mean_radius_original: float | None = None
    capillary_in_contact: bool | None = None
    sim_config: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)

    def __post_init__(self):
        for name, allowed in _META_CONSTRAINTS.items():
            _check_field(name, allowed, getattr(self, name))
        for name in ("surface_tension", "density", "mean_radius", "alpha", "drum_omega", "contact_angle"):
            setattr(self, name, float(getattr(self, name)))
        self.n_particles = int(self.n_particles)
        self.gravity = tuple(float(g) for g in self.gravity)
        if self.n_particles_original is None:
            self.n_particles_original = round(self.n_particles * self.alpha**3)
        self.n_particles_original = int(self.n_particles_original)
        if self.mean_radius_original is None:
            self.mean_radius_original = self.mean_radius / self.alpha
        self.mean_radius_original = float(self.mean_radius_original)
        for name in ("sim_config", "provenance"):
            problem = json_problem(getattr(self, name))
            if problem:
                raise ValidationError(name, f"must be JSON-serialisable: {problem}")
        _check_schema("sim_config", self.sim_config, _SIM_CONFIG_SCHEMA)
        _check_schema("provenance", self.provenance, _PROVENANCE_SCHEMA)
        if self.capillary_in_contact is None:
            self.capillary_in_contact = self.sim_config.get("params", {}).get("capillary_in_contact", False)
        self.capillary_in_contact = bool(self.capillary_in_contact)

    def validate(self) -> None:
        """Check every field again, e.g. after fields were assigned since construction.

        Raises
        ------
        ValidationError
            Naming the offending field.
        """
        self.__post_init__()

    def stopped_early(self, held="") -> list:
        """What the provenance says of a run that did not finish (phrases; none if nothing): its
        producer's ``provenance["interrupted"]``, or a simulator run that recorded no wall time
        (``sim`` writes it after the last frame), ``held`` added to that phrase (what the reader
        holds of it). :attr:`Run.unfinished <granalytics.core.reader.Run.unfinished>` and
        :attr:`RunStatistics.unfinished <granalytics.RunStatistics.unfinished>` say it."""
        reasons = [str(self.provenance["interrupted"])] if self.provenance.get("interrupted") else []
        if self.provenance.get("code") == "sim" and self.provenance.get("wall_time_s") is None:
            reasons.append(f"the simulator recorded no end (no wall time){held}")
        return reasons

    def to_dict(self) -> dict:
        """Plain-dict form (JSON-serialisable)."""
        out = dataclasses.asdict(self)
        out["gravity"] = list(self.gravity)
        return out

    @classmethod
    def from_dict(cls, data: dict) -> "RunMeta":
        """Build from :meth:`to_dict` output; unknown keys are kept in ``provenance`` with a warning."""
        names = {f.name for f in dataclasses.fields(cls)}
        known = {k: v for k, v in data.items() if k in names}
        unknown = {k: v for k, v in data.items() if k not in names}
        if unknown:
            warnings.warn(f"run metadata has unknown keys {sorted(unknown)}; kept under provenance['unknown_meta']",
                          stacklevel=user_stacklevel())
            known.setdefault("provenance", {})
            known["provenance"] = dict(known["provenance"], unknown_meta=unknown)
        return cls(**known)


_FINITE = [Interval(Real)]
_COUNT = [Interval(Integral, 1, None)]
_STEP = [Interval(Integral, 0, None)]
#: the constraints of RunMeta's fields (a CG factor below 1 would make the original particles larger;
#: one of 10⁶ is no meaningful run; numbers stored as text, "0.07" or "false", were changed by hand)
_META_CONSTRAINTS = {
    **dict.fromkeys(("surface_tension", "density", "mean_radius"), [POSITIVE]),
    "alpha": [Interval(Real, 1, MAX_ALPHA)],
    "drum_omega": _FINITE,
    "contact_angle": [Interval(Real, 0, math.pi / 2, closed="left")],
    "n_particles": _COUNT,
    "gravity": [Array(ndim=1, length=3, finite=True)],
    "n_particles_original": _COUNT + [None],
    "mean_radius_original": [POSITIVE, None],
    "capillary_in_contact": [FLAG, None],
    **dict.fromkeys(("sim_config", "provenance"), [Instance(dict, "a dict")]),
}
# what granalytics reads from the free-form dicts of RunMeta: the constraints of each entry (when
# present; None allowed where the producer may record "not measured"), or a nested schema (a table)
_SIM_PARAMS_SCHEMA = {
    **dict.fromkeys(("drum_radius", "drum_length", "d_mean", "baffle_height", "drum_omega", "alpha",
                     "surface_tension", "density", "contact_angle", "dt"), _FINITE),
    **dict.fromkeys(("n_baffles", "n_particles", "seed"), [Interval(Integral)]),
    **dict.fromkeys(("capillary_in_contact", "viscous"), [FLAG]),
}
_SIM_CONFIG_SCHEMA = {
    "params": _SIM_PARAMS_SCHEMA,
    "original": _SIM_PARAMS_SCHEMA,
    "confinement": dict.fromkeys(("drum_ratio", "length_ratio", "bed_depth_ratio", "fill_fraction"), _FINITE),
}
_PROVENANCE_SCHEMA = {
    **dict.fromkeys(("wall_time_s", "wall_time_per_simulated_s", "simulated_time_s", "cpu_time_s",
                     "cpu_time_per_simulated_s", "settle_wall_time_s", "settle_cpu_time_s"), _FINITE + [None]),
    "planned_frames": [Interval(Integral), None],
    "first_frame": [Interval(Integral, 0, None), None],
}


def _check_schema(name, table, schema) -> None:
    """Check the entries of ``table`` that ``schema`` knows (their constraints; nested tables must be
    dicts); other entries are free-form. Raises ValidationError naming the entry's dotted path."""
    for key, rule in schema.items():
        if key not in table:
            continue
        where, value = f"{name}.{key}", table[key]
        if isinstance(rule, dict):
            if not isinstance(value, dict):
                raise ValidationError(where, f"must be a table (a dict), got {typed_repr(value)}")
            _check_schema(where, value, rule)
        else:
            _check_field(where, rule, value)


def _check_field(name, allowed, value) -> None:
    """Raise ValidationError naming ``name`` when ``value`` satisfies none of the constraints ``allowed``."""
    why = violation_message(allowed, value)
    if why:
        raise ValidationError(name, why)


# field name -> (kind, trailing shape, sign constraint)
_PARTICLE_FIELDS = {
    "ids": ("int", (), None),
    "radius": ("float", (), "positive"),
    "position": ("float", (3,), None),
    "velocity": ("float", (3,), None),
    "angular_velocity": ("float", (3,), None),
    "film_volume": ("float", (), "nonnegative"),
}
_CONTACT_FIELDS = {
    "contact_i": ("int", (), None),
    "contact_j": ("int", (), None),
    "f_cap": ("float", (), "nonnegative"),
    "f_normal": ("float", (), None),
    "gap": ("float", (), None),
    "bridge_volume": ("float", (), "nonnegative"),
}
PARTICLE_FIELDS = tuple(_PARTICLE_FIELDS)
CONTACT_FIELDS = tuple(_CONTACT_FIELDS)


@dataclass(eq=False)
class Snapshot:
    """One frame: particles and their contacts / liquid bridges.

    Arrays are converted to float64 (int64 for ids and contact indices) and validated on
    construction; a violation raises :class:`~granalytics.ValidationError` naming the field and
    the first offending index.

    Parameters
    ----------
    time : float
        Simulated time [s].
    step : int
        Integration step number.
    ids : (N,) int array
        Particle ids, unique within the frame (stable across frames of a run).
    radius : (N,) float array
        Particle radii [m], > 0.
    position, velocity, angular_velocity : (N, 3) float arrays
        Positions [m], velocities [m/s], angular velocities [rad/s].
    film_volume : (N,) float array
        Liquid film volume carried by each particle [m³], ≥ 0.
    contact_i, contact_j : (M,) int arrays
        Row indices of the two particles of each contact or bridge, ``0 ≤ i < j < N``.
    f_cap : (M,) float array
        Magnitude of the capillary (cohesive) normal force F_coh [N], ≥ 0.
    f_normal : (M,) float array
        Total normal force [N] (sign convention of the source code; granalytics does not use it
        for identification).
    gap : (M,) float array
        Surface-to-surface gap [m]; negative means overlap.
    bridge_volume : (M,) float array
        Liquid bridge volume [m³], ≥ 0 (0 for a dry contact).
    meta : RunMeta, optional
        Metadata of the run the frame belongs to.
    """

    time: float
    step: int
    ids: np.ndarray
    radius: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    film_volume: np.ndarray
    contact_i: np.ndarray
    contact_j: np.ndarray
    f_cap: np.ndarray
    f_normal: np.ndarray
    gap: np.ndarray
    bridge_volume: np.ndarray
    meta: RunMeta | None = None

    def __post_init__(self):
        self.validate()

    def __repr__(self):
        """One line (the dataclass's own repr printed every array: ~500 lines for a frame)."""
        revs = self.revolutions
        at = f", revolution {revs:.4g}" if math.isfinite(revs) else ""
        return (f"Snapshot(t={self.time:.6g} s, step {self.step}{at}: {self.n_particles} particles, "
                f"{self.n_contacts} contacts)")

    # ------------------------------------------------------------------ validation
    def validate(self) -> None:
        """Coerce dtypes and check every invariant of the data model.

        Raises
        ------
        ValidationError
            Naming the field and the first offending index.
        """
        for name, allowed in (("time", _FINITE), ("step", _STEP), ("meta", [META, None])):
            _check_field(name, allowed, getattr(self, name))
        self.time, self.step = float(self.time), int(self.step)

        n = None
        for name, spec in _PARTICLE_FIELDS.items():
            arr = _coerce(name, getattr(self, name), spec, n)
            n = arr.shape[0] if n is None else n
            setattr(self, name, arr)
        if n == 0:
            raise ValidationError("ids", "the frame has no particles: a snapshot needs at least one")
        m = None
        for name, spec in _CONTACT_FIELDS.items():
            arr = _coerce(name, getattr(self, name), spec, m)
            m = arr.shape[0] if m is None else m
            setattr(self, name, arr)

        _check_unique("ids", self.ids, "particle id")
        ci, cj = self.contact_i, self.contact_j
        for name, arr in (("contact_i", ci), ("contact_j", cj)):
            refuse_first(name, (arr < 0) | (arr >= n), lambda k: f"particle index {int(arr[k])} out of range [0, {n})")
        refuse_first("contact_i", ci >= cj, lambda k: ("a particle paired with itself" if ci[k] == cj[k] else
                                                        "pair not ordered i < j") + f": i={int(ci[k])}, j={int(cj[k])}")
        _check_unique("contact_i", ci * np.int64(n) + cj, "contact pair", ci, cj)

    # ------------------------------------------------------------------ derived
    @property
    def n_particles(self) -> int:
        """Number of particles N."""
        return int(self.radius.shape[0])

    @property
    def n_contacts(self) -> int:
        """Number of contacts and liquid bridges M."""
        return int(self.contact_i.shape[0])

    @property
    def particle_volume(self) -> np.ndarray:
        """Particle volumes 4/3·π·R³ [m³]."""
        return 4.0 / 3.0 * np.pi * self.radius**3

    @property
    def revolutions(self) -> float:
        """Drum revolutions t·Ω/2π (NaN without metadata or with Ω = 0)."""
        if self.meta is None or self.meta.drum_omega == 0:
            return float("nan")
        return self.time * abs(self.meta.drum_omega) / (2 * math.pi)

    def take_particles(self, order) -> "Snapshot":
        """Return a copy with particles in the given order and contacts re-indexed.

        Parameters
        ----------
        order : (N,) int array
            A permutation of ``range(N)``: row ``k`` of the result is row ``order[k]`` here.
        """
        order = np.asarray(order, dtype=np.int64)
        if order.shape != (self.n_particles,) or not np.array_equal(np.sort(order), np.arange(self.n_particles)):
            raise ValidationError("order", "must be a permutation of range(n_particles)")
        new_index = np.empty_like(order)
        new_index[order] = np.arange(order.size)
        a, b = new_index[self.contact_i], new_index[self.contact_j]
        particle = {name: getattr(self, name)[order] for name in PARTICLE_FIELDS}
        contact = {name: getattr(self, name) for name in CONTACT_FIELDS}
        contact["contact_i"] = np.minimum(a, b)
        contact["contact_j"] = np.maximum(a, b)
        return Snapshot(time=self.time, step=self.step, meta=self.meta, **particle, **contact)


def _coerce(name, value, spec, expected_len):
    kind, trailing, sign = spec
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # a ragged nested list, an object numpy cannot take
        raise ValidationError(name, f"must be an array of numbers of shape (n{',' if trailing else ''}"
                              f"{','.join(map(str, trailing))}), got {type(value).__name__} that is not one "
                              f"({str(exc).split('.')[0]})") from None
    if kind == "int":
        if arr.dtype.kind not in "iu" or arr.dtype == np.bool_:
            if arr.size == 0 and arr.dtype.kind == "f":
                arr = arr.astype(np.int64)
            else:
                raise ValidationError(name, f"must have an integer dtype, got {arr.dtype}")
        arr = arr.astype(np.int64, copy=False)
    else:
        if arr.dtype.kind not in "iuf" or arr.dtype == np.bool_:
            raise ValidationError(name, f"must have a real numeric dtype, got {arr.dtype}")
        arr = arr.astype(np.float64, copy=False)
    # C order too: the kernels read these arrays many times per frame (a threshold sweep, a
    # column view of an (M, 2) pair array), and strided reads cost them up to a third more
    arr = np.ascontiguousarray(arr)
    if arr.ndim != 1 + len(trailing) or arr.shape[1:] != trailing:
        want = "(n," + ",".join(str(t) for t in trailing) + ")" if trailing else "(n,)"
        raise ValidationError(name, f"must have shape {want}, got {arr.shape}")
    if expected_len is not None and arr.shape[0] != expected_len:
        raise ValidationError(name, f"has length {arr.shape[0]}, expected {expected_len} like the other fields")
    if kind == "float":
        finite = np.isfinite(arr)
        if not finite.all():  # the row of the first non-finite value
            refuse_first(name, ~finite.reshape(arr.shape[0], -1).all(axis=1),
                         lambda k: f"non-finite value {arr[k].tolist()}")
        if sign is not None:
            refuse_first(name, arr <= 0 if sign == "positive" else arr < 0,
                         lambda k: f"must be {'>' if sign == 'positive' else '>='} 0, got {arr[k]!r}")
    return arr


def refuse_first(field, bad, message, *, shift=0, path=None) -> None:
    """Raise ValidationError naming ``field`` at the first True of the mask ``bad`` (index ``k`` +
    ``shift``), with ``message(k)``."""
    if bad.any():
        k = int(np.argmax(bad)) + shift
        raise ValidationError(field, message(k), index=k, path=path)


def _check_unique(name, keys, what, ci=None, cj=None):
    if keys.size < 2:
        return
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    dup = np.flatnonzero(sorted_keys[1:] == sorted_keys[:-1])
    if dup.size:
        k = int(order[dup + 1].min())
        duplicate = f"({int(ci[k])}, {int(cj[k])})" if ci is not None else f"{int(keys[k])}"
        raise ValidationError(name, f"duplicate {what} {duplicate}", index=k)


#: the constraint of an argument that takes one frame of a run (:mod:`granalytics.base.validation`)
SNAPSHOT = Instance(Snapshot, "a granalytics Snapshot (open the run with granalytics.open_run and pass one frame, "
                              "e.g. run[0])")
#: the constraint of an argument that takes a run's metadata
META = Instance(RunMeta, "a RunMeta (a run's run.meta)")
