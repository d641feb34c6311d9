"""The analysis layer: everything that goes over a run's frames and measures granules.

- :mod:`.frames`: the one frame loop (progress, frame selection, ``jobs``) every analysis uses;
- :mod:`.metrics`: the registry of per-frame statistics; :mod:`.stats`: per-frame statistics,
  steady states, size distributions;
- :mod:`.sensitivity`: threshold sensitivity; :mod:`.method_comparison`: methods side by side;
- :mod:`.cg`: the coarse-graining comparison; :mod:`.confinement`: the confinement curve and the
  decomposition of a CG deviation;
- :mod:`.tracking`: granule life histories, events and rates; :mod:`.table`: per-particle and
  per-track tables;
- :mod:`.study`: parameter studies (tables, replicas, growth fits, surrogates).

It imports the identification layer (:mod:`granalytics.identification`), the core
(:mod:`granalytics.core`) and the base (:mod:`granalytics.base`), never the command line, the plots or the exports. Public names are
re-exported by the top-level package; import them from there.
"""
