"""The native run file's layout: format name and version, the datasets of /particles and
/contacts with their units, chunking and HDF5 read settings (``docs/format.md``)."""

from __future__ import annotations

import numpy as np

from granalytics.core.snapshot import CONTACT_FIELDS, PARTICLE_FIELDS

FORMAT_NAME = "granalytics-run"
FORMAT_VERSION = 1

# dataset name in /particles -> (trailing shape, dtype, unit)
PARTICLE_LAYOUT = {
    "ids": ((), np.int64, "1"),
    "radius": ((), np.float64, "m"),
    "position": ((3,), np.float64, "m"),
    "velocity": ((3,), np.float64, "m s-1"),
    "angular_velocity": ((3,), np.float64, "rad s-1"),
    "film_volume": ((), np.float64, "m3"),
}
# Snapshot field -> (dataset name in /contacts, unit); index dtype chosen at creation
CONTACT_LAYOUT = {
    "contact_i": ("i", "1"),
    "contact_j": ("j", "1"),
    "f_cap": ("f_cap", "N"),
    "f_normal": ("f_normal", "N"),
    "gap": ("gap", "m"),
    "bridge_volume": ("bridge_volume", "m3"),
}
assert tuple(PARTICLE_LAYOUT) == PARTICLE_FIELDS and tuple(CONTACT_LAYOUT) == CONTACT_FIELDS

CONTACT_CHUNK_ROWS = 1 << 10
CHUNK_CACHE_BYTES = 64 * 1024**2
INDEX_DATASETS = ("frames/time", "frames/step", "contacts/count")
PER_FRAME_DATASETS = INDEX_DATASETS + tuple(f"particles/{name}" for name in PARTICLE_FIELDS)
CONTACT_DATASETS = tuple(f"contacts/{name}" for name, _unit in CONTACT_LAYOUT.values())
# HDF5 retries a metadata read that fails its checksum in SWMR read mode (the writer may be
# updating it), doubling the wait each time from 1 ns: its default of 100 attempts sleeps for
# hours on a file that was cut short. 30 attempts wait about 1 s in all.
SWMR_READ_ATTEMPTS = 30
