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
from numbers import Integral

import numpy as np

from granalytics.base.validation import POSITIVE, Interval, validate_params
from granalytics.core.snapshot import SNAPSHOT, Snapshot

__all__ = ["BedStructure", "bed_structure", "PLANAR_FRACTION", "AXIAL_NORMAL_MIN", "DrumConfinement", "confinement_of_drum",
           "FILL_PACKING"]

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


@validate_params({"snapshot": [SNAPSHOT], "axis": [Interval(Integral, 0, 2)]})
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
    v_across = float(np.mean(np.hypot(v[:, across[0]], v[:, across[1]])))
    ratio = float(np.mean(np.abs(v[:, axis]))) / v_across if v_across > 0 else math.nan
    z = snapshot.position[:, axis]
    extent = float(z.max() - z.min())  # a Snapshot holds at least one particle
    layers = int(np.unique(np.round(z / max(extent * 1e-9, 1e-300))).size)
    return BedStructure(n_particles=n, n_touching=int(touching.sum()), crossing_fraction=crossing,
                        axial_fabric=fabric, coordination=2 * int(touching.sum()) / n,
                        axial_speed_ratio=ratio, axial_layers=layers)


# ----------------------------------------------------------------------------- the drum's confinement
#: packing fraction at which the simulator's drums are filled (the nominal bed depth assumes it)
FILL_PACKING = 0.6


@dataclasses.dataclass(frozen=True)
class DrumConfinement:
    """How confined a drum's bed is: the drum against its particles.

    Attributes
    ----------
    drum_ratio : float
        D/d: drum diameter over the mean particle diameter.
    length_ratio : float
        L/d: axial drum length over the mean particle diameter.
    bed_depth_ratio : float
        Nominal bed depth over d: the depth of the circular segment that holds the particles at
        packing :data:`FILL_PACKING` (volume N·πd³/6 over the drum length), the bed at rest.
    fill_fraction : float
        That bed's share of the drum's cross-section.
    """

    drum_ratio: float
    length_ratio: float
    bed_depth_ratio: float
    fill_fraction: float

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def describe(self) -> str:
        """One line for a command's output."""
        return (f"D/d = {self.drum_ratio:.1f}, L/d = {self.length_ratio:.1f}, bed depth/d = {self.bed_depth_ratio:.1f} "
                f"(nominal, fill {100 * self.fill_fraction:.0f} % at packing {FILL_PACKING:g})")


def _segment_depth(fraction: float) -> float:
    """Depth over radius of the circular segment that covers ``fraction`` of a circle's area:
    solves (θ − sin θ)/(2π) = fraction for the central angle θ, depth = 1 − cos(θ/2)."""
    from scipy.optimize import brentq

    if fraction >= 1:
        return 2.0
    theta = brentq(lambda t: (t - math.sin(t)) / (2 * math.pi) - fraction, 0.0, 2 * math.pi, xtol=1e-14)
    return 1.0 - math.cos(theta / 2)


@validate_params({**dict.fromkeys(("drum_radius", "drum_length", "d_mean"), [POSITIVE]),
                  "n_particles": [Interval(Integral, 1, None)]})
def confinement_of_drum(drum_radius: float, drum_length: float, d_mean: float, n_particles: int) -> DrumConfinement:
    """The confinement of ``n_particles`` spheres of mean diameter ``d_mean`` [m] in a drum of
    radius ``drum_radius`` [m] and length ``drum_length`` [m] (:class:`DrumConfinement`)."""
    bed_area = n_particles * math.pi * d_mean**3 / 6 / FILL_PACKING / drum_length
    fill = bed_area / (math.pi * drum_radius**2)
    return DrumConfinement(drum_ratio=2 * drum_radius / d_mean, length_ratio=drum_length / d_mean,
                           bed_depth_ratio=_segment_depth(fill) * drum_radius / d_mean, fill_fraction=min(fill, 1.0))
