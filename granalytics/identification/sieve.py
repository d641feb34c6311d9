"""Virtual sieving: agglomerates sorted into sieve classes like a laboratory sieve analysis.

Agglomerates are the connected groups of particles joined by liquid bridges
(``connect="bridges"``), by any contact or bridge (``"contacts"``), or by the contacts that pass
the GNA criteria (``"gna"``). Geometric rule: an agglomerate passes a square aperture when its
*second-largest principal extent* is smaller than the aperture (a sieve lets an elongated grain
through lengthwise, so its width, not its length, decides). Principal axes come from the
volume-weighted gyration tensor of the particle centres; the extent along an axis spans the
member spheres' surfaces. A free particle's width is its diameter.

The analysis reports, per sieve, the mass fraction retained (the agglomerate stays on the
largest aperture not exceeding its width; narrower ones fall to the pan), the cumulative mass
fraction passing, and d10/d50/d90 (the apertures where 10/50/90 % of the mass passes,
interpolated linearly in log aperture).
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np
import pandas as pd

from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION
from granalytics.identification import kernels as _kernels
from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import Snapshot
from granalytics.identification.common import A_AGG_DEG, C_AGG, PAPER_A_AGG_DEG, PAPER_C_AGG, RADIUS_MODE, Identifier, mean_radius
from granalytics.identification.gna import GraphNetworkAnalysis
from granalytics.identification.result import IdentificationResult
from granalytics.base.validation import POSITIVE, Array, Interval, Options

__all__ = ["VirtualSieve", "sieve_analysis"]


class VirtualSieve(Identifier):
    """Agglomerates and their sieve analysis (method ``"sieve"``).

    Parameters
    ----------
    connect : {"contacts", "bridges", "gna"}, default "gna"
        Which pairs join particles into agglomerates. The default sieves GNA's granules (at the
        paper's thresholds): on a wet drum bed every particle touches the bed, so ``"contacts"``
        and ``"bridges"`` give one agglomerate holding the whole bed (yield 1.000 on lab-cg3 and
        0.999 on lab-cg1, revolutions [3, 3.5]); they suit a dry or a dilute system.
    c_agg, a_agg_deg, radius, cohesion : GNA criteria, used with ``connect="gna"``.
    apertures_m : sequence of float, optional
        Sieve apertures [m]. Default: a √2 series from half the mean particle diameter up to
        the first aperture wider than every agglomerate.
    ratio : float, default √2
        Progression of the default series.
    """

    method = "sieve"
    _parameter_constraints = {
        "connect": [Options(("contacts", "bridges", "gna"))], "c_agg": [C_AGG], "a_agg_deg": [A_AGG_DEG],
        "radius": [RADIUS_MODE], "apertures_m": [Array(ndim=1, within=POSITIVE), None],
        "ratio": [Interval(Real, 1, None, closed="neither")], "cohesion": [COHESION],
    }

    def __init__(self, connect="gna", *, c_agg=PAPER_C_AGG, a_agg_deg=PAPER_A_AGG_DEG, radius="pair", apertures_m=None, ratio=math.sqrt(2),
                 cohesion=DEFAULT_COHESION):
        self.connect = connect
        self.c_agg = c_agg
        self.a_agg_deg = a_agg_deg
        self.radius = radius
        self.apertures_m = apertures_m
        self.ratio = ratio
        self.cohesion = cohesion

    def _param_value(self, name):
        value = getattr(self, name)
        return list(value) if name == "apertures_m" and value is not None else value

    def _edges(self, snapshot):
        if self.connect == "contacts":
            return np.ones(snapshot.n_contacts, dtype=bool)
        if self.connect == "bridges":
            return snapshot.bridge_volume > 0
        return GraphNetworkAnalysis(self.c_agg, self.a_agg_deg, radius=self.radius,
                                    cohesion=self.cohesion).contact_mask(snapshot)

    def identify(self, snapshot: Snapshot) -> IdentificationResult:
        """Agglomerates (≥ 2 particles are granules) with ``extra["sieve"]`` (the sieve table),
        ``extra["widths_m"]`` (second-largest extent of every agglomerate, singletons included,
        indexed like ``extra["membership"]``) and ``extra["d10_m"]``, ``["d50_m"]``, ``["d90_m"]``."""
        keep = self._edges(snapshot)
        membership = _kernels.union_find_membership(
            snapshot.n_particles, snapshot.contact_i[keep], snapshot.contact_j[keep])
        groups, membership = np.unique(membership, return_inverse=True)
        membership = membership.astype(np.int64)
        volume = snapshot.particle_volume
        extents = _kernels.principal_extents(membership, groups.size, snapshot.position, snapshot.radius, volume)
        widths = extents[:, 1]
        mass = np.bincount(membership, weights=volume, minlength=groups.size)
        apertures = self._apertures(snapshot, widths)
        table, quantiles = sieve_analysis(widths, mass, apertures)
        labels, sizes = _kernels.canonical_labels(membership)
        return IdentificationResult(
            labels=labels, sizes=sizes, method=self.method, params=self.params(), snapshot=snapshot, kept=keep,
            extra={"sieve": table, "widths_m": widths, "membership": membership, **quantiles},
        )

    def _apertures(self, snapshot, widths):
        if self.apertures_m is not None:
            if len(self.apertures_m) == 0:
                raise ParameterError("VirtualSieve: apertures_m must hold at least one aperture, got none")
            return np.sort(np.asarray(self.apertures_m, dtype=float))
        first = mean_radius(snapshot)  # half the mean diameter
        n = max(1, math.ceil(math.log(max(widths.max(), first) / first, self.ratio)) + 1)
        return first * self.ratio ** np.arange(n + 1)


def sieve_analysis(widths, mass, apertures):
    """Sieve table and d10/d50/d90 for grains of given widths [m] and masses.

    Returns
    -------
    table : DataFrame
        One row per sieve, ascending, plus the pan (``aperture_m`` 0): ``aperture_m``,
        ``retained_fraction`` (mass on this sieve), ``passing_fraction`` (cumulative mass
        fraction with width < aperture).
    quantiles : dict
        ``d10_m``, ``d50_m``, ``d90_m`` (NaN when outside the sieve range).
    """
    widths, mass, apertures = np.asarray(widths, float), np.asarray(mass, float), np.asarray(apertures, float)
    total = mass.sum()
    if total <= 0:
        raise ParameterError("sieve analysis of zero mass")
    # index of the largest aperture <= width (−1: pan)
    on = np.searchsorted(apertures, widths, side="right") - 1
    retained = np.bincount(on + 1, weights=mass, minlength=apertures.size + 1) / total
    passing = np.array([mass[widths < a].sum() for a in apertures]) / total
    table = pd.DataFrame({
        "aperture_m": np.r_[0.0, apertures],
        "retained_fraction": retained,
        "passing_fraction": np.r_[0.0, passing],
    })
    quantiles = {}
    for q in (10, 50, 90):
        target = q / 100
        k = np.flatnonzero(passing >= target)
        if k.size and passing[k[0]] == target:
            quantiles[f"d{q}_m"] = float(apertures[k[0]])
            continue
        if not k.size or k[0] == 0:  # outside the sieve range
            quantiles[f"d{q}_m"] = math.nan
            continue
        k = k[0]
        p0, p1 = passing[k - 1], passing[k]
        x0, x1 = math.log(apertures[k - 1]), math.log(apertures[k])
        quantiles[f"d{q}_m"] = math.exp(x0 + (target - p0) / (p1 - p0) * (x1 - x0)) if p1 > p0 else apertures[k]
    return table, quantiles
