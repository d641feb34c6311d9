"""The per-granule table of one identified frame (size, volume, centre of mass, radius of
gyration, liquid)."""

from __future__ import annotations

from numbers import Integral

import numpy as np
import pandas as pd

from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import SNAPSHOT, Snapshot
from granalytics.base.validation import Array, validate_params

__all__ = ["granule_table"]


@validate_params({"snapshot": [SNAPSHOT], "labels": [Array(ndim=1, dtype=Integral)]})
def granule_table(snapshot: Snapshot, labels) -> pd.DataFrame:
    """One row per granule.

    Parameters
    ----------
    snapshot : Snapshot
    labels : (N,) int array
        Granule labels 0…G−1, −1 for free particles.

    Returns
    -------
    DataFrame indexed by ``granule``, columns:

    - ``n_particles``: particle count;
    - ``volume_m3``: sum of particle volumes [m³];
    - ``com_x_m``, ``com_y_m``, ``com_z_m``: centre of mass [m] (uniform density);
    - ``radius_of_gyration_m``: mass-weighted RMS distance of particle centres from the centre
      of mass [m] (particles as point masses);
    - ``film_volume_m3``: liquid in the members' films [m³];
    - ``bridge_volume_m3``: liquid in bridges with both ends in the granule [m³];
    - ``liquid_volume_m3``: film + bridge liquid [m³];
    - ``liquid_solid_ratio``: liquid volume / solid volume.
    """
    labels = np.asarray(labels)
    if labels.shape != (snapshot.n_particles,):
        raise ParameterError(f"granule_table: labels must have shape ({snapshot.n_particles},), got {labels.shape}")
    g = int(labels.max()) + 1 if labels.size else 0
    member = labels >= 0
    lab = labels[member]
    vol = snapshot.particle_volume[member]
    pos = snapshot.position[member]
    def total(weights, which=lab):
        return np.bincount(which, weights=weights, minlength=g).astype(np.float64, copy=False)

    count = np.bincount(lab, minlength=g)
    volume = total(vol)
    with np.errstate(invalid="ignore", divide="ignore"):
        com = np.column_stack([total(vol * pos[:, d]) for d in range(3)]).reshape(g, 3) / volume[:, None]
        d2 = ((pos - com[lab]) ** 2).sum(axis=1)
        rg = np.sqrt(total(vol * d2) / volume)
    film = total(snapshot.film_volume[member])
    li, lj = labels[snapshot.contact_i], labels[snapshot.contact_j]
    internal = (li >= 0) & (li == lj)
    bridge = total(snapshot.bridge_volume[internal], li[internal])
    table = pd.DataFrame(
        {
            "n_particles": count,
            "volume_m3": volume,
            "com_x_m": com[:, 0],
            "com_y_m": com[:, 1],
            "com_z_m": com[:, 2],
            "radius_of_gyration_m": rg,
            "film_volume_m3": film,
            "bridge_volume_m3": bridge,
            "liquid_volume_m3": film + bridge,
            "liquid_solid_ratio": (film + bridge) / volume,
        }
    )
    table.index.name = "granule"
    return table
