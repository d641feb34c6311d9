"""Numba kernels of the neighbour lists (private): cell lists, the Verlet pair list, the slot
lists of a rebuild and the transfer of every live interaction's state into them.

Interactions live in *slots*. Slots 0 … N·W−1 are particle–wall slots (slot i·W + w joins
particle i and wall body N + w); slots N·W … are particle–particle pairs (i < j) from the
Verlet list (:mod:`sim.neighbours` drives a rebuild; the time step is in :mod:`sim._kernels`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from .state import SLOT_FIELDS

# ----------------------------------------------------------------------------- cell lists


@njit(cache=True)
def cell_index(pos, lo, cell_size, n_cells):
    """Linear cell index of every particle (positions outside the grid are clamped)."""
    n = pos.shape[0]
    out = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for d in range(3):
            k = math.floor((pos[i, d] - lo[d]) / cell_size)
            if k < 0:
                k = 0
            elif k >= n_cells[d]:
                k = n_cells[d] - 1
            c = c * n_cells[d] + k
        out[i] = c
    return out


@njit(cache=True, inline="always")
def _unravel(c, n_cells):
    cz = c % n_cells[2]
    cy = (c // n_cells[2]) % n_cells[1]
    cx = c // (n_cells[2] * n_cells[1])
    return cx, cy, cz


@njit(cache=True, parallel=True)
def _pair_pass(pos, radius, cell_of, cell_rank, cell_start, n_cells, reach, fill, start, pair_j, count):
    """For every particle i, the partners j > i within R_i + R_j + reach in the 27 cells around
    it: counted into ``count[i]``, or (``fill``) written to ``pair_j[start[i]:]`` in ascending
    order.

    ``cell_of`` holds linear cell indices. The particles must be sorted by cell, in the order
    ``cell_rank`` gives the cells (cell c holds particles ``cell_start[r]`` …
    ``cell_start[r+1] − 1``, r = ``cell_rank[c]``), so a cell is scanned from its largest index
    down to the first j <= i, which skips the half of the candidates that belongs to the other
    particle of a pair without testing each one.
    """
    n = pos.shape[0]
    for i in prange(n):
        cx, cy, cz = _unravel(cell_of[i], n_cells)
        c_n = 0
        for ax in range(max(cx - 1, 0), min(cx + 2, n_cells[0])):
            for ay in range(max(cy - 1, 0), min(cy + 2, n_cells[1])):
                for az in range(max(cz - 1, 0), min(cz + 2, n_cells[2])):
                    c = cell_rank[(ax * n_cells[1] + ay) * n_cells[2] + az]
                    for j in range(cell_start[c + 1] - 1, cell_start[c] - 1, -1):
                        if j <= i:
                            break
                        dx = pos[j, 0] - pos[i, 0]
                        dy = pos[j, 1] - pos[i, 1]
                        dz = pos[j, 2] - pos[i, 2]
                        lim = radius[i] + radius[j] + reach
                        if dx * dx + dy * dy + dz * dz < lim * lim:
                            if fill:
                                pair_j[start[i] + c_n] = j
                            c_n += 1
        if fill:
            # insertion sort in place: a particle has a handful of partners, and np.sort would
            # allocate a new array for every particle
            for a in range(start[i] + 1, start[i + 1]):
                v = pair_j[a]
                b = a - 1
                while b >= start[i] and pair_j[b] > v:
                    pair_j[b + 1] = pair_j[b]
                    b -= 1
                pair_j[b + 1] = v
        else:
            count[i] = c_n


def count_pairs(pos, radius, cell_of, cell_rank, cell_start, n_cells, reach):
    """Number of partners j > i within R_i + R_j + reach of every particle i (particles sorted by
    cell in ``cell_rank`` order, see :func:`_pair_pass`)."""
    count = np.zeros(pos.shape[0], dtype=np.int64)
    _pair_pass(pos, radius, cell_of, cell_rank, cell_start, n_cells, reach, False,
               np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), count)
    return count


def fill_pairs(pos, radius, cell_of, cell_rank, cell_start, n_cells, reach, start, pair_j):
    """Write the partners counted by :func:`count_pairs` into ``pair_j[start[i]:start[i+1]]``,
    sorted ascending per particle (so the pair keys i·N + j are globally sorted)."""
    _pair_pass(pos, radius, cell_of, cell_rank, cell_start, n_cells, reach, True, start, pair_j,
               np.zeros(1, dtype=np.int64))


#: The per-slot arrays of a state (:data:`sim.state.SLOT_FIELDS`), passed to the rebuild
#: kernels by name.
SlotArrays = namedtuple("SlotArrays", SLOT_FIELDS)


@njit(cache=True)
def first_outside(pos, lo, hi):
    """Index of the first particle outside the box [lo, hi] (per axis), or −1."""
    for i in range(pos.shape[0]):
        for d in range(3):
            if pos[i, d] < lo[d] or pos[i, d] > hi[d]:
                return i
    return -1


@njit(cache=True, parallel=True)
def permute_rows(a, order):
    """``a[order]`` for a 2-D array, in parallel over rows."""
    out = np.empty((order.shape[0], a.shape[1]), dtype=a.dtype)
    for i in prange(order.shape[0]):
        for d in range(a.shape[1]):
            out[i, d] = a[order[i], d]
    return out


@njit(cache=True, parallel=True)
def new_slot_lists(order, n_walls, start, partners, radius_cubed, v_max_coef, old, new):
    """Fill the slot arrays ``new`` after a rebuild, in parallel over particles.

    Particle i (new numbering; ``order[i]`` is its old row) owns wall slots i·W … i·W + W − 1
    and pair slots N·W + start[i] … N·W + start[i+1] − 1 with partners ``partners[start[i]:]``.
    A wall slot keeps its interaction state (alive, V_b, spring, previous normal) from the old
    row ``old``; pair slots start dead (:func:`transfer_pair_state` then carries the live pairs
    over). Every slot gets its bodies (a wall's body index is N + wall), V_max = c·min(R_i, R_j)³
    (c·R_i³ for a wall slot; ``radius_cubed`` holds R³ per particle [m³]) and zero outputs and
    event flags.
    """
    # the arrays are taken out of the tuples first: a parallel loop loses the writes made
    # through a namedtuple's attribute (numba issue 5872)
    pair_i, pair_j, alive, v_b, v_max, fs, nprev = new.pair_i, new.pair_j, new.alive, new.v_b, new.v_max, new.fs, new.nprev
    created, ruptured, f_normal, f_cap, gap = new.created, new.ruptured, new.f_normal, new.f_cap, new.gap
    force, torque_i, torque_j = new.force, new.torque_i, new.torque_j
    old_alive, old_vb, old_fs, old_nprev = old.alive, old.v_b, old.fs, old.nprev
    n = order.shape[0]
    n_wall_slots = n * n_walls
    for i in prange(n):
        old_row = order[i] * n_walls
        for w in range(n_walls):
            k = i * n_walls + w
            pair_i[k] = i
            pair_j[k] = n + w
            v_max[k] = v_max_coef * radius_cubed[i]
            alive[k] = old_alive[old_row + w]
            v_b[k] = old_vb[old_row + w]
            for d in range(3):
                fs[k, d] = old_fs[old_row + w, d]
                nprev[k, d] = old_nprev[old_row + w, d]
            _clear_slot_outputs(k, created, ruptured, force, torque_i, torque_j, f_normal, f_cap, gap)
        for q in range(start[i], start[i + 1]):
            k = n_wall_slots + q
            j = partners[q]
            pair_i[k] = i
            pair_j[k] = j
            v_max[k] = v_max_coef * min(radius_cubed[i], radius_cubed[j])
            alive[k] = False
            v_b[k] = 0.0
            for d in range(3):
                fs[k, d] = 0.0
                nprev[k, d] = 0.0
            _clear_slot_outputs(k, created, ruptured, force, torque_i, torque_j, f_normal, f_cap, gap)


@njit(cache=True, inline="always")
def _clear_slot_outputs(k, created, ruptured, force, torque_i, torque_j, f_normal, f_cap, gap):
    created[k] = False
    ruptured[k] = 0.0
    _clear_output(k, force, torque_i, torque_j, f_normal, f_cap, gap)


@njit(cache=True, parallel=True)
def transfer_pair_state(new_index, n_wall_slots, start, partners, old, new):
    """Copy the state of every alive old pair slot to the same pair in the new list, in
    parallel (a pair is listed once, so no two old slots write the same new one).

    ``new_index[r]``: the new index of the particle in old row r. The new pair (i, j), i < j,
    is found among particle i's partners ``partners[start[i]:start[i+1]]`` (ascending). The
    new list orders every pair with i < j, so a pair whose particles swapped order in the
    renumbering changes orientation: its normal points the other way, and the spring, the
    tangential force on the slot's first body, now acts on the other body. Both are negated
    for such a pair.

    Returns the number of alive old pairs missing from the new list (must be 0).
    """
    old_i, old_j, old_alive, old_vb, old_fs, old_nprev = old.pair_i, old.pair_j, old.alive, old.v_b, old.fs, old.nprev
    new_alive, new_vb, new_fs, new_nprev = new.alive, new.v_b, new.fs, new.nprev  # (see new_slot_lists)
    missing = 0
    for k in prange(n_wall_slots, old_i.shape[0]):
        if old_alive[k]:
            a = new_index[old_i[k]]
            b = new_index[old_j[k]]
            first, second = min(a, b), max(a, b)
            q = start[first] + np.searchsorted(partners[start[first]:start[first + 1]], second)
            if q >= start[first + 1] or partners[q] != second:
                missing += 1
            else:
                sign = -1.0 if a > b else 1.0  # the pair's order flipped: re-orient it
                slot = n_wall_slots + q
                new_alive[slot] = True
                new_vb[slot] = old_vb[k]
                for d in range(3):
                    new_fs[slot, d] = sign * old_fs[k, d]
                    new_nprev[slot, d] = sign * old_nprev[k, d]
    return missing


@njit(cache=True, parallel=True)
def build_csr(n_walls, start, partners):
    """Slot lists per particle (pair slots only, for force gathering) and per body (particles
    then walls, all slots, for liquid migration), each in ascending slot order, for the slot
    layout of :func:`new_slot_lists`.

    In ascending slot order a particle b's pair slots are those where b is the second body
    (their first body is smaller, so they lie in earlier particles' runs), then its own run
    N·W + start[b] …; its body list puts its W wall slots b·W … first. Wall w's list is the
    slots i·W + w of every particle i. Only the transposition (which particles list b as a
    partner) is sequential.
    """
    n = start.shape[0] - 1
    n_wall_slots = n * n_walls
    as_second = np.zeros(n, dtype=np.int64)
    for q in range(partners.shape[0]):
        as_second[partners[q]] += 1
    part_start = np.zeros(n + 1, dtype=np.int64)
    for b in range(n):
        part_start[b + 1] = part_start[b] + as_second[b] + start[b + 1] - start[b]
    part_slots = np.empty(part_start[n], dtype=np.int64)
    fill = part_start[:-1].copy()
    for i in range(n):  # ascending i: each particle's "as second" slots come out ascending
        for q in range(start[i], start[i + 1]):
            j = partners[q]
            part_slots[fill[j]] = n_wall_slots + q
            fill[j] += 1
    body_start = np.empty(n + n_walls + 1, dtype=np.int64)
    for b in range(n + 1):
        body_start[b] = part_start[b] + n_walls * b
    for w in range(n_walls):
        body_start[n + w + 1] = body_start[n + w] + n
    body_slots = np.empty(body_start[-1], dtype=np.int64)
    for b in prange(n):
        own = part_start[b] + as_second[b]
        for q in range(start[b], start[b + 1]):
            part_slots[own + q - start[b]] = n_wall_slots + q
        for w in range(n_walls):
            body_slots[body_start[b] + w] = b * n_walls + w
        for m in range(part_start[b], part_start[b + 1]):
            body_slots[body_start[b] + n_walls + m - part_start[b]] = part_slots[m]
    for w in prange(n_walls):
        for i in range(n):
            body_slots[body_start[n + w] + i] = i * n_walls + w
    return part_start, part_slots, body_start, body_slots


@njit(cache=True)
def _clear_output(k, force, torque_i, torque_j, f_normal, f_cap, gap):
    for d in range(3):
        force[k, d] = 0.0
        torque_i[k, d] = 0.0
        torque_j[k, d] = 0.0
    f_normal[k] = 0.0
    f_cap[k] = 0.0
    gap[k] = 0.0
