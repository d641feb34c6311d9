"""The contact law as the force loop calls it: the tangential spring's rotation into the current
tangent plane (YADE's ScGeom::rotate), shared by every law, and one dispatcher,
:func:`contact_force`, over the laws of :mod:`sim.laws` (docs/physics.md, "Contact law"). Plain
numba functions on scalars (tuples in, tuples out, no allocation), shared by particle–particle and
particle–wall contacts.

Sign conventions: n is the unit normal from body i to body j; v_rel is the velocity of i's
contact point minus j's; v_n = v_rel·n > 0 when approaching; the stored spring ``fs`` is the
tangential spring force *on i*.
"""

from __future__ import annotations

from numba import njit

from .laws import CONTACT_LAWS, ContactLaw, kernel_id

__all__ = ["rotate_spring", "contact_force", "law_constants", "ContactLaw", "CONTACT_LAWS"]

#: length of the constants tuple every law's force function receives (the longest law's; the
#: others are padded with zeros, so that one compiled loop serves every law)
LAW_CONSTANTS = max(len(law.constants) for law in CONTACT_LAWS.values())


def law_constants(params) -> tuple:
    """``(kernel id, constants)`` of the run's contact law: the id :func:`contact_force`
    dispatches on and the law's :attr:`~sim.laws.ContactLaw.pack` of ``params`` padded with
    zeros to :data:`LAW_CONSTANTS` floats."""
    law = CONTACT_LAWS[params.contact_law]
    packed = tuple(float(value) for value in law.pack(params))
    if len(packed) != len(law.constants):
        raise ValueError(f"contact law {law.name!r} packed {len(packed)} constants, declares {len(law.constants)}")
    return kernel_id(law.name), packed + (0.0,) * (LAW_CONSTANTS - len(packed))


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


def _dispatcher(forces):
    """One numba function that calls ``forces[law]``: a chain of ``if law == 0`` tests, built
    once from the registry (the force loop cannot take a function as an argument without
    losing its cache and its parallelism). Inlined: with one law it is that law's force."""
    first, rest = forces[0], forces[1:]
    if not rest:
        @njit(inline="always")
        def dispatch(law, constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt):
            return first(constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt)
        return dispatch
    tail = _dispatcher(rest)

    @njit(inline="always")
    def dispatch(law, constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt):
        if law == 0:
            return first(constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt)
        return tail(law - 1, constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt)
    return dispatch


#: ``contact_force(law, constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt)
#: -> (f_n, sx, sy, sz, tx, ty, tz)``: the force function (:attr:`sim.laws.ContactLaw.force`) of
#: the law whose kernel id is ``law``, with the ``constants`` of :func:`law_constants`. The id is
#: checked where it is chosen (``SimParams`` refuses an unknown ``contact_law``), never here: this
#: function is inlined into the parallel force loop, and a ``raise`` in it gives the loop a second
#: exit, which makes numba run the loop on one thread (``tests/test_sim_physics.py`` checks that
#: every parallel loop stays parallel).
contact_force = _dispatcher(tuple(law.force for law in CONTACT_LAWS.values()))
