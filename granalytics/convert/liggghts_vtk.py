"""LIGGGHTS' VTK dumps (``dump custom/vtk``, ``dump local/gran/vtk``: what LIGGGHTS users open in
ParaView), read with the VTK library into the tables the dump reader uses, so that a run of VTK
files goes through the same mapping, checks and frame loop as a run of text dumps
(:mod:`granalytics.convert.lammps`).

One file holds one timestep, taken from the number before the extension (``atoms_5000.vtu``,
``pairs_5000.vtp``; LIGGGHTS' ``*`` in the file name). Each array becomes a column of the
block's table under the name the dump's column would have: the points ``x y z`` (LIGGGHTS writes
them in **single precision**), ``v`` → ``vx vy vz``, ``omega`` → ``omegax omegay omegaz``, any
other array of three components ``NAME_x NAME_y NAME_z``, one-component arrays under their own
name (``id``, ``radius``, ``id1``, ``id2``, ``delta``, ``f_…``). A mapping for the contacts of
``dump local/gran/vtk`` of ``compute pair/gran/local id pos force force_normal delta`` is then
``contact_id_i = "id1"``, ``contact_id_j = "id2"``, ``contact_f_normal = ["force_normal_x",
"force_normal_y", "force_normal_z"]``, ``contact_overlap = "delta"``.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pandas as pd

from granalytics.base.files import regular_input
from granalytics.convert._text import DumpFormatError

__all__ = ["VtkDumpFile", "is_vtk"]

_STEP = re.compile(r"(\d+)\.vt[kup]$")
_RENAMED = {"v": ("vx", "vy", "vz"), "omega": ("omegax", "omegay", "omegaz")}


def is_vtk(path) -> bool:
    """Whether ``path`` names a VTK file (``.vtu``, ``.vtp``, legacy ``.vtk``)."""
    return str(path).endswith((".vtu", ".vtp", ".vtk"))


class VtkDumpFile:
    """One VTK dump file of one timestep, with the interface of
    :class:`granalytics.convert.lammps.DumpFile` (its rows: the points of ``ATOMS``, the cells
    (lines) of ``ENTRIES``)."""

    def __init__(self, path, kind):
        regular_input(path)
        self.path, self.kind = path, kind
        self.size = os.path.getsize(path)
        self.bytes_read = 0
        match = _STEP.search(os.path.basename(str(path)))
        if not match:
            raise DumpFormatError(f"{path}: no timestep in the file name (LIGGGHTS names its VTK dumps NAME_STEP.vtu)")
        self.step = int(match[1])

    def first_step(self):
        return self.step

    def first_counts(self, blocks=1, enough=0):
        return (max(1, self.size // 100), 14)  # a bound from the file size: the header says nothing cheaper

    def blocks(self, int_columns=(), after=None):
        from granalytics.convert.lammps import Block

        if after is not None and self.step <= after:
            self.bytes_read = self.size
            yield Block(self.step, None, 0, 0)
            return
        table = self._table(int_columns)
        self.bytes_read = self.size
        yield Block(self.step, table, 0, 0)

    def _table(self, int_columns):
        from granalytics.convert.yade_vtk import _update, _vtk

        vtk, to_numpy = _vtk()
        reader = {".vtu": vtk.vtkXMLUnstructuredGridReader, ".vtp": vtk.vtkXMLPolyDataReader,
                  ".vtk": vtk.vtkGenericDataObjectReader}[os.path.splitext(str(self.path))[1]]()
        reader.SetFileName(str(self.path))
        data = _update(reader, self.path)
        arrays = data.GetPointData() if self.kind == "ATOMS" else data.GetCellData()
        columns = {}
        if self.kind == "ATOMS" and data.GetPoints() is not None:
            points = to_numpy(data.GetPoints().GetData()).astype(np.float64).reshape(-1, 3)
            columns.update(x=points[:, 0], y=points[:, 1], z=points[:, 2])
        for k in range(arrays.GetNumberOfArrays()):
            array = arrays.GetArray(k)
            name, values = array.GetName(), to_numpy(array)
            if values.ndim == 2 and values.shape[1] == 3:
                for c, column in enumerate(_RENAMED.get(name, (f"{name}_x", f"{name}_y", f"{name}_z"))):
                    columns[column] = values[:, c].astype(np.float64)
            elif values.ndim == 1:
                columns[name] = values
        table = pd.DataFrame(columns)
        for name in table.columns:
            values = table[name].to_numpy()
            if name in int_columns:
                whole = np.isfinite(values) & (values == np.round(values)) & (np.abs(values) <= 2**53)
                if not whole.all():
                    k = int(np.flatnonzero(~whole)[0])
                    raise DumpFormatError(f"{self.path}: row {k}: {name} {values[k]!r} is not a whole number")
                table[name] = values.astype(np.int64)
            elif not np.isfinite(values.astype(np.float64)).all():
                k = int(np.flatnonzero(~np.isfinite(values.astype(np.float64)))[0])
                raise DumpFormatError(f"{self.path}: row {k}: non-finite value in {name!r}")
        return table
