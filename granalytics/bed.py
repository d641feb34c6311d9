"""Structure of a particle bed: is it three-dimensional, how many contacts, how it moves.

A drum run whose particles never leave their axial planes (a lattice insertion with nothing to
break its symmetry: gravity along −y, rotation about z) is a stack of independent 2-D monolayers.
Its granules are planar and its statistics mean nothing for a 3-D bed. :func:`bed_structure`
measures what tells the two apart, for any snapshot (ours or converted from another code):

- the fraction of touching contacts whose unit normal has an axial component |n_z| > 0.1
  (a contact that crosses axial layers): 0 for a planar bed, about 0.9 for an isotropic packing;
- ⟨n_z²⟩, the axial entry of the fabric tensor: 0 planar, 1/3 isotropic;
- the mean coordination number (touching contacts per particle, walls not counted);
- ⟨|v_z|⟩ / ⟨|v_xy|⟩, axial against cross-sectional speeds (0 planar).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .errors import ParameterError
from .snapshot import Snapshot

__all__ = ["BedStructure", "bed_structure", "PLANAR_FRACTION", "AXIAL_NORMAL_MIN"]

#: a contact crosses axial layers when its unit normal has |n_axis| above this
AXIAL_NORMAL_MIN = 0.1
#: a bed with fewer than this fraction of its touching contacts crossing axial layers is planar
#: (a 2-D monolayer stack gives 0, an isotropic 3-D packing about 0.9, the simulator's settled
#: beds 0.75-0.85; physics-free synthetic frames about 0.35)
PLANAR_FRACTION = 0.25


@dataclasses.dataclass(frozen=True)
class BedStructure:
    """What :func:`bed_structure` measured on one frame.

    Attributes
    ----------
    n_particles : int
    n_touching : int
        Particle–particle contacts with a negative gap (overlap); bridges across a gap are not counted.
    crossing_fraction : float
        Fraction of the touching contacts with |n_axis| > :data:`AXIAL_NORMAL_MIN` (NaN without contacts).
    axial_fabric : float
        ⟨n_axis²⟩ over the touching contacts: 1/3 isotropic, 0 planar (NaN without contacts).
    coordination : float
        Mean number of touching particle contacts per particle (2·n_touching / N).
    axial_speed_ratio : float
        ⟨|v_axis|⟩ / ⟨|v_⊥|⟩ over the particles (NaN when no particle moves across the axis).
    axial_layers : int
        Distinct axial positions (to 1e-9 of the bed's axial extent): a handful in a planar bed,
        about N in a 3-D one.
    """

    n_particles: int
    n_touching: int
    crossing_fraction: float
    axial_fabric: float
    coordination: float
    axial_speed_ratio: float
    axial_layers: int

    @property
    def planar(self) -> bool:
        """True when the touching contacts lie in axial planes (fewer than :data:`PLANAR_FRACTION` cross them)."""
        return self.n_touching > 0 and self.crossing_fraction < PLANAR_FRACTION

    def to_dict(self) -> dict:
        out = dataclasses.asdict(self)
        out["planar"] = self.planar
        return out

    def describe(self) -> str:
        """One line for a command's output or a warning."""
        return (f"{100 * self.crossing_fraction:.1f} % of {self.n_touching} touching contacts cross axial layers "
                f"(|n_z| > {AXIAL_NORMAL_MIN:g}; isotropic 3-D ≈ 90 %), <n_z²> = {self.axial_fabric:.3f}, "
                f"coordination {self.coordination:.2f}, <|v_z|>/<|v_xy|> = {self.axial_speed_ratio:.3f}, "
                f"{self.axial_layers} axial positions")


def bed_structure(snapshot: Snapshot, axis: int = 2) -> BedStructure:
    """Measure whether the bed of ``snapshot`` is three-dimensional (see the module docstring).

    Parameters
    ----------
    snapshot : Snapshot
        One frame (positions [m], velocities [m/s], contacts with their gaps [m]).
    axis : int, default 2
        The drum axis (0, 1 or 2 for x, y, z); the simulator's drum turns about z.

    Returns
    -------
    BedStructure
    """
    if not isinstance(snapshot, Snapshot):
        raise ParameterError(f"bed_structure: snapshot must be a granalytics Snapshot, got {type(snapshot).__name__}")
    if axis not in (0, 1, 2) or isinstance(axis, bool):
        raise ParameterError(f"bed_structure: axis must be 0, 1 or 2 (x, y, z), got {axis!r}")
    n = snapshot.n_particles
    touching = snapshot.gap < 0
    i, j = snapshot.contact_i[touching], snapshot.contact_j[touching]
    d = snapshot.position[j] - snapshot.position[i]
    length = np.linalg.norm(d, axis=1)
    ok = length > 0
    n_axis = np.abs(d[ok, axis]) / length[ok]
    crossing = float(np.mean(n_axis > AXIAL_NORMAL_MIN)) if n_axis.size else math.nan
    fabric = float(np.mean(n_axis**2)) if n_axis.size else math.nan
    across = [k for k in range(3) if k != axis]
    v = snapshot.velocity
    v_across = float(np.mean(np.hypot(v[:, across[0]], v[:, across[1]]))) if n else 0.0
    ratio = float(np.mean(np.abs(v[:, axis]))) / v_across if v_across > 0 else math.nan
    z = snapshot.position[:, axis]
    extent = float(z.max() - z.min()) if n else 0.0
    layers = int(np.unique(np.round(z / max(extent * 1e-9, 1e-300))).size) if n else 0
    return BedStructure(n_particles=n, n_touching=int(touching.sum()), crossing_fraction=crossing,
                        axial_fabric=fabric, coordination=2 * int(touching.sum()) / n if n else math.nan,
                        axial_speed_ratio=ratio, axial_layers=layers)
