"""The simulator's mechanical contact laws, one module each (docs/architecture.md, "Adding a
contact law").

A law's module defines ``LAW``, a :class:`ContactLaw` that carries its parameters (which
become fields of :class:`sim.params.SimParams`), its numba force function, its closed-form
contact time and its coarse-graining rule. Adding a law is adding its module and its name to
:data:`LAW_MODULES`; nothing else in the simulator names a law.
"""

from __future__ import annotations

from importlib import import_module

from ._law import ContactLaw, LawParameter

__all__ = ["ContactLaw", "LawParameter", "CONTACT_LAWS", "LAW_MODULES", "law_parameters", "kernel_id"]

#: the modules of this package that each define one law, in kernel-id order (the first is the
#: default; append new laws so that the ids of the others stay)
LAW_MODULES = ("linear_coulomb", "hertz_mindlin")

#: law name -> :class:`ContactLaw`
CONTACT_LAWS = {law.name: law for law in (import_module(f"{__name__}.{module}").LAW for module in LAW_MODULES)}


def kernel_id(name: str) -> int:
    """The integer the kernels dispatch the law ``name`` on (its place in :data:`CONTACT_LAWS`)."""
    return list(CONTACT_LAWS).index(name)


def law_parameters() -> tuple:
    """Every registered law's :class:`LawParameter`, each name once, in registry order.

    Raises
    ------
    ValueError
        Two laws declare a parameter of the same name differently (default, unit or bound).
    """
    seen = {}
    for law in CONTACT_LAWS.values():
        for parameter in law.parameters:
            other = seen.setdefault(parameter.name, parameter)
            if (other.default, other.unit, other.bound) != (parameter.default, parameter.unit, parameter.bound):
                raise ValueError(f"contact laws declare parameter {parameter.name!r} differently: {other} and "
                                 f"{parameter} (law {law.name!r})")
    return tuple(seen.values())
