"""Per-contact quantities shared by the identification methods, the threshold sweep and the
contact table: the system's γ and mean radius, the normalised cohesion f = F_coh/(2πγR) under a
cohesion convention, and the co-motion test of every contact."""

from __future__ import annotations

import math
import warnings
from numbers import Real

import numpy as np
import pandas as pd

from granalytics.identification import kernels as _kernels
from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION, cohesive_force
from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import SNAPSHOT, Snapshot
from granalytics.base.validation import POSITIVE, Interval, Options, validate_params

__all__ = ["surface_tension", "mean_radius", "RADIUS_MODE", "A_AGG_DEG", "contact_strength", "largest_strength", "warn_if_c_agg_unreachable", "C_AGG_SAMPLE", "co_moving",
           "contact_table", "COMOTION_TESTS", "COMOTION", "DEFAULT_COMOTION", "DEFAULT_RIGID_TOL", "rigid_residual",
           "rigid_speed_scale", "co_moving_rigid", "comotion_mask", "RIGID_SCALES", "RIGID_SCALE", "DEFAULT_RIGID_SCALE"]

#: co-motion tests of GNA: ``"angle"`` (the paper's: velocities or angular velocities within A_agg)
#: and ``"rigid"`` (the pair moves as one rigid body to within a tolerance; :func:`co_moving_rigid`)
COMOTION_TESTS = ("angle", "rigid")
DEFAULT_COMOTION = "angle"
#: velocity scales of the rigid test: ``"granular"`` √(g·d), d = R_i + R_j the pair's mean
#: diameter (the scale of relative velocities in a dense granular flow; CG-invariant on the bundled
#: runs), ``"drum"`` the rim speed Ω·R_d (the same for every particle size)
RIGID_SCALES = ("granular", "drum")
DEFAULT_RIGID_SCALE = "granular"
#: default tolerance of the rigid test: non-rigid relative velocity below 0.2 √(g·d) (chosen so that
#: on lab-cg1 the rigid test passes the share of force-passing pairs the angle test passes at 20°;
#: docs/identification.md, "The rigid co-motion test")
DEFAULT_RIGID_TOL = 0.2
#: constraints (:mod:`granalytics.base.validation`): R in 2πγR, the pair's or the mean radius; A_agg [deg]
#: in (0, 180]; the co-motion test; the rigid test's velocity scale
RADIUS_MODE = Options(("pair", "mean"))
A_AGG_DEG = Interval(Real, 0, 180, closed="right")
COMOTION = Options(COMOTION_TESTS)
RIGID_SCALE = Options(RIGID_SCALES)

def surface_tension(snapshot: Snapshot, override=None) -> float:
    """γ [N/m]: ``override`` if given, else the run metadata's."""
    gamma = override
    if gamma is None:
        if snapshot.meta is None:
            raise ParameterError("the snapshot has no run metadata: pass surface_tension= (N/m)")
        gamma = snapshot.meta.surface_tension
    gamma = float(gamma)
    if not (math.isfinite(gamma) and gamma > 0):
        raise ParameterError(f"surface_tension must be > 0 N/m, got {gamma!r}")
    return gamma


def mean_radius(snapshot: Snapshot) -> float:
    """The run's mean particle radius [m] (metadata, else the frame's)."""
    return snapshot.meta.mean_radius if snapshot.meta is not None else float(snapshot.radius.mean())


@validate_params({"radius": [RADIUS_MODE], "cohesion": [COHESION]})
def largest_strength(snapshots, radius="pair", cohesion=DEFAULT_COHESION) -> float:
    """The largest F_coh / (2πγR) (:func:`contact_strength`) over ``snapshots`` (0 without contacts).

    No contact passes a cohesion threshold C_agg above it: GNA then finds no granule. In a wet
    drum it is the force of a touching (or barely separated) bridge at its largest volume V_max,
    F_cap(0⁺) ≈ 0.84–0.86·2πγR* (``docs/identification.md``, "The C_agg cliff").
    """
    return max((float(contact_strength(s, radius=radius, cohesion=cohesion).max(initial=0.0)) for s in snapshots),
               default=0.0)


#: frames (evenly spaced over a selection) in which :func:`warn_if_c_agg_unreachable` looks
C_AGG_SAMPLE = 5


def warn_if_c_agg_unreachable(frames, c_agg, cohesion, radius="pair") -> None:
    """One warning line when the cohesion threshold ``c_agg`` (every value of a grid: a grid
    that crosses the cliff is what a sensitivity sweep is for) lies above every contact's
    F_coh/(2πγR) in up to :data:`C_AGG_SAMPLE` frames of ``frames``: no contact can pass it, every
    statistic is that of a bed without granules (``docs/identification.md``, "The C_agg cliff")."""
    values = np.atleast_1d(np.asarray(c_agg, dtype=float))
    picks = np.unique(np.linspace(0, len(frames) - 1, min(C_AGG_SAMPLE, len(frames))).round().astype(int))
    largest = largest_strength((frames[int(k)] for k in picks), radius=radius, cohesion=cohesion)
    if values.min() > largest:
        what = f"C_agg {values[0]:g} is" if values.size == 1 else f"every C_agg of the grid (from {values.min():g}) is"
        warnings.warn(f"{frames.path}: {what} above the largest F_coh/(2πγR) of the run, {largest:.3f} "
                      f"(cohesion={cohesion}, {len(picks)} frames looked at): no contact passes, so no granule is "
                      "found (a touching bridge at its largest volume gives about 0.85)")


@validate_params({"snapshot": [SNAPSHOT], "radius": [RADIUS_MODE], "gamma": [POSITIVE, None], "cohesion": [COHESION]})
def contact_strength(snapshot: Snapshot, radius="pair", gamma=None, cohesion=DEFAULT_COHESION) -> np.ndarray:
    """f = F_coh / (2πγR) of every contact, with R the pair's 2RiRj/(Ri+Rj) or the mean radius
    and F_coh under the ``cohesion`` convention (:mod:`granalytics.identification.cohesion`).

    Bit-identical to the value the GNA kernels compare with C_agg.
    """
    r_mean = mean_radius(snapshot) if radius == "mean" else 0.0
    return _kernels.contact_strength(
        snapshot.contact_i, snapshot.contact_j, cohesive_force(snapshot, cohesion), snapshot.radius,
        2.0 * math.pi * surface_tension(snapshot, gamma), r_mean,
    )


@validate_params({"snapshot": [SNAPSHOT], "a_agg_deg": [A_AGG_DEG]})
def co_moving(snapshot: Snapshot, a_agg_deg) -> np.ndarray:
    """Contacts whose velocities or angular velocities make an angle below A_agg [deg]."""
    cos_a = math.cos(math.radians(float(a_agg_deg)))
    return _kernels.co_moving(snapshot.contact_i, snapshot.contact_j, snapshot.velocity, snapshot.angular_velocity, cos_a)


def rigid_residual(snapshot: Snapshot) -> np.ndarray:
    """Non-rigid relative velocity of every contact [m/s]: |v_j − v_i − ω̄ × (r_j − r_i)|,
    ω̄ = (ω_i + ω_j)/2.

    Zero for a pair that moves as one rigid body, whatever its particles' size or distance from
    the axis (the drum's solid-body rotation included)."""
    return _kernels.rigid_residual(snapshot.contact_i, snapshot.contact_j, snapshot.position, snapshot.velocity,
                                   snapshot.angular_velocity)


def _gravity(snapshot) -> float:
    g = float(np.linalg.norm(snapshot.meta.gravity)) if snapshot.meta is not None else 0.0
    if not g > 0:
        raise ParameterError("the rigid co-motion test with rigid_scale='granular' needs gravity: the snapshot has no "
                             "run metadata or zero gravity; pass speed_scale= (m/s) or use rigid_scale='drum'")
    return g


def _drum_speed(snapshot) -> float:
    meta = snapshot.meta
    params = meta.sim_config.get("params") if meta is not None and isinstance(meta.sim_config, dict) else None
    radius = params.get("drum_radius") if isinstance(params, dict) else None
    omega = abs(float(meta.drum_omega)) if meta is not None else 0.0
    if not (isinstance(radius, (int, float)) and radius > 0 and omega > 0):
        raise ParameterError("the rigid co-motion test with rigid_scale='drum' needs the drum's rim speed Ω·R_d: the run "
                             "records no drum radius (sim_config.params.drum_radius) or no rotation; pass speed_scale= (m/s)")
    return omega * float(radius)


@validate_params({"snapshot": [SNAPSHOT], "rigid_scale": [RIGID_SCALE], "speed_scale": [POSITIVE, None]})
def rigid_speed_scale(snapshot: Snapshot, rigid_scale=DEFAULT_RIGID_SCALE, speed_scale=None) -> np.ndarray | float:
    """The velocity [m/s] the rigid test's tolerance multiplies, per contact or one for all:
    ``speed_scale`` if given; else √(|g|·(R_i + R_j)) (``"granular"``) or the drum's rim speed
    Ω·R_d (``"drum"``) from the run metadata."""
    if speed_scale is not None:
        return float(speed_scale)
    if rigid_scale == "drum":
        return _drum_speed(snapshot)
    return np.sqrt(_gravity(snapshot) * (snapshot.radius[snapshot.contact_i] + snapshot.radius[snapshot.contact_j]))


@validate_params({"rigid_tol": [POSITIVE]})
def co_moving_rigid(snapshot: Snapshot, rigid_tol=DEFAULT_RIGID_TOL, rigid_scale=DEFAULT_RIGID_SCALE,
                    speed_scale=None) -> np.ndarray:
    """Contacts that move as a rigid pair: :func:`rigid_residual` < rigid_tol · V, with V the
    velocity scale of :func:`rigid_speed_scale`. With the default ``"granular"`` scale √(g·d) the
    test compares the pair's deformation with the relative velocities a dense granular flow of
    particles of that size has, so a coarse-grained run and its original pass alike."""
    return rigid_residual(snapshot) < float(rigid_tol) * rigid_speed_scale(snapshot, rigid_scale, speed_scale)


@validate_params({"comotion": [COMOTION]})
def comotion_mask(snapshot: Snapshot, comotion=DEFAULT_COMOTION, *, a_agg_deg=20.0, rigid_tol=DEFAULT_RIGID_TOL,
                  rigid_scale=DEFAULT_RIGID_SCALE, speed_scale=None) -> np.ndarray:
    """The co-motion test ``comotion`` of every contact: :func:`co_moving` at ``a_agg_deg`` or
    :func:`co_moving_rigid` at ``rigid_tol``."""
    if comotion == "angle":
        return co_moving(snapshot, a_agg_deg)
    return co_moving_rigid(snapshot, rigid_tol, rigid_scale, speed_scale)


def _angles_deg(a, b):
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.clip((a * b).sum(axis=1) / (na * nb), -1.0, 1.0)
    return np.where((na == 0) | (nb == 0), np.nan, np.degrees(np.arccos(cos)))


@validate_params({"snapshot": [SNAPSHOT], "radius": [RADIUS_MODE], "surface_tension": [POSITIVE, None],
                  "cohesion": [COHESION]})
def contact_table(snapshot: Snapshot, radius="pair", surface_tension=None, cohesion=DEFAULT_COHESION) -> pd.DataFrame:
    """One row per contact or bridge, the columns user criteria can use.

    Columns: ``i``, ``j`` (particle rows), ``id_i``, ``id_j``, ``f_cap`` [N] (the bridge force
    at max(s, 0⁺)), ``f_coh`` [N] (F_coh under ``cohesion``, :mod:`granalytics.identification.cohesion`),
    ``f_normal`` [N], ``gap`` [m], ``bridge_volume`` [m³], ``f_norm`` (F_coh/(2πγR), as GNA
    compares with C_agg),
    ``angle_v_deg`` and ``angle_w_deg`` (angles between the velocities and between the angular
    velocities [deg]; NaN when a vector is zero), ``rigid_residual`` [m/s] (:func:`rigid_residual`).
    """
    i, j = snapshot.contact_i, snapshot.contact_j
    return pd.DataFrame({
        "i": i, "j": j, "id_i": snapshot.ids[i], "id_j": snapshot.ids[j],
        "f_cap": snapshot.f_cap, "f_coh": cohesive_force(snapshot, cohesion), "f_normal": snapshot.f_normal,
        "gap": snapshot.gap, "bridge_volume": snapshot.bridge_volume,
        "f_norm": contact_strength(snapshot, radius, surface_tension, cohesion),
        "angle_v_deg": _angles_deg(snapshot.velocity[i], snapshot.velocity[j]),
        "angle_w_deg": _angles_deg(snapshot.angular_velocity[i], snapshot.angular_velocity[j]),
        "rigid_residual": rigid_residual(snapshot),
    })
