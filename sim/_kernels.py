"""Numba kernels of the time step (private); the neighbour lists' kernels are in :mod:`sim._neighbour_kernels`.

Interactions live in *slots*. Slots 0 … N·W−1 are particle–wall slots (slot i·W + w joins
particle i and wall body N + w); slots N·W … are particle–particle pairs (i < j) from the
Verlet list. Every slot carries its own state (alive, bridge volume, tangential spring,
previous normal), so the per-slot force loop is race-free; per-particle sums then gather the
slots of each particle in a fixed order. Results are therefore bit-identical for any thread
count.

Importing this module changes no global state; the threading set-up the simulator wants is
:func:`sim.threads.configure_threading`, applied by the command-line programs only (``python -m sim
run``, a sweep's point runner), never by :class:`sim.run.Simulation`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, prange

from .capillary import (
    BRIDGE_CONSTANTS,
    bridge_constants,
    bridge_force_from_constants,
    effective_radius,
    viscous_force,
)
from .contact import CONTACT_LAWS, contact_force, law_constants, rotate_spring
from .drum import baffle_directions, facet_reach, wall_contact
from .liquid import fill_new_bridges, migrate_events, spray
from ._neighbour_kernels import _clear_output

# ----------------------------------------------------------------------------- time steps

#: The float/int/bool parameters of the time-step kernels, passed by name (never by position:
#: two swapped floats would run silently with wrong physics). Built only by :func:`kernel_params`.
KernelParams = namedtuple("KernelParams", [
    "dt",  # time step [s]
    "n_walls", "drum_radius", "drum_length", "n_baffles", "baffle_height", "cylinder_facets", "drum_omega",
    "gx", "gy", "gz",  # gravity [m/s²] (three scalars: a parallel loop cannot take a tuple inside a named tuple)
    "law", "law_constants",  # contact law: its kernel id and constants (sim.contact.law_constants; docs/physics.md, "Contact law")
    # the registered laws' ids (0, 1, …), never read: its type is part of every kernel's compiled signature, so that
    # numba's cache, which does not see changes in other files, compiles afresh when a law is added or removed
    "registered_laws",
    "gamma", "eta", "theta", "model", "viscous", "capillary_in_contact",  # "Liquid bridges", "Capillary models"
    "v_min",  # "Liquid migration"
    "bridge_volume",  # the fixed-bridge-volume model's V_b [m³] (0: films, spray and migration)
    "wall_bridges",  # whether that model's wall contacts get V_b too (else they stay dry)
    "spray_interval", "spray_dose", "spray_radius",  # "Spraying"
    "half_skin",  # half the Verlet skin [m]: rebuild trigger
])

#: The arrays the time-step kernels read and write (views of a :class:`~sim.state.State`),
#: passed by name. Built only by :func:`kernel_arrays`.
KernelArrays = namedtuple("KernelArrays", [
    "pos", "vel", "omega", "radius", "mass", "inertia", "film", "x_ref",
    "pair_i", "pair_j", "alive", "created", "ruptured", "v_b", "v_max", "fs", "nprev",
    "force", "torque_i", "torque_j", "f_normal", "f_cap", "gap",
    "part_start", "part_slots", "body_start", "body_slots", "body_key",
    "bridge_table",  # (C, len(BRIDGE_CONSTANTS)) per-slot bridge constants, a cache keyed by v_b (not state)
])


def kernel_params(params, n_walls: int) -> KernelParams:
    """The kernel parameters of a :class:`~sim.params.SimParams`, converted to fixed types
    (float, int, bool) so that the kernels compile once."""
    from .capillary import CAPILLARY_MODELS

    p = params
    law_id, constants = law_constants(p)
    return KernelParams(
        dt=float(p.dt), n_walls=int(n_walls), drum_radius=float(p.drum_radius), drum_length=float(p.drum_length),
        n_baffles=int(p.n_baffles), baffle_height=float(p.baffle_height),
        cylinder_facets=int(p.cylinder_facets), drum_omega=float(p.drum_omega),
        gx=float(p.gravity[0]), gy=float(p.gravity[1]), gz=float(p.gravity[2]),
        law=law_id, law_constants=constants, registered_laws=tuple(range(len(CONTACT_LAWS))),
        gamma=float(p.surface_tension), eta=float(p.viscosity), theta=float(p.contact_angle),
        model=int(CAPILLARY_MODELS[p.capillary_model]), viscous=bool(p.viscous),
        capillary_in_contact=bool(p.capillary_in_contact), v_min=float(p.v_min), bridge_volume=float(p.bridge_volume),
        wall_bridges=bool(p.wall_bridges),
        spray_interval=float(p.spray_interval), spray_dose=float(p.spray_dose), spray_radius=float(p.spray_radius),
        half_skin=float(p.skin / 2),
    )


def new_bridge_table(n_slots: int) -> np.ndarray:
    """An empty per-slot cache of bridge constants (:func:`sim.capillary.bridge_constants`):
    every row's key (column 0, the volume it was computed for) is 0, which no live bridge has,
    so each row is filled the first time its slot holds a bridge. Valid for one slot list only
    (a rebuild renumbers the slots)."""
    return np.zeros((n_slots, len(BRIDGE_CONSTANTS)))


def kernel_arrays(state, body_key, bridge_table=None) -> KernelArrays:
    """The arrays of ``state`` for the kernels (no copies); ``body_key`` orders bodies in
    liquid migration (particle ids, then the walls); ``bridge_table`` is the cache of
    :func:`new_bridge_table` for the state's current slot list (default: a new, empty one)."""
    s = state
    if bridge_table is None:
        bridge_table = new_bridge_table(s.pair_i.shape[0])
    return KernelArrays(
        pos=s.pos, vel=s.vel, omega=s.omega, radius=s.radius, mass=s.mass, inertia=s.inertia, film=s.film,
        x_ref=s.x_ref, pair_i=s.pair_i, pair_j=s.pair_j, alive=s.alive, created=s.created, ruptured=s.ruptured,
        v_b=s.v_b, v_max=s.v_max, fs=s.fs, nprev=s.nprev, force=s.force, torque_i=s.torque_i,
        torque_j=s.torque_j, f_normal=s.f_normal, f_cap=s.f_cap, gap=s.gap, part_start=s.part_start,
        part_slots=s.part_slots, body_start=s.body_start, body_slots=s.body_slots, body_key=body_key,
        bridge_table=bridge_table,
    )


@njit(cache=True, parallel=True)
def advance(n_steps, step0, settling, n_sprays, kernel_params, arrays):
    """Advance up to ``n_steps`` leapfrog steps from step number ``step0`` (t = step·Δt).

    ``kernel_params`` is a :class:`KernelParams`, ``arrays`` a :class:`KernelArrays` (modified in place);
    ``n_sprays`` is the number of sprays done before ``step0``.

    Per step: wall and pair slot forces (parallel over blocks of slots) → liquid migration
    (sequential, over the blocks in which the force passes counted events) → gather and
    integrate (parallel over particles) → spray when t crosses the next spray time. Stops early,
    before a step, when a particle has moved more than half the Verlet skin since the last
    rebuild (the caller then rebuilds the lists and calls again). With ``settling`` the drum is at rest (Ω = 0, angle 0) and nothing is sprayed.
    With ``kernel_params.bridge_volume > 0`` (the fixed-bridge-volume model) every new bridge gets that
    volume instead of migrating liquid (none while settling), and nothing is sprayed.

    Returns
    -------
    steps_done : int
    n_sprays : int
        Sprays done so far (updated).
    sprayed : float
        Liquid volume added by sprays in this call [m³].
    """
    pos = arrays.pos
    radius = arrays.radius
    film = arrays.film
    x_ref = arrays.x_ref
    pair_i = arrays.pair_i
    pair_j = arrays.pair_j
    alive = arrays.alive
    created = arrays.created
    ruptured = arrays.ruptured
    v_b = arrays.v_b
    v_max = arrays.v_max
    body_start = arrays.body_start
    body_slots = arrays.body_slots
    body_key = arrays.body_key
    dt = kernel_params.dt
    n_walls = kernel_params.n_walls
    n_baffles = kernel_params.n_baffles
    v_min = kernel_params.v_min
    spray_interval = kernel_params.spray_interval
    spray_dose = kernel_params.spray_dose
    spray_radius = kernel_params.spray_radius
    half_skin = kernel_params.half_skin

    n = pos.shape[0]
    n_slots = pair_i.shape[0]
    omega_drum = 0.0 if settling else kernel_params.drum_omega
    fixed_volume = kernel_params.bridge_volume
    wall_volume = fixed_volume if kernel_params.wall_bridges else 0.0
    sprayed = 0.0
    done = 0
    baffle_dir = np.empty((n_baffles + 1, 2))
    # the list must be rebuilt before a step in which some particle starts more than half the
    # skin away from where it was at the last rebuild; checking before each step makes the
    # trajectory independent of how the steps are split into calls
    n_far = 0
    for i in prange(n):
        dx = pos[i, 0] - x_ref[i, 0]
        dy = pos[i, 1] - x_ref[i, 1]
        dz = pos[i, 2] - x_ref[i, 2]
        if dx * dx + dy * dy + dz * dz > half_skin * half_skin:
            n_far += 1
    # the force passes count each block's events (creations, ruptures) and reset the flags the
    # previous step left only in blocks that had some; the counts of that step, which may lie
    # before this call, are taken from the flags once here
    n_wall_blocks, n_pair_blocks = event_blocks(n, n_walls, n_slots)
    block_events = np.empty(n_wall_blocks + n_pair_blocks, dtype=np.int64)
    count_block_events(created, ruptured, n, n_walls, block_events)
    range_lo = np.empty(block_events.shape[0], dtype=np.int64)
    range_hi = np.empty(block_events.shape[0], dtype=np.int64)
    for it in range(n_steps):
        if n_far > 0:
            break
        baffle_directions(n_baffles, omega_drum * (step0 + it) * dt, baffle_dir)
        _slot_forces(0, n_wall_blocks, baffle_dir, omega_drum, block_events, kernel_params, arrays)  # wall slots
        _slot_forces(n_wall_blocks, n_wall_blocks + n_pair_blocks, baffle_dir, omega_drum, block_events, kernel_params, arrays)
        m = event_ranges(block_events, n, n_walls, n_slots, range_lo, range_hi)
        if fixed_volume > 0.0:
            if not settling:  # the bed settles dry in both liquid models
                fill_new_bridges(v_b, created, fixed_volume, wall_volume, n * n_walls, range_lo[:m], range_hi[:m])
        else:
            migrate_events(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured, body_start, body_slots, v_min,
                           body_key, range_lo[:m], range_hi[:m])
        n_far = _gather_integrate(kernel_params, arrays)
        done += 1
        if not settling and fixed_volume == 0.0 and (step0 + it + 1) * dt >= (n_sprays + 1) * spray_interval:
            sprayed += spray(film, pos, radius, n, spray_radius, spray_dose)
            n_sprays += 1
    return done, n_sprays, sprayed


@njit(cache=True, parallel=True)
def _gather_integrate(kernel_params, arrays):
    """Sum each particle's wall and pair slot forces and torques (in slot order) plus gravity,
    then one leapfrog update of velocity, angular velocity and position. Returns the number of
    particles now more than half the Verlet skin from their position at the last rebuild."""
    gx, gy, gz = kernel_params.gx, kernel_params.gy, kernel_params.gz
    pos = arrays.pos
    vel = arrays.vel
    omega_p = arrays.omega
    mass = arrays.mass
    inertia = arrays.inertia
    x_ref = arrays.x_ref
    pair_i = arrays.pair_i
    alive = arrays.alive
    force = arrays.force
    torque_i = arrays.torque_i
    torque_j = arrays.torque_j
    part_start = arrays.part_start
    part_slots = arrays.part_slots
    dt = kernel_params.dt
    n_walls = kernel_params.n_walls
    half_skin = kernel_params.half_skin
    n = pos.shape[0]
    n_far = 0
    for i in prange(n):
        fx = mass[i] * gx
        fy = mass[i] * gy
        fz = mass[i] * gz
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for w in range(n_walls):
            k = i * n_walls + w
            if not alive[k]:
                continue  # zero force and torque (the invariant of _slot_forces)
            fx += force[k, 0]
            fy += force[k, 1]
            fz += force[k, 2]
            tx += torque_i[k, 0]
            ty += torque_i[k, 1]
            tz += torque_i[k, 2]
        for q in range(part_start[i], part_start[i + 1]):
            k = part_slots[q]
            if not alive[k]:
                continue
            if pair_i[k] == i:
                fx += force[k, 0]
                fy += force[k, 1]
                fz += force[k, 2]
                tx += torque_i[k, 0]
                ty += torque_i[k, 1]
                tz += torque_i[k, 2]
            else:
                fx -= force[k, 0]
                fy -= force[k, 1]
                fz -= force[k, 2]
                tx += torque_j[k, 0]
                ty += torque_j[k, 1]
                tz += torque_j[k, 2]
        vel[i, 0] += dt * fx / mass[i]
        vel[i, 1] += dt * fy / mass[i]
        vel[i, 2] += dt * fz / mass[i]
        omega_p[i, 0] += dt * tx / inertia[i]
        omega_p[i, 1] += dt * ty / inertia[i]
        omega_p[i, 2] += dt * tz / inertia[i]
        pos[i, 0] += dt * vel[i, 0]
        pos[i, 1] += dt * vel[i, 1]
        pos[i, 2] += dt * vel[i, 2]
        dx = pos[i, 0] - x_ref[i, 0]
        dy = pos[i, 1] - x_ref[i, 1]
        dz = pos[i, 2] - x_ref[i, 2]
        if dx * dx + dy * dy + dz * dz > half_skin * half_skin:
            n_far += 1
    return n_far


#: particles per block of the wall pass, slots per block of the pair pass: the units in which
#: the force passes count the step's events for liquid migration (:func:`event_blocks`)
WALL_BLOCK = 32
PAIR_BLOCK = 256


@njit(cache=True)
def event_blocks(n_particles, n_walls, n_slots):
    """``(n_wall_blocks, n_pair_blocks)``: how many blocks the wall pass (``WALL_BLOCK``
    particles, i.e. their W wall slots each) and the pair pass (``PAIR_BLOCK`` pair slots) cut
    their slots into. Block b < n_wall_blocks covers wall slots b·WALL_BLOCK·W …; block
    n_wall_blocks + b covers pair slots N·W + b·PAIR_BLOCK …"""
    n_wall_blocks = (n_particles + WALL_BLOCK - 1) // WALL_BLOCK
    n_pair_blocks = (n_slots - n_particles * n_walls + PAIR_BLOCK - 1) // PAIR_BLOCK
    return n_wall_blocks, n_pair_blocks


@njit(cache=True, inline="always")
def _block_slots(blk, n_wall_blocks, n_particles, n_walls, n_slots):
    """Slot range [lo, hi) of event block ``blk`` (:func:`event_blocks`)."""
    if blk < n_wall_blocks:
        return blk * WALL_BLOCK * n_walls, min((blk + 1) * WALL_BLOCK, n_particles) * n_walls
    lo = n_particles * n_walls + (blk - n_wall_blocks) * PAIR_BLOCK
    return lo, min(lo + PAIR_BLOCK, n_slots)


@njit(cache=True, parallel=True)
def count_block_events(created, ruptured, n_particles, n_walls, block_events):
    """Write into ``block_events`` the number of slots of each event block (:func:`event_blocks`)
    whose created or ruptured flag is set: what the force passes need to know about flags left
    by a step before the current kernel call."""
    n_slots = created.shape[0]
    n_wall_blocks = event_blocks(n_particles, n_walls, n_slots)[0]
    for blk in prange(block_events.shape[0]):
        lo, hi = _block_slots(blk, n_wall_blocks, n_particles, n_walls, n_slots)
        e = 0
        for k in range(lo, hi):
            if created[k] or ruptured[k] != 0.0:
                e += 1
        block_events[blk] = e


@njit(cache=True)
def event_ranges(block_events, n_particles, n_walls, n_slots, range_lo, range_hi):
    """Slot ranges of the event blocks with a nonzero count, ascending, into ``range_lo[:m]`` and
    ``range_hi[:m]`` (each of length ≥ the number of blocks); returns m."""
    n_wall_blocks = event_blocks(n_particles, n_walls, n_slots)[0]
    m = 0
    for blk in range(block_events.shape[0]):
        if block_events[blk] != 0:
            range_lo[m], range_hi[m] = _block_slots(blk, n_wall_blocks, n_particles, n_walls, n_slots)
            m += 1
    return m


@njit(cache=True, inline="always")
def _clear_event_flags(lo, hi, created, ruptured):
    """Reset the created/ruptured flags of slots lo … hi−1, writing only where one is set."""
    for k in range(lo, hi):
        if created[k]:
            created[k] = False
        if ruptured[k] != 0.0:
            ruptured[k] = 0.0


@njit(cache=True, parallel=True)
def _slot_forces(block_lo, block_hi, baffle_dir, omega_drum, block_events, kernel_params, arrays):
    """Interaction state, force and torques of the slots of event blocks block_lo … block_hi−1
    (:func:`event_blocks`: wall blocks of ``WALL_BLOCK`` particles' W wall slots, then pair
    blocks of ``PAIR_BLOCK`` slots), in parallel over blocks (docs/physics.md, "Contact law" and
    "Liquid bridges"); ``kernel_params`` a :class:`KernelParams`, ``arrays`` a :class:`KernelArrays`. The
    step calls it for the wall blocks, then for the pair blocks, so that each thread gets an equal
    share of the expensive pair slots.

    ``block_events[b]`` holds on entry the number of created/ruptured flags that the previous
    step set in block b (they are reset first, only in blocks where it is nonzero) and on return
    the number this step set (creations, and ruptures of wet bridges): liquid migration visits
    only the blocks with events, and no pass reads every slot's flags.

    The body is written out in the loop: a numba call per slot with this many array arguments
    costs ~10x the work itself. A particle's wall geometry is read once for its W walls (its wall
    slots are consecutive), and a dead wall slot is skipped before any geometry when the particle
    surely cannot touch the wall: the cylinder and end-plate overlaps that
    :func:`sim.drum.wall_contact` computes are negative (the same expressions, bit for bit), or,
    for the baffles, the particle lies inside the circle of their inner edges with a margin of
    1e-9 of it (then its distance to any baffle exceeds its radius).

    Invariant: the outputs (force, torques, f_normal, f_cap, gap) of a dead slot are zero. A
    slot is born dead with zero outputs (:func:`sim.neighbours.empty_slots`) and dies only by
    rupture, which clears them; so a slot that stays dead is skipped without writing anything,
    which at large N saves most of the memory traffic of the N·W wall slots.
    """
    pos = arrays.pos
    vel = arrays.vel
    omega_p = arrays.omega
    radius = arrays.radius
    pair_i = arrays.pair_i
    pair_j = arrays.pair_j
    alive = arrays.alive
    created = arrays.created
    ruptured = arrays.ruptured
    v_b = arrays.v_b
    fs = arrays.fs
    nprev = arrays.nprev
    force = arrays.force
    torque_i = arrays.torque_i
    torque_j = arrays.torque_j
    f_normal = arrays.f_normal
    f_cap = arrays.f_cap
    gap = arrays.gap
    bridge_table = arrays.bridge_table
    dt = kernel_params.dt
    n_walls = kernel_params.n_walls
    drum_radius = kernel_params.drum_radius
    drum_length = kernel_params.drum_length
    n_baffles = kernel_params.n_baffles
    baffle_height = kernel_params.baffle_height
    cylinder_facets = kernel_params.cylinder_facets
    law = kernel_params.law
    constants = kernel_params.law_constants
    gamma = kernel_params.gamma
    eta = kernel_params.eta
    theta = kernel_params.theta
    model = kernel_params.model
    viscous = kernel_params.viscous
    capillary_in_contact = kernel_params.capillary_in_contact
    n_particles = pos.shape[0]
    n_slots = pair_i.shape[0]
    n_wall_blocks = event_blocks(n_particles, n_walls, n_slots)[0]
    inner_radius = drum_radius * (1.0 - baffle_height)
    # the cylinder's reach: R_d (smooth), or a facet polygon's inradius less a margin (facet_reach)
    cylinder_reach = facet_reach(drum_radius, cylinder_facets)
    for blk in prange(block_lo, block_hi):
        lo, hi = _block_slots(blk, n_wall_blocks, n_particles, n_walls, n_slots)
        if block_events[blk] != 0:
            _clear_event_flags(lo, hi, created, ruptured)
        events = 0
        walls = blk < n_wall_blocks
        # wall blocks: slot k = i·W + w, walked particle by particle
        i = lo // n_walls - 1
        w = n_walls - 1
        px = py = pz = ri = 0.0
        cylinder_apart = baffles_apart = low_apart = high_apart = False
        for k in range(lo, hi):
            if walls:
                w += 1
                if w == n_walls:
                    w = 0
                    i += 1
                    px, py, pz = pos[i, 0], pos[i, 1], pos[i, 2]
                    ri = radius[i]
                    r2 = px * px + py * py
                    reach = ri + 1e-9 * inner_radius
                    cylinder_apart = math.sqrt(r2) + ri - cylinder_reach < 0.0
                    baffles_apart = r2 < (inner_radius - reach) * (inner_radius - reach) and inner_radius > reach
                    low_apart = ri - pz < 0.0
                    high_apart = ri - (drum_length - pz) < 0.0
                if not alive[k]:
                    if w == 0:
                        apart = cylinder_apart
                    elif w <= n_baffles:
                        apart = baffles_apart
                    elif w == n_baffles + 1:
                        apart = low_apart
                    else:
                        apart = high_apart
                    if apart:
                        continue  # stays dead, outputs zero
                ok, nx, ny, nz, u, wvx, wvy = wall_contact(
                    w, px, py, pz, ri, drum_radius, drum_length, n_baffles, baffle_height, cylinder_facets, omega_drum,
                    baffle_dir)
                if not ok:
                    u = -1.0
                rj = math.inf
                vjx, vjy, vjz = wvx, wvy, 0.0
                ojx, ojy, ojz = 0.0, 0.0, omega_drum
            else:
                i = pair_i[k]
                j = pair_j[k]
                ri = radius[i]
                rj = radius[j]
                dx = pos[j, 0] - pos[i, 0]
                dy = pos[j, 1] - pos[i, 1]
                dz = pos[j, 2] - pos[i, 2]
                d2 = dx * dx + dy * dy + dz * dz
                if not alive[k] and d2 > (ri + rj) * (ri + rj) * (1.0 + 1e-9):
                    continue  # clearly apart (no square root needed): stays dead, outputs zero
                dist = math.sqrt(d2)
                u = ri + rj - dist
                if u < 0.0 and not alive[k]:
                    continue
                if dist == 0.0:
                    dist = 1e-300
                nx, ny, nz = dx / dist, dy / dist, dz / dist
                # contact point velocity of j: v_j + ω_j × (−R_j n)
                ojx, ojy, ojz = omega_p[j, 0], omega_p[j, 1], omega_p[j, 2]
                vjx = vel[j, 0] - (ojy * nz - ojz * ny) * rj
                vjy = vel[j, 1] - (ojz * nx - ojx * nz) * rj
                vjz = vel[j, 2] - (ojx * ny - ojy * nx) * rj
            r_eff = effective_radius(ri, rj)
            if not alive[k]:
                if u < 0.0:
                    continue  # a dead slot's outputs are all zero already (see the docstring)
                alive[k] = True
                created[k] = True
                events += 1
                fs[k, 0] = 0.0
                fs[k, 1] = 0.0
                fs[k, 2] = 0.0
                nprev[k, 0], nprev[k, 1], nprev[k, 2] = nx, ny, nz
            elif _bridge_ruptured(-u, model, v_b[k], r_eff, gamma, theta, bridge_table, k):
                alive[k] = False
                ruptured[k] = v_b[k]
                if v_b[k] != 0.0:
                    events += 1  # (a dry pair that parts leaves no flag and moves no liquid)
                v_b[k] = 0.0
                fs[k, 0] = 0.0
                fs[k, 1] = 0.0
                fs[k, 2] = 0.0
                _clear_output(k, force, torque_i, torque_j, f_normal, f_cap, gap)
                continue
            # contact point velocity of i: v_i + ω_i × (R_i n)
            oix, oiy, oiz = omega_p[i, 0], omega_p[i, 1], omega_p[i, 2]
            vrx = vel[i, 0] + (oiy * nz - oiz * ny) * ri - vjx
            vry = vel[i, 1] + (oiz * nx - oix * nz) * ri - vjy
            vrz = vel[i, 2] + (oix * ny - oiy * nx) * ri - vjz
            if u >= 0.0:  # mechanical contact
                twist = 0.5 * dt * (nx * (oix + ojx) + ny * (oiy + ojy) + nz * (oiz + ojz))
                sx, sy, sz = rotate_spring(fs[k, 0], fs[k, 1], fs[k, 2], nprev[k, 0], nprev[k, 1], nprev[k, 2],
                                           nx, ny, nz, twist)
                f_n, sx, sy, sz, tx, ty, tz = contact_force(law, constants, u, nx, ny, nz, vrx, vry, vrz, sx, sy, sz,
                                                            ri, rj, dt)
                fs[k, 0], fs[k, 1], fs[k, 2] = sx, sy, sz
                nprev[k, 0], nprev[k, 1], nprev[k, 2] = nx, ny, nz
                f_contact = bridge_table[k, 2] if v_b[k] > 0.0 else 0.0  # bridge_force at contact
                f_pull = f_contact if capillary_in_contact else 0.0
                fn_net = f_n - f_pull  # along −n on i (repulsive when positive)
                force[k, 0] = -fn_net * nx + tx
                force[k, 1] = -fn_net * ny + ty
                force[k, 2] = -fn_net * nz + tz
                # T_i = (R_i n) × F_t ; T_j = (−R_j n) × (−F_t) = R_j n × F_t
                cx = ny * tz - nz * ty
                cy = nz * tx - nx * tz
                cz = nx * ty - ny * tx
                torque_i[k, 0], torque_i[k, 1], torque_i[k, 2] = ri * cx, ri * cy, ri * cz
                if not walls:
                    torque_j[k, 0], torque_j[k, 1], torque_j[k, 2] = rj * cx, rj * cy, rj * cz
                f_normal[k] = fn_net
                f_cap[k] = f_contact
            else:  # separated, bridge active (0 < s < s_crit)
                s = -u
                f_c = 0.0
                if v_b[k] > 0.0:
                    f_c = bridge_force_from_constants(model, s, v_b[k], r_eff, gamma, theta, bridge_table, k)
                f_v = 0.0
                if viscous:
                    f_v = viscous_force(eta, ri, rj, vrx * nx + vry * ny + vrz * nz, s, v_b[k])
                pull = f_c - f_v  # along +n on i
                force[k, 0] = pull * nx
                force[k, 1] = pull * ny
                force[k, 2] = pull * nz
                torque_i[k, 0] = 0.0
                torque_i[k, 1] = 0.0
                torque_i[k, 2] = 0.0
                torque_j[k, 0] = 0.0
                torque_j[k, 1] = 0.0
                torque_j[k, 2] = 0.0
                f_normal[k] = -pull
                f_cap[k] = f_c
            gap[k] = -u
        block_events[blk] = events


@njit(cache=True, inline="always")
def _bridge_ruptured(gap, model, v_b, r_eff, gamma, theta, bridge_table, k):
    """:func:`sim.capillary.bridge_ruptured` of live slot ``k`` with its s_crit from the bridge
    table, whose row it first brings up to date with the slot's current volume (so that the
    force pass that follows can read the row)."""
    if v_b <= 0.0:
        return gap > 0.0  # s_crit = 0: a dry pair parts as soon as it separates
    if bridge_table[k, 0] != v_b:
        bridge_constants(model, v_b, r_eff, gamma, theta, bridge_table, k)
    return gap > 0.0 and gap >= bridge_table[k, 1]
