"""Pieces shared by the identification methods: the system's γ and mean radius, the
normalised capillary force f = F_coh/(2πγR) and the co-motion test of every contact."""

from __future__ import annotations

import math

import numpy as np

from .. import _kernels
from ..cohesion import DEFAULT_COHESION, cohesive_force
from ..errors import ParameterError
from ..snapshot import Snapshot


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


def check_angle(a_agg_deg) -> float:
    a = float(a_agg_deg)
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


def labels_from_clusters(cluster) -> tuple[np.ndarray, np.ndarray]:
    """Canonical labels and sizes from cluster ids in which −1 marks unclustered points."""
    cluster = np.asarray(cluster, dtype=np.int64)
    membership = cluster.copy()
    noise = np.flatnonzero(cluster < 0)
    membership[noise] = (cluster.max() + 1 if cluster.size else 0) + np.arange(noise.size)
    if membership.size and membership.max() >= membership.size:  # compact ids into [0, N)
        membership = np.unique(membership, return_inverse=True)[1].astype(np.int64)
    return _kernels.canonical_labels(membership)
