"""Export frames for ParaView: one VTK XML unstructured grid (``.vtu``, written by meshio) per
frame and a ``.pvd`` collection that ParaView opens as a time series.

Each ``.vtu`` holds the particles as points (vertex cells) with point data ``id``, ``radius``
[m], ``velocity`` [m/s], ``angular_velocity`` [rad/s], ``film_volume`` [m³], ``granule`` (label,
−1 free) and ``granule_size`` (particles in the particle's granule, 1 when free), and every
contact or bridge as a line cell with cell data ``kept`` (1 when the identification kept it),
``f_cap`` [N], ``bridge_volume`` [m³] and ``gap`` [m] (vertex cells carry 0 there). In
ParaView, a Glyph filter with scale array ``radius`` (×2) draws the spheres.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np
from tqdm.auto import tqdm

from ..files import staged_outputs
from ..errors import GranalyticsError
from ..identify import make_identifier

__all__ = ["export_vtk", "frame_mesh"]


def frame_mesh(result):
    """The meshio mesh of one identified snapshot (see the module docstring for the fields)."""
    import meshio

    s = result.snapshot
    n, m = s.n_particles, s.n_contacts
    size_of = np.ones(n, dtype=np.int64)
    member = result.labels >= 0
    size_of[member] = result.sizes[result.labels[member]]
    kept = result.kept.astype(np.int8) if result.kept is not None else np.zeros(m, dtype=np.int8)
    zeros = np.zeros(n)
    return meshio.Mesh(
        points=s.position,
        cells=[("vertex", np.arange(n).reshape(-1, 1)), ("line", np.column_stack([s.contact_i, s.contact_j]))],
        point_data={
            "id": s.ids, "radius": s.radius, "velocity": s.velocity, "angular_velocity": s.angular_velocity,
            "film_volume": s.film_volume, "granule": result.labels, "granule_size": size_of,
        },
        cell_data={
            "kept": [zeros.astype(np.int8), kept], "f_cap": [zeros, s.f_cap],
            "bridge_volume": [zeros, s.bridge_volume], "gap": [zeros, s.gap],
        },
    )


def export_vtk(frames, out_dir, method="gna", *, progress=False, **params):
    """Write ``out_dir/frame_NNNNN.vtu`` for every frame and ``out_dir/run.pvd``.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    out_dir : path
        Created if needed.
    method, params :
        Identification used for the ``granule`` fields and ``kept`` bonds.

    Returns
    -------
    str
        Path of the ``.pvd`` file.

    The export is written whole or not at all: every file goes into a staging folder inside
    ``out_dir`` first (:func:`granalytics.files.staged_outputs`) and is renamed into place only
    when all frames are written; a failure or Ctrl-C leaves ``out_dir`` as it was.
    """
    import meshio

    os.makedirs(out_dir, exist_ok=True)
    identifier = make_identifier(method, **params)
    frame_ids = frames.frame_indices if hasattr(frames, "frame_indices") else np.arange(len(frames))
    collection = ET.Element("VTKFile", type="Collection", version="0.1")
    datasets = ET.SubElement(collection, "Collection")
    pvd = os.path.join(out_dir, "run.pvd")
    with staged_outputs(out_dir) as stage:
        for k, snapshot in zip(frame_ids, tqdm(frames, disable=not progress, unit="frame", desc="export-vtk")):
            name = f"frame_{int(k):05d}.vtu"
            try:
                meshio.write(stage(os.path.join(out_dir, name)), frame_mesh(identifier.identify(snapshot)))
            except OSError as exc:
                raise GranalyticsError(f"{os.path.join(out_dir, name)}: cannot write ({exc})") from None
            ET.SubElement(datasets, "DataSet", timestep=repr(float(snapshot.time)), part="0", file=name)
        ET.ElementTree(collection).write(stage(pvd), xml_declaration=True, encoding="utf-8")
    return pvd
