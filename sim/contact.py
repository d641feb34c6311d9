"""Mechanical contact law (docs/physics.md, "Contact law"): linear viscoelastic normal force and a tangential
spring–dashpot with Coulomb friction, history rotated into the current tangent plane (YADE's
ScGeom::rotate). Plain numba functions on scalars (tuples in, tuples out, no allocation), shared
by particle–particle and particle–wall contacts.

Sign conventions: n is the unit normal from body i to body j; v_rel is the velocity of i's
contact point minus j's; v_n = v_rel·n > 0 when approaching; the stored spring ``fs`` is the
tangential spring force *on i*.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["rotate_spring", "mechanical_force", "contact_force", "CONTACT_LAWS"]

#: contact law name -> the integer id the kernels dispatch on (:func:`contact_force`). Adding a law:
#: write it as a numba function of the same arguments and results as :func:`mechanical_force`,
#: give it the next id here and a branch in :func:`contact_force` (docs/simulator.md, "Adding a
#: contact law"); ``SimParams.contact_law`` then accepts its name.
CONTACT_LAWS = {"linear_coulomb": 0}


@njit(cache=True, inline="always")
def rotate_spring(fx, fy, fz, px, py, pz, nx, ny, nz, twist):
    """Rotate the stored spring from the previous normal p to the current normal n and by the
    twist angle ``twist`` [rad] about n (YADE ScGeom::rotate: f −= f × (p × n);
    f −= f × (twist·n)); then drop any component along n.

    Returns
    -------
    (fx, fy, fz) : the rotated spring force [N].
    """
    ax = py * nz - pz * ny
    ay = pz * nx - px * nz
    az = px * ny - py * nx
    cx = fy * az - fz * ay
    cy = fz * ax - fx * az
    cz = fx * ay - fy * ax
    fx, fy, fz = fx - cx, fy - cy, fz - cz
    tx, ty, tz = twist * nx, twist * ny, twist * nz
    cx = fy * tz - fz * ty
    cy = fz * tx - fx * tz
    cz = fx * ty - fy * tx
    fx, fy, fz = fx - cx, fy - cy, fz - cz
    along = fx * nx + fy * ny + fz * nz
    return fx - along * nx, fy - along * ny, fz - along * nz


@njit(cache=True, inline="always")
def mechanical_force(u, nx, ny, nz, vx, vy, vz, fx, fy, fz, k_n, k_t, c_n, c_t, mu, dt):
    """Normal force and tangential force on i for a contact with overlap u ≥ 0.

    Parameters
    ----------
    u : float
        Overlap [m].
    nx, ny, nz : float
        Unit normal from i to j.
    vx, vy, vz : float
        Relative velocity of the contact point, i minus j [m/s].
    fx, fy, fz : float
        Stored tangential spring force on i [N], already rotated into the tangent plane.
    k_n, k_t, c_n, c_t, mu, dt : float
        Pair stiffnesses [N/m], dampings [N s/m], friction coefficient, time step [s].

    Returns
    -------
    f_n : float
        max(k_n·u + c_n·v_n, 0) [N]; the normal force on i is −f_n·n.
    (sx, sy, sz) : float
        Updated stored spring (−k_t·Δt·v_t added, then capped at μ·f_n).
    (tx, ty, tz) : float
        Tangential force applied on i: the spring, plus the dashpot −c_t·v_t when sticking.
    """
    v_n = vx * nx + vy * ny + vz * nz
    f_n = k_n * u + c_n * v_n
    if f_n < 0.0:
        f_n = 0.0
    vtx, vty, vtz = vx - v_n * nx, vy - v_n * ny, vz - v_n * nz
    fx -= k_t * dt * vtx
    fy -= k_t * dt * vty
    fz -= k_t * dt * vtz
    mag = math.sqrt(fx * fx + fy * fy + fz * fz)
    limit = mu * f_n
    if mag > limit:  # sliding: spring held at the Coulomb limit, no dashpot
        scale = limit / mag
        fx, fy, fz = fx * scale, fy * scale, fz * scale
        return f_n, fx, fy, fz, fx, fy, fz
    return f_n, fx, fy, fz, fx - c_t * vtx, fy - c_t * vty, fz - c_t * vtz


@njit(cache=True, inline="always")
def contact_force(law, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, k_n, k_t, c_n, c_t, mu, dt):
    """The contact law ``law`` (a value of :data:`CONTACT_LAWS`): the arguments and results of
    :func:`mechanical_force`, the linear viscoelastic law with Coulomb friction (law 0).

    A new law is a new branch before the last line. The id is checked where it is chosen
    (:class:`sim.params.SimParams` refuses an unknown ``contact_law``), never here: this function
    is inlined into the parallel force loop, and a ``raise`` in it gives the loop a second exit,
    which makes numba run the loop on one thread (the pair forces lost their two-thread speed-up
    that way once; ``tests/test_sim_physics.py`` checks that every parallel loop stays parallel).
    """
    # law 0 (and, ids being checked in SimParams, nothing else reaches here yet)
    return mechanical_force(u, nx, ny, nz, vx, vy, vz, fx, fy, fz, k_n, k_t, c_n, c_t, mu, dt)
