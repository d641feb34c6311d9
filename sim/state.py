"""Simulation state: a dataclass of plain numpy arrays (a checkpoint, :mod:`sim.checkpoint`, stores
them by field name)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

__all__ = ["State", "SLOT_FIELDS", "PARTICLE_FIELDS"]

#: per-particle arrays (permuted together when particles are reordered)
PARTICLE_FIELDS = ("ids", "pos", "vel", "omega", "radius", "mass", "inertia", "x_ref")
#: per-slot arrays
SLOT_FIELDS = ("pair_i", "pair_j", "alive", "created", "ruptured", "v_b", "v_max", "fs", "nprev",
               "force", "torque_i", "torque_j", "f_normal", "f_cap", "gap")
#: the per-slot outputs of the last step: every step's force pass writes them (a dead slot's are
#: zero) before anything reads them, so a state with them zeroed steps on to the same trajectory
SLOT_OUTPUT_FIELDS = ("force", "torque_i", "torque_j", "f_normal", "f_cap", "gap")


@dataclass
class State:
    """Everything that evolves. Particles are rows 0…N−1; bodies are particles then walls.

    Attributes (SI units)
    ---------------------
    step : int
        Steps since t = 0 (t = step·Δt); negative steps are not used (settling has its own clock).
    n_sprays : int
        Sprays done so far.
    sprayed_total : float
        Total liquid sprayed [m³].
    ids, pos, vel, omega, radius, mass, inertia, x_ref
        Particle ids, positions [m], half-step velocities [m/s] and angular velocities [rad/s],
        radii [m], masses [kg], moments of inertia [kg m²], positions at the last list rebuild.
    film : (N + W,)
        Liquid film volume of every body [m³] (walls collect the half of a ruptured wall bridge).
    pair_i, pair_j, alive, created, ruptured, v_b, v_max, fs, nprev
        Interaction slots (see ``sim._kernels``): bodies, existence, created / ruptured this
        step (ruptured holds the returned volume), bridge volume and V_max [m³], tangential
        spring on i [N], previous contact normal.
    force, torque_i, torque_j, f_normal, f_cap, gap
        Per-slot outputs of the last step: force on i [N], torques on i and j [N m], net normal
        force (positive repulsive) [N], the bridge's cohesive force F_cap(max(s, 0⁺)) [N] with the
        bridge volume the step's force pass saw (before liquid migration), gap [m].
    part_start, part_slots, body_start, body_slots
        CSR slot lists per particle (pair slots) and per body (all slots).
    """

    step: int
    n_sprays: int
    sprayed_total: float
    ids: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    x_ref: np.ndarray
    film: np.ndarray
    pair_i: np.ndarray
    pair_j: np.ndarray
    alive: np.ndarray
    created: np.ndarray
    ruptured: np.ndarray
    v_b: np.ndarray
    v_max: np.ndarray
    fs: np.ndarray
    nprev: np.ndarray
    force: np.ndarray
    torque_i: np.ndarray
    torque_j: np.ndarray
    f_normal: np.ndarray
    f_cap: np.ndarray
    gap: np.ndarray
    part_start: np.ndarray
    part_slots: np.ndarray
    body_start: np.ndarray
    body_slots: np.ndarray

    @property
    def n_particles(self) -> int:
        return int(self.radius.shape[0])

    def total_liquid(self) -> float:
        """Σ films (particles and walls) + Σ bridge volumes of live interactions [m³]."""
        return float(self.film.sum() + self.v_b[self.alive].sum())

    def to_arrays(self) -> dict:
        """Every field as a numpy array (counters as 0-d arrays), by name."""
        return {f.name: np.asarray(getattr(self, f.name)) for f in dataclasses.fields(self)}

    def check(self, n_walls: int) -> None:
        """Refuse (ValueError naming the field and the first offending index) a state that the
        kernels would read out of bounds or that holds a non-finite number: array shapes that do not
        agree with the particle count N, the wall count ``n_walls`` and the slot count, body
        indices outside [0, N + n_walls), CSR lists that are not monotone or point past the slots,
        NaN or infinity in a float field."""
        n = self.n_particles
        n_bodies = n + n_walls
        n_slots = int(np.shape(self.pair_i)[0]) if np.ndim(self.pair_i) else -1
        shapes = {"ids": (n,), "pos": (n, 3), "vel": (n, 3), "omega": (n, 3), "mass": (n,), "inertia": (n,),
                  "x_ref": (n, 3), "film": (n_bodies,), "part_start": (n + 1,), "body_start": (n_bodies + 1,)}
        shapes.update({name: (n_slots,) + np.shape(getattr(self, name))[1:] for name in SLOT_FIELDS})
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"state field {name} has shape {np.shape(getattr(self, name))}, expected {shape} "
                                 f"({n} particles, {n_walls} walls, {n_slots} slots)")
        for name, upper in (("pair_i", n_bodies), ("pair_j", n_bodies), ("part_slots", n_slots),
                            ("body_slots", n_slots)):
            values = np.asarray(getattr(self, name))
            bad = np.flatnonzero((values < 0) | (values >= upper))
            if bad.size:
                raise ValueError(f"state field {name}[{bad[0]}] = {values[bad[0]]} is outside [0, {upper})")
        for name, slots in (("part_start", "part_slots"), ("body_start", "body_slots")):
            start = np.asarray(getattr(self, name))
            if start[0] != 0 or (np.diff(start) < 0).any() or start[-1] != np.shape(getattr(self, slots))[0]:
                raise ValueError(f"state field {name} is not a list of slot ranges of {slots} (it must rise from 0 "
                                 f"to {np.shape(getattr(self, slots))[0]})")
        for f in dataclasses.fields(self):
            values = np.asarray(getattr(self, f.name))
            if values.dtype.kind == "f" and not np.isfinite(values).all():
                bad = [int(k) for k in np.argwhere(~np.isfinite(values))[0]]
                raise ValueError(f"state field {f.name}{list(bad)} is {values[tuple(bad)]}: not a finite number")

    @classmethod
    def from_arrays(cls, arrays) -> "State":
        """Inverse of :meth:`to_arrays`.

        Raises
        ------
        ValueError
            If a field is missing.
        """
        missing = [f.name for f in dataclasses.fields(cls) if f.name not in arrays]
        if missing:
            raise ValueError(f"state arrays missing: {', '.join(missing)}")
        values = {f.name: np.asarray(arrays[f.name]) for f in dataclasses.fields(cls)}
        for name in ("step", "n_sprays"):
            values[name] = int(values[name])
        values["sprayed_total"] = float(values["sprayed_total"])
        return cls(**values)
