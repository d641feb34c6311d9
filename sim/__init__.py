"""sim: the reference Numba wet-DEM simulator of a baffled drum granulator (in progress).

It writes runs through :class:`granalytics.RunWriter`; granalytics never imports sim.
"""
