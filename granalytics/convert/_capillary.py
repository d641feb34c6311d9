"""Capillary bridge forces that another code applied but did not export, filled in by its reader
so that a converted run keeps the run-file contract (``docs/format.md``: ``f_cap`` is the bridge
force at max(s, 0⁺) for every wet pair, touching or not).

Only the limit s → 0⁺ is needed: a code's export gives the force of its separated bridges, and a
touching wet pair carries the bridge at s → 0⁺ (whether the code applied it there is the run's
``capillary_in_contact``). ``tests/test_yade.py`` checks these against the simulator's own
capillary models (``sim.capillary``), which follow YADE's source.
"""

from __future__ import annotations

import numpy as np

__all__ = ["willett_numeric_contact_force", "effective_radius"]


def effective_radius(r_i, r_j):
    """The pair radius of the capillary laws, R = 2·r_i·r_j/(r_i + r_j) [m] (YADE's ViscElCapPhys)."""
    r_i, r_j = np.asarray(r_i, dtype=float), np.asarray(r_j, dtype=float)
    return 2.0 * r_i * r_j / (r_i + r_j)


def willett_numeric_contact_force(bridge_volume_m3, radius_m, surface_tension, contact_angle_rad):
    """Willett's (2000) numeric fit of a pendular bridge at s → 0⁺: F = 2πRγ·exp(f1), with
    f1 = a0(θ) + a1(θ)·L + a2(θ)·L² + a3(θ)·L³, L = ln(V_b/R³), capped at 2πRγ (YADE's
    ``Willett_numeric``; ``docs/physics.md``, "Capillary models").

    Parameters
    ----------
    bridge_volume_m3 : array
        Bridge volumes V_b > 0 [m³].
    radius_m : array
        Pair radii R [m] (:func:`effective_radius`).
    surface_tension : float
        γ [N/m].
    contact_angle_rad : float
        θ [rad].

    Returns
    -------
    array
        F_cap(0⁺) [N].
    """
    v = np.asarray(bridge_volume_m3, dtype=float)
    r = np.asarray(radius_m, dtype=float)
    t = float(contact_angle_rad)
    t2 = t * t
    lv = np.log(v / r**3)
    f1 = ((-0.44507 + 0.050832 * t - 1.1466 * t2)
          + (-0.1119 - 0.000411 * t - 0.1490 * t2) * lv
          + (-0.012101 - 0.0036456 * t - 0.01255 * t2) * lv**2
          + (-0.0005 - 0.0003505 * t - 0.00029076 * t2) * lv**3)
    scale = 2.0 * np.pi * r * surface_tension
    return np.minimum(scale * np.exp(f1), scale)
