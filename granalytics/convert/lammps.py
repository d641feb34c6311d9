"""Read LIGGGHTS / LAMMPS text dumps into snapshots.

A run is a particle dump (``dump custom``: ``id``, ``radius`` or ``diameter``, ``x y z``,
``vx vy vz``, ``omegax omegay omegaz`` in any order, optional liquid column; several timesteps
per file or one file per timestep; plain or gzip) plus the matching contact dump
(``compute pair/gran/local`` + ``dump local``). What cannot be read from the files is declared
in a :class:`DumpMapping` (units, which ``ENTRIES`` columns hold the particle ids, the cohesive
force, the normal force, the gap or overlap and the bridge volume, and the material
metadata); anything missing is asked for with an error naming the file, line and field,
never guessed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from granalytics.base.errors import ValidationError
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.convert._text import DumpFormatError, load_toml, read_complete_lines, warn_unused_contact_steps

__all__ = ["DumpMapping", "read_dump_blocks", "integer_column", "read_liggghts"]


@dataclass
class DumpMapping:
    """What the dump files cannot say. All quantities SI.

    Parameters
    ----------
    units : str
        Must be ``"si"`` (LAMMPS ``units si``); other unit systems are refused.
    surface_tension, density, drum_omega : float
        Run metadata [N/m, kg/m³, rad/s].
    contact_angle : float, default 0 [rad]; alpha : float, default 1
    contact_id_i, contact_id_j : str
        ``ENTRIES`` columns of the contact dump holding the two particle ids.
    contact_f_cap : str, list of 3 str, or None
        The cohesive force F_coh [N]. None (recommended for LIGGGHTS, whose ``pair/gran/local``
        has no separate cohesive force): the attractive part of the signed normal force of
        ``contact_f_normal``, i.e. the cohesion the code applied; a compressed contact has none.
        One column: a cohesive-force magnitude written by the code (taken as |value|). Three
        columns: a normal-force vector on particle ``contact_id_i``, whose attractive component
        along the branch vector is used.
    contact_f_normal : str, list of 3 str, or None
        The total normal force [N]. One column: signed, positive = repulsive. Three columns
        (LIGGGHTS ``force_normal``): the normal force vector acting on the particle of
        ``contact_id_i``; it is stored signed, ``−F·n̂`` with n̂ the unit vector from particle
        i to particle j (positive = repulsive). None: not in the dump (stored as 0 and recorded
        in provenance); then ``contact_f_cap`` is required.
    capillary_in_contact : bool, default True
        Whether the code applied cohesion between touching particles (LIGGGHTS' ``easo``
        capillary model does); recorded in the run metadata. With F_coh taken from the signed
        normal force, both cohesion conventions then agree.
    contact_gap : str or None
        Column with the surface gap [m]; or use ``contact_overlap`` (LIGGGHTS ``delta``, overlap
        = −gap). One of the two is required.
    contact_overlap : str or None
    contact_bridge_volume : str or None
        Column with the bridge volume [m³]; None: 0 (recorded in provenance).
    film_column : str or None
        Particle column with the liquid film; None: no film data (0).
    film_unit : {"m3", "percent_of_particle_volume"}
        Unit of ``film_column`` (LIGGGHTS' ``surfaceLiquidContent`` is in % of the particle
        volume).
    """

    surface_tension: float
    density: float
    drum_omega: float
    contact_id_i: str
    contact_id_j: str
    contact_f_cap: str | list | None = None
    units: str = "si"
    capillary_in_contact: bool = True
    contact_angle: float = 0.0
    alpha: float = 1.0
    contact_f_normal: str | None = None
    contact_gap: str | None = None
    contact_overlap: str | None = None
    contact_bridge_volume: str | None = None
    film_column: str | None = None
    film_unit: str = "m3"
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in ("surface_tension", "density", "drum_omega", "contact_angle", "alpha"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValidationError(name, f"must be a number in SI units, got {value!r}")
        for name in ("contact_f_cap", "contact_f_normal"):
            value = getattr(self, name)
            if isinstance(value, (list, tuple)) and (len(value) != 3 or not all(isinstance(c, str) for c in value)):
                raise ValidationError(name, f"must be one column name or a list of 3 (a vector), got {value!r}")
        if self.units != "si":
            raise ValidationError("units", f"only LAMMPS 'units si' dumps are read, got {self.units!r}")
        if (self.contact_gap is None) == (self.contact_overlap is None):
            raise ValidationError("contact_gap", "declare exactly one of contact_gap or contact_overlap")
        if self.contact_f_cap is None and self.contact_f_normal is None:
            raise ValidationError("contact_f_cap", "declare contact_f_normal (F_coh is its attractive part) or contact_f_cap")
        if not isinstance(self.capillary_in_contact, bool):
            raise ValidationError("capillary_in_contact", f"must be true or false, got {self.capillary_in_contact!r}")
        if self.film_unit not in ("m3", "percent_of_particle_volume"):
            raise ValidationError("film_unit", f"must be 'm3' or 'percent_of_particle_volume', got {self.film_unit!r}")

    @classmethod
    def from_toml(cls, path) -> "DumpMapping":
        """Read a mapping from a TOML file (keys as the constructor's)."""
        data = load_toml(path)
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValidationError("mapping", f"unknown keys {unknown} in {path}")
        try:
            return cls(**data)
        except TypeError as exc:
            raise ValidationError("mapping", f"{path}: {exc}") from None
        except ValidationError as exc:
            raise exc.located(path) from None


def read_dump_blocks(path, kind):
    """Yield ``(timestep, columns, data, first_line, text)`` for every block of a dump file.

    ``data`` holds the values as float64 (rows × columns), ``text`` the same fields as written
    (an array of str), from which :func:`integer_column` reads ids exactly. Fields may be
    separated by spaces or tabs, as LAMMPS' ``dump_modify format`` allows.

    Parameters
    ----------
    kind : {"ATOMS", "ENTRIES"}
        Particle dump (``dump custom``) or local dump (``dump local``).
    """
    count_item = "NUMBER OF ATOMS" if kind == "ATOMS" else "NUMBER OF ENTRIES"
    lines = read_complete_lines(path)
    k = 0
    seen = set()

    def fail(line_no, msg):
        raise DumpFormatError(f"{path}, line {line_no + 1}: {msg}")

    def expect(line_no, item):
        if line_no >= len(lines):
            fail(line_no, f"file ends where 'ITEM: {item}' was expected")
        if not " ".join(lines[line_no].split()).startswith(f"ITEM: {item}"):  # tabs or runs of spaces
            fail(line_no, f"expected 'ITEM: {item}', found {lines[line_no][:60]!r}")

    while k < len(lines):
        if not lines[k].strip():
            k += 1
            continue
        expect(k, "TIMESTEP")
        try:
            step = int(lines[k + 1])
        except (IndexError, ValueError):
            fail(k + 1, "timestep is not an integer")
        if step in seen:
            fail(k, f"timestep {step} appears twice")
        seen.add(step)
        expect(k + 2, count_item)
        try:
            n = int(lines[k + 3])
        except (IndexError, ValueError):
            fail(k + 3, f"{count_item.lower()} is not an integer")
        if n < 0:
            fail(k + 3, f"negative {count_item.lower()} {n}")
        expect(k + 4, "BOX BOUNDS")
        expect(k + 8, kind)
        columns = lines[k + 8].split()[2:]
        if len(set(columns)) != len(columns):
            fail(k + 8, f"repeated column names {columns}")
        first = k + 9
        rows = lines[first:first + n]
        if len(rows) < n:
            fail(first + len(rows), f"file ends after {len(rows)} of {n} rows of timestep {step}")
        data = np.empty((n, len(columns)))
        fields = []
        for r, text in enumerate(rows):
            fields.append(text.split())
            if len(fields[-1]) != len(columns):
                fail(first + r, f"{len(fields[-1])} values for {len(columns)} columns")
            try:
                data[r] = [float(x) for x in fields[-1]]
            except ValueError:
                fail(first + r, f"not a number in {text[:60]!r}")
        bad = ~np.isfinite(data)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            fail(first + r, f"non-finite value in column {columns[c]!r}")
        yield step, columns, data, first, np.array(fields, dtype=str).reshape(n, len(columns))
        k = first + n


def integer_column(texts, path, first_line, what) -> np.ndarray:
    """The fields ``texts`` of one column (as written, rows from ``first_line``, 0-based) as exact
    int64: an integer is read as written (never through float64, which rounds above 2**53); a
    number written as a float (``12.0``, ``1.2e3``) only when it is whole and at most 2**53, where
    float64 is exact. Anything else raises :class:`DumpFormatError` naming the line."""
    out = np.empty(len(texts), dtype=np.int64)
    for r, text in enumerate(texts):
        try:
            out[r] = int(text)
            continue
        except OverflowError:
            problem = "is beyond the 64-bit integers"
        except ValueError:
            value = float(text)  # a number: read_dump_blocks checked it
            if value.is_integer() and abs(value) <= 2**53:
                out[r] = int(value)
                continue
            problem = ("is written as a float above 2**53, where floats skip integers: write ids as integers"
                       if value.is_integer() else "is not a whole number")
        raise DumpFormatError(f"{path}, line {first_line + r + 1}: {what} {text!r} {problem}")
    return out


def _column(columns, name, path, line, what):
    if name not in columns:
        raise DumpFormatError(f"{path}, line {line}: no column {name!r} for {what} (columns: {' '.join(columns)})")
    return columns.index(name)


def _particles(columns, data, text, path, line, mapping):
    def col(name, what):
        return data[:, _column(columns, name, path, line, what)]

    if "radius" in columns:
        radius = col("radius", "radius")
    elif "diameter" in columns:
        radius = col("diameter", "diameter") / 2
    else:
        raise DumpFormatError(f"{path}, line {line}: the particle dump needs a 'radius' or 'diameter' column")
    ids = integer_column(text[:, _column(columns, "id", path, line, "particle ids")], path, line, "particle id")
    out = {
        "ids": ids,
        "radius": radius,
        "position": np.column_stack([col(c, "positions") for c in ("x", "y", "z")]),
        "velocity": np.column_stack([col(c, "velocities") for c in ("vx", "vy", "vz")]),
        "angular_velocity": np.column_stack([col(c, "angular velocities") for c in ("omegax", "omegay", "omegaz")]),
        "film_volume": np.zeros(len(ids)),
    }
    if mapping.film_column:
        film = col(mapping.film_column, "the liquid film")
        if mapping.film_unit == "percent_of_particle_volume":
            film = film / 100 * 4 / 3 * np.pi * radius**3
        out["film_volume"] = film
    return out


def _contacts(columns, data, text, path, line, mapping, id_to_row, position):
    def col(name, what):
        return data[:, _column(columns, name, path, line, what)]

    def signed_normal(name, what):
        """Signed normal force [N], positive = repulsive: a column as is, or −F·n̂ of a vector
        on particle i (n̂ from i to j)."""
        if not isinstance(name, (list, tuple)):
            return col(name, what)
        force = np.column_stack([col(c, what) for c in name])
        branch = position[rows[1]] - position[rows[0]]
        length = np.linalg.norm(branch, axis=1)
        length[length == 0] = np.inf  # coincident centres: no direction, no normal force
        return -(force * branch).sum(axis=1) / length

    rows = []
    for name in (mapping.contact_id_i, mapping.contact_id_j):
        ids = integer_column(text[:, _column(columns, name, path, line, name)], path, line, f"contact particle id ({name})")
        r = np.array([id_to_row.get(int(x), -1) for x in ids], dtype=np.int64)
        if (r < 0).any():
            k = int(np.flatnonzero(r < 0)[0])
            raise DumpFormatError(f"{path}, line {line + k + 1}: contact names particle id {int(ids[k])}, "
                                  "which is not in the particle dump of this timestep")
        rows.append(r)
    ci, cj = np.minimum(*rows), np.maximum(*rows)
    if mapping.contact_gap:
        gap = col(mapping.contact_gap, "contact_gap")
    else:
        gap = -col(mapping.contact_overlap, "contact_overlap")
    f_normal = (signed_normal(mapping.contact_f_normal, "contact_f_normal") if mapping.contact_f_normal
                else np.zeros(len(ci)))
    if mapping.contact_f_cap is None:
        f_coh = np.maximum(-f_normal, 0.0)
    elif isinstance(mapping.contact_f_cap, (list, tuple)):
        f_coh = np.maximum(-signed_normal(mapping.contact_f_cap, "contact_f_cap"), 0.0)
    else:
        f_coh = np.abs(col(mapping.contact_f_cap, "contact_f_cap"))
    volume = col(mapping.contact_bridge_volume, "contact_bridge_volume") if mapping.contact_bridge_volume else np.zeros(len(ci))
    return {
        "contact_i": ci, "contact_j": cj, "f_cap": f_coh, "f_normal": f_normal, "gap": gap, "bridge_volume": volume,
    }


def _blocks_by_step(files, kind):
    """``{timestep: (columns, data, first_line, path)}`` over all blocks of all files."""
    blocks = {}
    for path in files:
        for step, columns, data, line, text in read_dump_blocks(path, kind):
            if step in blocks:
                raise DumpFormatError(f"{path}, line {line}: timestep {step} already read from {blocks[step][3]}")
            blocks[step] = (columns, data, line, path, text)
    return blocks


def read_liggghts(particle_files, contact_files, mapping: DumpMapping, dt=None):
    """Snapshots of a LIGGGHTS / LAMMPS run.

    Parameters
    ----------
    particle_files, contact_files : sequence of paths
        Dumps (any number of timesteps each); every particle timestep needs a contact timestep.
    mapping : DumpMapping
    dt : float
        Time step [s] (time = timestep·dt). Required: dumps do not carry it.

    Returns
    -------
    (list of Snapshot, RunMeta)
    """
    if dt is None or not (math.isfinite(dt) and dt > 0):
        raise ValidationError("dt", f"the dumps do not record the time step: pass dt in seconds (> 0), got {dt!r}")
    contacts = _blocks_by_step(contact_files, "ENTRIES")
    particles = _blocks_by_step(particle_files, "ATOMS")
    if not particles:
        raise DumpFormatError("no particle timesteps in " + ", ".join(map(str, particle_files)))
    n0 = None
    snapshots = []
    for step in sorted(particles):
        columns, data, line, path, text = particles[step]
        if step not in contacts:
            raise DumpFormatError(f"{path}, line {line}: no contact dump for timestep {step}")
        part = _particles(columns, data, text, path, line, mapping)
        id_to_row = {int(pid): r for r, pid in enumerate(part["ids"])}
        if len(id_to_row) != len(part["ids"]):
            raise DumpFormatError(f"{path}, line {line}: duplicate particle ids in timestep {step}")
        ccols, cdata, cline, cpath, ctext = contacts[step]
        cont = _contacts(ccols, cdata, ctext, cpath, cline, mapping, id_to_row, part["position"])
        n0 = n0 or len(part["ids"])
        if len(part["ids"]) != n0:
            raise DumpFormatError(f"{path}, line {line}: timestep {step} has {len(part['ids'])} particles, the first "
                                  f"timestep {n0}; a run keeps its particles")
        try:
            snapshots.append(Snapshot(time=step * dt, step=step, **part, **cont))
        except ValidationError as exc:
            raise exc.located(f"{path} / {cpath} (timestep {step})") from None
    warn_unused_contact_steps(contacts, particles, contact_files)
    meta = RunMeta(
        surface_tension=mapping.surface_tension, density=mapping.density, drum_omega=mapping.drum_omega,
        n_particles=n0, mean_radius=float(snapshots[0].radius.mean()), alpha=mapping.alpha,
        contact_angle=mapping.contact_angle, capillary_in_contact=mapping.capillary_in_contact,
        provenance={"source": "LIGGGHTS/LAMMPS dumps", "particle_files": list(map(str, particle_files)),
                    "contact_files": list(map(str, contact_files)), "mapping": dataclasses.asdict(mapping),
                    "not_in_dumps": [k for k, v in (("f_normal", mapping.contact_f_normal),
                                                    ("bridge_volume", mapping.contact_bridge_volume),
                                                    ("film_volume", mapping.film_column)) if v is None]},
    )
    for s in snapshots:
        s.meta = meta
    return snapshots, meta
