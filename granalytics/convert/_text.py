"""What the readers of other codes' text files share: the format error, reading a text file
(plain or gzip) that must not be cut short, the TOML mapping files, the warning about unused
contact timesteps."""

from __future__ import annotations

import gzip
import warnings

from granalytics.base.errors import GranalyticsError, user_stacklevel
from granalytics.base.files import regular_input

__all__ = ["DumpFormatError", "open_text", "read_complete_lines", "load_toml", "warn_unused_contact_steps"]


class DumpFormatError(GranalyticsError, ValueError):
    """A dump file is malformed; the message names the file and line."""


def open_text(path):
    """A text file, plain or gzip (by its ``.gz`` ending), opened for reading."""
    path = str(path)
    return gzip.open(path, "rt") if path.endswith(".gz") else open(path)


def read_complete_lines(path) -> list:
    """The lines of a text file (plain or gzip), refusing a file that was cut short.

    LAMMPS, LIGGGHTS and the YADE export end every line with a newline, so a file whose last
    line has none was cut while being written or copied; its last number may be cut too
    (``-156.81`` read as ``-156``). Such a file raises :class:`DumpFormatError` naming the file
    and the line.
    """
    regular_input(path)  # a FIFO would block for ever
    try:
        with open_text(path) as f:
            text = f.read()
    except (OSError, EOFError, UnicodeDecodeError, gzip.BadGzipFile) as exc:
        raise DumpFormatError(f"{path}: cannot read ({' '.join(str(exc).split())})") from None
    lines = text.splitlines()
    if text and not text.endswith(("\n", "\r")):
        raise DumpFormatError(f"{path}, line {len(lines)}: the last line does not end with a newline: the file "
                              f"was cut short (last line {lines[-1][-60:]!r})")
    return lines


def load_toml(path) -> dict:
    """A TOML file as a dict; an unreadable or invalid file raises :class:`GranalyticsError`."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    regular_input(path)
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except RecursionError:
        raise GranalyticsError(f"{path}: cannot read the mapping: its tables or arrays are nested too deeply") from None
    except UnicodeDecodeError as exc:
        raise GranalyticsError(f"{path}: cannot read the mapping: not UTF-8 text (byte "
                               f"0x{exc.object[exc.start]:02x} at offset {exc.start}); a TOML file is "
                               "UTF-8 text") from None
    except (OSError, ValueError) as exc:  # tomllib.TOMLDecodeError is a ValueError
        raise GranalyticsError(f"{path}: cannot read the mapping ({' '.join(str(exc).split())})") from None


def warn_unused_contact_steps(contact_steps, particle_steps, contact_files) -> None:
    """Contact timesteps that no particle timestep uses are not converted.

    Those between the particle timesteps (contacts dumped more often than particles) get a
    warning. Those after the last particle timestep mean that the particle files end early (a dump
    cut at a timestep boundary, or a file left out): :class:`DumpFormatError`, naming them.
    """
    unused = sorted(set(contact_steps) - set(particle_steps))
    last = max(particle_steps)
    after = [s for s in unused if s > last]
    if after:
        shown = ", ".join(map(str, after[:5])) + (", ..." if len(after) > 5 else "")
        raise DumpFormatError(f"the particle files end at timestep {last} but the contact files go on to {after[-1]} "
                              f"({len(after)} timestep(s): {shown}; from {', '.join(map(str, contact_files[:3]))}"
                              f"{', ...' if len(contact_files) > 3 else ''}): a particle file was cut short or left out")
    if unused:
        shown = ", ".join(map(str, unused[:5])) + (", ..." if len(unused) > 5 else "")
        warnings.warn(f"{len(unused)} contact timestep(s) without a particle timestep are not converted "
                      f"({shown}; from {', '.join(map(str, contact_files[:3]))}"
                      f"{', ...' if len(contact_files) > 3 else ''})", stacklevel=user_stacklevel())
