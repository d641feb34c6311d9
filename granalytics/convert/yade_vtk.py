"""Read what YADE's ``VTKRecorder`` writes, frame by frame, with the VTK library.

YADE users keep the recorder's folder, not our CSV export. A frame is either

- one multiblock file ``<fileName>ITER.vtm`` (``multiblock=True``) naming an unstructured grid of
  the spheres and a poly-data file of the interactions, or
- ``<fileName>spheres.ITER.vtu`` and ``<fileName>intrs.ITER.vtp`` (the default layout; in YADE
  2023.02a its ``intr`` recorder writes one frame and then crashes, so keep ``multiblock=True``).

What the recorders write (read off YADE 2023.02a's files):

- ``spheres``: the centres (**single precision**) and ``radii``;
- ``velocity``: ``linVelVec`` [m/s] and ``angVelVec`` [rad/s];
- ``id``: the body ids (without it, the order of the spheres in the file is taken as their id, as
  YADE writes them in body order; a warning says so);
- ``intr``: one line per sphere-sphere interaction between the two centres (the same single-
  precision points as the spheres'), with the cell arrays ``forceN`` (the signed normal force
  [N], positive repulsive, negative while a liquid bridge pulls) and ``absForceT``; no ids, gap
  or bridge flag.

The reader recovers the rest: each line's particles from its end points (the exact points of
the spheres), the surface gap from the centres and radii (the points are single precision: good
to about 10⁻⁷ of the coordinates, a few nanometres in a drum of 10 cm about the origin), and the cohesive force of YADE's ``ViscElCapPhys`` bridges: ``−forceN`` of a
separated pair whose normal force pulls (YADE applies the capillary force only to an active
bridge, gap > 0), and Willett's force at contact F_cap(0⁺) from the mapping's bridge volume for
a touching pair, which YADE neither applies nor writes (as the CSV reader does;
``capillary_in_contact`` is false, so the "acting" cohesion convention gives touching pairs no
cohesion and the "bridge" convention counts them). ``tests/test_yade_vtk.py`` checks the rule
against the values of ``O.interactions`` written at the same instant.

The mapping (TOML) gives what the files do not: ``surface_tension`` [N/m], ``density``
[kg/m³], ``drum_omega`` [rad/s], ``contact_angle`` [rad], ``alpha``, ``capillary_type``
(``"Willett_numeric"``) and ``bridge_volume`` [m³], the ``Vb`` of the material (0: no bridge
force at contact). The files carry the iteration, not the time: ``dt_s`` gives it.
"""

from __future__ import annotations

import glob
import math
import os
import re
import warnings

import numpy as np

from granalytics.base.errors import GranalyticsError, ValidationError, user_stacklevel
from granalytics.base.files import regular_input
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.convert._capillary import effective_radius
from granalytics.convert._text import DumpFormatError
from granalytics.convert.registry import StreamedSource
from granalytics.convert.yade import _CAPILLARY_TYPES, read_yade_mapping

__all__ = ["YadeVtkRun", "open_yade_vtk", "find_vtk_frames"]

_MULTIBLOCK = re.compile(r"^(?P<prefix>.*?)-?(?P<iter>\d+)\.vtm$")
#: VTKRecorder writes ``fileName + "spheres." + iter + ".vtu"``: any prefix, "-" or not
_SPHERES = re.compile(r"^(?P<prefix>.*?)spheres\.(?P<iter>\d+)\.vtu$")
_INTRS = re.compile(r"^(?P<prefix>.*?)intrs\.(?P<iter>\d+)\.vtp$")


def _vtk():
    try:
        import vtk  # noqa: F401
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        raise GranalyticsError("reading VTK files needs the VTK library: pip install vtk "
                               "(or the project's extra: pip install 'granalytics[vtk]')") from None
    return vtk, vtk_to_numpy


def find_vtk_frames(paths):
    """The frames of a VTKRecorder's output: ``[(iteration, {"multiblock": path} or {"spheres":
    path, "intrs": path or None})]`` in iteration order, from a folder or a list of files.

    Raises
    ------
    DumpFormatError
        No frame found, several recorders' prefixes mixed, or an iteration twice.
    """
    files = []
    for path in paths:
        path = os.fspath(path)
        if os.path.isdir(path):
            files += sorted(glob.glob(os.path.join(glob.escape(path), "*.vt[mup]")))
        else:
            files.append(path)
    frames, prefixes = {}, set()
    for path in files:
        name = os.path.basename(path)
        for pattern, key in ((_SPHERES, "spheres"), (_INTRS, "intrs"), (_MULTIBLOCK, "multiblock")):
            match = pattern.match(name)
            if match:
                prefixes.add(os.path.join(os.path.dirname(path), match["prefix"]))
                entry = frames.setdefault(int(match["iter"]), {})
                if key in entry:
                    raise DumpFormatError(f"{path}: iteration {int(match['iter'])} already read from {entry[key]}")
                entry[key] = path
                break
    if not frames:
        raise DumpFormatError(f"no VTKRecorder frames (<fileName>ITER.vtm, or <fileName>spheres.ITER.vtu and "
                              f"<fileName>intrs.ITER.vtp) in {', '.join(map(str, paths))}")
    if len(prefixes) > 1:
        raise DumpFormatError(f"the recordings of {len(prefixes)} VTKRecorders are mixed ({', '.join(sorted(prefixes))}): "
                              "give the files of one")
    out = []
    for iteration in sorted(frames):
        entry = frames[iteration]
        if "multiblock" in entry and len(entry) > 1:
            raise DumpFormatError(f"iteration {iteration} is both a multiblock file and separate files")
        if "multiblock" not in entry and "spheres" not in entry:
            raise DumpFormatError(f"{entry['intrs']}: no spheres file (<fileName>spheres.{iteration}.vtu) beside it: "
                                  "add 'spheres' to the VTKRecorder's recorders")
        out.append((iteration, {"intrs": None, **entry}))
    return out


def _read_mapping(path):
    """``(capillary_type, bridge volume [m³], metadata)``: the CSV reader's mapping and ``bridge_volume``."""
    capillary_type, data = read_yade_mapping(path, extra_keys=("bridge_volume",))
    volume = data.pop("bridge_volume", 0.0)
    if not isinstance(volume, (int, float)) or isinstance(volume, bool) or not math.isfinite(volume) or volume < 0:
        raise ValidationError("mapping", f"{path}: bridge_volume must be a finite number >= 0 [m³], got {volume!r}")
    return capillary_type, float(volume), data


class YadeVtkRun(StreamedSource):
    """A YADE run read frame by frame from its VTKRecorder files (:func:`open_yade_vtk`); the
    same interface as the other streaming readers (:class:`granalytics.convert.registry.FrameSource`)."""

    def __init__(self, paths, mapping_path, dt):
        if dt is None or not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValidationError("dt", "VTKRecorder files record the iteration, not the time: pass the time step "
                                        f"(O.dt) in seconds, got {dt!r}")
        self.paths, self.mapping_path, self.dt = [os.fspath(p) for p in paths], mapping_path, float(dt)
        self.capillary_type, self.bridge_volume, self._meta_data = _read_mapping(mapping_path)
        self.frames = find_vtk_frames(self.paths)
        files = [f for _, entry in self.frames for f in _frame_files(entry)]
        for path in files:
            regular_input(path)
        self.total_bytes = sum(os.path.getsize(f) for f in files)
        self.bytes_read = 0
        self.meta = None
        self._warned_ids = False

    def frame_bytes(self) -> int:
        """Estimated memory of one frame while it is read [bytes]: eight times its files."""
        return 8 * max(sum(os.path.getsize(f) for f in _frame_files(entry)) for _, entry in self.frames)

    def _nothing_read(self):
        return DumpFormatError(f"no VTKRecorder frames after iteration {self._after} in {', '.join(self.paths)}")

    def _read(self):
        n0 = None
        for iteration, entry in self.frames:
            if self._after is not None and iteration <= self._after:
                self.bytes_read += sum(os.path.getsize(f) for f in _frame_files(entry))
                continue
            spheres, intrs, where = self._datasets(entry)
            part = self._particles(spheres, where)
            cont = self._contacts(intrs, where, part)
            n0 = n0 or len(part["ids"])
            if len(part["ids"]) != n0:
                raise DumpFormatError(f"{where}: iteration {iteration} has {len(part['ids'])} spheres, the first "
                                      f"frame {n0}; a run keeps its particles")
            if self.meta is None:
                self.meta = self._run_meta(n0, float(part["radius"].mean()))
            try:
                snapshot = Snapshot(time=iteration * self.dt, step=iteration, **part, **cont, meta=self.meta)
            except ValidationError as exc:
                raise exc.located(where) from None
            self.bytes_read += sum(os.path.getsize(f) for f in _frame_files(entry))
            yield snapshot

    def _datasets(self, entry):
        """(spheres grid, interactions poly data or None, the frame's file for messages)."""
        vtk, _ = _vtk()
        if "multiblock" in entry:
            where = entry["multiblock"]
            reader = vtk.vtkXMLMultiBlockDataReader()
            reader.SetFileName(where)
            data = _update(reader, where)
            blocks = [data.GetBlock(k) for k in range(data.GetNumberOfBlocks())]
            spheres = [b for b in blocks if isinstance(b, vtk.vtkUnstructuredGrid) and b.GetPointData().HasArray("radii")]
            intrs = [b for b in blocks if isinstance(b, vtk.vtkPolyData) and b.GetCellData().HasArray("forceN")]
            if not spheres:
                raise DumpFormatError(f"{where}: no block of spheres (radii): add 'spheres' to the VTKRecorder's "
                                      "recorders")
            return spheres[0], (intrs[0] if intrs else None), where
        where = entry["spheres"]
        reader = vtk.vtkXMLUnstructuredGridReader()
        reader.SetFileName(where)
        spheres = _update(reader, where)
        intrs = None
        if entry["intrs"]:
            reader = vtk.vtkXMLPolyDataReader()
            reader.SetFileName(entry["intrs"])
            intrs = _update(reader, entry["intrs"])
            where = f"{where} / {entry['intrs']}"
        return spheres, intrs, where

    def _particles(self, grid, where):
        _, to_numpy = _vtk()
        data = grid.GetPointData()

        def array(name, recorder, components=1):
            if not data.HasArray(name):
                raise DumpFormatError(f"{where}: no array {name!r}: add {recorder!r} to the VTKRecorder's recorders")
            values = to_numpy(data.GetArray(name)).astype(np.float64)
            return values.reshape(-1, components) if components > 1 else values

        n = grid.GetNumberOfPoints()
        if n == 0:
            raise DumpFormatError(f"{where}: no spheres")
        position = to_numpy(grid.GetPoints().GetData()).astype(np.float64).reshape(-1, 3)
        if data.HasArray("id"):
            ids = to_numpy(data.GetArray("id")).astype(np.int64)
        else:
            ids = np.arange(n, dtype=np.int64)
            if not self._warned_ids:
                warnings.warn(f"{where}: no 'id' array (the VTKRecorder's 'id' recorder): the spheres' order in the "
                              "files is taken as their ids (YADE writes them in body order)",
                              stacklevel=user_stacklevel())
                self._warned_ids = True
        return {"ids": ids, "radius": array("radii", "spheres"), "position": position,
                "velocity": array("linVelVec", "velocity", 3), "angular_velocity": array("angVelVec", "velocity", 3),
                "film_volume": np.zeros(n)}

    def _contacts(self, poly, where, part):
        if poly is None:
            raise DumpFormatError(f"{where}: no interactions: add 'intr' to the VTKRecorder's recorders (in YADE "
                                  "2023.02a with multiblock=True; without it the recorder crashes after one frame)")
        _, to_numpy = _vtk()
        lines = poly.GetLines()
        connectivity = to_numpy(lines.GetConnectivityArray()).astype(np.int64)
        offsets = to_numpy(lines.GetOffsetsArray()).astype(np.int64)
        if not np.array_equal(np.diff(offsets), np.full(len(offsets) - 1, 2)):
            raise DumpFormatError(f"{where}: the interactions are not lines of two points each")
        force = to_numpy(poly.GetCellData().GetArray("forceN")).astype(np.float64)
        points = to_numpy(poly.GetPoints().GetData()).astype(np.float64).reshape(-1, 3) if len(connectivity) else \
            np.empty((0, 3))
        rows = [self._sphere_rows(points[connectivity[k::2]], part["position"], where) for k in (0, 1)]
        pair = (rows[0] >= 0) & (rows[1] >= 0)  # an end that is no sphere: a wall interaction, left out
        i, j = rows[0][pair], rows[1][pair]
        force = force[pair]
        position, radius = part["position"], part["radius"]
        gap = np.linalg.norm(position[j] - position[i], axis=1) - radius[i] - radius[j]
        volume = np.full(len(i), self.bridge_volume)
        f_cap = np.where((gap > 0) & (force < 0), -force, 0.0)
        touching_wet = (gap <= 0) & (volume > 0)
        f_cap[touching_wet] = _CAPILLARY_TYPES[self.capillary_type](
            volume[touching_wet], effective_radius(radius[i[touching_wet]], radius[j[touching_wet]]),
            self._meta_data["surface_tension"], self._meta_data.get("contact_angle", 0.0))
        return {"contact_i": np.minimum(i, j), "contact_j": np.maximum(i, j), "f_cap": f_cap, "f_normal": force,
                "gap": gap, "bridge_volume": volume}

    @staticmethod
    def _sphere_rows(ends, centres, where):
        """The row of the sphere whose centre is each point of ``ends`` (-1 where none is)."""
        from scipy.spatial import cKDTree

        if not len(ends):
            return np.empty(0, dtype=np.int64)
        distance, rows = cKDTree(centres).query(ends, k=2)
        exact = distance[:, 0] == 0
        if (exact & (distance[:, 1] == 0)).any():
            raise DumpFormatError(f"{where}: two spheres share a centre: the interactions' ends cannot name them")
        return np.where(exact, rows[:, 0], -1)

    def _run_meta(self, n_particles, mean_radius) -> RunMeta:
        try:
            return RunMeta(n_particles=n_particles, mean_radius=mean_radius, capillary_in_contact=False,
                           provenance={"source": "YADE VTKRecorder", "capillary_type": self.capillary_type,
                                       "bridge_volume": self.bridge_volume, "dt_s": self.dt,
                                       "f_cap_in_contact": "Willett F_cap(0+) at the mapping's bridge_volume, "
                                                           "filled in by the reader",
                                       "gap": "from single-precision centres (about 1e-7 of the coordinates)",
                                       "files": [f for _, e in self.frames for f in _frame_files(e)][:1000]},
                           **self._meta_data)
        except TypeError as exc:
            raise GranalyticsError(f"{self.mapping_path}: {exc}") from None


def _frame_files(entry):
    """The files of a frame: its spheres and interactions, or its ``.vtm`` and the block files VTK
    writes into the folder of the same name beside it (for the progress and the size checks)."""
    files = [f for f in (entry.get("multiblock"), entry.get("spheres"), entry.get("intrs")) if f]
    if entry.get("multiblock"):
        blocks = os.path.splitext(entry["multiblock"])[0]
        files += sorted(glob.glob(os.path.join(glob.escape(blocks), "*.vt[up]"))) if os.path.isdir(blocks) else []
    return files


def _update(reader, path):
    """Run a VTK reader, turning its complaints (VTK prints them and returns an empty data set)
    into a :class:`DumpFormatError` naming the file."""
    vtk, _ = _vtk()
    errors = vtk.vtkStringOutputWindow()
    previous = vtk.vtkOutputWindow.GetInstance()
    vtk.vtkOutputWindow.SetInstance(errors)
    try:
        reader.Update()
    finally:
        vtk.vtkOutputWindow.SetInstance(previous)
    text = errors.GetOutput().strip()
    if reader.GetErrorCode() or "ERROR" in text:
        message = " ".join(text.split())[-300:] or "the VTK reader failed"
        raise DumpFormatError(f"{path}: cannot read as VTK XML ({message})")
    return reader.GetOutput() if not isinstance(reader, vtk.vtkXMLMultiBlockDataReader) else reader.GetOutputDataObject(0)


def open_yade_vtk(paths, mapping_path, dt=None) -> YadeVtkRun:
    """A YADE run from its VTKRecorder output (a folder, or the files of its frames), read frame by
    frame (:class:`YadeVtkRun`). ``mapping_path``: the TOML mapping (module docstring); ``dt``:
    the time step O.dt [s]."""
    return YadeVtkRun(paths if isinstance(paths, (list, tuple)) else [paths], mapping_path, dt)
