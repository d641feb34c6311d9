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
import gzip
import io
import math
import os
import zlib
import warnings
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd

from granalytics.base.errors import ValidationError, user_stacklevel
from granalytics.base.files import regular_input
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.convert._text import DumpFormatError, load_toml, warn_unused_contact_steps
from granalytics.convert.registry import StreamedSource

__all__ = ["DumpMapping", "DumpFile", "Block", "Box", "integer_column", "LiggghtsRun", "open_liggghts", "read_liggghts"]


#: ids from here on are checked for lost digits: LAMMPS writes ``dump local`` columns with ``%g``
#: (six significant digits), which writes an integer from 10**6 on in exponent form
FEW_DIGITS_ABOVE = 10**6

#: the radii a dump in SI units may hold [m]: outside them it is in another unit
MIN_RADIUS_M, MAX_RADIUS_M = 1e-7, 0.5


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


@dataclass(frozen=True)
class Box:
    """The simulation box of a dump block, as its ``ITEM: BOX BOUNDS`` gives it.

    Attributes
    ----------
    edges : ndarray (3, 3) [m]
        The box's edge vectors as columns (LAMMPS' restricted triclinic form: ``[[lx, xy, xz],
        [0, ly, yz], [0, 0, lz]]``; the tilts are 0 for an orthogonal box).
    periodic : tuple of 3 bool
        Which of x, y, z are periodic (the ``pp`` flags).
    """

    edges: np.ndarray
    periodic: tuple

    def minimum_image(self, branch):
        """The vectors ``branch`` (n×3 [m], between wrapped positions) to their nearest periodic
        image along the periodic axes, in LAMMPS' order (z, then y, then x)."""
        branch = np.array(branch, dtype=np.float64)
        for axis in (2, 1, 0):
            if self.periodic[axis]:
                branch -= np.rint(branch[:, axis] / self.edges[axis, axis])[:, None] * self.edges[:, axis]
        return branch


class Block(NamedTuple):
    """One timestep of a dump, as :meth:`DumpFile.blocks` yields it."""

    #: the timestep
    step: int
    #: its rows (a DataFrame), or None where passed over unparsed
    table: object
    #: the 0-based line of its first row (the 1-based line of its ``ITEM: ATOMS``/``ENTRIES``); 0 in a VTK file
    first_line: int
    #: the 1-based line of its ``ITEM: TIMESTEP``; 0 in a VTK file
    step_line: int
    #: its simulation box, None where the file does not give one (VTK) or gives no periodic axis
    box: Box | None = None


def _at(path, line) -> str:
    """``PATH, line N`` for an error, or ``PATH`` where there is no line (a VTK file)."""
    return f"{path}, line {line}" if line else f"{path}"


class DumpFile:
    """One dump file, read block by block (``dump custom`` or ``dump local``; plain or gzip).

    The file is read incrementally: one block (timestep) is in memory at a time, so a file of
    hundreds of timesteps costs the memory of one. Each block's rows are parsed by pandas' C
    reader; a block it cannot read cleanly is read again line by line to name the line and
    field at fault. :attr:`bytes_read` (of the file as stored, compressed or not) follows the
    reading, for progress bars.

    Parameters
    ----------
    path : str or path-like
    kind : {"ATOMS", "ENTRIES"}
        Particle dump (``dump custom``) or local dump (``dump local``).
    """

    def __init__(self, path, kind):
        regular_input(path)  # a FIFO would block for ever
        self.path, self.kind = path, kind
        self.size = os.path.getsize(path)
        self.bytes_read = 0

    def first_step(self):
        """The timestep of the file's first block (None for an empty file), from its first lines."""
        with _BlockReader(self, peek=True) as reader:
            return reader.peek_step()

    def first_counts(self, blocks=1, enough=0):
        """``(rows, columns)`` of the file's first block, from its header (``(0, 0)`` if empty); of
        the largest of its first ``blocks`` while they hold fewer than ``enough`` rows."""
        with _BlockReader(self, peek=True) as reader:
            return reader.peek_counts(blocks, enough)

    def blocks(self, int_columns=(), after=None):
        """Yield a :class:`Block` for every timestep: its ``table`` a DataFrame of the block's
        columns (float64; the ``int_columns`` present read exactly as int64, see
        :func:`integer_column`). Blocks of timesteps up to ``after`` are passed over unparsed
        (``table`` None)."""
        with _BlockReader(self) as reader:
            yield from reader.blocks(int_columns, after)


class _BlockReader:
    """The reading of one :class:`DumpFile`: its open file, the line count and the parsing."""

    #: bytes read from the (decompressed) file at a time
    CHUNK = 1 << 22

    def __init__(self, dump, peek=False):
        self.dump, self.path, self.peek = dump, dump.path, peek
        self.line = 0  # 0-based number of the next line
        self.buffer, self.at, self.eof = b"", 0, False  # read ahead in chunks; self.at: the next unread byte

    def __enter__(self):
        try:
            self.raw = open(self.path, "rb")
            self.file = gzip.GzipFile(fileobj=self.raw) if str(self.path).endswith(".gz") else self.raw
        except OSError as exc:
            raise DumpFormatError(f"{self.path}: cannot read ({' '.join(str(exc).split())})") from None
        return self

    def __exit__(self, *exc):
        if self.file is not self.raw:
            self.file.close()
        self.raw.close()

    def fail(self, line_no, msg):
        raise DumpFormatError(f"{self.path}, line {line_no + 1}: {msg}")

    def _read(self, call):
        try:
            out = call()
        except (OSError, EOFError, gzip.BadGzipFile, zlib.error) as exc:
            raise DumpFormatError(f"{self.path}: cannot read ({' '.join(str(exc).split())})") from None
        if not self.peek:
            self.dump.bytes_read = self.raw.tell()
        return out

    def _complete(self, data, n_lines):
        """Refuse a last line without its newline: the file was cut while being written."""
        if data and not data.endswith(b"\n"):
            last = data.rsplit(b"\n", 1)[-1].decode(errors="replace")
            self.fail(self.line + n_lines - 1, f"the last line does not end with a newline: the file was cut short "
                                               f"(last line {last[-60:]!r})")

    def _more(self) -> bool:
        """Read the next chunk into the buffer (dropping what was read); False at the end of the file."""
        if self.eof:
            return False
        chunk = self._read(lambda: self.file.read(self.CHUNK if not self.peek else 4096))
        self.buffer, self.at = self.buffer[self.at:] + chunk, 0
        self.eof = not chunk
        return bool(chunk)

    def read_lines(self, n) -> bytes:
        """The next ``n`` lines as bytes (fewer at the end of the file), without a Python loop over
        lines: whole chunks are read, each counted once, until they hold ``n`` newlines."""
        if n <= 0:
            return b""
        pieces, found = [self.buffer[self.at:]], self.buffer.count(b"\n", self.at)
        while found < n and not self.eof:
            chunk = self._read(lambda: self.file.read(self.CHUNK))
            self.eof = not chunk
            pieces.append(chunk)
            found += chunk.count(b"\n")
        last = pieces[-1]
        if found >= n:  # the n-th newline is in the last piece
            before = found - last.count(b"\n")
            newlines = np.flatnonzero(np.frombuffer(last, dtype=np.uint8) == 10)
            end = int(newlines[n - before - 1]) + 1
            pieces[-1], rest = last[:end], last[end:]
        else:
            rest = b""
        self.buffer, self.at = rest, 0
        return b"".join(pieces)

    def _readline(self) -> bytes:
        while (end := self.buffer.find(b"\n", self.at)) < 0 and self._more():
            pass
        end = len(self.buffer) if end < 0 else end + 1
        data, self.at = self.buffer[self.at:end], end
        return data

    def readline(self):
        """The next line as text (None at the end of the file)."""
        data = self._readline()
        if not data:
            return None
        self._complete(data, 1)
        self.line += 1
        try:
            return data.decode()
        except UnicodeDecodeError:
            self.fail(self.line - 1, "not UTF-8 text: not a LAMMPS dump")

    def next_item(self):
        """The next non-blank line (None at the end of the file)."""
        while (text := self.readline()) is not None and not text.strip():
            pass
        return text

    def expect(self, text, item):
        if text is None:
            self.fail(self.line, f"file ends where 'ITEM: {item}' was expected")
        if not " ".join(text.split()).startswith(f"ITEM: {item}"):  # tabs or runs of spaces
            self.fail(self.line - 1, f"expected 'ITEM: {item}', found {text[:60]!r}")

    def integer_line(self, what):
        text = self.readline()
        try:
            return int(text)
        except (TypeError, ValueError):
            self.fail(self.line - (text is not None), f"{what} is not an integer")

    def timestep_item(self):
        """The next block's ``ITEM: TIMESTEP`` line (None at the end of the file), past the
        ``ITEM: UNITS`` and ``ITEM: TIME`` that LAMMPS writes before it with ``dump_modify units
        yes`` / ``time yes`` (units other than ``si`` are refused)."""
        text = self.next_item()
        while text is not None and " ".join(text.split()) in ("ITEM: UNITS", "ITEM: TIME"):
            value = self.readline()
            if value is None:
                self.fail(self.line, f"file ends after {text.strip()!r}")
            if text.split()[1] == "UNITS" and value.strip() != "si":
                self.fail(self.line - 1, f"the dump is in LAMMPS units {value.strip()!r}: only 'units si' dumps are read")
            text = self.next_item()
        return text

    def header(self):
        """``(timestep, rows, columns, box)`` of the next block, or None at the end of the file;
        ``self.step_line`` is then the 1-based line of its ``ITEM: TIMESTEP``."""
        count_item = "NUMBER OF ATOMS" if self.dump.kind == "ATOMS" else "NUMBER OF ENTRIES"
        text = self.timestep_item()
        if text is None:
            return None
        self.expect(text, "TIMESTEP")
        self.step_line = self.line
        step = self.integer_line("timestep")
        self.expect(self.readline(), count_item)
        n = self.integer_line(count_item.lower())
        if n < 0:
            self.fail(self.line - 1, f"negative {count_item.lower()} {n}")
        self.expect(text := self.readline(), "BOX BOUNDS")
        box = self.box(text.split()[3:])
        self.expect(text := self.readline(), self.dump.kind)
        columns = text.split()[2:]
        if len(set(columns)) != len(columns):
            self.fail(self.line - 1, f"repeated column names {columns}")
        return step, n, columns, box

    def box(self, words):
        """The :class:`Box` of the three lines after ``ITEM: BOX BOUNDS`` (``words``: the item's
        words after ``BOUNDS``), or None where no axis is periodic (the lines are then only
        passed over). Restricted triclinic boxes (``xy xz yz``) are read; LAMMPS' general
        triclinic output (``abc origin``) of a periodic box is refused."""
        lines = []
        for _ in range(3):
            if (line := self.readline()) is None:
                self.fail(self.line, "file ends inside the box bounds")
            lines.append(line)
        tilted = words[:3] == ["xy", "xz", "yz"]
        flags = words[3:] if tilted else words[2:] if words[:2] == ["abc", "origin"] else words
        periodic = tuple(len(flags) == 3 and flag.startswith("p") for flag in flags) or (False,) * 3
        if not any(periodic):
            return None
        if words[:2] == ["abc", "origin"]:
            self.fail(self.line - 4, "a periodic general triclinic box ('abc origin') is not read: dump the "
                                     "restricted box (dump_modify triclinic/general no)")
        try:
            values = [[float(x) for x in line.split()] for line in lines]
            if any(len(v) != (3 if tilted else 2) for v in values) or not np.isfinite(sum(values, [])).all():
                raise ValueError
        except ValueError:
            self.fail(self.line - 3, f"the box bounds are not {3 if tilted else 2} finite numbers a line: "
                                     f"{' | '.join(line.strip() for line in lines)!r}")
        xy, xz, yz = (values[0][2], values[1][2], values[2][2]) if tilted else (0.0, 0.0, 0.0)
        # the bounds of a tilted box enclose it: LAMMPS widens x by the tilts and y by yz
        lx = (values[0][1] - max(0.0, xy, xz, xy + xz)) - (values[0][0] - min(0.0, xy, xz, xy + xz))
        ly = (values[1][1] - max(0.0, yz)) - (values[1][0] - min(0.0, yz))
        lz = values[2][1] - values[2][0]
        if min(lx, ly, lz) <= 0:
            self.fail(self.line - 3, f"box edges {lx:g}, {ly:g}, {lz:g} m: not a box")
        return Box(np.array([[lx, xy, xz], [0.0, ly, yz], [0.0, 0.0, lz]]), periodic)

    def peek_step(self):
        text = self.timestep_item()
        if text is None:
            return None
        self.expect(text, "TIMESTEP")
        return self.integer_line("timestep")

    def peek_counts(self, blocks=1, enough=0):
        """``(rows, columns)`` of the largest of the file's first ``blocks`` blocks (``(0, 0)`` if
        empty), from their headers; the next block's header is read only while the largest so
        far has fewer than ``enough`` rows (a run's first contact blocks may hold few or none)."""
        most = (0, 0)
        for k in range(blocks):
            if k and most[0] >= enough:
                break
            if (head := self.header()) is None:
                break
            most = max(most, (head[1], len(head[2])))
            self.read_lines(head[1])
            self.line += head[1]
        return most

    def blocks(self, int_columns, after):
        seen = set()
        while (head := self.header()) is not None:
            step, n, columns, box = head
            if step in seen:
                self.fail(self.step_line - 1, f"timestep {step} appears twice")
            seen.add(step)
            first = self.line
            data = self.read_lines(n)
            self._complete(data, data.count(b"\n") + 1)
            if after is not None and step <= after:
                if data.count(b"\n") != n:
                    self.fail(first + data.count(b"\n"), f"file ends inside the rows of timestep {step}")
                self.line = first + n
                yield Block(step, None, first, self.step_line, box)
                continue
            table = _parse_rows(data, columns, [c for c in int_columns if c in columns], n)
            if table is None:  # pandas could not: read it again line by line, naming the fault
                table = _parse_rows_slowly(data, columns, n, self.path, first, int_columns)
            self.line = first + n
            yield Block(step, table, first, self.step_line, box)


def _parse_rows(data: bytes, columns, int_columns, n):
    """The ``n`` rows of a block as a DataFrame (pandas' C reader), or None when they are not
    exactly ``n`` rows of ``len(columns)`` finite numbers (the slow reader then names the fault)."""
    if data.count(b"\n") != n:
        return None
    if n == 0:
        return pd.DataFrame({c: np.empty(0, dtype=np.int64 if c in int_columns else np.float64) for c in columns})
    try:
        with warnings.catch_warnings(record=True) as caught:  # rows longer than the header: a ParserWarning
            warnings.simplefilter("always", pd.errors.ParserWarning)
            table = pd.read_csv(io.BytesIO(data), sep=r"\s+", header=None, names=columns, index_col=False,
                                dtype={c: (np.int64 if c in int_columns else np.float64) for c in columns},
                                engine="c", skip_blank_lines=False, na_filter=False)
    except (ValueError, pd.errors.ParserError, OverflowError, UnicodeDecodeError):
        return None
    if any(issubclass(w.category, pd.errors.ParserWarning) for w in caught):
        return None  # pandas dropped values: the slow reader names the row
    if len(table) != n or any(not np.isfinite(table[c].to_numpy()).all()
                              for c in columns if c not in int_columns):
        return None
    if any((np.abs(table[c].to_numpy()) > 2**53).any() for c in int_columns):
        return None  # pandas reads 1e16 as an integer: only the written text says whether it was one
    large = [c for c in int_columns if (np.abs(table[c].to_numpy()) >= FEW_DIGITS_ABOVE).any()]
    if large and (b"e+" in data or b"E+" in data):  # pandas reads 1.23457e+06 as 1234570: was it written whole?
        texts = pd.read_csv(io.BytesIO(data), sep=r"\s+", header=None, names=columns, usecols=large, dtype=str,
                            index_col=False, engine="c", skip_blank_lines=False, na_filter=False)
        if any(texts[c].str.contains(r"[.eE]").any() for c in large):
            return None
    return table


def _parse_rows_slowly(data: bytes, columns, n, path, first, int_columns):
    """The rows of a block read line by line: the first fault raises :class:`DumpFormatError`
    naming the line (``first`` is the 0-based line of the first row)."""
    def fail(line_no, msg):
        raise DumpFormatError(f"{path}, line {line_no + 1}: {msg}")

    try:
        rows = data.decode().splitlines()
    except UnicodeDecodeError as exc:
        fail(first + data[:exc.start].count(b"\n"), "not UTF-8 text: not a LAMMPS dump")
    if len(rows) < n:
        fail(first + len(rows), f"file ends after {len(rows)} of {n} rows of this timestep")
    values = np.empty((n, len(columns)))
    fields = []
    for r, text in enumerate(rows):
        fields.append(text.split())
        if len(fields[-1]) != len(columns):
            fail(first + r, f"{len(fields[-1])} values for {len(columns)} columns")
        try:
            values[r] = [float(x) for x in fields[-1]]
        except ValueError:
            fail(first + r, f"not a number in {text[:60]!r}")
    bad = ~np.isfinite(values)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        fail(first + r, f"non-finite value in column {columns[c]!r}")
    text = np.array(fields, dtype=str).reshape(n, len(columns))
    return pd.DataFrame({c: (integer_column(text[:, k], path, first, c) if c in int_columns else values[:, k])
                         for k, c in enumerate(columns)})


def integer_column(texts, path, first_line, what) -> np.ndarray:
    """The fields ``texts`` of one column (as written, rows from ``first_line``, 0-based) as exact
    int64: an integer is read as written (never through float64, which rounds above 2**53); a
    number written as a float (``12.0``, ``1.2e3``) only when it is whole, at most 2**53, where
    float64 is exact, and, from :data:`FEW_DIGITS_ABOVE` on, written with as many significant
    digits as the integer has (LAMMPS' ``dump local`` writes every column with ``%g``, six digits:
    id 1234567 as ``1.23457e+06``, another particle's id). Anything else raises
    :class:`DumpFormatError` naming the line."""
    out = np.empty(len(texts), dtype=np.int64)
    for r, text in enumerate(texts):
        try:
            out[r] = int(text)
            continue
        except OverflowError:
            problem = "is beyond the 64-bit integers"
        except ValueError:
            value = float(text)  # a number: read_dump_blocks checked it
            digits = len(text.lower().split("e")[0].lstrip("+-").replace(".", "").lstrip("0"))
            needed = len(str(abs(int(value)))) if value.is_integer() and abs(value) >= FEW_DIGITS_ABOVE else 0
            if value.is_integer() and abs(value) <= 2**53 and digits >= needed:
                out[r] = int(value)
                continue
            if not value.is_integer():
                problem = "is not a whole number"
            elif abs(value) > 2**53:
                problem = "is written as a float above 2**53, where floats skip integers: write ids as integers"
            else:
                problem = (f"is written with {digits} significant digits, fewer than the id's {needed}: "
                           "the digits are lost, and the contact may name another particle (dump local writes "
                           "with %g, six digits, by default): add 'dump_modify DUMP-ID format float %.16g'")
        raise DumpFormatError(f"{path}, line {first_line + r + 1}: {what} {str(text)!r} {problem}")
    return out


def _column(table, name, path, line, what):
    if name not in table.columns:
        raise DumpFormatError(f"{_at(path, line)}: no column {name!r} for {what} (columns: {' '.join(table.columns)})")
    return table[name].to_numpy()


def _particles(table, path, line, mapping):
    def col(name, what):
        return _column(table, name, path, line, what).astype(np.float64, copy=False)

    if "radius" in table.columns:
        radius = col("radius", "radius")
    elif "diameter" in table.columns:
        radius = col("diameter", "diameter") / 2
    else:
        raise DumpFormatError(f"{_at(path, line)}: the particle dump needs a 'radius' or 'diameter' column")
    if len(radius) and not (MIN_RADIUS_M <= radius.min() and radius.max() <= MAX_RADIUS_M):
        bad = radius.min() if radius.min() < MIN_RADIUS_M else radius.max()
        raise DumpFormatError(f"{_at(path, line)}: a particle radius of {bad:g} m is not a DEM particle's in SI units "
                              f"([{MIN_RADIUS_M:g}, {MAX_RADIUS_M:g}] m are read): the dump is likely in "
                              f"{'millimetres or micrometres' if bad > MAX_RADIUS_M else 'another unit'}; the mapping "
                              "reads 'units si' dumps only")
    out = {
        "ids": _column(table, "id", path, line, "particle ids"),
        "radius": radius,
        "position": np.column_stack([col(c, "positions") for c in ("x", "y", "z")]),
        "velocity": np.column_stack([col(c, "velocities") for c in ("vx", "vy", "vz")]),
        "angular_velocity": np.column_stack([col(c, "angular velocities") for c in ("omegax", "omegay", "omegaz")]),
        "film_volume": np.zeros(len(table)),
    }
    if mapping.film_column:
        film = col(mapping.film_column, "the liquid film")
        if mapping.film_unit == "percent_of_particle_volume":
            film = film / 100 * 4 / 3 * np.pi * radius**3
        out["film_volume"] = film
    return out


def _contacts(table, path, line, mapping, ids, order, position, box=None):
    def col(name, what):
        return _column(table, name, path, line, what).astype(np.float64, copy=False)

    def signed_normal(name, what):
        """Signed normal force [N], positive = repulsive: a column as is, or −F·n̂ of a vector
        on particle i (n̂ from i to j, to j's nearest image in a periodic box)."""
        if not isinstance(name, (list, tuple)):
            return col(name, what)
        force = np.column_stack([col(c, what) for c in name])
        branch = position[rows[1]] - position[rows[0]]
        if box is not None:
            branch = box.minimum_image(branch)
        length = np.linalg.norm(branch, axis=1)
        length[length == 0] = np.inf  # coincident centres: no direction, no normal force
        return -(force * branch).sum(axis=1) / length

    sorted_ids = ids[order]  # order: argsort of ids
    rows = []
    for name in (mapping.contact_id_i, mapping.contact_id_j):
        named = _column(table, name, path, line, name)
        at = np.minimum(np.searchsorted(sorted_ids, named), len(ids) - 1)
        missing = sorted_ids[at] != named
        if missing.any():
            k = int(np.flatnonzero(missing)[0])
            raise DumpFormatError(f"{_at(path, line and line + k + 1)}: contact names particle id {int(named[k])}, "
                                  "which is not in the particle dump of this timestep")
        rows.append(order[at])
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


def _in_step_order(files, kind):
    """The :class:`DumpFile` (or, for ``.vtu``/``.vtp``/``.vtk`` files, :class:`~granalytics.convert.
    liggghts_vtk.VtkDumpFile`) of each path, ordered by their first timestep (files of one
    timestep each, named ``atoms.5000``, ``atoms.10000``, … come in any order)."""
    from granalytics.convert.liggghts_vtk import VtkDumpFile, is_vtk

    dumps = [(VtkDumpFile if is_vtk(path) else DumpFile)(path, kind) for path in files]
    first = {id(d): d.first_step() for d in dumps}
    return sorted(dumps, key=lambda d: (first[id(d)] is None, first[id(d)] or 0))


def _stream(dumps, int_columns, after=None):
    """``(block, path)`` of every :class:`Block` of ``dumps`` in turn, refusing a timestep read
    before (in this file or another) or one that goes back in time; the blocks up to timestep
    ``after`` are not parsed (``table`` None)."""
    seen = {}
    last = None
    for dump in dumps:
        for block in dump.blocks(int_columns, after):
            step, where = block.step, _at(dump.path, block.step_line)
            if step in seen:
                raise DumpFormatError(f"{where}: timestep {step} already read from {seen[step]}")
            if last is not None and step < last:
                raise DumpFormatError(f"{where}: timestep {step} comes after timestep {last}: "
                                      "the timesteps of a dump (and of its files, taken in the order of their first "
                                      "timestep) must increase")
            seen[step], last = dump.path, step
            yield block, dump.path


class LiggghtsRun(StreamedSource):
    """A LIGGGHTS / LAMMPS run read frame by frame from its dumps (:func:`open_liggghts`).

    Iterating yields the :class:`~granalytics.core.Snapshot` of each particle timestep in
    order; at most one particle block and one contact block are in memory at a time.
    :attr:`meta` is known once the first frame has been read (reading it if needed).
    :attr:`bytes_read` and :attr:`total_bytes` measure the progress over all the files (as
    stored, compressed or not).
    """

    def __init__(self, particle_files, contact_files, mapping: DumpMapping, dt):
        if dt is None or not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise ValidationError("dt", f"the dumps do not record the time step: pass dt in seconds (> 0), got {dt!r}")
        self.mapping, self.dt = mapping, float(dt)
        self.particle_files, self.contact_files = list(particle_files), list(contact_files)
        self._particles = _in_step_order(self.particle_files, "ATOMS")
        self._contacts = _in_step_order(self.contact_files, "ENTRIES")
        self.total_bytes = sum(d.size for d in self._particles + self._contacts)
        self.meta = None

    @property
    def bytes_read(self) -> int:
        return sum(d.bytes_read for d in self._particles + self._contacts)

    def frame_bytes(self) -> int:
        """Estimated memory of one frame while it is read [bytes] (text, parsed table and snapshot:
        about 40 bytes per value), from the headers of the first particle block and of the
        largest contact block among the first few (up to one with as many rows as there are
        particles: a run's first contact blocks may be empty) and the last file's first."""
        if not self._particles:
            return 0
        rows, columns = self._particles[0].first_counts()
        values = rows * max(columns, 14)
        if self._contacts:
            ends = {id(d): d for d in (self._contacts[0], self._contacts[-1])}.values()
            contacts, width = max(d.first_counts(blocks=5, enough=rows) for d in ends)
            values += contacts * max(width, 14)
        return 40 * values

    def _nothing_read(self):
        later = f" after timestep {self._after}" if self._after is not None else ""
        return DumpFormatError(f"no particle timesteps{later} in " + ", ".join(map(str, self.particle_files)))

    def _read(self):
        mapping = self.mapping
        contacts = _stream(self._contacts, (mapping.contact_id_i, mapping.contact_id_j), self._after)
        pending = next(contacts, None)
        unused, particle_steps, n0 = [], [], None
        for block, path in _stream(self._particles, ("id",), self._after):
            step, line = block.step, block.first_line
            while pending is not None and pending[0].step < step:
                unused.append(pending[0].step)
                pending = next(contacts, None)
            if pending is None or pending[0].step != step:
                raise DumpFormatError(f"{_at(path, block.step_line)}: no contact dump for timestep {step}")
            if block.table is None:  # up to start_after: passed over
                particle_steps.append(step)
                pending = next(contacts, None)
                continue
            part = _particles(block.table, path, line, mapping)
            block = block._replace(table=None)
            ids = part["ids"]
            if not len(ids):
                raise DumpFormatError(f"{_at(path, block.step_line)}: timestep {step} has no particles")
            order = np.argsort(ids, kind="stable")
            if (ids[order[1:]] == ids[order[:-1]]).any():
                raise DumpFormatError(f"{_at(path, line)}: duplicate particle ids in timestep {step}")
            cblock, cpath = pending
            cont = _contacts(cblock.table, cpath, cblock.first_line, mapping, ids, order, part["position"], block.box)
            pending = cblock = None
            n0 = n0 or len(ids)
            if len(ids) != n0:
                raise DumpFormatError(f"{_at(path, line)}: timestep {step} has {len(ids)} particles, the first "
                                      f"timestep {n0}; a run keeps its particles")
            if self.meta is None:
                self.meta = self._run_meta(n0, float(part["radius"].mean()), block.box, path)
            try:
                snapshot = Snapshot(time=step * self.dt, step=step, **part, **cont, meta=self.meta)
            except ValidationError as exc:
                raise exc.located(f"{path} / {cpath} (timestep {step})") from None
            particle_steps.append(step)
            yield snapshot
            pending = next(contacts, None)
        unused += ([pending[0].step] if pending is not None else []) + [c[0].step for c in contacts]
        if particle_steps:
            warn_unused_contact_steps(unused, particle_steps, self.contact_files)

    def _run_meta(self, n_particles, mean_radius, box, path) -> RunMeta:
        mapping = self.mapping
        periodic = "".join(axis for axis, p in zip("xyz", box.periodic) if p) if box is not None else ""
        if periodic:
            warnings.warn(f"{path}: the box is periodic along {periodic}: contact normals are taken between nearest "
                          "images, but positions are kept as dumped (wrapped into the box), so what uses positions "
                          "(the dbscan method, granule centres and extents) sees a granule across a periodic face "
                          "as cut", stacklevel=user_stacklevel())
        return RunMeta(
            surface_tension=mapping.surface_tension, density=mapping.density, drum_omega=mapping.drum_omega,
            n_particles=n_particles, mean_radius=mean_radius, alpha=mapping.alpha,
            contact_angle=mapping.contact_angle, capillary_in_contact=mapping.capillary_in_contact,
            provenance={"source": "LIGGGHTS/LAMMPS dumps", "particle_files": list(map(str, self.particle_files)),
                        "contact_files": list(map(str, self.contact_files)), "mapping": dataclasses.asdict(mapping),
                        "periodic_axes": periodic,
                        "not_in_dumps": [k for k, v in (("f_normal", mapping.contact_f_normal),
                                                        ("bridge_volume", mapping.contact_bridge_volume),
                                                        ("film_volume", mapping.film_column)) if v is None]},
        )


def open_liggghts(particle_files, contact_files, mapping: DumpMapping, dt=None) -> LiggghtsRun:
    """A LIGGGHTS / LAMMPS run, read lazily frame by frame (:class:`LiggghtsRun`).

    Parameters
    ----------
    particle_files, contact_files : sequence of paths
        Dumps (any number of timesteps each, in increasing order; files are taken in the order
        of their first timestep); every particle timestep needs a contact timestep.
    mapping : DumpMapping
    dt : float
        Time step [s] (time = timestep·dt). Required: dumps do not carry it.
    """
    return LiggghtsRun(particle_files, contact_files, mapping, dt)


def read_liggghts(particle_files, contact_files, mapping: DumpMapping, dt=None):
    """Every snapshot of a LIGGGHTS / LAMMPS run, in memory (:func:`open_liggghts` reads them one
    at a time instead).

    Returns
    -------
    (list of Snapshot, RunMeta)
    """
    run = open_liggghts(particle_files, contact_files, mapping, dt)
    snapshots = list(run)
    return snapshots, run.meta
