"""Liquid bookkeeping (docs/physics.md, "Liquid bridges", "Spraying", "Liquid migration"): liquid
migration between films and bridges (Mani, Kadau & Herrmann 2013, as YADE's ``LiqControl``),
spraying, and the total liquid volume.

Bodies are the particles 0 … N−1 followed by the walls N … N+W−1; every body has a film volume
(a wall's starts at 0 and only ever holds what ruptured wall bridges return to it). Interactions
live in slots k = 0 … C−1 joining bodies ``pair_i[k] < pair_j[k]``. All volumes are in [m³].

Everything that moves liquid is sequential with a fixed order, so results are bit-reproducible
for any thread count. No volume is created or destroyed: Σ film + Σ V_b (live slots) after
:func:`migrate_liquid` equals the same sum before it plus the volume returned by this step's
ruptures, up to floating-point rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["migrate_liquid", "migrate_events", "fill_new_bridges", "spray", "total_liquid"]


@njit(cache=True)
def _count_in_sorted(a, x):
    """Number of occurrences of ``x`` in the ascending int64 array ``a`` (binary search)."""
    lo, hi = 0, a.shape[0]
    while lo < hi:  # first index with a[idx] >= x
        mid = (lo + hi) >> 1
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    first = lo
    hi = a.shape[0]
    while lo < hi:  # first index with a[idx] > x
        mid = (lo + hi) >> 1
        if a[mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo - first


@njit(cache=True)
def migrate_liquid(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured_volume,
                   body_start, body_slots, v_min, body_key):
    """One step of liquid migration (docs/physics.md, "Liquid migration"), in place; call once per
    step after the forces.

    1. Each slot with ``ruptured_volume[k] > 0`` returns half of it to each of its two bodies'
       films (ascending slot order); those bodies are *marked*.
    2. Each created slot gets V_b = a_i + a_j, where body b offers a_b = (film_b − v_min)/n_new(b)
       (0 if film_b ≤ v_min), n_new(b) = number of slots created this step that involve b, with
       films read after step 1 and before any withdrawal. If a_i + a_j > v_max[k] both shares are
       scaled by v_max[k]/(a_i + a_j). The shares are withdrawn after all created slots are
       processed (a film never drops below v_min through rounding).
    3. Each marked body b, in ascending ``body_key`` (the particle id, as YADE orders bodies;
       rows are reordered spatially by the simulator), with A = film_b − v_min > 0, shares A with its
       alive slots having v_b < v_max (and v_max > 0): with D = Σ(v_max − v_b) over them, if
       D > A each gets (v_max − v_b)·A/D and film_b = v_min; otherwise each is filled to v_max
       and film_b loses D.

    Parameters
    ----------
    film : (B,) float64
        Film volume of every body [m³]; modified.
    pair_i, pair_j : (C,) int64
        Bodies of each slot, pair_i < pair_j (a wall pair has the wall as pair_j).
    v_b : (C,) float64
        Bridge volume of each slot [m³]; modified (created slots are assigned their volume,
        refilled ones grow).
    v_max : (C,) float64
        Maximum bridge volume 0.03·min(R_i, R_j)³ of each slot [m³] (wall pair: particle radius).
    alive : (C,) bool
        Interaction exists after this step's force pass (created: True; ruptured: False).
    created : (C,) bool
        Interaction created (first touch) this step. Read only.
    ruptured_volume : (C,) float64
        V_b of each bridge ruptured this step [m³], 0 elsewhere; the caller has already set
        alive False and v_b 0 for those slots. Read only. A slot must not be both ruptured and
        created in the same step (its pair would be unknown). A dry bridge (V_b = 0) that
        ruptures marks nothing ("Liquid migration": "every particle that received liquid"; YADE would mark
        its bodies too, which only matters for a body holding film and an under-filled bridge).
    body_start : (B+1,) int64
    body_slots : (M,) int64
        CSR slot lists: the slots of body b are body_slots[body_start[b]:body_start[b+1]] in a
        fixed order; dead slots may appear (skipped). Must list every alive slot of the body,
        including those created this step. Only used in step 3.
    v_min : float
        Minimum film volume V_min [m³] (0: YADE's default).

    Notes
    -----
    This scans all C slots for the events; the simulator's step calls :func:`migrate_events`
    with the few blocks of slots in which its force passes counted events instead.
    """
    every_slot = np.array([0, pair_i.shape[0]], dtype=np.int64)
    migrate_events(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured_volume, body_start, body_slots,
                   v_min, body_key, every_slot[:1], every_slot[1:])


@njit(cache=True)
def fill_new_bridges(v_b, created, volume, wall_volume, n_wall_slots, range_lo, range_hi):
    """The fixed-bridge-volume liquid model (YADE's ``ViscElCapMat`` without ``LiqControl``): every
    pair slot created this step gets the bridge volume ``volume`` [m³], every wall slot (the first
    ``n_wall_slots``) ``wall_volume`` (``volume``, or 0 for dry walls); films are not touched and a
    ruptured bridge's volume is not returned anywhere (the volume is a constant of the material,
    not a conserved liquid). Slots as in :func:`migrate_events`: the created ones lie in the
    ranges [range_lo[r], range_hi[r])."""
    for r in range(range_lo.shape[0]):
        for k in range(range_lo[r], range_hi[r]):
            if created[k]:
                v_b[k] = wall_volume if k < n_wall_slots else volume


@njit(cache=True)
def migrate_events(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured_volume, body_start, body_slots,
                   v_min, body_key, range_lo, range_hi):
    """:func:`migrate_liquid` given where the step's events are: every created or ruptured slot
    lies in one of the slot ranges [range_lo[r], range_hi[r]), which are disjoint and ascending
    (they may hold slots without events). Other arguments as :func:`migrate_liquid`.

    Scratch: arrays sized by this step's ruptures and creations.
    """
    n_rup = 0
    n_new = 0
    for r in range(range_lo.shape[0]):
        for k in range(range_lo[r], range_hi[r]):
            if ruptured_volume[k] > 0.0:
                n_rup += 1
            if created[k]:
                n_new += 1
    if n_rup == 0 and n_new == 0:
        return

    # ---- step 1: ruptures return V_b/2 to each body; collect the slots and marked bodies
    marked = np.empty(2 * n_rup, dtype=np.int64)
    new_slots = np.empty(n_new, dtype=np.int64)
    new_ends = np.empty(2 * n_new, dtype=np.int64)
    q = 0
    p = 0
    for r in range(range_lo.shape[0]):
        for k in range(range_lo[r], range_hi[r]):
            vr = ruptured_volume[k]
            if vr > 0.0:
                i = pair_i[k]
                j = pair_j[k]
                half = 0.5 * vr
                film[i] += half
                film[j] += half
                marked[2 * q] = i
                marked[2 * q + 1] = j
                q += 1
            if created[k]:
                new_slots[p] = k
                new_ends[2 * p] = pair_i[k]
                new_ends[2 * p + 1] = pair_j[k]
                p += 1

    # ---- step 2: new bridges take shares of the films (read before any withdrawal)
    if n_new > 0:
        new_ends.sort()
        share_i = np.empty(n_new, dtype=np.float64)
        share_j = np.empty(n_new, dtype=np.float64)
        for p in range(n_new):
            k = new_slots[p]
            i = pair_i[k]
            j = pair_j[k]
            a_i = 0.0
            a_j = 0.0
            if film[i] > v_min:
                a_i = (film[i] - v_min) / _count_in_sorted(new_ends, i)
            if film[j] > v_min:
                a_j = (film[j] - v_min) / _count_in_sorted(new_ends, j)
            vol = a_i + a_j
            if vol > v_max[k]:
                f = v_max[k] / vol
                a_i *= f
                a_j *= f
                vol = a_i + a_j
            v_b[k] = vol
            share_i[p] = a_i
            share_j[p] = a_j
        for p in range(n_new):
            k = new_slots[p]
            if share_i[p] > 0.0:
                i = pair_i[k]
                film[i] -= share_i[p]
                if film[i] < v_min:  # rounding only: the shares sum to at most film − v_min
                    film[i] = v_min
            if share_j[p] > 0.0:
                j = pair_j[k]
                film[j] -= share_j[p]
                if film[j] < v_min:
                    film[j] = v_min

    # ---- step 3: marked bodies (ascending) refill their under-filled live bridges
    if n_rup > 0:
        marked = marked[np.argsort(body_key[marked], kind="mergesort")]
        prev = -1
        for q in range(marked.shape[0]):
            b = marked[q]
            if b == prev:
                continue
            prev = b
            if film[b] <= v_min:
                continue
            avail = film[b] - v_min
            deficit = 0.0
            n_open = 0
            for s in range(body_start[b], body_start[b + 1]):
                k = body_slots[s]
                if alive[k] and v_max[k] > 0.0 and v_b[k] < v_max[k]:
                    deficit += v_max[k] - v_b[k]
                    n_open += 1
            if n_open == 0:
                continue
            if deficit > avail:
                fill = avail / deficit
                film[b] = v_min
                for s in range(body_start[b], body_start[b + 1]):
                    k = body_slots[s]
                    if alive[k] and v_max[k] > 0.0 and v_b[k] < v_max[k]:
                        v_b[k] += (v_max[k] - v_b[k]) * fill
            else:
                film[b] -= deficit
                for s in range(body_start[b], body_start[b + 1]):
                    k = body_slots[s]
                    if alive[k] and v_max[k] > 0.0 and v_b[k] < v_max[k]:
                        v_b[k] = v_max[k]


@njit(cache=True)
def spray(film, position, radius, n_particles, r_spray, dose_fraction):
    """Spray once (docs/physics.md, "Spraying"): each particle i < n_particles whose centre lies in the spray
    cylinder, √(x² + y²) < r_spray (drum axis along z), gets film_i += dose_fraction·(4/3)πR_i³.

    Parameters
    ----------
    film : (B,) float64
        Film volumes [m³]; entries 0 … n_particles−1 may be modified.
    position : (≥n_particles, 3) float64
        Particle centres [m].
    radius : (≥n_particles,) float64
        Particle radii [m].
    n_particles : int
    r_spray : float
        Spray-zone radius [m].
    dose_fraction : float
        Dose as a fraction of the particle's own volume (0.01 in the study).

    Returns
    -------
    float
        Total volume added [m³].
    """
    total = 0.0
    c = dose_fraction * (4.0 / 3.0) * math.pi
    for i in range(n_particles):
        x = position[i, 0]
        y = position[i, 1]
        if math.sqrt(x * x + y * y) < r_spray:
            r = radius[i]
            dv = c * r * r * r
            film[i] += dv
            total += dv
    return total


def total_liquid(film, v_b, alive):
    """Σ film + Σ v_b over alive slots [m³] (conservation checks).

    Parameters
    ----------
    film : (B,) float64
        Film volumes [m³].
    v_b : (C,) float64
        Bridge volumes [m³].
    alive : (C,) bool
        Live slots.

    Returns
    -------
    float
    """
    film = np.asarray(film, dtype=np.float64)
    v_b = np.asarray(v_b, dtype=np.float64)
    return float(film.sum() + v_b[np.asarray(alive, dtype=bool)].sum())
