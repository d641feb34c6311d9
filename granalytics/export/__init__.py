"""Exports for other tools: ParaView (:mod:`.vtk`: ``.vtu`` frames and a ``.pvd`` series with
granule labels, track ids and kept bonds). They run identification and tracking, so they sit above
the analysis layer; the run-file layer (:mod:`granalytics.core`) never imports them."""
