"""Which force counts as cohesion F_coh in the GNA criterion F_coh ≥ C_agg·2πγR.

Two conventions (``cohesion=`` everywhere in granalytics; the default is ``"acting"``):

``"acting"``
    F_coh is the cohesive force the DEM code actually applied to the pair: the capillary force
    of a *separated* bridge (gap > 0), and for a touching pair (gap ≤ 0) the bridge force only
    if the run applied capillary force in contact (:attr:`RunMeta.capillary_in_contact`),
    otherwise 0. YADE's ``ViscElCapMat`` law, used by the paper, applies no capillary force
    while particles touch, so this is what a post-processing of YADE's forces sees.
``"bridge"``
    F_coh is the force of the pair's liquid bridge evaluated at max(s, 0⁺) for every wet pair,
    touching or not (the bridge's *potential* cohesion). In a wet bed almost every bridge is
    filled to V_max, so a touching wet pair scores F_cap(0⁺)/(2πγR) ≈ 0.83 (Willett, V_max =
    0.03 R³) and every C_agg below that keeps all of them.

Readers of LIGGGHTS/LAMMPS dumps store as F_coh the attractive part of the signed normal force
(what the code applied; a compressed contact has none), and YADE's export the force of active
(separated) bridges; for such runs both conventions give the same answer.
"""

from __future__ import annotations

import numpy as np

from granalytics.core.snapshot import SNAPSHOT, Snapshot
from granalytics.base.validation import Options, validate, validate_params

__all__ = ["COHESION_CONVENTIONS", "DEFAULT_COHESION", "COHESION", "check_cohesion", "cohesion_counts",
           "cohesion_counts_all", "cohesive_force"]

#: the cohesion conventions: "acting" (the force the simulator applied) and "bridge" (every bridge
#: counts, touching ones at Willett's force at contact); docs/identification.md
COHESION_CONVENTIONS = ("acting", "bridge")
DEFAULT_COHESION = "acting"
#: the constraint of a ``cohesion`` argument (:mod:`granalytics.base.validation`)
COHESION = Options(COHESION_CONVENTIONS)


def check_cohesion(cohesion, where=None) -> str:
    """``cohesion`` if it names a convention, else a :class:`~granalytics.base.errors.ParameterError`
    (naming ``where`` if given), for a function that checks it in its body rather than declaring
    :data:`COHESION` with :func:`~granalytics.base.validation.validate_params`."""
    validate(where, {"cohesion": [COHESION]}, {"cohesion": cohesion})
    return cohesion


@validate_params({"snapshot": [SNAPSHOT], "cohesion": [COHESION]})
def cohesion_counts_all(snapshot: Snapshot, cohesion: str = DEFAULT_COHESION) -> bool:
    """True when every contact's bridge force counts as cohesion under ``cohesion`` (``"bridge"``,
    or a run that applied capillary force in contact); else only separated pairs count."""
    return cohesion == "bridge" or (snapshot.meta is not None and bool(snapshot.meta.capillary_in_contact))


@validate_params({"snapshot": [SNAPSHOT], "cohesion": [COHESION]})
def cohesion_counts(snapshot: Snapshot, cohesion: str = DEFAULT_COHESION) -> np.ndarray:
    """Boolean mask of the contacts whose bridge force counts as cohesion under ``cohesion``:
    every contact for ``"bridge"``; for ``"acting"`` the separated ones (gap > 0), or all of
    them when the run applied capillary force in contact."""
    if cohesion_counts_all(snapshot, cohesion):
        return np.ones(snapshot.n_contacts, dtype=bool)
    return snapshot.gap > 0


@validate_params({"snapshot": [SNAPSHOT], "cohesion": [COHESION]})
def cohesive_force(snapshot: Snapshot, cohesion: str = DEFAULT_COHESION) -> np.ndarray:
    """F_coh [N] of every contact of ``snapshot`` under a cohesion convention.

    Parameters
    ----------
    snapshot : Snapshot
        Its ``f_cap`` is the bridge force at max(s, 0⁺) [N], ``gap`` the surface gap [m]
        (negative = overlap); ``meta.capillary_in_contact`` says whether the producing code
        applied the bridge force between touching particles (False without metadata).
    cohesion : {"acting", "bridge"}, default "acting"

    Returns
    -------
    (M,) float array [N], ≥ 0; ``snapshot.f_cap`` itself (no copy) where every force counts.
    """
    counts = cohesion_counts(snapshot, cohesion)
    return snapshot.f_cap if counts.all() else np.where(counts, snapshot.f_cap, 0.0)
