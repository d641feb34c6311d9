"""Which system a run simulates, and the checks wherever runs are combined: replicas must be one
system at different seeds, CG levels one original system at different α.

A run of our simulator records its original (α = 1) parameters (``sim_config["original"]``); its
*system* is those parameters without the seed, α and the CG rule. Runs of other codes record no
parameters: for them only the original particle count and mean radius are compared.
"""

from __future__ import annotations

import math
import warnings

from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.base.validation import validate_params
from granalytics.core.snapshot import META

__all__ = ["system_of", "run_identity", "check_replicas", "check_one_system"]

#: original parameters that may differ between runs of one system: the filling's seed, and for CG
#: levels the factor and the rule that made them
_FREE = {"seed", "alpha", "cg_rule"}


@validate_params({"meta": [META]})
def system_of(meta) -> dict | None:
    """The original parameters of a simulator run without seed, α and CG rule (None for a run of
    another code, whose metadata has no parameters)."""
    original = meta.sim_config.get("original")  # a dict where present (RunMeta's schema)
    if not original:
        return None
    return {k: v for k, v in original.items() if k not in _FREE}


def run_identity(run) -> dict:
    """What tells one run from another: ``path``, ``alpha``, ``n_particles``, ``seed`` (the
    simulator's filling seed; None for other codes), ``system`` (:func:`system_of`) and ``content``
    (a checksum of the first and last frames' positions: equal for copies of one run)."""
    import hashlib

    import numpy as np

    meta = run.meta
    digest = hashlib.sha256()
    for k in (0, len(run) - 1):
        digest.update(np.ascontiguousarray(run[k].position).tobytes())
    return {"path": str(run.path), "alpha": meta.alpha, "n_particles": meta.n_particles,
            "seed": meta.sim_config.get("params", {}).get("seed"), "system": system_of(meta),
            "content": digest.hexdigest()}


def _differences(a: dict, b: dict) -> list:
    """The parameters in which two systems differ, as ``name: a vs b`` texts (numbers equal to 1e-12);
    a parameter only one of them records (a run of an older simulator) is not compared."""
    out = []
    for key in sorted(set(a) & set(b)):
        x, y = a.get(key), b.get(key)
        same = (math.isclose(x, y, rel_tol=1e-12, abs_tol=0.0) if isinstance(x, float) and isinstance(y, float)
                else x == y)
        if not same:
            out.append(f"{key}: {x!r} vs {y!r}")
    return out


def check_replicas(members) -> None:
    """Refuse (:class:`ParameterError`) replicas that are not one system at different seeds.

    Parameters
    ----------
    members : sequence of dict
        :func:`run_identity` of each run.
    """
    first = members[0]
    for other in members[1:]:
        if (other["alpha"], other["n_particles"]) != (first["alpha"], first["n_particles"]):
            raise ParameterError(f"{other['path']}: not a replica of {first['path']} (α = {other['alpha']:g} with "
                                 f"{other['n_particles']} particles against α = {first['alpha']:g} with "
                                 f"{first['n_particles']})")
        if first["system"] is not None and other["system"] is not None:
            differ = _differences(first["system"], other["system"])
            if differ:
                raise ParameterError(f"{other['path']}: not a replica of {first['path']}: its system differs in "
                                     f"{'; '.join(differ[:4])}{' …' if len(differ) > 4 else ''}")
    seen = {}
    for member in members:
        key = member["seed"] if member["seed"] is not None else member.get("content")
        if key is not None and key in seen:
            what = f"seed {key}" if member["seed"] is not None else "frames"
            raise ParameterError(f"{member['path']}: the same {what} as {seen[key]}: a copy of one run, not a "
                                 "replica (a replica is the same system at another seed)")
        seen[key] = member["path"]


def check_one_system(infos, *, mixed_systems=False, where="compare_cg") -> None:
    """Refuse (or with ``mixed_systems`` warn about) CG levels that are not coarse-grained from one
    original system: simulator runs whose original parameters differ in anything but the seed, α
    and the rule; for runs of other codes, original particle counts or mean radii that differ by
    more than 1 %.

    Parameters
    ----------
    infos : sequence of dict
        One per CG level: ``run`` (its label), ``system`` (:func:`system_of`),
        ``n_particles_original``, ``mean_radius_original``.
    """
    problems = []
    systems = [(i["run"], i["system"]) for i in infos if i["system"] is not None]
    for label, system in systems[1:]:
        differ = _differences(systems[0][1], system)
        if differ:
            problems.append(f"{label} differs from {systems[0][0]} in {'; '.join(differ[:4])}"
                            f"{' …' if len(differ) > 4 else ''}")
    for key, what in (("n_particles_original", "original particle counts"),
                      ("mean_radius_original", "original mean radii")):
        values = [i[key] for i in infos]
        if max(values) > 1.01 * min(values):
            problems.append(f"their {what} differ (" + ", ".join(f"{i['run']}: {i[key]:.4g}" for i in infos) + ")")
    if not problems:
        return
    message = f"{where}: the runs are not coarse-grained from one system: {problems[0]}"
    if not mixed_systems:
        raise ParameterError(message + " (pass mixed_systems=True, or --mixed-systems, to compare them anyway)")
    warnings.warn(message + "; their differences are not those of coarse-graining", stacklevel=user_stacklevel())
