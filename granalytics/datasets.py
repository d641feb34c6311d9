"""Bundled snapshot series (``datasets/`` in the source tree), made by ``sim``.

Each dataset is one run file registered here with its sha256 sum and the exact command that
made it (also in ``datasets/README.md``). :func:`dataset_path` checks the sum before handing the
file out, so a corrupted or regenerated file is never analysed silently.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from .errors import GranalyticsError

__all__ = ["DATASETS", "dataset_path", "open_dataset"]

DATASET_DIR = Path(__file__).resolve().parents[1] / "datasets"

#: name -> file, sha256, command that made it, description
DATASETS = {
    "lab-cg3": {
        "file": "lab-cg3.h5",
        "sha256": "93aacc5d283b115f2838c598366c37a3f6dee560488cc505be4434ccd093686a",
        "command": "python -m sim run --preset lab-cg3 --revolutions 6 --seed 0 --out datasets/lab-cg3.h5",
        "description": "lab drum, CG3 (741 particles of 4.5 mm), Table 1 physics, 6 revolutions, "
                       "a frame every 0.05 revolution (121 frames)",
    },
}


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def dataset_path(name: str) -> Path:
    """Path of a bundled dataset after checking its sha256 sum.

    Raises
    ------
    GranalyticsError
        Unknown name, missing file (e.g. an installed package without the source tree), or a
        checksum mismatch.
    """
    try:
        entry = DATASETS[name]
    except KeyError:
        raise GranalyticsError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}") from None
    path = DATASET_DIR / entry["file"]
    if not path.exists():
        raise GranalyticsError(f"{path}: dataset file missing (datasets live in the source tree; made by: {entry['command']})")
    digest = _sha256(path)
    if digest != entry["sha256"]:
        raise GranalyticsError(f"{path}: sha256 {digest} does not match the registry ({entry['sha256']})")
    return path


def open_dataset(name: str):
    """Open a bundled dataset as a :class:`~granalytics.Run`."""
    from .io import open_run

    return open_run(dataset_path(name))
