"""The coarse-graining rules: how a system's parameters change when its particles are made α times
larger (docs/physics.md, "Coarse-graining rules").

A rule is defined by the power of α that every force is multiplied by (at the same strain u/d and
the same velocities). Lengths scale as α (radii, skin), particle counts as α⁻³, liquid volumes as
α³, masses as α³; the drum, Ω, gravity, density, friction, contact angle and the volume fractions
of liquid are unchanged under every rule. With forces × α^f:

========================  =================  ===========  ===========
quantity                  power of α         ``weber``    ``bond``
========================  =================  ===========  ===========
forces                    f                  2            3
γ, η                      f − 1              1            2
spring stiffness k        f − 1              1            2
dashpot c                 (f + 2)/2          2            2.5
Δt (∝ √(m/k))             (4 − f)/2          1            0.5
========================  =================  ===========  ===========

so that the restitution, t_c/Δt and the overlap u/d are those of the original system under both.

- ``weber`` is Table 2 of the study: it keeps the Weber number (inertia over capillarity), but
  gravity scales as α³ while cohesion scales as α², so the Bond number (capillary force over
  weight) falls as 1/α.
- ``bond`` scales every force as the weight does: it keeps the Bond number and, with Ω and the
  drum unchanged, the Froude number; the Weber number then falls as 1/α, and Δt grows only as √α
  (a run costs about α^0.5 times a ``weber`` run).

Each contact law scales its own parameters for a rule (:attr:`sim.laws.ContactLaw.cg_scaled`)
and names the rules it supports (:attr:`sim.laws.ContactLaw.cg_rules`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CGRule", "CG_RULES", "DEFAULT_CG_RULE", "cg_rule"]


@dataclass(frozen=True)
class CGRule:
    """A coarse-graining rule (the module's docstring).

    Attributes
    ----------
    name : str
        ``SimParams.cg_rule``, ``python -m sim run --cg-rule``.
    force_exponent : float
        f: every force of the coarse-grained system is α^f times the original's.
    description : str
        One line for ``--help`` and the docs.
    """

    name: str
    force_exponent: float
    description: str

    def surface_tension(self, alpha: float) -> float:
        """Factor of γ [N/m] and of the viscosity η [Pa s]: α^(f−1)."""
        return alpha ** (self.force_exponent - 1)

    def stiffness(self, alpha: float) -> float:
        """Factor of a linear spring stiffness [N/m]: α^(f−1)."""
        return alpha ** (self.force_exponent - 1)

    def damping(self, alpha: float) -> float:
        """Factor of a linear dashpot [N s/m]: α^((f+2)/2) = √(stiffness · mass)."""
        return alpha ** ((self.force_exponent + 2) / 2)

    def time_step(self, alpha: float) -> float:
        """Factor of Δt [s]: α^((4−f)/2) = √(mass / stiffness), so that t_c/Δt is unchanged."""
        return alpha ** ((4 - self.force_exponent) / 2)


#: the rules by name; the first is the default
CG_RULES = {rule.name: rule for rule in (
    CGRule("weber", 2.0, "Table 2 of the study: forces × α², keeps the Weber number (the Bond number falls as 1/α)"),
    CGRule("bond", 3.0, "forces × α³ like the weight: keeps the Bond and Froude numbers (Weber falls as 1/α; "
                        "Δt × √α)"),
)}
DEFAULT_CG_RULE = next(iter(CG_RULES))


def cg_rule(name: str) -> CGRule:
    """The rule called ``name``; ValueError naming the known ones."""
    try:
        return CG_RULES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown CG rule {name!r}; the rules are {', '.join(CG_RULES)}") from None
