"""The linear viscoelastic contact law with Coulomb friction (docs/physics.md, "Contact law"):
a normal spring–dashpot, f_n = max(k_n·u + c_n·v_n, 0), and a tangential spring–dashpot whose
spring is capped at μ·f_n (YADE's ``ViscElPhys`` with its linear law). The simulator's default.

Sign conventions (all laws): n is the unit normal from body i to body j; v is the velocity of
i's contact point minus j's; v_n = v·n > 0 when approaching; the stored spring is the tangential
spring force *on i*.
"""

from __future__ import annotations

import math

from numba import njit

from ._coulomb import coulomb_tangential
from ._law import ContactLaw, LawParameter

__all__ = ["LAW", "force"]

PARAMETERS = (
    LawParameter("k_n", 150.0, "N/m", "positive", "normal stiffness of a pair"),
    LawParameter("k_t", 120.0, "N/m", "positive", "tangential stiffness of a pair"),
    LawParameter("c_n", 0.0011, "N s/m", "nonnegative", "normal damping coefficient"),
    LawParameter("c_t", 0.0011, "N s/m", "nonnegative", "tangential damping coefficient"),
    LawParameter("friction", 0.5, "", "nonnegative", "Coulomb friction coefficient μ"),
)


def pack(params) -> tuple:
    """(k_n, k_t, c_n, c_t, μ) of a ``SimParams``, as floats."""
    return (float(params.k_n), float(params.k_t), float(params.c_n), float(params.c_t), float(params.friction))


@njit(cache=True, inline="always")
def force(constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt):
    """Normal force and tangential force on i for a contact with overlap u ≥ 0
    (:attr:`sim.laws.ContactLaw.force`; this law does not read the radii).

    Returns
    -------
    f_n : float
        max(k_n·u + c_n·v_n, 0) [N]; the normal force on i is −f_n·n.
    (sx, sy, sz) : float
        Updated stored spring (−k_t·Δt·v_t added, then capped at μ·f_n).
    (tx, ty, tz) : float
        Tangential force applied on i: the spring, plus the dashpot −c_t·v_t when sticking.
    """
    k_n = constants[0]
    k_t = constants[1]
    c_n = constants[2]
    c_t = constants[3]
    mu = constants[4]
    v_n = vx * nx + vy * ny + vz * nz
    f_n = k_n * u + c_n * v_n
    if f_n < 0.0:
        f_n = 0.0
    vtx, vty, vtz = vx - v_n * nx, vy - v_n * ny, vz - v_n * nz
    return coulomb_tangential(f_n, fx, fy, fz, vtx, vty, vtz, k_t, c_t, mu, dt)


def contact_time(params, radius) -> float:
    """π/(ω₀√(1−ζ²)) [s], ω₀ = √(k_n/m_eff), ζ = c_n/(2√(k_n m_eff)), m_eff = m/2 for two equal
    spheres of ``radius`` [m]."""
    m = params.density * 4 / 3 * math.pi * radius**3
    m_eff = m / 2
    w0 = math.sqrt(params.k_n / m_eff)
    zeta = params.c_n / (2 * math.sqrt(params.k_n * m_eff))
    if zeta >= 1:
        raise ValueError(f"parameter c_n = {params.c_n:.3g} N s/m overdamps the normal contact of particles of "
                         f"radius {radius:.3g} m (damping ratio ζ = {zeta:.3g} >= 1)")
    return math.pi / (w0 * math.sqrt(1 - zeta**2))


def check(params, radius, pair_mass) -> None:
    """The tangential spring–dashpot of the lightest pair, whose sticking mode has the effective
    mass (2/7)·m* of two rolling solid spheres: its half period π/ω_t, ω_t = √(k_t/((2/7)m*)),
    must span 20 time steps as the normal contact does, and its dashpot c_t·Δt must stay below
    (2/7)·m* (an explicit dashpot beyond that amplifies instead of damping)."""
    m_t = 2 / 7 * pair_mass
    half_period = math.pi / math.sqrt(params.k_t / m_t)
    if half_period < 20 * params.dt:
        raise ValueError(f"parameter k_t = {params.k_t:.3g} N/m: the tangential oscillation of the smallest particles "
                         f"lasts {half_period / params.dt:.3g} time steps, fewer than 20: lower k_t or Δt")
    if params.c_t * params.dt > m_t:
        raise ValueError(f"parameter c_t = {params.c_t:.3g} N s/m: c_t·Δt is {params.c_t * params.dt / m_t:.3g} times the "
                         f"tangential effective mass (2/7)m* = {m_t:.3g} kg of the smallest particles; above 1 the explicit "
                         "dashpot is unstable: lower c_t or Δt")


def cg_scaled(params, alpha, rule) -> dict:
    """k_n, k_t × the rule's stiffness factor α^(f−1), c_n, c_t × its damping factor α^((f+2)/2)
    (``weber``, Table 2 of the paper: ×α and ×α²; ``bond``: ×α² and ×α^2.5); friction unchanged.
    Restitution and t_c/Δt are then those of the original system."""
    stiffness, damping = rule.stiffness(alpha), rule.damping(alpha)
    return {"k_n": params.k_n * stiffness, "k_t": params.k_t * stiffness,
            "c_n": params.c_n * damping, "c_t": params.c_t * damping}


LAW = ContactLaw("linear_coulomb", PARAMETERS, ("k_n", "k_t", "c_n", "c_t", "mu"), pack, force,
                 contact_time, cg_scaled, cg_rules=("weber", "bond"), check=check)
