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
from dataclasses import dataclass
from typing import Callable

from numba import njit

__all__ = ["rotate_spring", "mechanical_force", "contact_force", "ContactLaw", "LINEAR_COULOMB", "CONTACT_LAWS"]


@dataclass(frozen=True)
class ContactLaw:
    """A mechanical contact law as the rest of the simulator sees it: the id its numba force
    function is dispatched on in :func:`contact_force`, the :class:`~sim.params.SimParams` fields
    it reads, its closed-form contact time and its coarse-graining rule.

    Attributes
    ----------
    name : str
        ``SimParams.contact_law``.
    kernel_id : int
        The branch of :func:`contact_force` (the kernels pass an integer: a numba loop cannot
        carry a Python object).
    parameters : tuple of str
        The ``SimParams`` fields the law reads (recorded with the run; a sweep may grid them).
    contact_time : callable
        ``contact_time(params, radius) -> t_c [s]``: the normal contact time of two equal spheres
        of ``radius`` [m]; the time step is chosen from it (Δt ≤ t_c/20). Raises ``ValueError``
        where there is none (an overdamped contact).
    cg_scaled : callable
        ``cg_scaled(params, alpha) -> {field: value}``: the law's parameters of the system
        coarse-grained by α from the original ``params`` (:func:`sim.params.cg_scale`).
    """

    name: str
    kernel_id: int
    parameters: tuple
    contact_time: Callable
    cg_scaled: Callable


def _linear_contact_time(params, radius) -> float:
    """π/(ω₀√(1−ζ²)) [s], ω₀ = √(k_n/m_eff), ζ = c_n/(2√(k_n m_eff)), m_eff = m/2."""
    m = params.density * 4 / 3 * math.pi * radius**3
    m_eff = m / 2
    w0 = math.sqrt(params.k_n / m_eff)
    zeta = params.c_n / (2 * math.sqrt(params.k_n * m_eff))
    if zeta >= 1:
        raise ValueError(f"parameter c_n = {params.c_n:.3g} N s/m overdamps the normal contact of particles of "
                         f"radius {radius:.3g} m (damping ratio ζ = {zeta:.3g} >= 1)")
    return math.pi / (w0 * math.sqrt(1 - zeta**2))


def _linear_cg_scaled(params, alpha) -> dict:
    """Table 2 of the paper (Weber scaling): k_n, k_t ×α; c_n, c_t ×α²; friction unchanged."""
    return {"k_n": params.k_n * alpha, "k_t": params.k_t * alpha,
            "c_n": params.c_n * alpha**2, "c_t": params.c_t * alpha**2}


#: the linear viscoelastic normal force with a tangential spring–dashpot and Coulomb friction
LINEAR_COULOMB = ContactLaw("linear_coulomb", 0, ("k_n", "k_t", "c_n", "c_t", "friction"),
                            _linear_contact_time, _linear_cg_scaled)

#: contact law name -> :class:`ContactLaw`. Adding a law (docs/architecture.md, "Adding a contact
#: law"): its numba force function (the arguments and results of :func:`mechanical_force`) and a
#: branch in :func:`contact_force` for its ``kernel_id``, its ``ContactLaw`` here;
#: ``SimParams.contact_law`` then accepts its name.
CONTACT_LAWS = {law.name: law for law in (LINEAR_COULOMB,)}


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
    """The contact law whose ``kernel_id`` is ``law`` (:data:`CONTACT_LAWS`): the arguments and
    results of :func:`mechanical_force`, the linear viscoelastic law with Coulomb friction (law 0).

    A new law is a new branch before the last line. The id is checked where it is chosen
    (:class:`sim.params.SimParams` refuses an unknown ``contact_law``), never here: this function
    is inlined into the parallel force loop, and a ``raise`` in it gives the loop a second exit,
    which makes numba run the loop on one thread (the pair forces lost their two-thread speed-up
    that way once; ``tests/test_sim_physics.py`` checks that every parallel loop stays parallel).
    """
    # law 0 (and, ids being checked in SimParams, nothing else reaches here yet)
    return mechanical_force(u, nx, ny, nz, vx, vy, vz, fx, fy, fz, k_n, k_t, c_n, c_t, mu, dt)
