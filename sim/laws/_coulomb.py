"""The tangential spring–dashpot with Coulomb friction that the laws share (docs/physics.md,
"Tangential force, friction and the stored spring")."""

from __future__ import annotations

import math

from numba import njit

__all__ = ["coulomb_tangential"]


@njit(cache=True, inline="always")
def coulomb_tangential(f_n, fx, fy, fz, vtx, vty, vtz, k_t, c_t, mu, dt):
    """The stored spring f [N] (on i, in the tangent plane) after a step at tangential velocity
    v_t [m/s]: −k_t·Δt·v_t added [k_t in N/m], then held at the Coulomb limit μ·f_n if it
    exceeds it (sliding: no dashpot); sticking, the dashpot −c_t·v_t [c_t in N s/m] acts too.

    Returns
    -------
    (f_n, sx, sy, sz, tx, ty, tz) : the normal force as given, the updated spring and the
    tangential force on i [N] (the results of :attr:`sim.laws.ContactLaw.force`).
    """
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
