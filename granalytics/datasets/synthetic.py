"""Synthetic, physics-free snapshots and runs for demos, tests and benchmarks.

**No physics here.** Particles sit on a jittered cubic lattice; "granules" are planted as blobs
of neighbouring particles that share a velocity and angular velocity direction and hold strong
liquid bridges. Everything else moves in random directions with random, mostly weak bridges.
This gives data with the shape and scale of a wet-drum DEM frame (Table 1 particle sizes, a few
contacts per particle) on which the identification must find the planted blobs. Use the
simulator (``sim``) for physically meaningful data.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from granalytics.base.errors import ParameterError
from granalytics.core.snapshot import RunMeta, Snapshot

__all__ = ["synthetic_meta", "synthetic_snapshot", "write_synthetic_run"]

_GAMMA = 0.1095  # N/m, Table 1
_RHO = 2500.0  # kg/m³, Table 1
_R0 = 0.75e-3  # m, mean radius d_o/2, Table 1


def synthetic_meta(n_particles, alpha=1.0, drum_omega=2.0) -> RunMeta:
    """Metadata of a synthetic run with Table 1 material values scaled by CG factor ``alpha``."""
    return RunMeta(
        surface_tension=_GAMMA * alpha,
        density=_RHO,
        drum_omega=drum_omega,
        n_particles=n_particles,
        mean_radius=_R0 * alpha,
        alpha=alpha,
        provenance={"source": "granalytics.datasets.synthetic (physics-free test data)"},
    )


def synthetic_snapshot(
    n_particles=10_000,
    *,
    contacts_per_particle=2.5,
    granulated_fraction=0.5,
    mean_blob_size=12.0,
    wet_fraction=0.6,
    time=0.0,
    step=0,
    alpha=1.0,
    seed=0,
    meta=None,
) -> Snapshot:
    """One physics-free frame with planted granules.

    Parameters
    ----------
    n_particles : int
        Number of particles N.
    contacts_per_particle : float, default 2.5
        Contacts M ≈ this · N (at most 3, the lattice's bonds per particle).
    granulated_fraction : float, default 0.5
        Approximate fraction of particles inside planted blobs.
    mean_blob_size : float, default 12
        Mean particles per planted blob (sizes are geometric-like, so a few are large).
    wet_fraction : float, default 0.6
        Fraction of the other contacts carrying a (random-strength) liquid bridge.
    time, step : float, int
        Stamped on the snapshot.
    alpha : float, default 1
        CG factor: radii, γ scale with α, so capillary forces scale with α².
    seed : int
    meta : RunMeta, optional
        Defaults to :func:`synthetic_meta` (n_particles, alpha).
    """
    rng = np.random.default_rng(seed)
    meta = meta if meta is not None else synthetic_meta(n_particles, alpha)
    spacing = 2.0 * meta.mean_radius
    site, side, radius, position = _lattice(n_particles, meta.mean_radius, spacing, rng)
    ci, cj = _lattice_contacts(site, side, contacts_per_particle, rng)
    blob, n_blobs = _plant_blobs(position, spacing, granulated_fraction, mean_blob_size, rng)
    velocity, angular_velocity = _velocities(blob, n_blobs, rng)
    v_particle = 4 / 3 * math.pi * radius**3
    f_cap, f_normal, gap, bridge_volume = _bridges(radius, v_particle, ci, cj, blob, meta.surface_tension, alpha,
                                                   wet_fraction, rng)
    return Snapshot(
        time=time,
        step=step,
        ids=np.arange(n_particles, dtype=np.int64),
        radius=radius,
        position=position,
        velocity=velocity,
        angular_velocity=angular_velocity,
        film_volume=rng.uniform(0.0, 0.01, n_particles) * v_particle,
        contact_i=ci,
        contact_j=cj,
        f_cap=f_cap,
        f_normal=f_normal,
        gap=gap,
        bridge_volume=bridge_volume,
        meta=meta,
    )


def _lattice(n_particles, r0, spacing, rng):
    """Particles on the first ``n_particles`` sites of a cubic lattice of ``spacing`` [m]: their
    integer sites (N, 3), the lattice's side, radii (``r0`` ± 20 %) [m] and jittered positions [m]."""
    side = math.ceil(n_particles ** (1 / 3))
    site = np.stack(np.unravel_index(np.arange(n_particles), (side, side, side)), axis=1)
    radius = r0 * rng.uniform(0.8, 1.2, n_particles)
    position = site * spacing + rng.normal(0.0, 0.02 * r0, (n_particles, 3))
    return site, side, radius, position


def _lattice_contacts(site, side, contacts_per_particle, rng):
    """Contacts (i, j) along the lattice bonds (+x, +y, +z) of the particles at ``site``, a random
    subset of about ``contacts_per_particle`` per particle, in bond order."""
    n_particles = len(site)
    flat = np.ravel_multi_index(site.T, (side, side, side))
    lookup = np.full(side**3, -1, dtype=np.int64)
    lookup[flat] = np.arange(n_particles)
    pairs = []
    for axis in range(3):
        nb = site.copy()
        nb[:, axis] += 1
        inside = nb[:, axis] < side
        j = lookup[np.ravel_multi_index(nb[inside].T, (side, side, side))]
        i = np.arange(n_particles)[inside]
        ok = j >= 0
        pairs.append(np.column_stack([i[ok], j[ok]]))
    pairs = np.concatenate(pairs)
    n_keep = min(len(pairs), int(round(contacts_per_particle * n_particles)))
    pairs = pairs[np.sort(rng.choice(len(pairs), n_keep, replace=False))]
    return pairs[:, 0], pairs[:, 1]


def _plant_blobs(position, spacing, granulated_fraction, mean_blob_size, rng):
    """Blob of every particle (−1: none) and the number of blobs: balls of about a geometric
    number of particles (mean ``mean_blob_size``) grown around random centres until
    ``granulated_fraction`` of the particles is covered."""
    n_particles = len(position)
    blob = np.full(n_particles, -1, dtype=np.int64)
    tree = cKDTree(position)
    target = int(granulated_fraction * n_particles)
    covered, b = 0, 0
    order = rng.permutation(n_particles)
    for centre in order:
        if covered >= target:
            break
        if blob[centre] >= 0:
            continue
        size = 2 + rng.geometric(1.0 / max(mean_blob_size - 1.0, 1.0))
        reach = spacing * (0.75 * size / math.pi) ** (1 / 3) * 1.05
        members = np.asarray(tree.query_ball_point(position[centre], reach), dtype=np.int64)
        members = members[blob[members] < 0]
        if members.size < 2:
            continue
        blob[members] = b
        covered += members.size
        b += 1
    return blob, b


def _directions(rng, k):
    """``k`` random unit vectors (k, 3)."""
    d = rng.normal(size=(k, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _velocities(blob, n_blobs, rng):
    """Velocities [m/s] and angular velocities [rad/s] (N, 3): random, but shared (plus a little
    noise) by the particles of one blob."""
    n_particles, nb = len(blob), max(n_blobs, 1)
    blob_v = _directions(rng, nb) * rng.uniform(0.1, 0.5, (nb, 1))
    blob_w = _directions(rng, nb) * rng.uniform(5.0, 50.0, (nb, 1))
    velocity = _directions(rng, n_particles) * rng.uniform(0.05, 0.5, (n_particles, 1))
    angular_velocity = _directions(rng, n_particles) * rng.uniform(1.0, 60.0, (n_particles, 1))
    inb = blob >= 0
    velocity[inb] = blob_v[blob[inb]] + rng.normal(0.0, 0.01, (inb.sum(), 3))
    angular_velocity[inb] = blob_w[blob[inb]] + rng.normal(0.0, 0.5, (inb.sum(), 3))
    return velocity, angular_velocity


def _bridges(radius, v_particle, ci, cj, blob, gamma, alpha, wet_fraction, rng):
    """Contact columns ``f_cap``, ``f_normal`` [N], ``gap`` [m] and ``bridge_volume`` [m³]: every
    contact inside a blob wet and strong (65–100 % of the capillary maximum 2πγR*), the others wet
    with probability ``wet_fraction`` at a random strength, dry ones slightly overlapping."""
    r_star = 2 * radius[ci] * radius[cj] / (radius[ci] + radius[cj])
    f_max = 2 * math.pi * gamma * r_star
    same = (blob[ci] >= 0) & (blob[ci] == blob[cj])
    wet = same | (rng.random(ci.size) < wet_fraction)
    strength = np.where(same, rng.uniform(0.65, 1.0, ci.size), rng.uniform(0.0, 1.0, ci.size))
    f_cap = np.where(wet, strength * f_max, 0.0)
    gap = np.where(wet, rng.uniform(0.0, 0.05, ci.size) * r_star, -rng.uniform(0.0, 1e-3, ci.size) * r_star)
    bridge_volume = np.where(wet, 1e-3 * np.minimum(v_particle[ci], v_particle[cj]), 0.0)
    f_normal = np.where(gap < 0, 150.0 * alpha * -gap, 0.0) - f_cap
    return f_cap, f_normal, gap, bridge_volume


def write_synthetic_run(path, n_particles=3000, revolutions=6.0, frames_per_revolution=20, *, alpha=1.0,
                        final_fraction=0.55, seed=0, overwrite=True):
    """Write a physics-free run whose planted granulated fraction grows like a granulation curve.

    The planted fraction follows ``final_fraction·(1 − exp(−rev/0.7))`` so that the time series
    rises over the first two revolutions and then fluctuates about a plateau, like Fig. 6 of the
    paper. Frames are independent draws (no trajectories).

    The file is written whole or not at all (:func:`granalytics.core.replacing_run`): an error
    or Ctrl-C leaves an earlier ``path`` as it was, and a link at ``path`` is replaced, not
    written through.

    Returns
    -------
    str
        The path written.

    Raises
    ------
    ParameterError
        The run would need more memory or disk than this machine has (its size is named).
    """
    from granalytics.core import RunWriter, replacing_run
    from granalytics.base.resources import check_disk, check_memory

    meta = synthetic_meta(n_particles, alpha)
    meta.provenance["command"] = (
        f"write_synthetic_run({str(path)!r}, n_particles={n_particles}, revolutions={revolutions}, "
        f"frames_per_revolution={frames_per_revolution}, alpha={alpha}, seed={seed})"
    )
    period = 2 * math.pi / meta.drum_omega
    if isinstance(frames_per_revolution, bool) or not isinstance(frames_per_revolution, (int, np.integer)) \
            or frames_per_revolution < 1:
        raise ParameterError(f"frames_per_revolution must be a whole number >= 1, got {frames_per_revolution!r}")
    if isinstance(revolutions, bool) or not isinstance(revolutions, (int, float, np.integer, np.floating)) \
            or not 0 <= revolutions < math.inf:
        raise ParameterError(f"revolutions must be a finite number >= 0, got {revolutions!r}")
    n_frames = int(round(revolutions * frames_per_revolution)) + 1
    # random positions and velocities hardly compress: about 100 bytes a particle and frame on disk
    check_memory(f"a synthetic frame of {n_particles} particles", 400 * n_particles)
    check_disk(f"{path}: a synthetic run of {n_frames} frames of {n_particles} particles",
               100 * n_frames * n_particles, path)
    with replacing_run(path, overwrite) as tmp, RunWriter(tmp, meta, overwrite=True) as writer:
        for k in range(n_frames):
            rev = k / frames_per_revolution
            writer.append(
                synthetic_snapshot(
                    n_particles, granulated_fraction=final_fraction * (1 - math.exp(-rev / 0.7)),
                    time=rev * period, step=k * 1000, alpha=alpha, seed=seed * 100_003 + k, meta=meta,
                )
            )
    return str(path)
