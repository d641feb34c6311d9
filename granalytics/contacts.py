"""Per-contact quantities shared by the identification methods, the threshold sweep and the
contact table: the system's γ and mean radius, the normalised cohesion f = F_coh/(2πγR) under a
cohesion convention, and the co-motion test of every contact."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from . import _kernels
from .cohesion import DEFAULT_COHESION, cohesive_force
from .errors import ParameterError
from .snapshot import Snapshot

__all__ = ["surface_tension", "mean_radius", "check_radius_mode", "as_number", "check_angle", "contact_strength", "co_moving",
           "contact_table"]


def surface_tension(snapshot: Snapshot, override=None) -> float:
    """γ [N/m]: ``override`` if given, else the run metadata's."""
    gamma = override
    if gamma is None:
        if snapshot.meta is None:
            raise ParameterError("the snapshot has no run metadata: pass surface_tension= (N/m)")
        gamma = snapshot.meta.surface_tension
    gamma = float(gamma)
    if not (math.isfinite(gamma) and gamma > 0):
        raise ParameterError(f"surface_tension must be > 0 N/m, got {gamma!r}")
    return gamma


def mean_radius(snapshot: Snapshot) -> float:
    """The run's mean particle radius [m] (metadata, else the frame's)."""
    return snapshot.meta.mean_radius if snapshot.meta is not None else float(snapshot.radius.mean())


def check_radius_mode(radius) -> None:
    if radius not in ("pair", "mean"):
        raise ParameterError(f"radius must be 'pair' or 'mean', got {radius!r}")


def as_number(name, value, requirement) -> float:
    """``value`` as a float; a bool, a string or another non-number raises a
    :class:`ParameterError` naming ``name`` and the ``requirement``."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise ParameterError(f"{name} must be {requirement}, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be {requirement}, got {value!r}") from None


def check_angle(a_agg_deg) -> float:
    """A_agg [deg] as a float in (0, 180]."""
    a = as_number("a_agg_deg", a_agg_deg, "a number of degrees in (0, 180]")
    if not 0 < a <= 180:
        raise ParameterError(f"a_agg_deg must be in (0, 180] degrees, got {a_agg_deg!r}")
    return a


def contact_strength(snapshot: Snapshot, radius="pair", gamma=None, cohesion=DEFAULT_COHESION) -> np.ndarray:
    """f = F_coh / (2πγR) of every contact, with R the pair's 2RiRj/(Ri+Rj) or the mean radius
    and F_coh under the ``cohesion`` convention (:mod:`granalytics.cohesion`).

    Bit-identical to the value the GNA kernels compare with C_agg.
    """
    check_radius_mode(radius)
    r_mean = mean_radius(snapshot) if radius == "mean" else 0.0
    return _kernels.contact_strength(
        snapshot.contact_i, snapshot.contact_j, cohesive_force(snapshot, cohesion), snapshot.radius,
        2.0 * math.pi * surface_tension(snapshot, gamma), r_mean,
    )


def co_moving(snapshot: Snapshot, a_agg_deg) -> np.ndarray:
    """Contacts whose velocities or angular velocities make an angle below A_agg [deg]."""
    cos_a = math.cos(math.radians(check_angle(a_agg_deg)))
    return _kernels.co_moving(snapshot.contact_i, snapshot.contact_j, snapshot.velocity, snapshot.angular_velocity, cos_a)


def _angles_deg(a, b):
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.clip((a * b).sum(axis=1) / (na * nb), -1.0, 1.0)
    return np.where((na == 0) | (nb == 0), np.nan, np.degrees(np.arccos(cos)))


def contact_table(snapshot: Snapshot, radius="pair", surface_tension=None, cohesion=DEFAULT_COHESION) -> pd.DataFrame:
    """One row per contact or bridge, the columns user criteria can use.

    Columns: ``i``, ``j`` (particle rows), ``id_i``, ``id_j``, ``f_cap`` [N] (the bridge force
    at max(s, 0⁺)), ``f_coh`` [N] (F_coh under ``cohesion``, :mod:`granalytics.cohesion`),
    ``f_normal`` [N], ``gap`` [m], ``bridge_volume`` [m³], ``f_norm`` (F_coh/(2πγR), as GNA
    compares with C_agg),
    ``angle_v_deg`` and ``angle_w_deg`` (angles between the velocities and between the angular
    velocities [deg]; NaN when a vector is zero).
    """
    i, j = snapshot.contact_i, snapshot.contact_j
    return pd.DataFrame({
        "i": i, "j": j, "id_i": snapshot.ids[i], "id_j": snapshot.ids[j],
        "f_cap": snapshot.f_cap, "f_coh": cohesive_force(snapshot, cohesion), "f_normal": snapshot.f_normal,
        "gap": snapshot.gap, "bridge_volume": snapshot.bridge_volume,
        "f_norm": contact_strength(snapshot, radius, surface_tension, cohesion),
        "angle_v_deg": _angles_deg(snapshot.velocity[i], snapshot.velocity[j]),
        "angle_w_deg": _angles_deg(snapshot.angular_velocity[i], snapshot.angular_velocity[j]),
    })
