"""sim: the reference Numba wet-DEM simulator of a baffled drum granulator.

It writes runs through :class:`granalytics.core.RunWriter` (the run-file contract) and imports
nothing of granalytics beyond :mod:`granalytics.core` and :mod:`granalytics.base`; granalytics
never imports sim.

Public force laws (numpy arrays in, SI units):

- :func:`capillary_force` ``(gap, r1, r2, bridge_volume, surface_tension, contact_angle, model=...)``
  → N, attractive magnitude, zero beyond rupture;
- :func:`rupture_distance` ``(bridge_volume, r1, r2, contact_angle)`` → m;
- :func:`scale_parameters` ``(params, alpha)`` → CG-scaled :class:`SimParams` (Table 2).

(The scalar numba kernels of the same physics are ``sim.capillary.capillary_force_scalar`` and
``sim.capillary.rupture_distance_scalar``, with the effective radius as argument.)
"""

import importlib

#: public name -> (module, name there), imported on first use (PEP 562): ``python -m sim`` starts
#: without loading numba, so that a Ctrl-C while it loads is held (``sim/__main__.py``)
_EXPORTS = {
    "capillary_force": (".capillary", "pair_capillary_force"),
    "rupture_distance": (".capillary", "pair_rupture_distance"),
    "CAPILLARY_MODELS": (".capillary", "CAPILLARY_MODELS"),
    "scale_parameters": (".params", "cg_scale"),
    "SimParams": (".params", "SimParams"),
    "PRESETS": (".params", "PRESETS"),
    "preset": (".params", "preset"),
}

__all__ = ["capillary_force", "rupture_distance", "scale_parameters", "SimParams", "PRESETS", "preset", "CAPILLARY_MODELS"]


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sim' has no attribute {name!r}")
    module, attribute = _EXPORTS[name]
    value = getattr(importlib.import_module(module, __name__), attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
