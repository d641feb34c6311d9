"""Graph network analysis (GNA), §2.2 of the paper, with interchangeable graph backends.

A contact (i, j) is kept when both criteria hold:

1. cohesion: ``F_coh ≥ C_agg · 2πγR``, with F_coh under the ``cohesion`` convention
   (``"acting"``: the force the DEM code applied; ``"bridge"``: the bridge force of every wet
   pair, touching or not; see :mod:`granalytics.identification.cohesion`), γ the surface tension of the run and R the pair's
   effective radius ``R* = 2RiRj/(Ri+Rj)`` (default, ``radius="pair"``) or the run's mean
   particle radius (``radius="mean"``). Because γ and R are those of the analysed system, a
   coarse-grained run (γ·α, R·α) gets ``F_agg,CG = α²·F_agg,o`` automatically (§3.1).
2. co-motion, by one of two tests (``comotion``):

   - ``"angle"`` (the paper's, default): ``angle(v_i, v_j) < A_agg`` **or** ``angle(ω_i, ω_j) < A_agg``.
     A zero vector has no direction, so an angle involving one never passes; the pair can still
     pass through the other vector. The drum's rotation alone puts an angle of about d/r between
     neighbours' velocities (r the distance from the axis), so this test is harder to pass for
     larger (coarse-grained) particles.
   - ``"rigid"``: the pair moves as one rigid body to within ``rigid_tol``:
     ``|v_j − v_i − ω̄ × (r_j − r_i)| < rigid_tol · V`` with ω̄ = (ω_i + ω_j)/2 and V the velocity
     scale ``rigid_scale``: √(g·d), d = R_i + R_j (default), or the drum's rim speed Ω·R_d
     (:func:`granalytics.identification.contacts.co_moving_rigid`). A rigid granule passes exactly, whatever its
     particles' size, and so does the drum's solid-body rotation.

Granules are the connected components of the kept contacts with at least ``min_size`` particles
(default 2: every bonded pair is a granule).
"""

from __future__ import annotations

import math

import networkx as nx
import numpy as np

from granalytics.identification import kernels as _kernels
from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION, cohesion_counts_all
from granalytics.core.snapshot import Snapshot
from granalytics.identification.contacts import (COMOTION, DEFAULT_COMOTION, DEFAULT_RIGID_SCALE, DEFAULT_RIGID_TOL, RIGID_SCALE,
                                                 co_moving_rigid, contact_strength)
from granalytics.identification.common import (A_AGG_DEG, C_AGG, MIN_SIZE, PAPER_A_AGG_DEG, PAPER_C_AGG, RADIUS_MODE, Identifier,
                                               mean_radius, surface_tension)
from granalytics.identification.result import IdentificationResult
from granalytics.base.validation import POSITIVE, Options

__all__ = ["GraphNetworkAnalysis", "BACKENDS"]


def _membership_networkx(n, ei, ej):
    """The paper's pipeline: an nx.Graph of kept contacts, BFS connected components."""
    graph = nx.Graph()
    graph.add_nodes_from(range(n))
    graph.add_edges_from(zip(ei.tolist(), ej.tolist()))
    membership = np.empty(n, dtype=np.int64)
    for c, nodes in enumerate(nx.connected_components(graph)):
        membership[list(nodes)] = c
    return membership


def _membership_igraph(n, ei, ej):
    import igraph

    graph = igraph.Graph(n=n, edges=np.column_stack([ei, ej]).tolist(), directed=False)
    return np.asarray(graph.connected_components(mode="weak").membership, dtype=np.int64)


def _membership_scipy(n, ei, ej):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    adjacency = coo_matrix((np.ones(ei.size, dtype=np.int8), (ei, ej)), shape=(n, n))
    _, membership = connected_components(adjacency, directed=False)
    return membership.astype(np.int64)


#: graph backends: name -> function(n, edge_i, edge_j) -> component id per node.
#: ``"fast"`` is the fused numba kernel and is handled separately.
BACKENDS = {
    "fast": None,
    "networkx": _membership_networkx,
    "igraph": _membership_igraph,
    "scipy": _membership_scipy,
}


class GraphNetworkAnalysis(Identifier):
    """Granule identification by graph network analysis (method ``"gna"``).

    Parameters
    ----------
    c_agg : float, default 0.6
        Cohesion threshold coefficient: keep a contact when F_coh ≥ c_agg·2πγR. ≥ 0.
    a_agg_deg : float, default 20
        Co-motion threshold angle A_agg [degrees], in (0, 180].
    radius : {"pair", "mean"}, default "pair"
        R in 2πγR: the pair's effective radius 2RiRj/(Ri+Rj), or the run's mean radius
        (``meta.mean_radius``, else the snapshot's mean radius).
    backend : {"fast", "networkx", "igraph", "scipy"}, default "fast"
        Connected-components implementation. All give identical labels.
    surface_tension : float, optional
        γ [N/m]; defaults to the snapshot's ``meta.surface_tension``.
    cohesion : {"acting", "bridge"}, default "acting"
        Which force is F_coh (:mod:`granalytics.identification.cohesion`).
    comotion : {"angle", "rigid"}, default "angle"
        The co-motion test (module docstring): the paper's angle test at ``a_agg_deg``, or the
        rigid-pair test at ``rigid_tol``.
    rigid_tol : float, default 0.2
        Tolerance of the rigid test: non-rigid relative velocity below ``rigid_tol`` · V
        (dimensionless, > 0); used with ``comotion="rigid"``.
    rigid_scale : {"granular", "drum"}, default "granular"
        V of the rigid test: √(|g|·(R_i + R_j)) per pair, or the drum's rim speed Ω·R_d.
    speed_scale : float, optional
        V [m/s] for every pair instead of ``rigid_scale`` (e.g. for a run without gravity or drum
        radius in its metadata).
    min_size : int, default 2
        Fewest particles a granule has; smaller connected groups are free particles (−1).
    """

    method = "gna"
    _parameter_constraints = {
        "c_agg": [C_AGG], "a_agg_deg": [A_AGG_DEG], "radius": [RADIUS_MODE], "backend": [Options(BACKENDS)],
        "surface_tension": [POSITIVE, None], "cohesion": [COHESION], "comotion": [COMOTION], "rigid_tol": [POSITIVE],
        "rigid_scale": [RIGID_SCALE], "speed_scale": [POSITIVE, None], "min_size": [MIN_SIZE],
    }

    def __init__(self, c_agg=PAPER_C_AGG, a_agg_deg=PAPER_A_AGG_DEG, *, radius="pair", backend="fast", surface_tension=None,
                 cohesion=DEFAULT_COHESION, comotion=DEFAULT_COMOTION, rigid_tol=DEFAULT_RIGID_TOL,
                 rigid_scale=DEFAULT_RIGID_SCALE, speed_scale=None, min_size=2):
        self.c_agg = c_agg
        self.a_agg_deg = a_agg_deg
        self.radius = radius
        self.backend = backend
        self.surface_tension = surface_tension
        self.cohesion = cohesion
        self.comotion = comotion
        self.rigid_tol = rigid_tol
        self.rigid_scale = rigid_scale
        self.speed_scale = speed_scale
        self.min_size = min_size

    def kernel_args(self, snapshot: Snapshot) -> tuple:
        """Arguments of the numba GNA kernels after ``(ci, cj, f_coh, radius, vel, omega)``:
        ``(2πγ, mean_radius or 0, c_agg, cos A_agg)``."""
        self._validate_params()
        gamma = surface_tension(snapshot, self.surface_tension)
        r_mean = mean_radius(snapshot) if self.radius == "mean" else 0.0
        return 2.0 * math.pi * gamma, r_mean, float(self.c_agg), math.cos(math.radians(float(self.a_agg_deg)))

    def contact_mask(self, snapshot: Snapshot) -> np.ndarray:
        """Boolean mask of the contacts that pass both criteria."""
        args = self.kernel_args(snapshot)
        if self.comotion == "rigid":
            return self._rigid_mask(snapshot, args[2])
        return _kernels.gna_contact_mask(*_contact_arrays(snapshot, self.cohesion), *args)

    def _rigid_mask(self, snapshot, c_agg):
        """Both criteria with the rigid co-motion test: f = F_coh/(2πγR) ≥ C_agg (the value the
        angle kernels compare) and :func:`~granalytics.identification.contacts.co_moving_rigid`."""
        strength = contact_strength(snapshot, self.radius, self.surface_tension, self.cohesion)
        return (strength >= c_agg) & co_moving_rigid(snapshot, self.rigid_tol, self.rigid_scale, self.speed_scale)

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Identify granules in one snapshot.

        Returns
        -------
        IdentificationResult
            ``labels`` (−1 = free), ``sizes``, and ``kept`` (the contacts that passed).
        """
        args = self.kernel_args(snapshot)
        if self.backend == "fast" and self.comotion == "angle":
            labels, sizes, kept = _kernels.gna_fused(*_contact_arrays(snapshot, self.cohesion), *args)
        else:
            kept = self.contact_mask(snapshot)
            if self.backend == "fast":
                labels, sizes = _kernels.merge_and_label(snapshot.n_particles, snapshot.contact_i, snapshot.contact_j, kept)
            else:
                membership = BACKENDS[self.backend](
                    snapshot.n_particles, snapshot.contact_i[kept], snapshot.contact_j[kept]
                )
                labels, sizes = _kernels.canonical_labels(membership)
        labels, sizes = drop_small_granules(labels, sizes, self.min_size)
        return IdentificationResult(
            labels=labels, sizes=sizes, method=self.method, params=self.params(),
            snapshot=snapshot, kept=kept,
        )


def drop_small_granules(labels, sizes, min_size):
    """Canonical ``labels`` and ``sizes`` without the granules of fewer than ``min_size``
    particles (their particles become free, −1); the others keep their numbers (sizes are
    non-increasing, so the dropped granules are the last ones)."""
    if min_size <= 2:
        return labels, sizes
    n_keep = int(np.count_nonzero(sizes >= min_size))
    labels = np.where(labels >= n_keep, -1, labels)
    return labels, sizes[:n_keep]


def _contact_arrays(snapshot: Snapshot, cohesion) -> tuple:
    """``(ci, cj, f_cap, gap, all_count, radius, vel, omega)`` for the GNA kernels: the
    cohesion convention is applied inside them (:func:`granalytics.identification.cohesion.cohesion_counts`)."""
    all_count = cohesion_counts_all(snapshot, cohesion)
    gap = np.zeros(0) if all_count else snapshot.gap
    return (
        snapshot.contact_i, snapshot.contact_j, snapshot.f_cap, gap, all_count, snapshot.radius,
        snapshot.velocity, snapshot.angular_velocity,
    )
