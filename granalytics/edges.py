"""Contact graphs in and out: the contact table of a frame (the columns user edge criteria can
use, see :class:`granalytics.identify.CustomEdges`), and the kept graph of an identification as
NetworkX / igraph objects or an edge list."""

from __future__ import annotations


import numpy as np
import pandas as pd

from .cohesion import DEFAULT_COHESION, cohesive_force
from .errors import ParameterError
from .identify.common import contact_strength
from .identify.result import IdentificationResult
from .snapshot import Snapshot

__all__ = ["contact_table", "edge_table", "to_networkx", "to_igraph"]


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


def edge_table(result: IdentificationResult) -> pd.DataFrame:
    """The contacts a contact-based identification kept, with their granule label."""
    if result.kept is None:
        raise ParameterError(f"method {result.method!r} does not select contacts")
    table = contact_table(result.snapshot, cohesion=result.params.get("cohesion", DEFAULT_COHESION))
    table = table[result.kept].reset_index(drop=True)
    table["granule"] = result.labels[table["i"].to_numpy()]
    return table


def to_networkx(result: IdentificationResult):
    """The kept contact graph as a ``networkx.Graph`` on particle ids, with node attribute
    ``granule`` and edge attributes from :func:`edge_table`."""
    import networkx as nx

    graph = nx.Graph()
    ids = result.snapshot.ids
    graph.add_nodes_from((int(pid), {"granule": int(g)}) for pid, g in zip(ids, result.labels))
    edges = edge_table(result)
    attrs = edges.drop(columns=["i", "j", "id_i", "id_j"]).to_dict("records")
    graph.add_edges_from(zip(edges["id_i"].tolist(), edges["id_j"].tolist(), attrs))
    return graph


def to_igraph(result: IdentificationResult):
    """The kept contact graph as an ``igraph.Graph`` (vertex k = particle row k, attributes
    ``id`` and ``granule``; edge attributes from :func:`edge_table`)."""
    import igraph

    edges = edge_table(result)
    graph = igraph.Graph(n=result.snapshot.n_particles, edges=edges[["i", "j"]].to_numpy().tolist())
    graph.vs["id"] = result.snapshot.ids.tolist()
    graph.vs["granule"] = result.labels.tolist()
    for column in edges.columns.drop(["i", "j"]):
        graph.es[column] = edges[column].tolist()
    return graph
