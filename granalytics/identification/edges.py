"""Contact graphs in and out: the contact table of a frame (the columns user edge criteria can
use, see :class:`granalytics.identification.CustomEdges`), and the kept graph of an identification as
NetworkX / igraph objects or an edge list."""

from __future__ import annotations

import pandas as pd

from granalytics.identification.cohesion import DEFAULT_COHESION
from granalytics.identification.contacts import contact_table
from granalytics.base.errors import ParameterError
from granalytics.identification.result import RESULT, IdentificationResult
from granalytics.base.validation import validate_params

__all__ = ["contact_table", "edge_table", "to_networkx", "to_igraph"]


@validate_params({"result": [RESULT]})
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
