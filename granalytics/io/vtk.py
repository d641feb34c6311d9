"""Deprecated home of the ParaView export: it moved to :mod:`granalytics.export.vtk` (an export
runs identification and tracking, which sit above the run-file layer). This module forwards to
it, with a DeprecationWarning, for one release."""

import warnings

from ..export.vtk import drum_mesh, export_vtk, frame_mesh

__all__ = ["export_vtk", "frame_mesh", "drum_mesh"]

warnings.warn("granalytics.io.vtk moved to granalytics.export.vtk; the old path goes in the next release",
              DeprecationWarning, stacklevel=2)
