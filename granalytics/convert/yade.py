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

import io
import re

import numpy as np
import pandas as pd

from granalytics.base.errors import GranalyticsError, ValidationError
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.convert._capillary import effective_radius, willett_numeric_contact_force
from granalytics.convert._text import DumpFormatError, load_toml, read_complete_lines, warn_unused_contact_steps

__all__ = ["read_yade_csv", "PARTICLE_COLUMNS", "CONTACT_COLUMNS"]

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


def _read(path, columns):
    lines = read_complete_lines(path)  # refuses a file whose last line was cut
    header = lines[0] if lines else ""
    try:
        table = pd.read_csv(io.StringIO("\n".join(lines[1:]) + "\n"), dtype=float)
    except (pd.errors.ParserError, ValueError) as exc:
        raise DumpFormatError(f"{path}: cannot read as a granalytics YADE export "
                              f"({' '.join(str(exc).split())})") from None
    info = dict(re.findall(r"(\w+)=(\S+)", header)) if header.startswith("#") else {}
    if "time_s" not in info or "step" not in info:
        raise DumpFormatError(f"{path}, line 1: expected '# time_s=... step=...', found {header.strip()[:60]!r}")
    if list(table.columns) != columns:
        raise DumpFormatError(f"{path}, line 2: columns {list(table.columns)}, expected {columns}")
    bad = ~np.isfinite(table.to_numpy())
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise DumpFormatError(f"{path}, line {r + 3}: non-finite or missing value in column {columns[c]!r}")
    try:
        return float(info["time_s"]), int(info["step"]), table
    except ValueError:
        raise DumpFormatError(f"{path}, line 1: time_s must be a number and step a whole number, found "
                              f"time_s={info['time_s']!r} step={info['step']!r}") from None


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


def read_yade_csv(particle_files, contact_files, meta_toml):
    """Snapshots (sorted by step) and metadata of a YADE run exported by ``scripts/yade_export.py``."""
    capillary_type, meta_data = read_yade_mapping(meta_toml)
    gamma, theta = meta_data.get("surface_tension"), meta_data.get("contact_angle", 0.0)
    contacts = {}
    for path in contact_files:
        time, step, table = _read(path, CONTACT_COLUMNS)
        if step in contacts:
            raise DumpFormatError(f"{path}: contact step {step} already read")
        contacts[step] = (table, path)
    frames = {}
    for path in particle_files:
        time, step, table = _read(path, PARTICLE_COLUMNS)
        if step in frames:
            raise DumpFormatError(f"{path}: particle step {step} already read")
        frames[step] = (time, table, path)
    if not frames:
        raise DumpFormatError("no particle files given")
    warn_unused_contact_steps(contacts, frames, list(contact_files))
    snapshots = []
    for step in sorted(frames):
        time, p, path = frames[step]
        if step not in contacts:
            raise DumpFormatError(f"{path}: no contact file for step {step}")
        c, cpath = contacts[step]
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
        f_cap[touching_wet] = _CAPILLARY_TYPES[capillary_type](
            volume[touching_wet], effective_radius(radius[rows[0][touching_wet]], radius[rows[1][touching_wet]]),
            gamma, theta)
        try:
            snapshots.append(Snapshot(
                time=time, step=step, ids=ids, radius=p["radius"].to_numpy(),
                position=p[["x", "y", "z"]].to_numpy(), velocity=p[["vx", "vy", "vz"]].to_numpy(),
                angular_velocity=p[["wx", "wy", "wz"]].to_numpy(), film_volume=p["film_volume"].to_numpy(),
                contact_i=np.minimum(*rows), contact_j=np.maximum(*rows),
                f_cap=f_cap, f_normal=np.where(gap > 0, -force, force), gap=gap, bridge_volume=volume,
            ))
        except ValidationError as exc:
            raise exc.located(f"{path} / {cpath}") from None
    first = snapshots[0]
    try:
        meta = RunMeta(n_particles=first.n_particles, mean_radius=float(first.radius.mean()),
                       capillary_in_contact=False,  # YADE's ViscElCapPhys law: no capillary force in contact
                       provenance={"source": "YADE export (scripts/yade_export.py)", "capillary_type": capillary_type,
                                   "f_cap_in_contact": "Willett F_cap(0+) filled in by the reader",
                                   "particle_files": list(map(str, particle_files)),
                                   "contact_files": list(map(str, contact_files))},
                       **meta_data)
    except TypeError as exc:
        raise GranalyticsError(f"{meta_toml}: {exc}") from None
    for s in snapshots:
        s.meta = meta
    return snapshots, meta
