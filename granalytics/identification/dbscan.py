"""Density-based clustering (DBSCAN, scikit-learn) as a granule identification method.

Features are particle positions in units of the run's mean particle diameter d̄ (so ``eps`` means
the same at every CG level), optionally with velocities appended. scikit-learn clusters a
precomputed sparse neighbourhood graph: all pairs closer than ``eps`` (``radius_neighbors_graph``),
or only the pairs that share a liquid bridge (``bridged_only=True``).

With ``min_samples=2`` every particle with a neighbour is a core point and the clusters are the
connected components of the ε-graph, independent of particle order. With larger
``min_samples``, scikit-learn assigns a border point to the first cluster that reaches it, which
can depend on particle order.
"""

from __future__ import annotations

import math
from numbers import Integral, Real

import numpy as np
from scipy.sparse import coo_matrix

from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION, cohesion_counts
from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import Snapshot
from granalytics.identification.common import Identifier, labels_from_clusters, mean_radius
from granalytics.identification.result import IdentificationResult
from granalytics.base.validation import FLAG, POSITIVE, Interval

__all__ = ["DBSCANClustering"]


class DBSCANClustering(Identifier):
    """Granules as DBSCAN clusters (method ``"dbscan"``).

    Parameters
    ----------
    eps_diameters : float, default 1.05
        Neighbourhood radius in units of the mean particle diameter d̄ (centre distance; 1.0
        is touching for equal spheres). A bridge ruptures at about 0.1–0.2 d̄ beyond touching.
    min_samples : int, default 2
        scikit-learn's ``min_samples`` (the point itself included).
    bridged_only : bool, default True
        Only pairs that share a liquid bridge (bridge volume > 0) whose force counts as
        cohesion under ``cohesion`` can be neighbours. The defaults were chosen on the bundled
        drums (lab-cg3 and lab-cg1, revolutions [3, 3.5]): on positions alone a dense bed is one
        cluster (``bridged_only=False``: yield 0.999 and 0.995 at ε = 1.1 d̄, 0.81 and 0.83 even at
        ε = 1.0 d̄); acting bridges within 1.05 d̄ give 0.39 and 0.60, where GNA gives 0.40 and 0.56.
    velocity_weight : float, default 0
        Append velocity features v / v_rms · weight (v_rms: RMS particle speed of the frame), so
        that a unit of velocity difference counts like one mean diameter of distance times the
        weight. 0 clusters on positions alone.
    cohesion : {"acting", "bridge"}, default "acting"
        Which bridges count for ``bridged_only`` (:mod:`granalytics.identification.cohesion`): ``"bridge"``
        every wet pair, ``"acting"`` only those whose bridge force acted (separated pairs,
        unless the run applied capillary force in contact).
    """

    method = "dbscan"
    _parameter_constraints = {
        "eps_diameters": [POSITIVE], "min_samples": [Interval(Integral, 1, None)], "bridged_only": [FLAG],
        "velocity_weight": [Interval(Real, 0, None)], "cohesion": [COHESION],
    }

    def __init__(self, eps_diameters=1.05, min_samples=2, *, bridged_only=True, velocity_weight=0.0,
                 cohesion=DEFAULT_COHESION):
        self.eps_diameters = eps_diameters
        self.min_samples = min_samples
        self.bridged_only = bridged_only
        self.velocity_weight = velocity_weight
        self.cohesion = cohesion

    def _features(self, snapshot):
        diameter = 2.0 * mean_radius(snapshot)
        x = snapshot.position / diameter
        if self.velocity_weight:
            v_rms = math.sqrt(float((snapshot.velocity**2).sum(axis=1).mean()))
            if v_rms == 0:
                raise ParameterError("velocity_weight > 0 but every particle is at rest in this frame")
            x = np.hstack([x, snapshot.velocity / v_rms * float(self.velocity_weight)])
        return x

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Cluster one snapshot; particles in clusters of ≥ 2 are granules."""
        from sklearn.cluster import DBSCAN
        from sklearn.neighbors import radius_neighbors_graph

        eps = float(self.eps_diameters)
        x = self._features(snapshot)
        n = snapshot.n_particles
        if self.bridged_only:
            wet = (snapshot.bridge_volume > 0) & cohesion_counts(snapshot, self.cohesion)
            i, j = snapshot.contact_i[wet], snapshot.contact_j[wet]
            d = np.linalg.norm(x[i] - x[j], axis=1)
            near = d <= eps
            i, j, d = i[near], j[near], d[near]
            # stored distances must be > 0 to count as edges; coincident points get a tiny one
            d = np.maximum(d, np.finfo(float).tiny)
            graph = coo_matrix((np.r_[d, d], (np.r_[i, j], np.r_[j, i])), shape=(n, n)).tocsr()
        else:
            graph = radius_neighbors_graph(x, radius=eps, mode="distance", include_self=False)
        clusters = DBSCAN(eps=eps, min_samples=int(self.min_samples), metric="precomputed").fit_predict(graph)
        labels, sizes = labels_from_clusters(clusters)
        return IdentificationResult(labels=labels, sizes=sizes, method=self.method, params=self.params(),
                                    snapshot=snapshot)

