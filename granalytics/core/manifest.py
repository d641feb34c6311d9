"""The sweep manifest ``DIR/manifest.csv``: one schema, written by ``sim.sweep``, read by
:func:`granalytics.study_table` and ``granalytics.datasets.bundle_sweep``.

One row per grid point: ``point`` (its name), ``status`` (``running``, ``done`` or ``failed``), the
point's parameters (:data:`NAMED_PARAMETERS` first, in that order, then any other swept field,
sorted), then :data:`MANIFEST_COLUMNS`: the preset, revolutions, output interval [revolutions],
the simulator's physics version, the simulator's wall time [s], whether the point was resumed,
the run file (relative to ``DIR``), its sha256, the one-line error of a failed point and the UTC
time it finished.
"""

from __future__ import annotations

import math
import os

from granalytics.base.errors import ParameterError, one_line
from granalytics.base.files import write_atomically

__all__ = ["MANIFEST_NAME", "NAMED_PARAMETERS", "MANIFEST_COLUMNS", "manifest_path", "read_manifest",
           "write_manifest", "manifest_rows", "file_sha256"]

MANIFEST_NAME = "manifest.csv"


def file_sha256(path) -> str:
    """The sha256 of a file's bytes (hex), read in blocks of 1 MiB: what a manifest records of each
    point and a registry of each dataset."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


#: canonical order of the named parameters in point names and manifest columns (others follow, sorted)
NAMED_PARAMETERS = ("gamma", "omega", "alpha", "seed", "particles")
#: manifest columns after ``point``, ``status`` and the parameters
MANIFEST_COLUMNS = ("preset", "revolutions", "frame_every_rev", "physics_version", "wall_time_s", "resumed", "file",
                    "sha256", "error", "finished_utc")
_TEXT_COLUMNS = ("point", "status", "preset", "file", "sha256", "error", "finished_utc")
_REQUIRED = ("point", "status", "file")


def manifest_path(sweep_dir) -> str:
    """``sweep_dir/manifest.csv``."""
    return os.path.join(os.fspath(sweep_dir), MANIFEST_NAME)


def read_manifest(sweep_dir):
    """The manifest of ``sweep_dir`` as a DataFrame (text columns as str, empty where missing).

    Raises
    ------
    ParameterError
        No manifest, an unreadable one, or a table without the ``point``, ``status`` and ``file``
        columns (one line naming the file).
    """
    import pandas as pd

    path = manifest_path(sweep_dir)
    if not os.path.isfile(path):
        raise ParameterError(f"{path}: no sweep manifest (is {sweep_dir} a folder written by 'sim sweep'?)")
    try:
        table = pd.read_csv(path, dtype={c: str for c in _TEXT_COLUMNS})
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ParameterError(f"{path}: cannot read the manifest ({one_line(exc)})") from None
    missing = [c for c in _REQUIRED if c not in table]
    if missing:
        raise ParameterError(f"{path}: not a sweep manifest (no column {missing[0]!r})")
    for col in ("sha256", "error", "file", "finished_utc"):
        if col in table:
            table[col] = table[col].fillna("")
    return table


def manifest_rows(sweep_dir) -> dict:
    """The manifest's rows by point name, each a dict (None for missing numbers); {} without a manifest."""
    if not os.path.exists(manifest_path(sweep_dir)):
        return {}
    rows = {}
    for row in read_manifest(sweep_dir).to_dict("records"):
        rows[row["point"]] = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}
    return rows


def write_manifest(sweep_dir, rows) -> None:
    """Write ``rows`` (dicts with ``point``, ``status``, parameters and :data:`MANIFEST_COLUMNS`)
    as the manifest of ``sweep_dir``, atomically, columns in the schema's order."""
    import pandas as pd

    rows = list(rows)
    params = []
    for row in rows:
        for key in row:
            if key not in ("point", "status", *MANIFEST_COLUMNS) and key not in params:
                params.append(key)
    params = [k for k in NAMED_PARAMETERS if k in params] + sorted(k for k in params if k not in NAMED_PARAMETERS)
    table = pd.DataFrame(rows, columns=["point", "status", *params, *MANIFEST_COLUMNS])
    write_atomically(manifest_path(sweep_dir), lambda tmp: table.to_csv(tmp, index=False))
