"""Export frames for ParaView: one VTK XML unstructured grid (``.vtu``, written by meshio) per
frame and a ``.pvd`` collection that ParaView opens as a time series.

Each ``.vtu`` holds the particles as points (vertex cells) with point data ``id``, ``radius``
[m], ``velocity`` [m/s], ``angular_velocity`` [rad/s], ``film_volume`` [m³], ``granule`` (label,
−1 free), ``granule_track`` (the granule's track id, which keeps its value while the granule
lives, through the events it survives as the main branch by default, −1 free;
:mod:`granalytics.analysis.tracking`) and ``granule_size`` (particles in the particle's
granule, 1 when free), and every
contact or bridge as a line cell with cell data ``kept`` (1 when the identification kept it),
``f_cap`` [N], ``bridge_volume`` [m³] and ``gap`` [m] (vertex cells carry 0 there). In
ParaView, a Glyph filter with scale array ``radius`` (×2) draws the spheres.

For runs of the simulator (whose metadata give the drum), every frame also has a
``drum_NNNNN.vtu``: the cylinder, the end plates and the baffles at the frame's drum angle Ωt, as a
surface with cell data ``part`` (0 cylinder, 1 end plates, 2 baffles); the ``.pvd`` lists it as
part 1 of each time step.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np
from tqdm.auto import tqdm

from granalytics.report.files import staged_outputs
from granalytics.base.errors import GranalyticsError
from granalytics.analysis.frames import map_frames
from granalytics.identification import make_identifier
from granalytics.identification.result import IdentificationResult
from granalytics.analysis.tracking import track_granules
from granalytics.analysis.tracking.linking import CONTINUATION
from granalytics.base.validation import FLAG, validate_params

__all__ = ["export_vtk", "frame_mesh", "drum_mesh"]


def drum_mesh(geometry, time_s, segments=64):
    """The drum's surface at time ``time_s`` [s] (meshio mesh): cylinder, end plates and baffles at
    the angle Ω·t. ``geometry``: the simulator's parameters (``drum_radius``, ``drum_length``
    [m], ``n_baffles``, ``baffle_height`` (fraction of R), ``drum_omega`` [rad/s])."""
    import meshio

    r, length = float(geometry["drum_radius"]), float(geometry["drum_length"])
    n_b, h, omega = int(geometry.get("n_baffles", 0)), float(geometry.get("baffle_height", 0.0)), float(geometry["drum_omega"])
    phi = 2 * np.pi * np.arange(segments) / segments
    ring = np.column_stack([r * np.cos(phi), r * np.sin(phi)])
    points = [np.column_stack([ring, np.zeros(segments)]), np.column_stack([ring, np.full(segments, length)]),
              np.array([[0.0, 0.0, 0.0], [0.0, 0.0, length]])]
    k = np.arange(segments)
    quads = [np.column_stack([k, (k + 1) % segments, segments + (k + 1) % segments, segments + k])]
    centre = 2 * segments
    triangles = np.concatenate([np.column_stack([np.full(segments, centre), (k + 1) % segments, k]),
                                np.column_stack([np.full(segments, centre + 1), segments + k,
                                                 segments + (k + 1) % segments])])
    base = centre + 2
    angle = omega * time_s
    for b in range(n_b):
        a = angle + 2 * np.pi * b / n_b
        e = np.array([np.cos(a), np.sin(a), 0.0])
        inner, outer = r * (1 - h) * e, r * e
        points.append(np.array([inner, outer, outer + [0, 0, length], inner + [0, 0, length]]))
        quads.append(np.array([[base, base + 1, base + 2, base + 3]]))
        base += 4
    quads = np.concatenate(quads)
    part = np.zeros(len(quads), dtype=np.int8)
    part[segments:] = 2
    return meshio.Mesh(points=np.concatenate(points), cells=[("quad", quads), ("triangle", triangles)],
                       cell_data={"part": [part, np.ones(len(triangles), dtype=np.int8)]})


def frame_mesh(result, track=None):
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
            **({"granule_track": np.asarray(track, dtype=np.int64)} if track is not None else {}),
        },
        cell_data={
            "kept": [zeros.astype(np.int8), kept], "f_cap": [zeros, s.f_cap],
            "bridge_volume": [zeros, s.bridge_volume], "gap": [zeros, s.gap],
        },
    )


@validate_params({"continuation": [CONTINUATION], "progress": [FLAG]})
def export_vtk(frames, out_dir, method="gna", *, continuation="main", progress=False, **params):
    """Write ``out_dir/frame_NNNNN.vtu`` for every frame and ``out_dir/run.pvd``.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    out_dir : path
        Created if needed.
    method, params :
        Identification used for the ``granule`` fields and ``kept`` bonds.
    continuation : {"main", "strict"}, default "main"
        Which granule keeps its ``granule_track`` through coalescence and breakage
        (:func:`granalytics.track_granules`): the main branch, or none.
    progress : bool, default False
        Show progress bars over frames.

    Returns
    -------
    str
        Path of the ``.pvd`` file.

    The export is written whole or not at all: every file goes into a staging folder inside
    ``out_dir`` first (:func:`granalytics.report.files.staged_outputs`) and is renamed into place only
    when all frames are written; a failure or Ctrl-C leaves ``out_dir`` as it was.
    """
    import meshio

    identifier = make_identifier(method, **params)
    # one identification pass (labels, sizes and kept bonds of every frame; the track ids need
    # them all), then the files (a second pass over the frames, reading only)
    def identified(snapshot):  # the result's arrays, not the snapshot (one frame in memory at a time)
        r = identifier.identify(snapshot)
        return (r.labels, r.sizes, r.method, r.params, r.kept), snapshot.ids, snapshot.time

    frame_ids, found = map_frames(frames, identified, progress=progress, desc="identify", what="export")
    tracks = track_granules([f[0][0] for f in found], [f[1] for f in found], [f[2] for f in found],
                            continuation=continuation)
    os.makedirs(out_dir, exist_ok=True)
    collection = ET.Element("VTKFile", type="Collection", version="0.1")
    datasets = ET.SubElement(collection, "Collection")
    pvd = os.path.join(out_dir, "run.pvd")
    with staged_outputs(out_dir) as stage:
        for k, (index, snapshot) in enumerate(zip(frame_ids, tqdm(frames, disable=not progress, unit="frame",
                                                                    desc="export-vtk"))):
            name = f"frame_{int(index):05d}.vtu"
            labels, sizes, used, used_params, kept = found[k][0]
            result = IdentificationResult(labels, sizes, used, used_params, snapshot, kept)
            mapping = tracks.labels_to_tracks[k]
            track = np.where(result.labels >= 0, mapping[np.maximum(result.labels, 0)] if mapping.size else -1, -1)
            geometry = ((snapshot.meta.sim_config or {}).get("params") if snapshot.meta is not None else None) or {}
            try:
                meshio.write(stage(os.path.join(out_dir, name)), frame_mesh(result, track))
                if {"drum_radius", "drum_length", "drum_omega"} <= set(geometry):
                    drum = f"drum_{int(index):05d}.vtu"
                    meshio.write(stage(os.path.join(out_dir, drum)), drum_mesh(geometry, snapshot.time))
                    ET.SubElement(datasets, "DataSet", timestep=repr(float(snapshot.time)), part="1", file=drum)
            except OSError as exc:
                raise GranalyticsError(f"{os.path.join(out_dir, name)}: cannot write ({exc})") from None
            ET.SubElement(datasets, "DataSet", timestep=repr(float(snapshot.time)), part="0", file=name)
        ET.ElementTree(collection).write(stage(pvd), xml_declaration=True, encoding="utf-8")
    return pvd
