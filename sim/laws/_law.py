"""What a contact law is, as the rest of the simulator sees it (:class:`ContactLaw`), and its
parameters (:class:`LawParameter`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

__all__ = ["LawParameter", "ContactLaw"]

#: the bounds a law parameter may declare: name -> (test, how a message says it)
BOUNDS = {
    "positive": (lambda value: value > 0, "> 0"),
    "nonnegative": (lambda value: value >= 0, ">= 0"),
    "restitution": (lambda value: 0 < value <= 1, "in (0, 1]"),
    "poisson_ratio": (lambda value: -1 < value < 0.5, "in (-1, 0.5)"),
}


@dataclass(frozen=True)
class LawParameter:
    """One parameter of a contact law, a field of :class:`sim.params.SimParams`.

    Attributes
    ----------
    name : str
        The field's name (a run's ``sim_config`` key, a sweep key, ``--law-parameter NAME=VALUE``).
    default : float
        Its value in the paper's Table 1 system (α = 1).
    unit : str
        SI unit, as the docs print it (``""`` for a pure number).
    bound : str
        A key of :data:`BOUNDS` (``"positive"``, ``"nonnegative"``, ``"restitution"``: (0, 1],
        ``"poisson_ratio"``: (−1, 0.5)), checked by ``SimParams``.
    description : str
        What it is, in a few words.
    """

    name: str
    default: float
    unit: str
    bound: str
    description: str

    def __post_init__(self):
        if self.bound not in BOUNDS:
            raise ValueError(f"law parameter {self.name}: bound must be one of {tuple(BOUNDS)}, got {self.bound!r}")

    def check(self, value) -> None:
        """Raise ``ValueError`` naming the parameter unless ``value`` is a finite number within
        its bound."""
        test, said = BOUNDS[self.bound]
        if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
                and test(value)):
            raise ValueError(f"parameter {self.name} must be a finite number {said}, got {value!r}")


@dataclass(frozen=True)
class ContactLaw:
    """A mechanical contact law: everything about it lives in its module of :mod:`sim.laws`.

    Attributes
    ----------
    name : str
        ``SimParams.contact_law``.
    parameters : tuple of LawParameter
        Its parameters; each becomes a field of ``SimParams`` (a parameter that several laws
        share, such as ``friction``, is declared the same way by each).
    constants : tuple of str
        The names of the numbers :attr:`pack` gives the force function, in order.
    pack : callable
        ``pack(params) -> tuple of float``: :attr:`constants` from a ``SimParams``, computed once
        per run (derived quantities, such as a damping coefficient from a restitution, belong
        here rather than in the force loop).
    force : numba function
        ``force(constants, u, nx, ny, nz, vx, vy, vz, fx, fy, fz, r_i, r_j, dt)
        -> (f_n, sx, sy, sz, tx, ty, tz)``, compiled with ``inline="always"``: ``constants`` the
        tuple of :attr:`pack` (padded with zeros to the longest law's), overlap u ≥ 0 [m], unit
        normal n from i to j, relative velocity of the contact point v (i minus j) [m/s], the
        stored tangential spring f on i [N] already rotated into the tangent plane, the radii
        [m] of i and j (a wall: r_j = inf), the time step [s]. A law that needs masses computes
        them from the radii (one density per run; pack ρ): loading the partner's mass for every
        pair slot cost the linear law, which does not read it, a quarter of its speed. Returns
        the normal force magnitude f_n ≥ 0 [N] (on i: −f_n·n), the updated stored spring s and
        the tangential force t applied on i [N]. It must not ``raise`` (a second exit
        serialises the parallel loop).
    contact_time : callable
        ``contact_time(params, radius) -> t_c [s]``: the normal contact time of two equal
        spheres of ``radius`` [m]; Δt ≤ t_c/20 is required. Raises ``ValueError`` where there is
        none (an overdamped contact).
    cg_scaled : callable
        ``cg_scaled(params, alpha, rule) -> {field: value}``: the law's parameters in the system
        coarse-grained by α under ``rule`` (a :class:`sim.cg_rules.CGRule`) from the original
        ``params`` (:func:`sim.params.cg_scale`).
    cg_rules : tuple of str
        The names of the CG rules (:data:`sim.cg_rules.CG_RULES`) ``cg_scaled`` implements;
        ``SimParams`` refuses any other with this law.
    check : callable, optional
        ``check(params, radius, pair_mass)``: raise ``ValueError`` naming a parameter whose value
        the explicit integration cannot resolve for the lightest pair (two spheres of ``radius``
        [m], reduced mass ``pair_mass`` [kg]) beyond the contact-time rule Δt ≤ t_c/20 that
        ``SimParams`` applies to every law.
    """

    name: str
    parameters: tuple
    constants: tuple
    pack: Callable
    force: object
    contact_time: Callable
    cg_scaled: Callable
    cg_rules: tuple = ("weber",)
    check: Callable = lambda params, radius, pair_mass: None
