"""Initial packing of the drum and the checks of the settled bed.

The particles are inserted on a body-centred cubic (bcc) lattice whose nearest-neighbour distance
is the largest diameter + 2 %, lowest sites first, each particle moved by a random vector inside
the ball that keeps it clear of every other site's ball (radius = half the site spacing − its own
radius): no overlaps, and nothing is left in a plane. A bcc site has its nearest neighbours on
the cube diagonals, so the layers interpenetrate: as the bed settles every particle comes to rest
on particles of the neighbouring axial layers, and the settled bed is a random 3-D packing.
(A simple cubic lattice whose axial spacing exceeds every diameter never leaves its planes:
gravity is along −y and the drum turns about z, so no force ever gets a z component.)

After settling, :func:`check_settled_bed` refuses a planar packing (and warns on a bed that has not
settled), and
:func:`settled_solid_fraction` measures the bulk solid fraction of the bed below its free surface.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from granalytics.core import Snapshot

__all__ = ["insertion_positions", "settled_solid_fraction", "check_settled_bed", "settled_bed_report",
           "PLANAR_FRACTION", "AXIAL_NORMAL_MIN"]

#: a contact crosses axial layers when its unit normal has |n_z| above this (the rule of
#: :func:`granalytics.bed_structure`, which measures any run's bed; a test keeps the two equal)
AXIAL_NORMAL_MIN = 0.1
#: a settled bed with fewer than this fraction of its touching contacts crossing axial layers is
#: planar and the drum is not started
PLANAR_FRACTION = 0.25


def insertion_positions(params, radius: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Positions [m] of ``len(radius)`` particles inserted without overlaps into the static drum.

    Sites of a bcc lattice (nearest-neighbour distance s = 2.04 R_max, cube edge 2s/√3) inside
    the drum and clear of the baffles and end plates (margin 1.05 R_max), lowest first (ties by z,
    then x); particle k is then moved by a vector drawn uniformly from the ball of radius
    s/2 − R_k, so two particles never overlap and no two share a plane by construction.

    Raises
    ------
    ValueError
        The drum holds fewer sites than particles.
    """
    p = params
    n = len(radius)
    spacing = 2 * p.r_max * 1.02  # nearest-neighbour distance of the lattice
    edge = 2 * spacing / math.sqrt(3)
    margin = p.r_max * 1.05
    sites = []
    for shift in (0.0, 0.5 * edge):  # the two simple cubic sublattices of the bcc lattice
        axis = np.arange(-p.drum_radius + margin + shift, p.drum_radius - margin + 1e-12, edge)
        axis_z = np.arange(margin + shift, p.drum_length - margin + 1e-12, edge)
        gx, gy, gz = np.meshgrid(axis, axis, axis_z, indexing="ij")
        sites.append(np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()]))
    sites = np.concatenate(sites)
    keep = np.hypot(sites[:, 0], sites[:, 1]) < p.drum_radius - margin
    inner = p.drum_radius * (1 - p.baffle_height)
    for b in range(p.n_baffles):
        phi = 2 * math.pi * b / p.n_baffles
        along = sites[:, 0] * math.cos(phi) + sites[:, 1] * math.sin(phi)
        across = -sites[:, 0] * math.sin(phi) + sites[:, 1] * math.cos(phi)
        keep &= ~((along > inner - margin) & (np.abs(across) < margin))
    sites = sites[keep]
    if len(sites) < n:
        raise ValueError(f"the drum (R_d = {p.drum_radius} m, L = {p.drum_length} m) holds only {len(sites)} "
                         f"insertion sites for {n} particles")
    sites = sites[np.lexsort((sites[:, 0], sites[:, 2], sites[:, 1]))[:n]]
    # uniform in a ball: a direction uniform on the sphere, a distance with density ∝ r²
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    reach = np.maximum(spacing / 2 - radius, 0.0) * rng.uniform(0.0, 1.0, n) ** (1 / 3)
    return sites + direction * reach[:, None]


def settled_solid_fraction(params, position: np.ndarray, radius: np.ndarray) -> float:
    """Bulk solid fraction of a bed at rest in the static drum (gravity along −y).

    The free surface height y_s is the median, over the columns of width 2·d_mean in (x, z)
    whose centre lies in the middle half of the bed's chord, of the highest particle top
    y + R in the column; the bed volume is the circular segment of the drum below y_s times the
    drum length (the thin baffles take no volume). Returns Σ V_particle / V_bed.
    """
    p = params
    top = position[:, 1] + radius
    width = 2 * p.d_mean
    cx = np.floor(position[:, 0] / width).astype(np.int64)
    cz = np.floor(position[:, 2] / width).astype(np.int64)
    key = cx * 1_000_003 + cz
    order = np.lexsort((-top, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    column_top, column_x = top[order][first], (cx[order][first] + 0.5) * width
    half_chord = np.sqrt(max(p.drum_radius**2 - np.median(column_top) ** 2, 0.0))
    middle = np.abs(column_x) < 0.5 * half_chord
    y_s = float(np.median(column_top[middle] if middle.any() else column_top))
    h = min(max(y_s + p.drum_radius, 0.0), 2 * p.drum_radius)  # depth of the segment from the drum's bottom
    r = p.drum_radius
    segment = r * r * math.acos((r - h) / r) - (r - h) * math.sqrt(max(2 * r * h - h * h, 0.0))
    return float(np.sum(4 / 3 * math.pi * radius**3) / (segment * p.drum_length))


def settled_bed_report(params, snapshot: Snapshot) -> dict:
    """The settled bed's touching contacts, the share of them that cross axial layers (|n_z| >
    :data:`AXIAL_NORMAL_MIN`), ⟨n_z²⟩ over them, the mean coordination and the bulk solid fraction,
    as a dict (kept in the run metadata; :func:`granalytics.bed_structure` measures the same and
    more on any frame)."""
    touching = snapshot.gap < 0
    normal = snapshot.position[snapshot.contact_j[touching]] - snapshot.position[snapshot.contact_i[touching]]
    length = np.linalg.norm(normal, axis=1)
    n_z = np.abs(normal[length > 0, 2]) / length[length > 0]
    n, n_touching = snapshot.n_particles, int(touching.sum())
    return {"n_particles": n, "n_touching": n_touching,
            "crossing_fraction": float(np.mean(n_z > AXIAL_NORMAL_MIN)) if n_z.size else None,
            "axial_fabric": float(np.mean(n_z**2)) if n_z.size else None,
            "coordination": 2 * n_touching / n,
            "solid_fraction": settled_solid_fraction(params, snapshot.position, snapshot.radius)}


def check_settled_bed(report: dict, settle_time: float) -> None:
    """Refuse to start the drum on a planar settled bed; warn when the bed has not settled.

    Parameters
    ----------
    report : dict
        :func:`settled_bed_report` of the bed.
    settle_time : float
        How long it settled [s] (named in the warning).

    Raises
    ------
    ValueError
        Fewer than :data:`PLANAR_FRACTION` of the touching contacts cross axial
        layers (one line naming the measured fraction).

    Warns
    -----
    UserWarning
        Fewer touching contacts than particles (mean coordination < 1): the particles are still
        falling, ``settle_time`` is too short for a settled bed (short settles are used on
        purpose in tests; the drum then starts on a falling cloud).
    """
    if report["n_touching"] and report["crossing_fraction"] < PLANAR_FRACTION:
        raise ValueError(
            f"the settled bed is planar: {100 * report['crossing_fraction']:.1f} % of its {report['n_touching']} "
            f"touching contacts cross axial layers (|n_z| > {AXIAL_NORMAL_MIN:g}; at least {100 * PLANAR_FRACTION:.0f} % needed, "
            "an isotropic 3-D packing has about 90 %); the drum is not started")
    if report["coordination"] < 1:
        warnings.warn(f"the bed has not settled after settle_time = {settle_time:g} s: {report['n_touching']} touching "
                      f"contacts for {report['n_particles']} particles (mean coordination "
                      f"{report['coordination']:.2f}); the drum starts on a falling cloud", stacklevel=3)
