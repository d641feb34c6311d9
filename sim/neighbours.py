"""Cell lists and Verlet lists: rebuild the interaction slots of a :class:`~sim.state.State`.

A rebuild sorts the particles by cell, the cells in Morton (Z-curve) order (so that particles
close in space are close in memory, as LAMMPS' ``atom_modify sort``), lists every pair
closer than R_i + R_j + reach (reach = the largest possible bridge rupture distance + the
skin), carries the state of every live interaction over to the new list, and rebuilds the slot
lists. Pair lists are counted first and then filled into exactly sized arrays, so they can
never overflow.
"""

from __future__ import annotations

import functools

import numpy as np

from granalytics.base.sorting import counting_sort

from . import _neighbour_kernels as _kernels
from .state import PARTICLE_FIELDS, SLOT_FIELDS, State

__all__ = ["max_rupture_distance", "rebuild", "empty_slots", "morton_rank"]


def max_rupture_distance(params) -> float:
    """Upper bound of the rupture distance of any bridge [m]: s_crit at V_b = V_max.

    With V_max = c·min(R_i, R_j)³ and R_eff ≥ min(R_i, R_j):
    s_crit ≤ (1 + θ/2)(c^(1/3) + 0.1·c^(2/3))·R_max, raised by 0.1 % against rounding. With a
    fixed bridge volume V_b (``params.bridge_volume > 0``) and R_eff ≥ R_min, the smallest radius:
    s_crit ≤ (1 + θ/2)(V_b^(1/3) + 0.1·V_b^(2/3)/R_min), raised likewise.
    """
    if params.bridge_volume > 0:
        v, r_min = params.bridge_volume, params.r_mean * (1 - params.d_spread)
        return 1.001 * (1 + params.contact_angle / 2) * (v ** (1 / 3) + 0.1 * v ** (2 / 3) / r_min)
    c = params.v_max_coef
    return 1.001 * (1 + params.contact_angle / 2) * (c ** (1 / 3) + 0.1 * c ** (2 / 3)) * params.r_max


def _grid(params):
    reach = max_rupture_distance(params) + params.skin
    cell = 2 * params.r_max + reach
    lo = np.array([-params.drum_radius, -params.drum_radius, 0.0])
    extent = np.array([2 * params.drum_radius, 2 * params.drum_radius, params.drum_length])
    n_cells = np.maximum(1, np.floor(extent / cell)).astype(np.int64)
    return reach, cell, lo, n_cells


@functools.lru_cache(maxsize=8)
def morton_rank(n_cells: tuple[int, int, int]) -> np.ndarray:
    """Position of every cell in Morton (Z-curve) order, indexed by its linear index
    (cx·n_y + cy)·n_z + cz.

    The Morton key interleaves the bits of (cx, cy, cz), most significant first: cells that are
    close in space get close keys, so that in key order a cell's 26 neighbours lie mostly within
    a few cells' distance instead of n_y·n_z cells away (the row order's neighbours across x).
    Keys are unique, so the order has no ties: it is a permutation of the cells, the same on
    every machine (read-only, cached per grid).

    Parameters
    ----------
    n_cells : tuple of 3 ints
        Cells along x, y and z.
    """
    bits = max(1, int(max(n_cells) - 1).bit_length())
    coords = [c.ravel().astype(np.int64) for c in np.indices(n_cells)]
    key = np.zeros(coords[0].shape, dtype=np.int64)
    for b in range(bits - 1, -1, -1):
        for c in coords:
            key = (key << 1) | ((c >> b) & 1)
    rank = np.empty_like(key)
    rank[np.argsort(key, kind="stable")] = np.arange(key.size)
    rank.flags.writeable = False
    return rank


def empty_slots(n_particles, n_walls, n_pairs):
    """Slot arrays for N·W wall slots and ``n_pairs`` pair slots, all dead, with zero outputs."""
    s = n_particles * n_walls + n_pairs
    out = {name: np.zeros(s) for name in ("ruptured", "v_b", "v_max", "f_normal", "f_cap", "gap")}
    out.update({name: np.zeros((s, 3)) for name in ("fs", "nprev", "force", "torque_i", "torque_j")})
    out.update(alive=np.zeros(s, dtype=np.bool_), created=np.zeros(s, dtype=np.bool_))
    out["pair_i"] = np.empty(s, dtype=np.int64)
    out["pair_j"] = np.empty(s, dtype=np.int64)
    out["pair_i"][: n_particles * n_walls] = np.repeat(np.arange(n_particles), n_walls)
    out["pair_j"][: n_particles * n_walls] = n_particles + np.tile(np.arange(n_walls), n_particles)
    return out


def _permuted(a, order):
    """``a[order]`` (rows), computed in parallel."""
    return _kernels.permute_rows(a.reshape(a.shape[0], -1), order).reshape((order.shape[0],) + a.shape[1:])


def rebuild(state: State, params, n_walls: int) -> State:
    """Reorder particles by cell, rebuild the pair list, carry live interactions over.

    Particles are sorted by the Morton rank of their cell (:func:`morton_rank`), stably, so
    that the particles of a cell keep their previous relative order: the new order depends only
    on the positions and the previous order, never on the thread count.

    Everything proportional to the number of particles or slots runs in compiled code, in
    parallel except the counting sorts (the cell sort and the partner transposition in
    :func:`sim._neighbour_kernels.build_csr`).

    Raises
    ------
    RuntimeError
        If a live interaction is not in the new list (the skin did not cover the motion), or a
        particle has left the drum's bounding box.
    """
    n = state.n_particles
    reach, cell, lo, n_cells = _grid(params)
    hi = lo + np.array([2 * params.drum_radius, 2 * params.drum_radius, params.drum_length])
    i = _kernels.first_outside(state.pos, lo - params.r_max, hi + params.r_max)
    if i >= 0:
        raise RuntimeError(f"particle id {state.ids[i]} left the drum at step {state.step}: position {state.pos[i].tolist()} m")
    cell_of = _kernels.cell_index(state.pos, lo, cell, n_cells)
    rank = morton_rank(tuple(int(c) for c in n_cells))
    order, cell_start = counting_sort(rank[cell_of], rank.size)
    new_index = np.empty(n, dtype=np.int64)
    new_index[order] = np.arange(n)

    for name in PARTICLE_FIELDS:
        if name != "x_ref":  # reset to the new positions below
            setattr(state, name, _permuted(getattr(state, name), order))
    state.film = np.concatenate([_permuted(state.film[:n], order), state.film[n:]])

    # new pair list; the particles are now in cell order, so each cell's particles are a run
    # (cell c's run starts at cell_start[rank[c]])
    cell_of = _permuted(cell_of, order)
    count = _kernels.count_pairs(state.pos, state.radius, cell_of, rank, cell_start, n_cells, reach)
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(count, out=start[1:])
    partners = np.empty(start[-1], dtype=np.int64)
    _kernels.fill_pairs(state.pos, state.radius, cell_of, rank, cell_start, n_cells, reach, start, partners)

    old = _kernels.SlotArrays(*(getattr(state, name) for name in SLOT_FIELDS))
    n_slots = n * n_walls + partners.size
    new = _kernels.SlotArrays(*(np.empty((n_slots,) + a.shape[1:], dtype=a.dtype) for a in old))
    _kernels.new_slot_lists(order, n_walls, start, partners, state.radius**3, params.v_max_coef, old, new)
    # carry live particle pairs over (re-oriented where the renumbering swapped the pair's order)
    missing = _kernels.transfer_pair_state(new_index, n * n_walls, start, partners, old, new)
    if missing:
        raise RuntimeError(f"{missing} live interactions fell outside the Verlet list at step {state.step}; increase the skin")
    for name, value in zip(SLOT_FIELDS, new):
        setattr(state, name, value)
    state.part_start, state.part_slots, state.body_start, state.body_slots = _kernels.build_csr(n_walls, start, partners)
    state.x_ref = state.pos.copy()
    return state


def pair_count_reference(pos, radius, reach):
    """All pairs closer than R_i + R_j + reach by brute force, O(N²) (for tests)."""
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    lim = radius[:, None] + radius[None, :] + reach
    i, j = np.nonzero(np.triu(d < lim, k=1))
    return set(zip(i.tolist(), j.tolist()))


