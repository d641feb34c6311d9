"""Granule identification methods behind one interface.

Every method is an object with parameters in its constructor and ``identify(snapshot)``
returning an :class:`IdentificationResult`; :func:`identify` is the functional shortcut.
"""

from __future__ import annotations

import inspect

from granalytics.base.errors import ParameterError
from granalytics.identification.common import Identifier
from granalytics.identification.community import CommunityDetection
from granalytics.identification.custom import CustomEdges
from granalytics.identification.dbscan import DBSCANClustering
from granalytics.identification.gna import BACKENDS, GraphNetworkAnalysis
from granalytics.identification.result import IdentificationResult
from granalytics.identification.sieve import VirtualSieve, sieve_analysis
from granalytics.base.validation import validate_params
from granalytics.core.snapshot import SNAPSHOT

__all__ = [
    "identify", "make_identifier", "METHODS", "DEFAULT_METHODS", "BACKENDS", "method_parameters", "accepted_params", "IdentificationResult", "Identifier",
    "GraphNetworkAnalysis", "DBSCANClustering", "VirtualSieve", "CommunityDetection", "CustomEdges", "sieve_analysis",
]

#: method name -> identifier class
METHODS = {
    "gna": GraphNetworkAnalysis,
    "dbscan": DBSCANClustering,
    "sieve": VirtualSieve,
    "community": CommunityDetection,
    "custom": CustomEdges,
}


def method_parameters(method) -> tuple:
    """Names of the constructor parameters of ``method`` (a :data:`METHODS` key)."""
    try:
        cls = METHODS[method]
    except (KeyError, TypeError):  # TypeError: an unhashable method (a list)
        raise ParameterError(f"unknown method {method!r}; available: {sorted(METHODS)}") from None
    return tuple(inspect.signature(cls).parameters)


def accepted_params(method, **candidates) -> dict:
    """The ``candidates`` that ``method`` accepts, the others dropped: a command's shared options
    (``c_agg``, ``a_agg_deg``, ``cohesion``) handed to whichever method was chosen."""
    names = method_parameters(method)
    return {k: v for k, v in candidates.items() if k in names}


#: the methods that run with their defaults: every one but ``custom`` (it needs a criterion), the
#: choices of the command line's ``--method``
DEFAULT_METHODS = tuple(name for name, cls in METHODS.items()
                        if all(p.default is not inspect.Parameter.empty for p in inspect.signature(cls).parameters.values()))


def make_identifier(method="gna", **params):
    """Build the identifier object of ``method`` with ``params``, its parameters checked against
    their constraints at once (text from ``--set`` is refused before any frame is read)."""
    try:
        cls = METHODS[method]
    except (KeyError, TypeError):  # TypeError: an unhashable method (a list)
        raise ParameterError(f"unknown method {method!r}; available: {sorted(METHODS)}") from None
    try:
        identifier = cls(**params)
    except TypeError as exc:
        raise ParameterError(f"method {method!r}: {exc}") from None
    identifier._validate_params()
    return identifier


@validate_params({"snapshot": [SNAPSHOT]})
def identify(snapshot, method="gna", **params) -> IdentificationResult:
    """Identify granules in one snapshot.

    Parameters
    ----------
    snapshot : Snapshot
    method : {"gna", "dbscan", "sieve", "community"}, default "gna"
        One of :data:`METHODS`.
    **params
        Constructor parameters of the method, e.g. for ``"gna"``: ``c_agg=0.6``,
        ``a_agg_deg=20.0``, ``radius="pair"``, ``backend="fast"``; for ``"dbscan"``:
        ``eps_diameters``, ``min_samples``; for ``"sieve"``: ``connect``, ``apertures_m``;
        for ``"community"``: ``c_agg``, ``a_agg_deg``, ``resolution``, ``seed``.

    Examples
    --------
    >>> result = identify(snapshot, c_agg=0.6, a_agg_deg=20)    # doctest: +SKIP
    >>> result.labels, result.granules                          # doctest: +SKIP
    """
    return make_identifier(method, **params).identify(snapshot)
