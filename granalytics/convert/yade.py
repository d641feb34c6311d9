"""Read the CSV export of ``scripts/yade_export.py`` (YADE has no standard contact file).

Each frame is a particle file (``# time_s=… step=… dt_s=…`` then ``id,radius,x,y,z,vx,vy,vz,
wx,wy,wz,film_volume``) and a contact file (``id1,id2,gap,normal_force,bridge_active,
bridge_volume``). YADE applies the capillary force only while a bridge is active (separated,
s < s_crit): the force of an active bridge is its exported normal force; a touching pair with a
bridge volume carries the bridge at s → 0⁺, which YADE neither applies nor exports, so the reader
fills in Willett's F_cap(0⁺) from V_b, the pair radius, γ and θ (``capillary_type``
``"Willett_numeric"``, the only one read so far); ``capillary_in_contact`` is false, so the
"acting" convention still gives such pairs no cohesion and the "bridge" convention counts them,
as for runs of ``sim``. The total normal force is stored positive when repulsive (touching) and
negative when attractive (bridge). Material metadata (γ, ρ, Ω, θ, α, the capillary type) come from
a TOML file, as the CSVs do not carry them.
"""

from __future__ import annotations

import gzip
import io
import os
import re

import numpy as np
import pandas as pd

from granalytics.base.errors import GranalyticsError, ValidationError
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.convert._capillary import effective_radius, willett_numeric_contact_force
from granalytics.base.files import regular_input
from granalytics.convert._text import (DumpFormatError, load_toml, open_text, read_complete_lines,
                                       warn_unused_contact_steps)
from granalytics.convert.registry import StreamedSource

__all__ = ["YadeCsvRun", "open_yade_csv", "read_yade_csv", "PARTICLE_COLUMNS", "CONTACT_COLUMNS"]

PARTICLE_COLUMNS = ["id", "radius", "x", "y", "z", "vx", "vy", "vz", "wx", "wy", "wz", "film_volume"]
CONTACT_COLUMNS = ["id1", "id2", "gap", "normal_force", "bridge_active", "bridge_volume"]
_META_KEYS = {"surface_tension", "density", "drum_omega", "contact_angle", "alpha", "capillary_type"}
#: YADE ViscElCapMat capillary types whose F_cap(0⁺) the reader can fill in
_CAPILLARY_TYPES = {"Willett_numeric": willett_numeric_contact_force}


def _whole_numbers(values, path, what, first_line):
    """``values`` (read as numbers) as int64, refusing (DumpFormatError naming the line) one that is
    not a whole number within float64's exact integers (an id 11.5 was read as 11)."""
    values = np.asarray(values)
    if values.dtype.kind in "iu":
        return values.astype(np.int64)
    as_float = values.astype(float)
    bad = np.flatnonzero(~np.isfinite(as_float) | (as_float != np.round(as_float)) | (np.abs(as_float) > 2**53))
    if bad.size:
        k = int(bad[0])
        raise DumpFormatError(f"{path}, line {first_line + k}: {what} {float(values[k]):g} is not a whole number")
    return as_float.astype(np.int64)


def _header(path, line):
    """``(time [s], step)`` of an export file's first line ``line`` (``# time_s=… step=…``)."""
    info = dict(re.findall(r"(\w+)=(\S+)", line)) if line.startswith("#") else {}
    if "time_s" not in info or "step" not in info:
        raise DumpFormatError(f"{path}, line 1: expected '# time_s=... step=...', found {line.strip()[:60]!r}")
    try:
        return float(info["time_s"]), int(info["step"])
    except ValueError:
        raise DumpFormatError(f"{path}, line 1: time_s must be a number and step a whole number, found "
                              f"time_s={info['time_s']!r} step={info['step']!r}") from None


def _first_line(path) -> str:
    """The first line of an export file (plain or gzip), without reading the rest."""
    regular_input(path)
    try:
        with open_text(path) as f:
            return f.readline()
    except (OSError, EOFError, UnicodeDecodeError, gzip.BadGzipFile) as exc:
        raise DumpFormatError(f"{path}: cannot read ({' '.join(str(exc).split())})") from None


def _read(path, columns):
    lines = read_complete_lines(path)  # refuses a file whose last line was cut
    time, step = _header(path, lines[0] if lines else "")
    try:
        table = pd.read_csv(io.StringIO("\n".join(lines[1:]) + "\n"), dtype=float)
    except (pd.errors.ParserError, ValueError) as exc:
        raise DumpFormatError(f"{path}: cannot read as a granalytics YADE export "
                              f"({' '.join(str(exc).split())})") from None
    if list(table.columns) != columns:
        raise DumpFormatError(f"{path}, line 2: columns {list(table.columns)}, expected {columns}")
    bad = ~np.isfinite(table.to_numpy())
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise DumpFormatError(f"{path}, line {r + 3}: non-finite or missing value in column {columns[c]!r}")
    return time, step, table


def read_yade_mapping(meta_toml, extra_keys=()):
    """``(capillary_type, metadata)`` of a YADE mapping file: the keys of :data:`_META_KEYS` (and
    ``extra_keys``), a capillary type the readers can fill in, γ and θ numbers (the bridge force at
    contact needs them). Shared by the CSV reader and the VTKRecorder reader."""
    meta_data = load_toml(meta_toml)
    allowed = _META_KEYS | set(extra_keys)
    unknown = sorted(set(meta_data) - allowed)
    if unknown:
        raise ValidationError("mapping", f"unknown keys {unknown} in {meta_toml} (allowed: {sorted(allowed)})")
    capillary_type = meta_data.pop("capillary_type", "Willett_numeric")
    if capillary_type not in _CAPILLARY_TYPES:
        raise ValidationError("mapping", f"{meta_toml}: capillary_type {capillary_type!r} is not read (known: "
                              f"{', '.join(_CAPILLARY_TYPES)})")
    gamma, theta = meta_data.get("surface_tension"), meta_data.get("contact_angle", 0.0)
    for key, value in (("surface_tension", gamma), ("contact_angle", theta)):
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ValidationError("mapping", f"{meta_toml}: {key} must be a number (the bridge force at contact "
                                  f"needs it), got {value!r}")
    return capillary_type, meta_data


class YadeCsvRun(StreamedSource):
    """A run exported by ``scripts/yade_export.py``, read one frame (a particle file and its contact
    file) at a time: the same interface as the other streaming readers
    (:class:`granalytics.convert.registry.FrameSource`). The files are ordered by the step their
    first line gives; a step twice, a particle step without its contact file, and contact files
    after the last particle step are refused before anything else is read."""

    def __init__(self, particle_files, contact_files, meta_toml):
        self.capillary_type, self._meta_data = read_yade_mapping(meta_toml)
        self.meta_toml = meta_toml
        self.particle_files, self.contact_files = list(particle_files), list(contact_files)
        if not self.particle_files:
            raise DumpFormatError("no particle files given")
        contacts = self._by_step(self.contact_files, "contact")
        particles = self._by_step(self.particle_files, "particle")
        warn_unused_contact_steps(contacts, particles, self.contact_files)
        missing = next((step for step in sorted(particles) if step not in contacts), None)
        if missing is not None:
            raise DumpFormatError(f"{particles[missing]}: no contact file for step {missing}")
        self._pairs = [(step, particles[step], contacts[step]) for step in sorted(particles)]
        self.total_bytes = sum(os.path.getsize(path) for path in self.particle_files + self.contact_files)
        self._bytes_read = 0
        self.meta = None

    @staticmethod
    def _by_step(files, what) -> dict:
        """{step: path} of ``files`` from their first lines."""
        out = {}
        for path in files:
            _, step = _header(path, _first_line(path))
            if step in out:
                raise DumpFormatError(f"{path}: {what} step {step} already read from {out[step]}")
            out[step] = path
        return out

    @property
    def bytes_read(self) -> int:
        return self._bytes_read

    def frame_bytes(self) -> int:
        """Estimated memory of one frame while it is read [bytes]: about eight times its largest
        particle and contact files as stored (the text, its lines, the table and the snapshot)."""
        return 8 * max(os.path.getsize(p) + os.path.getsize(c) for _, p, c in self._pairs)

    def _nothing_read(self):
        later = f" after step {self._after}" if self._after is not None else ""
        return DumpFormatError(f"no frames{later} in " + ", ".join(map(str, self.particle_files[:3]))
                               + (", ..." if len(self.particle_files) > 3 else ""))

    def _read(self):
        for step, path, cpath in self._pairs:
            snapshot = None if self._after is not None and step <= self._after else self._snapshot(path, cpath)
            self._bytes_read += os.path.getsize(path) + os.path.getsize(cpath)
            if snapshot is not None:
                yield snapshot

    def _snapshot(self, path, cpath) -> Snapshot:
        time, step, p = _read(path, PARTICLE_COLUMNS)
        _, _, c = _read(cpath, CONTACT_COLUMNS)
        gamma, theta = self._meta_data.get("surface_tension"), self._meta_data.get("contact_angle", 0.0)
        ids = _whole_numbers(p["id"].to_numpy(), path, "particle id", first_line=3)
        row = {int(pid): k for k, pid in enumerate(ids)}
        rows = []
        for name in ("id1", "id2"):
            r = np.array([row.get(int(x), -1) for x in _whole_numbers(c[name].to_numpy(), cpath, name, first_line=3)],
                         dtype=np.int64)
            if (r < 0).any():
                k = int(np.flatnonzero(r < 0)[0])
                raise DumpFormatError(f"{cpath}, line {k + 3}: particle id {int(c[name].iloc[k])} is not in {path}")
            rows.append(r)
        active = c["bridge_active"].to_numpy() != 0
        gap = c["gap"].to_numpy()
        force = c["normal_force"].to_numpy()
        volume = c["bridge_volume"].to_numpy()
        radius = p["radius"].to_numpy()
        touching_wet = (gap <= 0) & (volume > 0)
        f_cap = np.where(active, force, 0.0)
        f_cap[touching_wet] = _CAPILLARY_TYPES[self.capillary_type](
            volume[touching_wet], effective_radius(radius[rows[0][touching_wet]], radius[rows[1][touching_wet]]),
            gamma, theta)
        if self.meta is None:
            self.meta = self._run_meta(len(ids), float(radius.mean()))
        try:
            return Snapshot(
                time=time, step=step, ids=ids, radius=radius,
                position=p[["x", "y", "z"]].to_numpy(), velocity=p[["vx", "vy", "vz"]].to_numpy(),
                angular_velocity=p[["wx", "wy", "wz"]].to_numpy(), film_volume=p["film_volume"].to_numpy(),
                contact_i=np.minimum(*rows), contact_j=np.maximum(*rows),
                f_cap=f_cap, f_normal=np.where(gap > 0, -force, force), gap=gap, bridge_volume=volume, meta=self.meta,
            )
        except ValidationError as exc:
            raise exc.located(f"{path} / {cpath}") from None

    def _run_meta(self, n_particles, mean_radius) -> RunMeta:
        try:
            return RunMeta(n_particles=n_particles, mean_radius=mean_radius,
                           capillary_in_contact=False,  # YADE's ViscElCapPhys law: no capillary force in contact
                           provenance={"source": "YADE export (scripts/yade_export.py)",
                                       "capillary_type": self.capillary_type,
                                       "f_cap_in_contact": "Willett F_cap(0+) filled in by the reader",
                                       "particle_files": list(map(str, self.particle_files)),
                                       "contact_files": list(map(str, self.contact_files))},
                           **self._meta_data)
        except TypeError as exc:
            raise GranalyticsError(f"{self.meta_toml}: {exc}") from None


def open_yade_csv(particle_files, contact_files, meta_toml) -> YadeCsvRun:
    """A YADE run exported by ``scripts/yade_export.py``, read lazily frame by frame (:class:`YadeCsvRun`)."""
    return YadeCsvRun(particle_files, contact_files, meta_toml)


def read_yade_csv(particle_files, contact_files, meta_toml):
    """Snapshots (sorted by step) and metadata of a YADE run exported by ``scripts/yade_export.py``,
    every frame in memory (:func:`open_yade_csv` reads them one at a time)."""
    run = open_yade_csv(particle_files, contact_files, meta_toml)
    snapshots = list(run)
    return snapshots, run.meta
