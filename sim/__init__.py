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

from .capillary import CAPILLARY_MODELS
from .capillary import pair_capillary_force as capillary_force
from .capillary import pair_rupture_distance as rupture_distance
from .params import PRESETS, SimParams, preset
from .params import cg_scale as scale_parameters

__all__ = ["capillary_force", "rupture_distance", "scale_parameters", "SimParams", "PRESETS", "preset", "CAPILLARY_MODELS"]
