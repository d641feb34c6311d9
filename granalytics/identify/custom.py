"""User-defined edge criteria as a variant of graph network analysis (method ``"custom"``)."""

from __future__ import annotations

import numpy as np

from .. import _kernels
from ..edges import contact_table
from ..errors import ParameterError
from ..snapshot import Snapshot
from .result import IdentificationResult

__all__ = ["CustomEdges"]


class CustomEdges:
    """GNA with user-defined edge criteria (method ``"custom"``): granules are the connected
    components (≥ 2 particles) of the contacts a criterion keeps.

    Parameters
    ----------
    criterion : str or callable
        A :meth:`pandas.DataFrame.eval` expression on the columns of :func:`contact_table`
        (e.g. ``"f_norm >= 0.5 and (angle_v_deg < 30 or angle_w_deg < 30)"``), or a callable
        taking that table and returning a boolean array.
    radius : {"pair", "mean"}
        R in ``f_norm``.
    """

    method = "custom"

    def __init__(self, criterion, *, radius="pair", surface_tension=None):
        self.criterion = criterion
        self.radius = radius
        self.surface_tension = surface_tension

    def params(self) -> dict:
        """The constructor parameters (a callable criterion by its name)."""
        crit = self.criterion if isinstance(self.criterion, str) else getattr(self.criterion, "__name__", repr(self.criterion))
        return {"criterion": crit, "radius": self.radius, "surface_tension": self.surface_tension}

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Keep the contacts the criterion selects; label their components."""
        table = contact_table(snapshot, self.radius, self.surface_tension)
        try:
            keep = table.eval(self.criterion) if isinstance(self.criterion, str) else self.criterion(table)
        except Exception as exc:  # a user expression: report it, whatever it raised
            raise ParameterError(f"edge criterion {self.params()['criterion']!r} failed: {exc}") from None
        keep = np.asarray(keep)
        if keep.shape != (snapshot.n_contacts,) or keep.dtype != np.bool_:
            raise ParameterError(f"edge criterion must give one boolean per contact ({snapshot.n_contacts}), "
                                 f"got dtype {keep.dtype} shape {keep.shape}")
        membership = _kernels.union_find_membership(snapshot.n_particles, snapshot.contact_i[keep], snapshot.contact_j[keep])
        labels, sizes = _kernels.canonical_labels(membership)
        return IdentificationResult(labels=labels, sizes=sizes, method=self.method, params=self.params(),
                                    snapshot=snapshot, kept=keep)


