"""Cell lists and Verlet lists: rebuild the interaction slots of a :class:`~sim.state.State`.

A rebuild sorts the particles by cell (so neighbours are close in memory), lists every pair
closer than R_i + R_j + reach (reach = the largest possible bridge rupture distance + the
skin), carries the state of every live interaction over to the new list, and rebuilds the slot
lists. Pair lists are counted first and then filled into exactly sized arrays, so they can
never overflow.
"""

from __future__ import annotations


import numpy as np

from . import _kernels
from .state import PARTICLE_FIELDS, State

__all__ = ["max_rupture_distance", "rebuild", "empty_slots"]


def max_rupture_distance(params) -> float:
    """Upper bound of the rupture distance of any bridge [m]: s_crit at V_b = V_max.

    With V_max = c·min(R_i, R_j)³ and R_eff ≥ min(R_i, R_j):
    s_crit ≤ (1 + θ/2)(c^(1/3) + 0.1·c^(2/3))·R_max, raised by 0.1 % against rounding.
    """
    c = params.v_max_coef
    return 1.001 * (1 + params.contact_angle / 2) * (c ** (1 / 3) + 0.1 * c ** (2 / 3)) * params.r_max


def _grid(params):
    reach = max_rupture_distance(params) + params.skin
    cell = 2 * params.r_max + reach
    lo = np.array([-params.drum_radius, -params.drum_radius, 0.0])
    extent = np.array([2 * params.drum_radius, 2 * params.drum_radius, params.drum_length])
    n_cells = np.maximum(1, np.floor(extent / cell)).astype(np.int64)
    return reach, cell, lo, n_cells


def _zero_outputs(s):
    """The per-step outputs and event flags of ``s`` slots, zero (as a dead slot has them)."""
    out = {name: np.zeros(s) for name in ("ruptured", "f_normal", "f_cap", "gap")}
    out.update({name: np.zeros((s, 3)) for name in ("force", "torque_i", "torque_j")})
    out["created"] = np.zeros(s, dtype=np.bool_)
    return out


def empty_slots(n_particles, n_walls, n_pairs):
    """Slot arrays for N·W wall slots and ``n_pairs`` pair slots, all dead."""
    s = n_particles * n_walls + n_pairs
    out = _zero_outputs(s)
    out.update({name: np.zeros(s) for name in ("v_b", "v_max")})
    out.update({name: np.zeros((s, 3)) for name in ("fs", "nprev")})
    out["alive"] = np.zeros(s, dtype=np.bool_)
    out["pair_i"] = np.empty(s, dtype=np.int64)
    out["pair_j"] = np.empty(s, dtype=np.int64)
    out["pair_i"][: n_particles * n_walls] = np.repeat(np.arange(n_particles), n_walls)
    out["pair_j"][: n_particles * n_walls] = n_particles + np.tile(np.arange(n_walls), n_particles)
    return out


def rebuild(state: State, params, n_walls: int) -> State:
    """Reorder particles by cell, rebuild the pair list, carry live interactions over.

    Raises
    ------
    RuntimeError
        If a live interaction is not in the new list (the skin did not cover the motion), or a
        particle has left the drum's bounding box.
    """
    n = state.n_particles
    reach, cell, lo, n_cells = _grid(params)
    hi = lo + np.array([2 * params.drum_radius, 2 * params.drum_radius, params.drum_length])
    outside = np.flatnonzero(((state.pos < lo - params.r_max) | (state.pos > hi + params.r_max)).any(axis=1))
    if outside.size:
        i = outside[0]
        raise RuntimeError(f"particle id {state.ids[i]} left the drum at step {state.step}: position {state.pos[i].tolist()} m")
    order, _ = _kernels.counting_sort(_kernels.cell_index(state.pos, lo, cell, n_cells), int(np.prod(n_cells)))
    new_index = np.empty(n, dtype=np.int64)
    new_index[order] = np.arange(n)

    for name in PARTICLE_FIELDS:
        setattr(state, name, np.ascontiguousarray(getattr(state, name)[order]))
    state.film = np.concatenate([state.film[:n][order], state.film[n:]])

    n_wall_slots = n * n_walls

    # new pair list
    cell_of = _kernels.cell_index(state.pos, lo, cell, n_cells)
    members, cell_start = _kernels.counting_sort(cell_of, int(np.prod(n_cells)))
    count = _kernels.count_pairs(state.pos, state.radius, cell_of, cell_start, members, n_cells, reach)
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(count, out=start[1:])
    partners = np.empty(start[-1], dtype=np.int64)
    _kernels.fill_pairs(state.pos, state.radius, cell_of, cell_start, members, n_cells, reach, start, partners)
    pair_i, pair_j, alive, v_b, fs, nprev, r_min = _kernels.new_slot_lists(
        order, n_walls, start, partners, state.radius, state.alive, state.v_b, state.fs, state.nprev)

    # carry live particle pairs over, by key i·N + j in the new numbering (re-oriented where
    # the renumbering swapped the pair's order)
    new_key = pair_i[n_wall_slots:] * n + pair_j[n_wall_slots:]
    pairs = slice(n_wall_slots, None)  # the pair slots, in the old arrays and in the new
    missing = _kernels.transfer_pair_state(
        n, new_index[state.pair_i[pairs]], new_index[state.pair_j[pairs]], state.alive[pairs], state.v_b[pairs],
        state.fs[pairs], state.nprev[pairs], new_key, alive[pairs], v_b[pairs], fs[pairs], nprev[pairs],
    )
    if missing:
        raise RuntimeError(f"{missing} live interactions fell outside the Verlet list at step {state.step}; increase the skin")

    slots = _zero_outputs(pair_i.size)
    slots.update(pair_i=pair_i, pair_j=pair_j, alive=alive, v_b=v_b, fs=fs, nprev=nprev,
                 v_max=params.v_max_coef * r_min**3)
    for name, value in slots.items():
        setattr(state, name, value)
    state.part_start, state.part_slots, state.body_start, state.body_slots = _kernels.build_csr(
        n, n_walls, state.pair_i, state.pair_j, n_wall_slots)
    state.x_ref = state.pos.copy()
    return state


def pair_count_reference(pos, radius, reach):
    """All pairs closer than R_i + R_j + reach by brute force, O(N²) (for tests)."""
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    lim = radius[:, None] + radius[None, :] + reach
    i, j = np.nonzero(np.triu(d < lim, k=1))
    return set(zip(i.tolist(), j.tolist()))


