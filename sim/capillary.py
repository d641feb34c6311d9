"""Liquid-bridge forces (docs/physics.md, "Liquid bridges" and "Capillary models"): capillary
force models, rupture distance and the Pitois viscous lubrication force.

The scalar functions are numba kernels on plain floats, callable from other kernels; the model
is passed as an integer id, ``CAPILLARY_MODELS[name]``. SI units throughout: lengths [m],
volumes [m³], surface tension [N/m], viscosity [Pa s], angles [rad], forces [N].

Notation: s is the surface-to-surface gap, V_b the bridge volume, R the bridge's effective
radius 2·R_i·R_j/(R_i + R_j) (a wall pair: the particle radius), γ the surface tension and θ the
contact angle. Every capillary model returns the attractive magnitude F ≥ 0. For s ≤ 0 the
models return their limit s → 0⁺ (the value at contact); a bridge with V_b ≤ 0 exerts no force.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "CAPILLARY_MODELS",
    "capillary_force_scalar",
    "rupture_distance_scalar",
    "effective_radius",
    "bridge_ruptured",
    "bridge_force",
    "pair_bridge_force",
    "viscous_force",
    "capillary_force_curve",
    "BRIDGE_CONSTANTS",
    "bridge_constants",
    "bridge_force_from_constants",
]

#: the capillary force laws by name, with the index the kernels use (Willett numeric and analytic,
#: Rabinovich, Lambert; docs/physics.md)
CAPILLARY_MODELS = {"willett_numeric": 0, "willett_analytic": 1, "rabinovich": 2, "lambert": 3}


@njit(cache=True, inline="always")
def _willett_coefficients(v_b, r, theta):
    """The polynomials f1 … f4 of Willett's fit (:func:`_willett_numeric`), functions of
    L = ln(V_b/R³) and θ only. Requires v_b > 0."""
    lv = math.log(v_b / r**3)
    t = theta
    t2 = t * t
    f1 = ((-0.44507 + 0.050832 * t - 1.1466 * t2)
          + (-0.1119 - 0.000411 * t - 0.1490 * t2) * lv
          + (-0.012101 - 0.0036456 * t - 0.01255 * t2) * lv**2
          + (-0.0005 - 0.0003505 * t - 0.00029076 * t2) * lv**3)
    f2 = ((1.9222 - 0.57473 * t - 1.2918 * t2)
          + (-0.0668 - 0.1201 * t - 0.22574 * t2) * lv
          + (-0.0013375 - 0.0068988 * t - 0.01137 * t2) * lv**2)
    f3 = ((1.268 - 0.01396 * t - 0.23566 * t2)
          + (0.198 + 0.092 * t - 0.06418 * t2) * lv
          + (0.02232 + 0.02238 * t - 0.009853 * t2) * lv**2
          + (0.0008585 + 0.001318 * t - 0.00053 * t2) * lv**3)
    f4 = ((-0.010703 + 0.073776 * t - 0.34742 * t2)
          + (0.03345 + 0.04543 * t - 0.09056 * t2) * lv
          + (0.0018574 + 0.004456 * t - 0.006257 * t2) * lv**2)
    return f1, f2, f3, f4


@njit(cache=True, inline="always")
def _willett_separated(s, r, gamma, f1, f2, f3, f4, root):
    """Willett's fit at gap s > 0 from its coefficients and root = √(V_b/R)."""
    ls = math.log(0.5 * s / root)
    return 2.0 * math.pi * r * gamma * math.exp(f1 - f2 * math.exp(f3 * ls + f4 * ls * ls))


@njit(cache=True)
def _willett_numeric(s, v_b, r, gamma, theta):
    """Willett (2000) appendix fit, YADE's ``Willett_numeric``.

    With L = ln(V_b/R³), t = θ and s⁺ = (s/2)/√(V_b/R):
    F = 2πRγ·exp(f1 − f2·exp(f3·ln s⁺ + f4·(ln s⁺)²)), f1…f4 polynomials in L and t
    (docs/physics.md, "Capillary models").
    For s ≤ 0 returns the limit s → 0⁺, 2πRγ·exp(f1). Requires v_b > 0.
    """
    f1, f2, f3, f4 = _willett_coefficients(v_b, r, theta)
    if s <= 0.0:
        return 2.0 * math.pi * r * gamma * math.exp(f1)
    return _willett_separated(s, r, gamma, f1, f2, f3, f4, math.sqrt(v_b / r))


@njit(cache=True)
def _willett_analytic(s, v_b, r, gamma, theta):
    """Willett (2000) eqs. 12–13: F = 2πRγ·cosθ/(1 + 2.1·s⁺ + 10·s⁺²), s⁺ = (s/2)/√(V_b/R).

    For s ≤ 0 returns 2πRγ·cosθ. Requires v_b > 0.
    """
    sp = 0.5 * max(s, 0.0) / math.sqrt(v_b / r)
    return 2.0 * math.pi * r * gamma * math.cos(theta) / (1.0 + 2.1 * sp + 10.0 * sp * sp)


@njit(cache=True)
def _lambert(s, v_b, r, gamma, theta):
    """Lambert's term of Rabinovich (2005): F = 2πRγ·cosθ/(1 + s/(2·d_sp)),
    d_sp = (s/2)(−1 + √(1 + 2V_b/(πR·s²))).

    Evaluated as 2πRγ·cosθ·(q − s)/q with q = √(s² + 2V_b/(πR)), the same expression free of
    the 0/0 at s = 0; for s ≤ 0 returns 2πRγ·cosθ. Requires v_b > 0.
    """
    s = max(s, 0.0)
    a = 2.0 * v_b / (math.pi * r)
    q = math.sqrt(s * s + a)
    return 2.0 * math.pi * r * gamma * math.cos(theta) * (a / (q + s)) / q


@njit(cache=True)
def _rabinovich(s, v_b, r, gamma, theta):
    """Rabinovich (2005) with Lambert's correction: the :func:`_lambert` term plus
    2πRγ·sin α·sin(θ + α), α = √((s/R)(−1 + √(1 + 2V_b/(πR·s²)))).

    α is evaluated as √(a/(R(q + s))), a = 2V_b/(πR), q = √(s² + a) (the same expression),
    which is continuous at s = 0; for s ≤ 0 returns the limit s → 0⁺,
    2πRγ·(cosθ + sin α₀·sin(θ + α₀)) with α₀ = (2V_b/(πR³))^¼. Requires v_b > 0.
    """
    s = max(s, 0.0)
    a = 2.0 * v_b / (math.pi * r)
    q = math.sqrt(s * s + a)
    alpha = math.sqrt(a / (r * (q + s)))
    return (_lambert(s, v_b, r, gamma, theta)
            + 2.0 * math.pi * r * gamma * math.sin(alpha) * math.sin(theta + alpha))


@njit(cache=True)
def capillary_force_scalar(model, s, v_b, r_eff, gamma, theta):
    """Attractive magnitude of the capillary force of a liquid bridge (docs/physics.md,
    "Capillary models").

    Parameters
    ----------
    model : int
        Model id, a value of :data:`CAPILLARY_MODELS` (0 willett_numeric, 1 willett_analytic,
        2 rabinovich, 3 lambert).
    s : float
        Surface-to-surface gap [m]; s ≤ 0 gives the value at contact, the limit s → 0⁺.
    v_b : float
        Bridge volume [m³].
    r_eff : float
        Effective radius 2·R_i·R_j/(R_i + R_j) [m]; the particle radius for a wall pair.
    gamma : float
        Surface tension [N/m].
    theta : float
        Contact angle [rad].

    Returns
    -------
    float
        F ≥ 0 [N], pulling the pair together; 0.0 when v_b ≤ 0. The caller applies it only
        while 0 < s < :func:`rupture_distance_scalar`. ``willett_numeric`` is capped at 2πRγ (its value
        at contact, 2πRγ·e^{f1}, stays below that for the volumes Willett fitted, but f1 is cubic
        in ln V* and exceeds 0 for V_b/R³ below about 1e-5, growing without bound as V_b → 0 —
        a volume migration's tiny leftover films do reach; 1e-24 m³ gave ~1e3 N).

    Raises
    ------
    ValueError
        If ``model`` is not a known id.
    """
    if v_b <= 0.0:
        return 0.0
    if model == 0:
        return min(_willett_numeric(s, v_b, r_eff, gamma, theta), 2.0 * math.pi * r_eff * gamma)
    if model == 1:
        return _willett_analytic(s, v_b, r_eff, gamma, theta)
    if model == 2:
        return _rabinovich(s, v_b, r_eff, gamma, theta)
    if model == 3:
        return _lambert(s, v_b, r_eff, gamma, theta)
    raise ValueError("unknown capillary model id")


@njit(cache=True)
def rupture_distance_scalar(v_b, r_eff, theta):
    """Gap at which a bridge ruptures (Willett 2000 eq. 15, full gap; docs/physics.md,
    "Liquid bridges").

    s_crit = (1 + θ/2)·(V_b^⅓ + 0.1·V_b^⅔/R).

    Parameters
    ----------
    v_b : float
        Bridge volume [m³].
    r_eff : float
        Effective radius 2·R_i·R_j/(R_i + R_j) [m]; the particle radius for a wall pair.
    theta : float
        Contact angle [rad].

    Returns
    -------
    float
        s_crit [m]; 0.0 when v_b ≤ 0.
    """
    if v_b <= 0.0:
        return 0.0
    c = v_b ** (1.0 / 3.0)
    return (1.0 + 0.5 * theta) * (c + 0.1 * c * c / r_eff)


@njit(cache=True, inline="always")
def effective_radius(r_i, r_j):
    """Effective radius of a bridge, 2·R_i·R_j/(R_i + R_j) [m]; a wall (``r_j = inf``) gives R_i."""
    if math.isinf(r_j):
        return r_i
    return 2.0 * r_i * r_j / (r_i + r_j)


@njit(cache=True, inline="always")
def bridge_ruptured(gap, v_b, r_eff, theta):
    """Whether a bridge at surface gap ``gap`` [m] has ruptured: s > 0 and s ≥ s_crit(V_b)
    (:func:`rupture_distance_scalar`). The engine ends a bridge in the first step where this holds."""
    return gap > 0.0 and gap >= rupture_distance_scalar(v_b, r_eff, theta)


@njit(cache=True, inline="always")
def bridge_force(model, gap, v_b, r_eff, gamma, theta):
    """Capillary force [N] ≥ 0 of a bridge that has not ruptured, at surface gap ``gap`` [m]:
    :func:`capillary_force_scalar` at max(gap, 0⁺) (touching or overlapping pairs get the value at
    contact). This is the value the engine computes for every live bridge, applied while the
    pair is separated (and in contact too with ``capillary_in_contact``)."""
    return capillary_force_scalar(model, gap if gap > 0.0 else 0.0, v_b, r_eff, gamma, theta)


#: columns of a bridge-constants row (:func:`bridge_constants`)
BRIDGE_CONSTANTS = ("v_b", "s_crit", "f_contact", "f1", "f2", "f3", "f4", "root")


@njit(cache=True, inline="always")
def bridge_constants(model, v_b, r_eff, gamma, theta, table, k):
    """Fill row ``k`` of ``table`` (:data:`BRIDGE_CONSTANTS`) with what a bridge's force and
    rupture test need that depends only on its volume (v_b > 0): the volume itself (the row's
    key), s_crit (:func:`rupture_distance_scalar`), the force at contact (:func:`bridge_force` at
    s ≤ 0) and, for ``willett_numeric``, f1 … f4 and √(V_b/R). A bridge's volume changes only
    when liquid migrates, so the engine computes these once per volume instead of every step;
    :func:`bridge_force_from_constants` then gives bit for bit what :func:`bridge_force` gives."""
    table[k, 0] = v_b
    table[k, 1] = rupture_distance_scalar(v_b, r_eff, theta)
    table[k, 2] = capillary_force_scalar(model, 0.0, v_b, r_eff, gamma, theta)
    if model == 0:
        f1, f2, f3, f4 = _willett_coefficients(v_b, r_eff, theta)
        table[k, 3] = f1
        table[k, 4] = f2
        table[k, 5] = f3
        table[k, 6] = f4
        table[k, 7] = math.sqrt(v_b / r_eff)


@njit(cache=True, inline="always")
def bridge_force_from_constants(model, gap, v_b, r_eff, gamma, theta, table, k):
    """:func:`bridge_force` of a bridge whose row ``k`` of ``table`` holds its constants
    (:func:`bridge_constants`, same v_b > 0)."""
    if gap <= 0.0:
        return table[k, 2]
    if model == 0:
        return min(_willett_separated(gap, r_eff, gamma, table[k, 3], table[k, 4], table[k, 5], table[k, 6],
                                      table[k, 7]), 2.0 * math.pi * r_eff * gamma)
    return capillary_force_scalar(model, gap, v_b, r_eff, gamma, theta)


@njit(cache=True)
def pair_bridge_force(model, gap, r_i, r_j, v_b, gamma, theta):
    """The engine's capillary force law for one pair, in one function: 0 once the bridge has
    ruptured (:func:`bridge_ruptured`), else :func:`bridge_force`, with the effective radius of
    radii ``r_i``, ``r_j`` (``r_j = inf``: a wall). Used by the public ``sim.capillary_force``."""
    r_eff = effective_radius(r_i, r_j)
    if bridge_ruptured(gap, v_b, r_eff, theta):
        return 0.0
    return bridge_force(model, gap, v_b, r_eff, gamma, theta)


@njit(cache=True)
def viscous_force(eta, r_i, r_j, v_n, s, v_b):
    """Pitois et al. (2000) normal lubrication force of an active bridge (docs/physics.md,
    "Liquid bridges").

    F_vis = 6πη·R*²·v_n/s·(1 − 1/√(1 + 2V_b/(πR*·s²)))², R* = R_i·R_j/(R_i + R_j), with s
    replaced by max(s, 1e-3·R*). The bracket is evaluated as b/(p(p + s)), b = 2V_b/(πR*),
    p = √(s² + b) (the same expression, without cancellation at large s).

    Parameters
    ----------
    eta : float
        Liquid viscosity [Pa s].
    r_i, r_j : float
        Radii [m]; for a wall pass ``r_j = inf`` (then R* = r_i).
    v_n : float
        Normal relative velocity [m/s], > 0 when approaching.
    s : float
        Surface-to-surface gap [m].
    v_b : float
        Bridge volume [m³].

    Returns
    -------
    float
        F_vis [N], with the sign of v_n: > 0 opposes approach (pushes the pair apart), < 0
        opposes separation; 0.0 when v_b ≤ 0.
    """
    if v_b <= 0.0:
        return 0.0
    r_star = 1.0 / (1.0 / r_i + 1.0 / r_j)
    s = max(s, 1e-3 * r_star)
    b = 2.0 * v_b / (math.pi * r_star)
    p = math.sqrt(s * s + b)
    bracket = b / (p * (p + s))
    return 6.0 * math.pi * eta * r_star * r_star * v_n / s * bracket * bracket


@njit(cache=True)
def _force_loop(model, s, v_b, r_eff, gamma, theta, out):
    """Fill ``out`` with :func:`capillary_force_scalar` over equal-length 1-D arrays."""
    for k in range(out.size):
        out[k] = capillary_force_scalar(model, s[k], v_b[k], r_eff[k], gamma[k], theta[k])


def capillary_force_curve(model: str, s, v_b, r_eff, gamma, theta=0.0) -> np.ndarray:
    """Capillary force over arrays of gaps (and optionally other parameters).

    Parameters
    ----------
    model : str
        A key of :data:`CAPILLARY_MODELS`.
    s : array_like
        Surface-to-surface gaps [m].
    v_b : array_like
        Bridge volume(s) [m³].
    r_eff : array_like
        Effective radius (radii) 2·R_i·R_j/(R_i + R_j) [m].
    gamma : array_like
        Surface tension(s) [N/m].
    theta : array_like, optional
        Contact angle(s) [rad], default 0.

    All arguments are broadcast together.

    Returns
    -------
    numpy.ndarray
        F ≥ 0 [N] of :func:`capillary_force_scalar`, float64, of the broadcast shape. The force is
        evaluated at every gap; rupture (s ≥ :func:`rupture_distance_scalar`) is not applied.

    Raises
    ------
    ValueError
        If ``model`` is not a key of :data:`CAPILLARY_MODELS`.
    """
    if model not in CAPILLARY_MODELS:
        raise ValueError(
            f"unknown capillary model {model!r}; valid models: {', '.join(CAPILLARY_MODELS)}"
        )
    args = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64)
                                 for x in (s, v_b, r_eff, gamma, theta)))
    flat = [np.array(x, dtype=np.float64).ravel() for x in args]
    out = np.empty(flat[0].size)
    _force_loop(CAPILLARY_MODELS[model], *flat, out)
    return out.reshape(args[0].shape)


@njit(cache=True)
def _pair_force_loop(model, gap, r1, r2, v_b, gamma, theta, out):
    for k in range(out.size):
        out[k] = pair_bridge_force(model, gap[k], r1[k], r2[k], v_b[k], gamma[k], theta[k])


@njit(cache=True)
def _pair_rupture_loop(v_b, r1, r2, theta, out):
    for k in range(out.size):
        out[k] = rupture_distance_scalar(v_b[k], effective_radius(r1[k], r2[k]), theta[k])


def _flat_float_arrays(*values):
    """Broadcast ``values`` together; contiguous flat float64 copies and the common shape."""
    args = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in values))
    return [np.array(x, dtype=np.float64).ravel() for x in args], args[0].shape  # copies: writeable, contiguous


def pair_rupture_distance(bridge_volume, r1, r2, contact_angle=0.0) -> np.ndarray:
    """Rupture distance s_crit [m] of bridges between spheres of radii r1, r2 [m] (arrays
    broadcast; r2 = inf for a wall), bridge volume [m³], contact angle [rad]. Exported as
    ``sim.rupture_distance``."""
    (v, a, b, th), shape = _flat_float_arrays(bridge_volume, r1, r2, contact_angle)
    out = np.empty(v.size)
    _pair_rupture_loop(v, a, b, th, out)
    return out.reshape(shape)


def pair_capillary_force(gap, r1, r2, bridge_volume, surface_tension, contact_angle=0.0, model="willett_numeric") -> np.ndarray:
    """Attractive capillary force [N] ≥ 0 of bridges between spheres of radii r1, r2 [m] at
    surface gap ``gap`` [m] (arrays broadcast; r2 = inf for a wall): the model's value at
    max(gap, 0⁺) while gap < s_crit, 0 from the rupture distance on. Exported as
    ``sim.capillary_force``; ``model`` is one of :data:`CAPILLARY_MODELS`.

    This is the engine's own law (:func:`pair_bridge_force`, the same compiled code the time
    step uses), so for every live pair of a frame written by the simulator it returns the
    frame's ``f_cap`` bit for bit, given the frame's gap, radii and bridge volume.
    """
    if model not in CAPILLARY_MODELS:
        raise ValueError(
            f"unknown capillary model {model!r}; valid models: {', '.join(CAPILLARY_MODELS)}"
        )
    (s, a, b, v, g, th), shape = _flat_float_arrays(gap, r1, r2, bridge_volume, surface_tension, contact_angle)
    out = np.empty(s.size)
    _pair_force_loop(CAPILLARY_MODELS[model], s, a, b, v, g, th, out)
    return out.reshape(shape)
