"""The Hertz–Mindlin contact law with Coulomb friction (no-slip Mindlin tangential stiffness,
Tsuji-type damping), as LIGGGHTS' ``granular/hertz/history`` writes it, most of our users' default.

For a pair of effective radius R* = (1/r_i + 1/r_j)⁻¹ and mass m* = (1/m_i + 1/m_j)⁻¹ (a wall: R* = r_i,
m* = m_i) at overlap u, with S_n = 2E*√(R*u) and S_t = 8G*√(R*u):

- normal: f_n = max(4/3·E*√(R*u)·u + γ_n·v_n, 0), γ_n = 2√(5/6)·b·√(S_n m*);
- tangential: the stored spring gains −S_t·Δt·v_t (incremental, with the current stiffness, as
  YADE's Mindlin law does), is capped at μ·f_n, and a dashpot −γ_t·v_t, γ_t = 2√(5/6)·b·√(S_t m*),
  acts while it sticks;

with E* = E/(2(1−ν²)), G* = E/(4(2−ν)(1+ν)) for one material and b = −ln e/√(ln²e + π²).
The coefficient of restitution that results does not depend on the impact speed (Tsuji); it is
close to, not equal to, e (b is the linear law's relation).

Coarse-graining: at the same strain u/R a Hertz contact of spheres ×α carries forces ×α²·(E's
factor), so a rule with forces × α^f scales E by α^(f−2) (ν, e, μ unchanged). Under ``weber``
(f = 2) E is unchanged and the contact time scales ×α, as Δt does; under ``bond`` (f = 3) E ×α and
the contact time scales ×α^0.6 against Δt ×α^0.5 (t_c/Δt grows by α^0.1: never fewer steps per
contact than the original).
"""

from __future__ import annotations

import math

from numba import njit

from ._coulomb import coulomb_tangential
from ._law import ContactLaw, LawParameter

__all__ = ["LAW", "force", "contact_time"]

PARAMETERS = (
    LawParameter("youngs_modulus", 5e6, "Pa", "positive",
                 "Young's modulus E (soft, as DEM uses: Δt = 3 µs resolves lab particles at 1 m/s)"),
    LawParameter("poisson_ratio", 0.3, "", "poisson_ratio", "Poisson's ratio ν"),
    LawParameter("restitution", 0.8, "", "restitution", "coefficient of restitution e the damping is set from"),
    LawParameter("friction", 0.5, "", "nonnegative", "Coulomb friction coefficient μ"),
    LawParameter("impact_speed", 1.0, "m/s", "positive",
                 "fastest normal impact speed the time step must resolve (Hertz's t_c falls as v^(-1/5))"),
)

#: 2·∫₀¹ dx/√(1 − x^(5/2)): Hertz's contact time is this × (15m*/(16E*√R*))^(2/5) × v^(−1/5)
_HERTZ_TIME = 2.9432


def _moduli(params) -> tuple:
    """(E*, G*) [Pa] of a pair of one material."""
    e, nu = params.youngs_modulus, params.poisson_ratio
    return e / (2 * (1 - nu * nu)), e / (4 * (2 - nu) * (1 + nu))


def damping_factor(restitution: float) -> float:
    """2√(5/6)·b, b = −ln e/√(ln²e + π²) (0 for e = 1)."""
    log_e = math.log(restitution)
    return 2 * math.sqrt(5 / 6) * -log_e / math.sqrt(log_e * log_e + math.pi * math.pi)


def pack(params) -> tuple:
    """(E*, G*, 2√(5/6)·b, μ, 4/3·π·ρ) of a ``SimParams`` (the last turns a radius into a mass)."""
    e_star, g_star = _moduli(params)
    return (e_star, g_star, damping_factor(params.restitution), float(params.friction),
            4 / 3 * math.pi * params.density)


@njit(cache=True, inline="always")
def force(constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt):
    """Normal force and tangential force on i for a contact with overlap u ≥ 0
    (:attr:`sim.laws.ContactLaw.force`).

    Returns
    -------
    f_n : float
        max(4/3·E*√(R*u)·u + γ_n·v_n, 0) [N]; the normal force on i is −f_n·n.
    (sx, sy, sz) : float
        Updated stored spring (−S_t·Δt·v_t added, then capped at μ·f_n).
    (tx, ty, tz) : float
        Tangential force applied on i: the spring, plus the dashpot −γ_t·v_t when sticking.
    """
    e_star = constants[0]
    g_star = constants[1]
    damping = constants[2]
    mu = constants[3]
    mass_per_cube = constants[4]
    r_pair = 1.0 / (1.0 / r_i + 1.0 / r_j)
    m_pair = mass_per_cube / (1.0 / (r_i * r_i * r_i) + 1.0 / (r_j * r_j * r_j))
    root = math.sqrt(r_pair * u)
    s_n = 2.0 * e_star * root
    s_t = 8.0 * g_star * root
    v_n = vx * nx + vy * ny + vz * nz
    f_n = 2.0 / 3.0 * s_n * u + damping * math.sqrt(s_n * m_pair) * v_n
    if f_n < 0.0:
        f_n = 0.0
    vtx, vty, vtz = vx - v_n * nx, vy - v_n * ny, vz - v_n * nz
    return coulomb_tangential(f_n, fx, fy, fz, vtx, vty, vtz, s_t, damping * math.sqrt(s_t * m_pair), mu, dt)


def contact_time(params, radius, speed=None) -> float:
    """Hertz's (undamped) contact time of two equal spheres of ``radius`` [m] meeting at relative
    normal ``speed`` [m/s] (default ``params.impact_speed``): 2.9432·(15m*/(16E*√R*))^(2/5)·v^(−1/5)
    with m* = m/2, R* = r/2 [s]. Damping lengthens it a little; this is the shorter bound."""
    v = params.impact_speed if speed is None else speed
    m_pair = params.density * 4 / 3 * math.pi * radius**3 / 2
    e_star, _ = _moduli(params)
    return _HERTZ_TIME * (15 * m_pair / (16 * e_star * math.sqrt(radius / 2))) ** 0.4 * v ** -0.2


def cg_scaled(params, alpha, rule) -> dict:
    """E × α^(f−2) for a rule with forces × α^f (the module's docstring): unchanged under ``weber``."""
    return {"youngs_modulus": params.youngs_modulus * alpha ** (rule.force_exponent - 2)}


LAW = ContactLaw("hertz_mindlin", PARAMETERS, ("e_star", "g_star", "damping", "mu", "mass_per_cube"), pack, force,
                 contact_time, cg_scaled, cg_rules=("weber", "bond"))
